//! Person segmentation: MediaPipe's selfie segmentation network (general model, Apache-2.0),
//! converted from TFLite to ONNX at set-up (`scripts/tflite_to_onnx.py`), run with ONNX
//! Runtime.
//!
//! # Assumptions
//! * Input `input_1`: 1 x 256 x 256 x 3 (NHWC), RGB in 0..1; output `activation_10`:
//!   1 x 256 x 256 x 1, the probability of the person (head, hair, body, whatever they hold
//!   or wear) against the background.
//! * It is trained on upright head-and-shoulders views, so it is shown an upright square
//!   around the face ([`crate::person::mask_window`]), resampled bilinearly; where the square
//!   leaves the photo the photo's edge pixels are repeated (a body cut by the frame goes on).
//!
//! The sampling ([`sample_window`]) is pure; the session is the only I/O.

use std::path::{Path, PathBuf};

use image::RgbImage;
use ort::value::TensorRef;

use super::{DetectError, LoadFailure, SessionConfig};
use crate::person::{PersonError, PersonMask, bilinear_rgb, mask_window};

/// Graph input name.
pub const INPUT: &str = "input_1";
/// Graph output name.
pub const OUTPUT: &str = "activation_10";
/// The network's square input side, pixels.
pub const SIDE: usize = 256;

/// Why a person mask could not be made.
#[derive(Debug, thiserror::Error)]
pub enum SegmentError {
    #[error("cannot read person segmentation model {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path} is not the person segmentation model: {reason}")]
    Model { path: PathBuf, reason: String },
    #[error(transparent)]
    Runtime(#[from] DetectError),
    #[error("person segmentation with model {path} failed: {reason}")]
    Inference { path: PathBuf, reason: String },
    #[error("person segmentation: {0}")]
    Face(#[from] PersonError),
}

/// The segmentation network with an ONNX Runtime session, ready to run.
#[derive(Debug)]
pub struct PersonSegmenter {
    model: super::OnnxModel,
}

impl PersonSegmenter {
    /// Loads the model (set-up converts it: [`crate::assets::ModelPaths::segmenter`]) with ONNX Runtime from
    /// `ort_library`, on one thread.
    pub fn load(model: &Path, ort_library: &Path) -> Result<Self, SegmentError> {
        let config = SessionConfig::default();
        let io = |path, source| SegmentError::Io { path, source };
        let wrong = |path, reason| SegmentError::Model { path, reason };
        let model = super::OnnxModel::load(model, ort_library, &config, Ok, [INPUT, OUTPUT], false)
            .map_err(|e: LoadFailure| e.into_error(model, io, wrong))?;
        Ok(PersonSegmenter { model })
    }

    /// The person's probability around the face with these 68 landmarks (photo pixels).
    pub fn segment(
        &mut self,
        img: &RgbImage,
        landmarks: &[[f32; 2]],
    ) -> Result<PersonMask, SegmentError> {
        let (centre, side) = mask_window(landmarks)?;
        let input = sample_window(img, centre, side).ok_or_else(|| SegmentError::Inference {
            path: self.model.path.clone(),
            reason: format!("empty {}x{} image", img.width(), img.height()),
        })?;
        let path = self.model.path.clone();
        let infer_err = |reason: String| SegmentError::Inference {
            path: path.clone(),
            reason,
        };
        let tensor = TensorRef::from_array_view(&input).map_err(|e| infer_err(e.to_string()))?;
        let out = self
            .model
            .run_one(INPUT, tensor, OUTPUT, SIDE * SIDE)
            .map_err(infer_err)?;
        let prob: Vec<f32> = out
            .iter()
            .map(|v| {
                if v.is_finite() {
                    v.clamp(0.0, 1.0)
                } else {
                    0.5
                }
            })
            .collect();
        let step = side / SIDE as f32;
        Ok(PersonMask {
            size: SIDE,
            origin: [centre[0] - side / 2.0, centre[1] - side / 2.0],
            step,
            prob,
        })
    }
}

/// The network's input: the upright square of side `side` (photo pixels) centred at `centre`,
/// bilinear, edge pixels repeated beyond the photo, RGB 0..1, NHWC. `None` for an empty image.
pub fn sample_window(img: &RgbImage, centre: [f32; 2], side: f32) -> Option<ndarray::Array4<f32>> {
    let (w, h) = img.dimensions();
    if w == 0 || h == 0 {
        return None;
    }
    let step = side / SIDE as f32;
    let x0 = centre[0] - side / 2.0;
    let y0 = centre[1] - side / 2.0;
    let mut out = ndarray::Array4::<f32>::zeros((1, SIDE, SIDE, 3));
    for r in 0..SIDE {
        let y = y0 + (r as f32 + 0.5) * step - 0.5;
        for c in 0..SIDE {
            let x = x0 + (c as f32 + 0.5) * step - 0.5;
            let rgb = bilinear_rgb(img, x, y);
            for (k, v) in rgb.into_iter().enumerate() {
                out[[0, r, c, k]] = v;
            }
        }
    }
    Some(out)
}
