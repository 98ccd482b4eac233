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

/// How the Poisson solve went.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolveReport {
    pub iterations: usize,
    /// Final residual norm over the right-hand side's norm.
    pub relative_residual: f32,
    /// Covered cells (unknowns).
    pub unknowns: usize,
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

/// A Gaussian-like blur of `values` weighted by `weights` (0 = ignore the cell): three passes
/// of a running box in each direction (cost independent of sigma), normalised by the blurred
/// weights. Cells of weight 0 get the blurred value of their neighbourhood (or 0).
pub fn blur_weighted(
    values: &[f32],
    weights: &[f32],
    cols: usize,
    rows: usize,
    sigma: f32,
) -> Vec<f32> {
    let mut num: Vec<f32> = values.iter().zip(weights).map(|(v, w)| v * w).collect();
    let mut den = weights.to_vec();
    let r = box_radius(sigma);
    let mut scratch = Vec::new();
    for field in [&mut num, &mut den] {
        box3(field, cols, rows, r, &mut scratch);
    }
    num.iter()
        .zip(&den)
        .map(|(n, d)| if *d > 1e-6 { n / d } else { 0.0 })
        .collect()
}

/// A weighted blur whose weights are fixed: the blurred weights are computed once and shared
/// by every field blurred with them.
struct Normaliser {
    radius: usize,
    den: Vec<f32>,
}

impl Normaliser {
    fn new(weights: &[f32], cols: usize, rows: usize, sigma: f32) -> Self {
        let radius = box_radius(sigma);
        let mut den = weights.to_vec();
        box3(&mut den, cols, rows, radius, &mut Vec::new());
        Normaliser { radius, den }
    }

    /// [`blur_weighted`] of `values` with the weights given to [`Normaliser::new`].
    fn blur(&self, values: &[f32], weights: &[f32], cols: usize, rows: usize) -> Vec<f32> {
        let mut num: Vec<f32> = values.iter().zip(weights).map(|(v, w)| v * w).collect();
        box3(&mut num, cols, rows, self.radius, &mut Vec::new());
        num.iter()
            .zip(&self.den)
            .map(|(n, d)| if *d > 1e-6 { n / d } else { 0.0 })
            .collect()
    }
}

/// [`blur_weighted`] with every weight 1 (the grid's edges still renormalised).
pub fn blur(values: &[f32], cols: usize, rows: usize, sigma: f32) -> Vec<f32> {
    let mut num = values.to_vec();
    let r = box_radius(sigma);
    let mut scratch = Vec::new();
    box3(&mut num, cols, rows, r, &mut scratch);
    // The blurred weights of an all-ones field are separable: a row factor times a column one.
    let edge = |len: usize| {
        let mut w = vec![1f32; len];
        for _ in 0..3 {
            let src = w.clone();
            box_line(&src, r, &mut w);
        }
        w
    };
    let (wx, wy) = (edge(cols), edge(rows));
    for y in 0..rows {
        for x in 0..cols {
            num[y * cols + x] /= (wx[x] * wy[y]).max(1e-6);
        }
    }
    num
}

/// Box radius whose three passes have about the variance of a Gaussian of `sigma` (three boxes
/// of width 2r + 1 have variance r (r + 1)).
fn box_radius(sigma: f32) -> usize {
    (((sigma * sigma + 0.25).sqrt() - 0.5).round() as usize).max(1)
}

/// Three box passes along rows, then three along columns.
fn box3(field: &mut [f32], cols: usize, rows: usize, r: usize, scratch: &mut Vec<f32>) {
    for _ in 0..3 {
        for y in 0..rows {
            let row = &mut field[y * cols..(y + 1) * cols];
            box_line(row, r, scratch);
            row.copy_from_slice(scratch);
        }
    }
    for _ in 0..3 {
        box_columns(field, cols, rows, r, scratch);
    }
}

/// Running box sum of width 2r + 1 along one line (values beyond the ends are 0), normalised
/// by the full width so weights and values stay comparable.
fn box_line(src: &[f32], r: usize, dst: &mut Vec<f32>) {
    let n = src.len();
    dst.clear();
    dst.resize(n, 0.0);
    let scale = 1.0 / (2 * r + 1) as f32;
    let mut acc = 0f32;
    for v in src.iter().take(r.min(n)) {
        acc += v;
    }
    for i in 0..n {
        if i + r < n {
            acc += src[i + r];
        }
        if i > r {
            acc -= src[i - r - 1];
        }
        dst[i] = acc * scale;
    }
}

/// [`box_line`] down every column at once, a row at a time (streams through memory in order).
fn box_columns(field: &mut [f32], cols: usize, rows: usize, r: usize, acc: &mut Vec<f32>) {
    let scale = 1.0 / (2 * r + 1) as f32;
    acc.clear();
    acc.resize(cols, 0.0);
    for y in 0..r.min(rows) {
        for (a, v) in acc.iter_mut().zip(&field[y * cols..(y + 1) * cols]) {
            *a += v;
        }
    }
    // Rows leave the window after they were overwritten: keep the originals of the last
    // 2r + 1 rows in a ring.
    let ring_len = 2 * r + 1;
    let mut ring = vec![0f32; ring_len * cols];
    for y in 0..rows {
        if y + r < rows {
            let add = &field[(y + r) * cols..(y + r + 1) * cols];
            for (a, v) in acc.iter_mut().zip(add) {
                *a += v;
            }
        }
        if y > r {
            let slot = (y - r - 1) % ring_len;
            for (a, v) in acc.iter_mut().zip(&ring[slot * cols..(slot + 1) * cols]) {
                *a -= v;
            }
        }
        let slot = y % ring_len;
        ring[slot * cols..(slot + 1) * cols].copy_from_slice(&field[y * cols..(y + 1) * cols]);
        for (out, a) in field[y * cols..(y + 1) * cols].iter_mut().zip(acc.iter()) {
            *out = a * scale;
        }
    }
}

/// One level of the multigrid hierarchy, stored with a border of one uncovered cell on every
/// side so that neighbour reads need no bounds checks (uncovered cells always hold 0).
#[derive(Clone, Debug)]
struct Level {
    /// Padded width and height.
    w: usize,
    h: usize,
    mask: Vec<bool>,
    /// Covered cells by colour ((x + y) even: red, odd: black), padded indices.
    colour: [Vec<u32>; 2],
    x: Vec<f32>,
    b: Vec<f32>,
    r: Vec<f32>,
}

impl Level {
    fn new(w: usize, h: usize, mask: Vec<bool>) -> Self {
        let mut colour = [Vec::new(), Vec::new()];
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                let i = y * w + x;
                if mask[i] {
                    colour[(x + y) % 2].push(i as u32);
                }
            }
        }
        Level {
            w,
            h,
            mask,
            colour,
            x: vec![0.0; w * h],
            b: vec![0.0; w * h],
            r: vec![0.0; w * h],
        }
    }

    fn unknowns(&self) -> usize {
        self.colour[0].len() + self.colour[1].len()
    }

    /// Gauss-Seidel over one colour: x = (b + sum of neighbours) / 4.
    fn relax(&mut self, colour: usize) {
        let w = self.w;
        let (x, b) = (&mut self.x, &self.b);
        for &i in &self.colour[colour] {
            let i = i as usize;
            x[i] = 0.25 * (b[i] + x[i - 1] + x[i + 1] + x[i - w] + x[i + w]);
        }
    }

    /// r = b - A x over the covered cells.
    fn residual(&mut self) {
        let w = self.w;
        let (x, b, r) = (&self.x, &self.b, &mut self.r);
        for list in &self.colour {
            for &i in list {
                let i = i as usize;
                r[i] = b[i] - (4.0 * x[i] - x[i - 1] - x[i + 1] - x[i - w] - x[i + w]);
            }
        }
    }
}

/// Poisson solver on a masked grid with h = 0 on every uncovered cell: conjugate gradients
/// preconditioned by a multigrid V-cycle (as McAdams et al. 2010 do for irregular domains). A
/// coarse cell is covered when any of its four children is; residuals are restricted by the
/// children's mean and corrections injected back, with red-black Gauss-Seidel smoothing in
/// mirrored order on the way down and up, so the preconditioner is symmetric.
#[derive(Clone, Debug)]
pub struct Poisson {
    cols: usize,
    rows: usize,
    levels: Vec<Level>,
}

/// Smoothing sweeps (each a red and a black half) before and after the coarse correction, and
/// symmetric sweeps on the coarsest level.
const PRE_SWEEPS: usize = 1;
const COARSEST_SWEEPS: usize = 30;
/// Coarsening stops at this many covered cells or fewer.
const COARSEST_UNKNOWNS: usize = 64;

impl Poisson {
    /// The hierarchy for `mask` (row-major `cols` x `rows`).
    pub fn new(mask: &[bool], cols: usize, rows: usize) -> Self {
        let (w, h) = (cols + 2, rows + 2);
        let mut m = vec![false; w * h];
        for y in 0..rows {
            for x in 0..cols {
                m[(y + 1) * w + x + 1] = mask[y * cols + x];
            }
        }
        let mut levels = vec![Level::new(w, h, m)];
        loop {
            let fine = levels.last().expect("one level at least");
            let (fc, fr) = (fine.w - 2, fine.h - 2);
            if fine.unknowns() <= COARSEST_UNKNOWNS || fc < 4 || fr < 4 {
                break;
            }
            let (cc, cr) = (fc.div_ceil(2), fr.div_ceil(2));
            let (cw, ch) = (cc + 2, cr + 2);
            let mut cm = vec![false; cw * ch];
            for y in 0..fr {
                for x in 0..fc {
                    if fine.mask[(y + 1) * fine.w + x + 1] {
                        cm[(y / 2 + 1) * cw + x / 2 + 1] = true;
                    }
                }
            }
            levels.push(Level::new(cw, ch, cm));
        }
        Poisson { cols, rows, levels }
    }

    /// Solves A h = `rhs` (A h = 4 h - the sum of the covered neighbours' h, on covered cells)
    /// to `tolerance` x |rhs|, starting from `h` (row-major, unpadded; uncovered cells are set
    /// to 0).
    pub fn solve(
        &mut self,
        rhs: &[f32],
        h: &mut [f32],
        tolerance: f32,
        max_iterations: usize,
    ) -> SolveReport {
        let (cols, w) = (self.cols, self.levels[0].w);
        let pad = |i: usize| (i / cols + 1) * w + i % cols + 1;
        let mask = self.levels[0].mask.clone();
        let n = mask.len();
        // Vectors in f32 (half the memory traffic), dot products accumulated in f64.
        let mut x = vec![0f32; n];
        let mut b = vec![0f32; n];
        for i in 0..cols * self.rows {
            let p = pad(i);
            if mask[p] {
                x[p] = h[i];
                b[p] = rhs[i];
            }
        }
        let unknowns = self.levels[0].unknowns();
        let covered: Vec<usize> = self.levels[0]
            .colour
            .iter()
            .flatten()
            .map(|&i| i as usize)
            .collect();
        let apply = |v: &[f32], out: &mut [f32]| {
            for &i in &covered {
                out[i] = 4.0 * v[i] - v[i - 1] - v[i + 1] - v[i - w] - v[i + w];
            }
        };
        let dot = |a: &[f32], b: &[f32]| {
            covered
                .iter()
                .map(|&i| f64::from(a[i]) * f64::from(b[i]))
                .sum::<f64>()
        };
        let mut r = vec![0f32; n];
        let mut q = vec![0f32; n];
        apply(&x, &mut q);
        for &i in &covered {
            r[i] = b[i] - q[i];
        }
        let norm_b = dot(&b, &b).sqrt().max(1e-30);
        let mut z = vec![0f32; n];
        self.precondition(&r, &mut z);
        let mut p = z.clone();
        let mut rz = dot(&r, &z);
        let mut report = SolveReport {
            iterations: 0,
            relative_residual: (dot(&r, &r).sqrt() / norm_b) as f32,
            unknowns,
        };
        while report.relative_residual > tolerance && report.iterations < max_iterations {
            apply(&p, &mut q);
            let pq = dot(&p, &q);
            if pq.abs() < 1e-300 {
                break;
            }
            let alpha = (rz / pq) as f32;
            for &i in &covered {
                x[i] += alpha * p[i];
                r[i] -= alpha * q[i];
            }
            report.iterations += 1;
            report.relative_residual = (dot(&r, &r).sqrt() / norm_b) as f32;
            if report.relative_residual <= tolerance {
                break;
            }
            self.precondition(&r, &mut z);
            let rz_new = dot(&r, &z);
            let beta = (rz_new / rz) as f32;
            rz = rz_new;
            for &i in &covered {
                p[i] = z[i] + beta * p[i];
            }
        }
        for (i, out) in h.iter_mut().enumerate().take(cols * self.rows) {
            let p = pad(i);
            *out = if mask[p] { x[p] } else { 0.0 };
        }
        report
    }

    /// z = one V-cycle applied to r (from z = 0).
    fn precondition(&mut self, r: &[f32], z: &mut [f32]) {
        self.levels[0].b.copy_from_slice(r);
        self.v_cycle(0);
        z.copy_from_slice(&self.levels[0].x);
    }

    fn v_cycle(&mut self, l: usize) {
        let last = self.levels.len() - 1;
        {
            let level = &mut self.levels[l];
            level.x.iter_mut().for_each(|v| *v = 0.0);
            if l == last {
                for _ in 0..COARSEST_SWEEPS {
                    level.relax(0);
                    level.relax(1);
                    level.relax(1);
                    level.relax(0);
                }
                return;
            }
            for _ in 0..PRE_SWEEPS {
                level.relax(0);
                level.relax(1);
            }
            level.residual();
        }
        // Restrict with the transpose of the prolongation (cell-centred bilinear: a fine cell
        // takes 9/16 of its parent, 3/16 of the parent's two neighbours on its side, 1/16 of
        // the diagonal one), so the preconditioner stays symmetric. The weights a fine cell
        // gives sum to 1 and each coarse cell gathers four cells' worth: its unscaled operator
        // (twice the spacing) is four times weaker, which this matches.
        {
            let (fine, coarse) = self.levels.split_at_mut(l + 1);
            let (f, c) = (&fine[l], &mut coarse[0]);
            c.b.iter_mut().for_each(|v| *v = 0.0);
            for y in 1..f.h - 1 {
                for x in 1..f.w - 1 {
                    let i = y * f.w + x;
                    if f.mask[i] {
                        let r = f.r[i];
                        for (j, w) in bilinear_parents(x, y, c.w) {
                            c.b[j] += w * r;
                        }
                    }
                }
            }
        }
        self.v_cycle(l + 1);
        {
            let (fine, coarse) = self.levels.split_at_mut(l + 1);
            let (f, c) = (&mut fine[l], &coarse[0]);
            for y in 1..f.h - 1 {
                for x in 1..f.w - 1 {
                    let i = y * f.w + x;
                    if f.mask[i] {
                        f.x[i] += bilinear_parents(x, y, c.w)
                            .iter()
                            .map(|&(j, w)| w * c.x[j])
                            .sum::<f32>();
                    }
                }
            }
            for _ in 0..PRE_SWEEPS {
                f.relax(1);
                f.relax(0);
            }
        }
    }
}

/// The four coarse cells (padded index in a level `cw` wide) a fine cell at padded (x, y)
/// interpolates from, with their cell-centred bilinear weights. The coarse grid's border of
/// uncovered cells makes every index valid.
fn bilinear_parents(x: usize, y: usize, cw: usize) -> [(usize, f32); 4] {
    let (px, py) = ((x - 1) / 2 + 1, (y - 1) / 2 + 1);
    // The neighbour on the fine cell's side of its parent.
    let nx = if (x - 1).is_multiple_of(2) {
        px - 1
    } else {
        px + 1
    };
    let ny = if (y - 1).is_multiple_of(2) {
        py - 1
    } else {
        py + 1
    };
    [
        (py * cw + px, 9.0 / 16.0),
        (py * cw + nx, 3.0 / 16.0),
        (ny * cw + px, 3.0 / 16.0),
        (ny * cw + nx, 1.0 / 16.0),
    ]
}

#[cfg(test)]
mod tests {
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
