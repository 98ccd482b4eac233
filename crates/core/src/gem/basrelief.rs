//! Gradient-domain bas-relief: a height field squeezed to a stone's depth with its detail kept
//! (Weyrich et al. 2007, "Digital bas-relief from 3D scenes"; Kerber et al. 2009, "Feature
//! sensitive bas relief generation").
//!
//! A linear scale-down of a head to a few millimetres keeps its bulk and loses everything
//! else: the slopes of an eyelid or a lip become a fraction of what the eye can see. Here the
//! *gradients* of the height field are compressed instead, large ones (the bulk, the
//! silhouette) much more than small ones (the features), and the surface is rebuilt from them
//! by solving a Poisson equation:
//!
//! 1. gradients by forward differences between two covered cells (an edge to an uncovered cell
//!    has none: the relief's border is where the heights return to 0);
//! 2. depth jumps (|g| > [`Compression::jump_slope`]: an ear's rim over the skull, hair over the
//!    forehead) are clamped to that slope, so an overlap stays a crisp step instead of eating
//!    the depth;
//! 3. attenuation above a threshold `a` = [`Compression::threshold`] x the mean |g|:
//!    |g'| = a (|g| / a)^b, b = [`Compression::power`] < 1; gradients below `a` are kept;
//! 4. detail boost by unsharp masking of the gradients: low = blur(g, `sigma_low`),
//!    high = blur(g - low, `sigma_high`) (a band-pass: the finest noise stays out),
//!    g' = g + [`Compression::boost`] high, with blurs that ignore uncovered cells;
//! 5. divergence by backward differences and a Poisson solve with h = 0 outside the mask,
//!    by conjugate gradients preconditioned with a multigrid V-cycle ([`Poisson`]).
//!
//! Units: heights and the cell size in the same unit (model millimetres in the cameo); slopes are
//! height per plane distance. Pure computation: no I/O, no GPU.

use super::blur::{Normaliser, box_radius};
pub use super::blur::{blur, blur_weighted};
pub use super::poisson::{Poisson, SolveReport};

/// Parameters of the gradient compression.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Compression {
    /// Slopes above this are depth jumps and clamped to it.
    pub jump_slope: f32,
    /// The attenuation threshold `a` as a multiple of the mean gradient magnitude.
    pub threshold: f32,
    /// Attenuation power `b` in (0, 1]: 1 keeps every gradient, smaller flattens more.
    pub power: f32,
    /// Gain of the detail band added back.
    pub boost: f32,
    /// Widths of the two blurs of the unsharp mask, in cells.
    pub sigma_low: f32,
    pub sigma_high: f32,
    /// Relative residual at which the Poisson solve stops.
    pub tolerance: f32,
}

impl Default for Compression {
    fn default() -> Self {
        Compression {
            jump_slope: 2.0,
            threshold: 0.3,
            power: 0.6,
            boost: 2.0,
            sigma_low: 4.0,
            sigma_high: 1.2,
            tolerance: SOLVE_TOLERANCE,
        }
    }
}

/// Why a compression was refused.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ReliefError {
    #[error("grid {cols} x {rows} does not match {len} values")]
    Size {
        cols: usize,
        rows: usize,
        len: usize,
    },
    #[error("compression parameter {what} is {value}: {problem}")]
    Param {
        what: &'static str,
        value: f32,
        problem: &'static str,
    },
}

impl Compression {
    /// Checks every field, naming the first bad one.
    pub fn validate(&self) -> Result<(), ReliefError> {
        let checks: [(&'static str, f32, bool, &'static str); 7] = [
            (
                "tolerance",
                self.tolerance,
                self.tolerance > 0.0 && self.tolerance < 1.0,
                "must be in (0, 1)",
            ),
            (
                "jump_slope",
                self.jump_slope,
                self.jump_slope > 0.0,
                "must be positive",
            ),
            (
                "threshold",
                self.threshold,
                self.threshold > 0.0,
                "must be positive",
            ),
            (
                "power",
                self.power,
                self.power > 0.0 && self.power <= 1.0,
                "must be in (0, 1]",
            ),
            ("boost", self.boost, self.boost >= 0.0, "must be >= 0"),
            (
                "sigma_low",
                self.sigma_low,
                self.sigma_low > 0.0,
                "must be positive",
            ),
            (
                "sigma_high",
                self.sigma_high,
                self.sigma_high > 0.0 && self.sigma_high < self.sigma_low,
                "must be positive and below sigma_low",
            ),
        ];
        for (what, value, ok, problem) in checks {
            if !(value.is_finite() && ok) {
                return Err(ReliefError::Param {
                    what,
                    value,
                    problem,
                });
            }
        }
        Ok(())
    }
}

/// Relative residual at which the Poisson solve stops: the heights are then within about a
/// thousandth of their range, far below what a 5 mm relief shows.
const SOLVE_TOLERANCE: f32 = 1e-3;

/// Compresses `height` (row-major `cols` x `rows`, cells of size `cell`) over the covered
/// cells `mask` and returns relative relief heights: 0 outside the mask and on its border,
/// in the unit of `height` but no longer to scale (the caller scales them to its depth).
/// `emphasis` (per cell, or empty for all 1) multiplies the compressed gradients: parts that
/// must stand out (the face) keep theirs, the rest can be carved lower. `initial` (empty, or
/// a previous result on the same grid) starts the Poisson solve: when one relief follows
/// another (a tracked face), the solve then needs far fewer iterations.
#[allow(clippy::too_many_arguments)]
pub fn compress(
    height: &[f32],
    mask: &[bool],
    emphasis: &[f32],
    initial: &[f32],
    cols: usize,
    rows: usize,
    cell: f32,
    params: &Compression,
) -> Result<(Vec<f32>, SolveReport), ReliefError> {
    params.validate()?;
    let n = cols * rows;
    let optional = |f: &[f32]| f.is_empty() || f.len() == n;
    if height.len() != n || mask.len() != n || !optional(emphasis) || !optional(initial) {
        return Err(ReliefError::Size {
            cols,
            rows,
            len: height.len().min(mask.len()),
        });
    }
    if !(cell.is_finite() && cell > 0.0) {
        return Err(ReliefError::Param {
            what: "cell",
            value: cell,
            problem: "must be positive",
        });
    }
    // Work on the covered cells' bounding box (with a margin for the blurs): outside it the
    // relief is 0 anyway.
    let (mut x0, mut y0, mut x1, mut y1) = (cols, rows, 0, 0);
    for (i, _) in mask
        .iter()
        .zip(height)
        .enumerate()
        .filter(|(_, (m, h))| **m && h.is_finite())
    {
        let (x, y) = (i % cols, i / cols);
        (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
    }
    if x0 > x1 {
        return Ok((vec![0.0; n], SolveReport::default()));
    }
    let margin = 3 * box_radius(params.sigma_low) + 1;
    let (x0, y0) = (x0.saturating_sub(margin), y0.saturating_sub(margin));
    let (x1, y1) = ((x1 + margin).min(cols - 1), (y1 + margin).min(rows - 1));
    if (x0, y0, x1, y1) != (0, 0, cols - 1, rows - 1) {
        let (w, h) = (x1 - x0 + 1, y1 - y0 + 1);
        let crop = |f: &dyn Fn(usize) -> (f32, bool)| -> (Vec<f32>, Vec<bool>) {
            (0..w * h)
                .map(|k| f((y0 + k / w) * cols + x0 + k % w))
                .unzip()
        };
        let (sub_h, sub_m) = crop(&|i| (height[i], mask[i]));
        let sub = |f: &[f32]| -> Vec<f32> {
            if f.is_empty() {
                Vec::new()
            } else {
                crop(&|i| (f[i], true)).0
            }
        };
        let (rel, report) = compress(
            &sub_h,
            &sub_m,
            &sub(emphasis),
            &sub(initial),
            w,
            h,
            cell,
            params,
        )?;
        let mut out = vec![0f32; n];
        for (k, v) in rel.iter().enumerate() {
            out[(y0 + k / w) * cols + x0 + k % w] = *v;
        }
        return Ok((out, report));
    }
    let covered = |i: usize| mask[i] && height[i].is_finite();
    // Edge slopes: gx[i] between cell i and its right neighbour, gy[i] and the one above
    // (row + 1); `ex`, `ey` say whether the edge exists (both cells covered).
    let mut gx = vec![0f32; n];
    let mut gy = vec![0f32; n];
    let mut ex = vec![0f32; n];
    let mut ey = vec![0f32; n];
    let inv = 1.0 / cell;
    let clip = params.jump_slope;
    for y in 0..rows {
        for x in 0..cols {
            let i = y * cols + x;
            if !covered(i) {
                continue;
            }
            if x + 1 < cols && covered(i + 1) {
                gx[i] = ((height[i + 1] - height[i]) * inv).clamp(-clip, clip);
                ex[i] = 1.0;
            }
            if y + 1 < rows && covered(i + cols) {
                gy[i] = ((height[i + cols] - height[i]) * inv).clamp(-clip, clip);
                ey[i] = 1.0;
            }
        }
    }
    // Per-cell gradient magnitude (the mean of the edges on each side) and its attenuation.
    let mut factor = vec![1f32; n];
    let (mut sum, mut count) = (0f64, 0usize);
    let side = |g: &[f32], e: &[f32], i: usize, j: Option<usize>| {
        let (mut s, mut w) = (g[i] * e[i], e[i]);
        if let Some(j) = j {
            s += g[j] * e[j];
            w += e[j];
        }
        if w > 0.0 { s / w } else { 0.0 }
    };
    let mut magnitude = vec![0f32; n];
    for y in 0..rows {
        for x in 0..cols {
            let i = y * cols + x;
            if !covered(i) {
                continue;
            }
            let mx = side(&gx, &ex, i, (x > 0).then(|| i - 1));
            let my = side(&gy, &ey, i, (y > 0).then(|| i - cols));
            let m = mx.hypot(my);
            magnitude[i] = m;
            if m > 1e-6 {
                sum += f64::from(m);
                count += 1;
            }
        }
    }
    let a = if count > 0 {
        (params.threshold as f64 * sum / count as f64) as f32
    } else {
        1.0
    };
    for i in 0..n {
        let m = magnitude[i];
        if m > a {
            factor[i] = (m / a).powf(params.power - 1.0);
        }
        if !emphasis.is_empty() {
            factor[i] *= emphasis[i];
        }
    }
    for y in 0..rows {
        for x in 0..cols {
            let i = y * cols + x;
            if ex[i] > 0.0 {
                gx[i] *= 0.5 * (factor[i] + factor[i + 1]);
            }
            if ey[i] > 0.0 {
                gy[i] *= 0.5 * (factor[i] + factor[i + cols]);
            }
        }
    }
    if params.boost > 0.0 {
        // Both components are blurred with the covered cells as weights (an edge's own
        // validity differs from its cell's only along the border), so the two normalising
        // blurs are shared.
        let weights: Vec<f32> = (0..n).map(|i| f32::from(u8::from(covered(i)))).collect();
        let norm_low = Normaliser::new(&weights, cols, rows, params.sigma_low);
        let norm_high = Normaliser::new(&weights, cols, rows, params.sigma_high);
        for (g, e) in [(&mut gx, &ex), (&mut gy, &ey)] {
            let low = norm_low.blur(g, &weights, cols, rows);
            let rest: Vec<f32> = g.iter().zip(&low).map(|(g, l)| g - l).collect();
            let high = norm_high.blur(&rest, &weights, cols, rows);
            for i in 0..n {
                g[i] += params.boost * high[i] * e[i];
            }
        }
    }
    // Divergence (backward differences), in height units: the Poisson equation on the grid is
    // sum(neighbours) - 4 h = div.
    let mut rhs = vec![0f32; n];
    for y in 0..rows {
        for x in 0..cols {
            let i = y * cols + x;
            if !covered(i) {
                continue;
            }
            let mut d = gx[i] + gy[i];
            if x > 0 {
                d -= gx[i - 1];
            }
            if y > 0 {
                d -= gy[i - cols];
            }
            // A h = 4 h - sum(neighbours) = -div.
            rhs[i] = -d * cell;
        }
    }
    let solve_mask: Vec<bool> = (0..n).map(covered).collect();
    let mut solver = Poisson::new(&solve_mask, cols, rows);
    let mut h = if initial.is_empty() {
        vec![0f32; n]
    } else {
        initial
            .iter()
            .map(|v| if v.is_finite() { *v } else { 0.0 })
            .collect()
    };
    let report = solver.solve(&rhs, &mut h, params.tolerance, 200);
    Ok((h, report))
}

#[cfg(test)]
mod tests {
    use super::super::blur::{box_columns, box_line};
    use super::*;

    fn disk(cols: usize, rows: usize, r: f32) -> Vec<bool> {
        let (cx, cy) = (cols as f32 / 2.0, rows as f32 / 2.0);
        (0..cols * rows)
            .map(|i| ((i % cols) as f32 - cx).hypot((i / cols) as f32 - cy) < r)
            .collect()
    }

    /// A h for a field (uncovered cells 0).
    fn apply(h: &[f32], mask: &[bool], cols: usize, rows: usize) -> Vec<f32> {
        let at = |x: isize, y: isize| {
            if x < 0 || y < 0 || x >= cols as isize || y >= rows as isize {
                0.0
            } else {
                let i = y as usize * cols + x as usize;
                if mask[i] { h[i] } else { 0.0 }
            }
        };
        (0..cols * rows)
            .map(|i| {
                if !mask[i] {
                    return 0.0;
                }
                let (x, y) = ((i % cols) as isize, (i / cols) as isize);
                4.0 * at(x, y) - at(x - 1, y) - at(x + 1, y) - at(x, y - 1) - at(x, y + 1)
            })
            .collect()
    }

    #[test]
    fn poisson_recovers_a_known_field_on_irregular_masks() {
        for (cols, rows) in [(7, 5), (64, 48), (221, 281)] {
            // A disk with a notch and a hole: the solver must cope with any shape.
            let mut mask = disk(cols, rows, cols.min(rows) as f32 * 0.45);
            for (i, m) in mask.iter_mut().enumerate() {
                let (x, y) = (i % cols, i / cols);
                if (x * 3 / cols == 1 && y < rows / 2) || (x + y) % 37 == 0 {
                    *m = false;
                }
            }
            let truth: Vec<f32> = (0..cols * rows)
                .map(|i| {
                    let (x, y) = ((i % cols) as f32, (i / cols) as f32);
                    if mask[i] {
                        (x * 0.21).sin() * 3.0 + (y * 0.13).cos() * 2.0 + 0.01 * x * y
                    } else {
                        0.0
                    }
                })
                .collect();
            let rhs = apply(&truth, &mask, cols, rows);
            let mut h = vec![0f32; cols * rows];
            let mut solver = Poisson::new(&mask, cols, rows);
            let report = solver.solve(&rhs, &mut h, 1e-6, 200);
            let worst = h
                .iter()
                .zip(&truth)
                .map(|(a, b)| (a - b).abs())
                .fold(0f32, f32::max);
            println!("{cols}x{rows}: {report:?}, worst error {worst:.2e}");
            assert!(report.relative_residual <= 1e-6, "{report:?}");
            assert!(worst < 2e-3, "{cols}x{rows}: worst error {worst}");
            // The preconditioner earns its keep: plain conjugate gradients need about as many
            // iterations as the domain is wide (here some 200) for this accuracy.
            if cols > 100 {
                assert!(report.iterations < 60, "{report:?}");
            }
        }
    }

    #[test]
    fn poisson_handles_empty_and_tiny_masks() {
        let mut solver = Poisson::new(&[false; 12], 4, 3);
        let mut h = vec![1.0; 12];
        let report = solver.solve(&[0.0; 12], &mut h, 1e-6, 10);
        assert_eq!(report.unknowns, 0);
        assert!(h.iter().all(|v| *v == 0.0));
        let mut one = [false; 9];
        one[4] = true;
        let mut solver = Poisson::new(&one, 3, 3);
        let mut h = vec![0.0; 9];
        solver.solve(&[8.0; 9], &mut h, 1e-9, 10);
        assert!((h[4] - 2.0).abs() < 1e-6, "{h:?}");
    }

    /// A dome with a fine ripple and a cliff: the compressed relief keeps the ripple's share of
    /// the height range far above a linear scale-down, and the cliff no longer takes the depth.
    #[test]
    fn compression_keeps_detail_and_flattens_jumps() {
        let (cols, rows, cell) = (120usize, 100usize, 1.0f32);
        let mask = disk(cols, rows, 46.0);
        let base = |x: f32, y: f32| {
            let r2 = ((x - 60.0).powi(2) + (y - 50.0).powi(2)) / (46.0f32 * 46.0);
            60.0 * (1.0 - r2).max(0.0).sqrt() + if x > 75.0 { 40.0 } else { 0.0 }
        };
        let ripple = |x: f32, y: f32| 0.8 * (x * 0.9).sin() * (y * 0.7).cos();
        let height: Vec<f32> = (0..cols * rows)
            .map(|i| {
                let (x, y) = ((i % cols) as f32, (i / cols) as f32);
                base(x, y) + ripple(x, y)
            })
            .collect();
        let (h, report) = compress(
            &height,
            &mask,
            &[],
            &[],
            cols,
            rows,
            cell,
            &Compression::default(),
        )
        .unwrap();
        assert!(report.relative_residual <= SOLVE_TOLERANCE, "{report:?}");
        assert!(h.iter().all(|v| v.is_finite()));
        // Outside the mask and on its border the relief is 0.
        assert!(h.iter().zip(&mask).all(|(v, m)| *m || *v == 0.0));
        // Ripple amplitude relative to the height range, before and after: the high-pass of
        // the field (minus a 3-cell box mean) over the inner disk.
        let detail = |f: &[f32]| {
            let mut s = 0f64;
            let mut n = 0usize;
            for y in 20..80 {
                for x in 20..100 {
                    let (fx, fy) = (x as f32, y as f32);
                    if (fx - 60.0).hypot(fy - 50.0) > 38.0 || (fx - 75.0).abs() < 4.0 {
                        continue;
                    }
                    let i = y * cols + x;
                    let mean = (f[i - 1] + f[i + 1] + f[i - cols] + f[i + cols]) / 4.0;
                    s += f64::from(f[i] - mean).powi(2);
                    n += 1;
                }
            }
            (s / n as f64).sqrt() as f32
        };
        let range = |f: &[f32]| f.iter().cloned().fold(0f32, f32::max);
        let before = detail(&height) / range(&height);
        let after = detail(&h) / range(&h);
        println!("detail share of the range: {before:.4} -> {after:.4}");
        assert!(after > 3.0 * before, "{before} -> {after}");
        // The cliff: a 40-unit jump in 100 was 40 % of the range; now a small step.
        let jump = |f: &[f32]| {
            let i = 50 * cols + 75;
            (f[i + 1] - f[i]).abs() / range(f)
        };
        println!("cliff share: {:.3} -> {:.3}", jump(&height), jump(&h));
        assert!(jump(&h) < 0.25 * jump(&height));
    }

    /// Starting from a previous result of a slightly different field needs fewer iterations
    /// and reaches the same relief (within the tolerance).
    #[test]
    fn a_warm_start_saves_iterations() {
        let (cols, rows, cell) = (90usize, 80usize, 1.0f32);
        let mask = disk(cols, rows, 36.0);
        let field = |shift: f32| -> Vec<f32> {
            (0..cols * rows)
                .map(|i| {
                    let (x, y) = ((i % cols) as f32 + shift, (i / cols) as f32);
                    let r2 = ((x - 45.0).powi(2) + (y - 40.0).powi(2)) / (36.0f32 * 36.0);
                    50.0 * (1.0 - r2).max(0.0).sqrt() + 2.0 * (x * 0.5).sin()
                })
                .collect()
        };
        let p = Compression::default();
        let (first, _) = compress(&field(0.0), &mask, &[], &[], cols, rows, cell, &p).unwrap();
        let next = field(0.3);
        let (cold, c) = compress(&next, &mask, &[], &[], cols, rows, cell, &p).unwrap();
        let (warm, w) = compress(&next, &mask, &[], &first, cols, rows, cell, &p).unwrap();
        println!("cold {c:?}, warm {w:?}");
        assert!(w.iterations < c.iterations, "cold {c:?} warm {w:?}");
        let range = cold.iter().cloned().fold(0f32, f32::max);
        let worst = cold
            .iter()
            .zip(&warm)
            .map(|(a, b)| (a - b).abs())
            .fold(0f32, f32::max);
        assert!(worst < 0.01 * range, "{worst} of {range}");
    }

    #[test]
    fn blur_is_normalised_and_ignores_unweighted_cells() {
        let (cols, rows) = (30, 20);
        let values: Vec<f32> = (0..cols * rows)
            .map(|i| if i % cols < 15 { 5.0 } else { 100.0 })
            .collect();
        let weights: Vec<f32> = (0..cols * rows)
            .map(|i| if i % cols < 15 { 1.0 } else { 0.0 })
            .collect();
        let b = blur_weighted(&values, &weights, cols, rows, 3.0);
        // Only the weighted (constant 5) cells count, wherever they are blurred to.
        assert!(
            b.iter().all(|v| (*v - 5.0).abs() < 1e-3 || *v == 0.0),
            "{b:?}"
        );
        let ones = vec![1.0; cols * rows];
        let b = blur_weighted(&values, &ones, cols, rows, 2.0);
        assert!(b.iter().all(|v| (4.999..=100.001).contains(v)), "{b:?}");
    }

    #[test]
    fn column_boxes_equal_row_boxes_of_the_transpose() {
        let (cols, rows) = (13, 29);
        let field: Vec<f32> = (0..cols * rows)
            .map(|i| ((i * 7919) % 101) as f32)
            .collect();
        for r in [1, 2, 5, 20] {
            let mut down = field.clone();
            let mut scratch = Vec::new();
            box_columns(&mut down, cols, rows, r, &mut scratch);
            for x in 0..cols {
                let column: Vec<f32> = (0..rows).map(|y| field[y * cols + x]).collect();
                box_line(&column, r, &mut scratch);
                for y in 0..rows {
                    assert!(
                        (scratch[y] - down[y * cols + x]).abs() < 1e-3,
                        "r {r} ({x}, {y})"
                    );
                }
            }
        }
        // The uniform blur equals the weighted one with unit weights.
        let a = blur(&field, cols, rows, 2.5);
        let b = blur_weighted(&field, &vec![1.0; cols * rows], cols, rows, 2.5);
        assert!(a.iter().zip(&b).all(|(a, b)| (a - b).abs() < 1e-3));
    }

    #[test]
    fn bad_parameters_are_named() {
        let p = Compression {
            power: 1.5,
            ..Compression::default()
        };
        assert!(matches!(
            p.validate(),
            Err(ReliefError::Param { what: "power", .. })
        ));
        assert!(matches!(
            compress(
                &[1.0; 4],
                &[true; 3],
                &[],
                &[],
                2,
                2,
                1.0,
                &Compression::default()
            ),
            Err(ReliefError::Size { .. })
        ));
    }
}
