//! Fast Gaussian blurs on the relief grid: three box passes per axis (a running sum, so the
//! cost does not grow with the radius), and a weighted form that ignores uncovered cells.

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
pub(super) struct Normaliser {
    radius: usize,
    den: Vec<f32>,
}

impl Normaliser {
    pub(super) fn new(weights: &[f32], cols: usize, rows: usize, sigma: f32) -> Self {
        let radius = box_radius(sigma);
        let mut den = weights.to_vec();
        box3(&mut den, cols, rows, radius, &mut Vec::new());
        Normaliser { radius, den }
    }

    /// [`blur_weighted`] of `values` with the weights given to [`Normaliser::new`].
    pub(super) fn blur(
        &self,
        values: &[f32],
        weights: &[f32],
        cols: usize,
        rows: usize,
    ) -> Vec<f32> {
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
pub(super) fn box_radius(sigma: f32) -> usize {
    (((sigma * sigma + 0.25).sqrt() - 0.5).round() as usize).max(1)
}

/// Three box passes along rows, then three along columns.
pub(super) fn box3(field: &mut [f32], cols: usize, rows: usize, r: usize, scratch: &mut Vec<f32>) {
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
pub(super) fn box_line(src: &[f32], r: usize, dst: &mut Vec<f32>) {
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
pub(super) fn box_columns(
    field: &mut [f32],
    cols: usize,
    rows: usize,
    r: usize,
    acc: &mut Vec<f32>,
) {
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
