//! Gauss-Newton normal equations of the fitting objective, for any block of parameters: the
//! camera's six, the first identity coefficients, the expressions. One routine serves the
//! first iteration's block solves (identity alone, expressions alone) and the joint steps.
//!
//! Units: image residuals in pixels, weighted by `1 / (s sigma)^2` (i.e. measured in model
//! millimetres); closed-lip residuals in mm. Matrices are row-major `p x p`, `p` =
//! [`Params::len`]; only their upper triangle is filled in.
//!
//! With an affine camera (scaled orthographic) the Jacobian of a point's projection does not
//! depend on the point, so the mapped landmarks' part of the Hessian comes from second moments
//! of the basis rows summed once per model ([`BasisProducts`]), and gradient and camera cross
//! terms from first moments (nine short multiply-adds per landmark); only the outline
//! correspondences and closed lips need rows of their own. Against a Gram product over two
//! rows per landmark this cut a no-contour fit's Hessian cost by about 5x.

use std::borrow::Cow;

use nalgebra::{Matrix2x3, Vector3};

use super::{Camera, Coefficients, Correspondence, linalg};
use crate::shapemodel::{AXIS_PAIRS, BasisProducts, SurreyModel};
use crate::simd::with_avx2;

/// Which parameters a linearisation covers, in this order: camera (6, in the order of
/// [`Camera::update`]) if `camera`, the first `identity` identity coefficients, the first
/// `expressions` expression coefficients.
#[derive(Clone, Copy, Debug)]
pub(super) struct Params {
    pub camera: bool,
    pub identity: usize,
    pub expressions: usize,
}

impl Params {
    pub fn cameras(&self) -> usize {
        if self.camera { 6 } else { 0 }
    }

    pub fn coefficients(&self) -> usize {
        self.identity + self.expressions
    }

    pub fn len(&self) -> usize {
        self.cameras() + self.coefficients()
    }
}

/// Sums over the first `count` correspondences of every list the loop builds (the mapped
/// landmarks present), for an affine camera: second moments of the basis rows (the model's,
/// less the missing landmarks') and first moments that depend on the landmarks only.
pub(super) struct FixedProducts<'a> {
    pub count: usize,
    pub products: Cow<'a, BasisProducts>,
    /// `N_a = sum_v m_va` per axis `a` (all identity and expression columns).
    basis: [Vec<f64>; 3],
    /// `U_ra = sum_v u_vr m_va`, image coordinate `r` (y up) times basis row.
    image: [[Vec<f64>; 3]; 2],
}

impl<'a> FixedProducts<'a> {
    /// The model's products over all mapped landmarks, less those of the `missing` vertices;
    /// `mapped` are the landmarks present.
    pub fn new(model: &'a SurreyModel, mapped: &[Correspondence], missing: &[usize]) -> Self {
        // Whichever is fewer: take the missing landmarks' products out of the model's, or add
        // up the present ones'.
        let products = if missing.len() <= mapped.len() {
            let mut products = Cow::Borrowed(model.landmark_products());
            if !missing.is_empty() {
                products.to_mut().add_vertices(&model.packed, missing, -1.0);
            }
            products
        } else {
            let cols = model.packed.identity + model.packed.expressions;
            let mut products = BasisProducts::new(cols);
            let present: Vec<usize> = mapped.iter().map(|c| c.vertex).collect();
            products.add_vertices(&model.packed, &present, 1.0);
            Cow::Owned(products)
        };
        let (basis, image) = first_moments(model, mapped);
        FixedProducts {
            count: mapped.len(),
            products,
            basis,
            image,
        }
    }
}

with_avx2! {
    /// `(N_a, U_ra)` of [`FixedProducts`].
    fn first_moments / first_moments_avx2 => first_moments_generic
        (model: &SurreyModel, mapped: &[Correspondence]) -> ([Vec<f64>; 3], [[Vec<f64>; 3]; 2])
}

#[inline(always)]
fn first_moments_generic(
    model: &SurreyModel,
    mapped: &[Correspondence],
) -> ([Vec<f64>; 3], [[Vec<f64>; 3]; 2]) {
    let cols = model.packed.identity + model.packed.expressions;
    let mut basis: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; cols]);
    let mut image: [[Vec<f64>; 3]; 2] =
        std::array::from_fn(|_| std::array::from_fn(|_| vec![0.0; cols]));
    for c in mapped {
        for (axis, n) in basis.iter_mut().enumerate() {
            let row = basis_row(model, c.vertex, axis);
            add_scaled(n, row, 1.0);
            add_scaled(&mut image[0][axis], row, c.image_up.x);
            add_scaled(&mut image[1][axis], row, c.image_up.y);
        }
    }
    (basis, image)
}

/// Vertex `v`'s basis row for `axis`: identity then expression columns.
#[inline(always)]
fn basis_row(model: &SurreyModel, v: usize, axis: usize) -> &[f32] {
    model.packed.basis(3 * v + axis)
}

/// `d += f x` for an f32 source.
#[inline(always)]
fn add_scaled(d: &mut [f64], x: &[f32], f: f64) {
    let n = d.len().min(x.len());
    let (d, x) = (&mut d[..n], &x[..n]);
    for j in 0..n {
        d[j] += f * x[j] as f64;
    }
}

/// Weights of the two kinds of residual.
#[derive(Clone, Copy, Debug)]
pub(super) struct Weights {
    /// Image residuals, pixels^-2.
    pub landmarks: f64,
    /// Closed-lip gaps, mm^-2.
    pub lips: f64,
}

/// The linearisation point.
pub(super) struct At<'a, C> {
    pub camera: &'a C,
    pub shape: &'a [f32],
    pub expression: &'a [f32],
}

/// Normal equations at a point, with the residuals' sums of squares there.
pub(super) struct Linearised {
    pub h: Vec<f64>,
    pub g: Vec<f64>,
    /// Unweighted squared image residuals, pixels^2.
    pub rss_px: f64,
    /// Unweighted squared closed-lip gaps, mm^2.
    pub lips_mm2: f64,
}

with_avx2! {
    /// `(H, g)` with `H = J^T W J` and `g = J^T W r`: `r` the residuals (image point minus
    /// projection, along the normal for sliding outline points; lower minus upper lip vertex in
    /// 3D for closed lips), `J` their derivative with respect to `params`. A Gauss-Newton step is
    /// `H delta = g`. Only the upper triangle of `H` is filled in (all that the Cholesky
    /// factorisation reads; [`mirror_upper`] completes it). `H` is built in `buffer`, whose
    /// contents do not matter (pass an old `H` to save an allocation).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn normal_equations<C: Camera> / normal_equations_avx2 => normal_equations_generic (
        model: &SurreyModel,
        corr: &[Correspondence],
        closed_lips: &[(usize, usize)],
        at: &At<C>,
        params: Params,
        weights: Weights,
        fixed: Option<&FixedProducts>,
        buffer: Vec<f64>,
    ) -> Linearised
}

#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn normal_equations_generic<C: Camera>(
    model: &SurreyModel,
    corr: &[Correspondence],
    closed_lips: &[(usize, usize)],
    at: &At<C>,
    params: Params,
    weights: Weights,
    fixed: Option<&FixedProducts>,
    buffer: Vec<f64>,
) -> Linearised {
    let p = params.len();
    // A reused buffer (hot in cache, no allocation) when the caller has one.
    let mut h = buffer;
    h.clear();
    h.resize(p * p, 0.0);
    let mut g = vec![0f64; p];
    let k = Coefficients::new(model, at.shape, at.expression);
    let mut sums = (0f64, 0f64);
    let affine = fixed
        .filter(|f| f.count <= corr.len())
        .zip(at.camera.affine_jacobian());
    let count = match affine {
        Some((fixed, jx)) => {
            add_fixed(
                model,
                &corr[..fixed.count],
                at,
                &k,
                params,
                weights.landmarks,
                fixed,
                &jx,
                &mut h,
                &mut g,
                &mut sums.0,
            );
            fixed.count
        }
        None => 0,
    };
    add_rows(
        model,
        &corr[count..],
        closed_lips,
        at,
        &k,
        params,
        weights,
        &mut h,
        &mut g,
        &mut sums,
    );
    Linearised {
        h,
        g,
        rss_px: sums.0,
        lips_mm2: sums.1,
    }
}

/// The coefficient columns of `params` as runs of basis-product columns:
/// `(first parameter, first product column, length)`.
fn coefficient_runs(params: Params, identity_columns: usize) -> [(usize, usize, usize); 2] {
    let c = params.cameras();
    [
        (c, 0, params.identity),
        (c + params.identity, identity_columns, params.expressions),
    ]
}

/// Runs that continue each other in both parameters and product columns (all identity
/// coefficients, then the expressions) as one.
fn merge_runs(runs: &[(usize, usize, usize); 2]) -> Vec<(usize, usize, usize)> {
    let [(p0, c0, l0), (p1, c1, l1)] = *runs;
    if p0 + l0 == p1 && c0 + l0 == c1 {
        vec![(p0, c0, l0 + l1)]
    } else {
        runs.iter().copied().filter(|r| r.2 > 0).collect()
    }
}

/// `d += sum_t f[t] s[t]`: one pass over the output for the six basis-product matrices.
#[inline(always)]
fn combine6(d: &mut [f64], s: [&[f64]; 6], f: [f64; 6]) {
    let n = s.iter().fold(d.len(), |n, s| n.min(s.len()));
    let d = &mut d[..n];
    let [s0, s1, s2, s3, s4, s5] = s;
    let (s0, s1, s2, s3, s4, s5) = (&s0[..n], &s1[..n], &s2[..n], &s3[..n], &s4[..n], &s5[..n]);
    for j in 0..n {
        d[j] += ((f[0] * s0[j] + f[1] * s1[j]) + (f[2] * s2[j] + f[3] * s3[j]))
            + (f[4] * s4[j] + f[5] * s5[j]);
    }
}

/// The mapped landmarks' part through moments of the basis rows (see the module doc): the
/// coefficient block from the second moments `Q_ab`; gradient and camera cross terms from the
/// first moments `S_ea = sum_v x_ve m_va` (accumulated here, nine short multiply-adds per
/// landmark), `N_a` and `U_ra`, using that an affine camera's projection and parameter
/// Jacobian are affine in the point.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn add_fixed<C: Camera>(
    model: &SurreyModel,
    corr: &[Correspondence],
    at: &At<C>,
    coefficients: &Coefficients,
    params: Params,
    w: f64,
    fixed: &FixedProducts,
    jx: &Matrix2x3<f64>,
    h: &mut [f64],
    g: &mut [f64],
    rss: &mut f64,
) {
    let p = params.len();
    let runs = coefficient_runs(params, model.packed.identity);
    let products = &fixed.products;
    let cols = products.columns;
    // Coefficient block: sum over axis pairs of (J^T J)_ab Q_ab.
    let jj = jx.transpose() * jx;
    let pair_weights = AXIS_PAIRS.map(|(a, b)| w * jj[(a, b)]);
    // Upper triangle only, mirrored below (the six matrices are symmetric).
    let merged = merge_runs(&runs);
    for &(row_param, row_col, rows) in &runs {
        for r in 0..rows {
            let i = row_param + r;
            let dst = &mut h[i * p..(i + 1) * p];
            let at_col = |col: usize| (row_col + r) * cols + col;
            for &(param, col, len) in &merged {
                // The part of this run on or right of the diagonal.
                let skip = i.saturating_sub(param).min(len);
                let (param, col, len) = (param + skip, col + skip, len - skip);
                let s = &products.sums;
                let (a, b) = (at_col(col), at_col(col) + len);
                let src = [
                    &s[0][a..b],
                    &s[1][a..b],
                    &s[2][a..b],
                    &s[3][a..b],
                    &s[4][a..b],
                    &s[5][a..b],
                ];
                combine6(&mut dst[param..param + len], src, pair_weights);
            }
        }
    }
    // Per landmark: first moments, and the camera's own block and gradient.
    // Only over the product columns the parameters use (the block solves need six or 63).
    let lo = runs
        .iter()
        .filter(|r| r.2 > 0)
        .map(|r| r.1)
        .min()
        .unwrap_or(0);
    let hi = runs.iter().map(|r| r.1 + r.2).max().unwrap_or(0).max(lo);
    // moments[a][e] = S_ea.
    let mut moments: [[Vec<f64>; 3]; 3] =
        std::array::from_fn(|_| std::array::from_fn(|_| vec![0f64; cols]));
    for c in corr {
        debug_assert!(c.blend.is_none() && c.normal.is_none());
        let x = model.point(c.vertex, coefficients);
        for (axis, m) in moments.iter_mut().enumerate() {
            let row = &basis_row(model, c.vertex, axis)[lo..hi];
            let [m0, m1, m2] = m;
            add_scaled3(
                [&mut m0[lo..hi], &mut m1[lo..hi], &mut m2[lo..hi]],
                row,
                [x[0], x[1], x[2]],
            );
        }
        let residual = c.image_up - at.camera.project_up(&x);
        *rss += residual.norm_squared();
        if params.camera {
            let r = residual * w;
            let jp = at.camera.parameter_jacobian(&x);
            for i in 0..6 {
                let (u, v) = (w * jp[(0, i)], w * jp[(1, i)]);
                g[i] += jp[(0, i)] * r.x + jp[(1, i)] * r.y;
                for j in i..6 {
                    h[i * p + j] += u * jp[(0, j)] + v * jp[(1, j)];
                }
            }
        }
    }
    // Coefficients' gradient: sum_a sum_r J_ra (U_ra - t_r N_a - sum_e J_re S_ea).
    let origin = at.camera.project_up(&Vector3::zeros());
    let mut grad = vec![0f64; cols];
    for a in 0..3 {
        for (r, t) in [origin.x, origin.y].into_iter().enumerate() {
            add_scaled64(&mut grad, &fixed.image[r][a], jx[(r, a)]);
            add_scaled64(&mut grad, &fixed.basis[a], -jx[(r, a)] * t);
        }
        for e in 0..3 {
            add_scaled64(&mut grad, &moments[a][e], -jj[(a, e)]);
        }
    }
    for &(param, col, len) in &runs {
        for (gk, v) in g[param..param + len].iter_mut().zip(&grad[col..col + len]) {
            *gk += w * v;
        }
    }
    if params.camera {
        // Cross terms: with jp(x) = A_0 + sum_e x_e A_e,
        // C_k = sum_r sum_a J_ra (A_0[r][k] N_a + sum_e A_e[r][k] S_ea).
        let a0 = at.camera.parameter_jacobian(&Vector3::zeros());
        let ae = [0, 1, 2].map(|e| {
            at.camera
                .parameter_jacobian(&Vector3::from_fn(|i, _| if i == e { 1.0 } else { 0.0 }))
                - a0
        });
        let mut cross = vec![0f64; cols];
        for k in 0..6 {
            cross.fill(0.0);
            for a in 0..3 {
                let f0 = jx[(0, a)] * a0[(0, k)] + jx[(1, a)] * a0[(1, k)];
                add_scaled64(&mut cross, &fixed.basis[a], f0);
                for (e, ae) in ae.iter().enumerate() {
                    let f = jx[(0, a)] * ae[(0, k)] + jx[(1, a)] * ae[(1, k)];
                    add_scaled64(&mut cross, &moments[a][e], f);
                }
            }
            for &(param, col, len) in &runs {
                for (d, v) in h[k * p + param..k * p + param + len]
                    .iter_mut()
                    .zip(&cross[col..col + len])
                {
                    *d += w * v;
                }
            }
        }
    }
}

/// `d[e] += f[e] x` for three outputs, reading (and widening) `x` once.
#[inline(always)]
fn add_scaled3(d: [&mut [f64]; 3], x: &[f32], f: [f64; 3]) {
    let [d0, d1, d2] = d;
    let n = x.len().min(d0.len()).min(d1.len()).min(d2.len());
    let (d0, d1, d2, x) = (&mut d0[..n], &mut d1[..n], &mut d2[..n], &x[..n]);
    for j in 0..n {
        let v = x[j] as f64;
        d0[j] += f[0] * v;
        d1[j] += f[1] * v;
        d2[j] += f[2] * v;
    }
}

/// `d += f x`.
#[inline(always)]
fn add_scaled64(d: &mut [f64], x: &[f64], f: f64) {
    let n = d.len().min(x.len());
    let (d, x) = (&mut d[..n], &x[..n]);
    for j in 0..n {
        d[j] += f * x[j];
    }
}

/// Everything else, row by row: outline correspondences (blended vertices, sliding normals),
/// any correspondence when the camera is not affine, and the closed lips.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn add_rows<C: Camera>(
    model: &SurreyModel,
    corr: &[Correspondence],
    closed_lips: &[(usize, usize)],
    at: &At<C>,
    coefficients: &Coefficients,
    params: Params,
    weights: Weights,
    h: &mut [f64],
    g: &mut [f64],
    sums: &mut (f64, f64),
) {
    sums.1 += add_lips(model, closed_lips, coefficients, params, weights.lips, h, g);
    let rows = 2 * corr.len();
    if rows == 0 {
        return;
    }
    let p = params.len();
    let cams = params.cameras();
    // Column-major, rows scaled by the square root of their weight.
    let mut a = vec![0f64; rows * p];
    let mut t = vec![0f64; rows];
    let sw = weights.landmarks.sqrt();
    let basis_rows = |v: usize| {
        [0, 1, 2].map(|axis| {
            let (_, identity, expr) = model.packed.row(3 * v + axis);
            (&identity[..params.identity], &expr[..params.expressions])
        })
    };
    let mut d = vec![[0f64; 2]; p];
    for (i, c) in corr.iter().enumerate() {
        let x = c.position(model, coefficients);
        let r = c.image_up - at.camera.project_up(&x);
        let jx = at.camera.jacobian(&x);
        if params.camera {
            let jp = at.camera.parameter_jacobian(&x);
            for k in 0..6 {
                d[k] = [jp[(0, k)], jp[(1, k)]];
            }
        }
        let first = basis_rows(c.vertex);
        let second = c.blend.map(|(v2, t)| (basis_rows(v2), t));
        for k in 0..params.coefficients() {
            let coef = |rows: &[(&[f32], &[f32]); 3], axis: usize| {
                let (identity, expr) = rows[axis];
                (if k < params.identity {
                    identity[k]
                } else {
                    expr[k - params.identity]
                }) as f64
            };
            let mut m = [0, 1, 2].map(|axis| coef(&first, axis));
            if let Some((rows2, t)) = &second {
                for (axis, v) in m.iter_mut().enumerate() {
                    *v = (1.0 - t) * *v + t * coef(rows2, axis);
                }
            }
            d[cams + k] = [
                jx[(0, 0)] * m[0] + jx[(0, 1)] * m[1] + jx[(0, 2)] * m[2],
                jx[(1, 0)] * m[0] + jx[(1, 1)] * m[1] + jx[(1, 2)] * m[2],
            ];
        }
        sums.0 += match c.normal {
            Some(n) => n.dot(&r).powi(2),
            None => r.norm_squared(),
        };
        match c.normal {
            Some(n) => {
                for (k, dk) in d.iter().enumerate() {
                    a[k * rows + 2 * i] = sw * (n.x * dk[0] + n.y * dk[1]);
                }
                t[2 * i] = sw * n.dot(&r);
            }
            None => {
                for (k, dk) in d.iter().enumerate() {
                    a[k * rows + 2 * i] = sw * dk[0];
                    a[k * rows + 2 * i + 1] = sw * dk[1];
                }
                t[2 * i] = sw * r.x;
                t[2 * i + 1] = sw * r.y;
            }
        }
    }
    let (gram, rhs) = linalg::gram(&a, rows, p, &t);
    h.iter_mut().zip(&gram).for_each(|(d, s)| *d += s);
    g.iter_mut().zip(&rhs).for_each(|(d, s)| *d += s);
}

/// Closed lips: per axis, the residual `lower - upper` (mm) and its derivative, the difference
/// of the two vertices' basis rows, added as rank-one updates of the coefficient block (they
/// do not involve the camera, and a Gram product over nine rows costs more than the updates).
#[inline(always)]
fn add_lips(
    model: &SurreyModel,
    closed_lips: &[(usize, usize)],
    coefficients: &Coefficients,
    params: Params,
    weight: f64,
    h: &mut [f64],
    g: &mut [f64],
) -> f64 {
    let (p, cams, n) = (params.len(), params.cameras(), params.coefficients());
    let mut d = vec![0f64; n];
    let mut sum = 0.0;
    for &(upper, lower) in closed_lips {
        let gap = model.point(upper, coefficients) - model.point(lower, coefficients);
        sum += gap.norm_squared();
        for axis in 0..3 {
            let (_, iu, eu) = model.packed.row(3 * upper + axis);
            let (_, il, el) = model.packed.row(3 * lower + axis);
            let (ki, ke) = (params.identity, params.expressions);
            let diffs = iu[..ki]
                .iter()
                .zip(&il[..ki])
                .chain(eu[..ke].iter().zip(&el[..ke]));
            for (dk, (u, l)) in d.iter_mut().zip(diffs) {
                *dk = (u - l) as f64;
            }
            for (i, &di) in d.iter().enumerate() {
                g[cams + i] -= weight * di * gap[axis];
                // Upper triangle only, like the rest of H here.
                let f = weight * di;
                let row = &mut h[(cams + i) * p + cams + i..(cams + i + 1) * p];
                row.iter_mut()
                    .zip(&d[i..])
                    .for_each(|(hk, dk)| *hk += f * dk);
            }
        }
    }
    sum
}

/// Copies the upper triangle of a row-major `n x n` matrix below the diagonal.
pub(super) fn mirror_upper(h: &mut [f64], n: usize) {
    for i in 0..n {
        for j in i + 1..n {
            h[j * n + i] = h[i * n + j];
        }
    }
}

/// `H x` for a row-major `n x n` matrix.
pub(super) fn multiply(h: &[f64], x: &[f64]) -> Vec<f64> {
    let n = x.len();
    h.chunks_exact(n)
        .map(|row| row.iter().zip(x).map(|(a, b)| a * b).sum())
        .collect()
}

/// Right-hand side for solving a block's coefficients outright rather than a step:
/// `H x_current + g` (exact for the orthographic camera, one Gauss-Newton step otherwise).
pub(super) fn absolute_rhs(h: &[f64], g: &[f64], current: &[f32]) -> Vec<f64> {
    let x: Vec<f64> = current.iter().map(|&v| v as f64).collect();
    multiply(h, &x).iter().zip(g).map(|(a, b)| a + b).collect()
}
