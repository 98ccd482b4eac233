//! The Poisson solve of the bas-relief: conjugate gradients preconditioned with a multigrid
//! V-cycle, on a grid with h = 0 outside the covered cells. Heights and the cell size in the
//! same unit.

/// How the Poisson solve went.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolveReport {
    pub iterations: usize,
    /// Final residual norm over the right-hand side's norm.
    pub relative_residual: f32,
    /// Covered cells (unknowns).
    pub unknowns: usize,
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
