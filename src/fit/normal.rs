//! Gauss-Newton normal equations of the fitting objective, for any block of parameters: the
//! camera's six, the first identity coefficients, the expressions. One routine serves the
//! first iteration's block solves (identity alone, expressions alone) and the joint steps.
//!
//! Units: image residuals in pixels, weighted by `1 / (s sigma)^2` (i.e. measured in model
//! millimetres); closed-lip residuals in mm. Matrices are row-major `p x p`, `p` =
//! [`Params::len`].
//!
//! With an affine camera (scaled orthographic) the Jacobian of a point's projection does not
//! depend on the point, so the mapped landmarks' part of the Hessian comes from basis products
//! summed once per model ([`BasisProducts`]); only the outline correspondences and closed lips
//! need rows of their own. That cut a no-contour fit's Hessian cost by about 5x.

use std::borrow::Cow;

use nalgebra::Matrix2x3;

use super::{Camera, Coefficients, Correspondence, linalg};
use crate::shapemodel::{AXIS_PAIRS, BasisProducts, SurreyModel};

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

/// Basis products over the first `count` correspondences of every list the loop builds (the
/// mapped landmarks present), for an affine camera.
pub(super) struct FixedProducts<'a> {
    pub count: usize,
    pub products: Cow<'a, BasisProducts>,
}

impl<'a> FixedProducts<'a> {
    /// The model's products over all mapped landmarks, less those of the `missing` vertices.
    pub fn new(model: &'a SurreyModel, count: usize, missing: &[usize]) -> Self {
        let mut products = Cow::Borrowed(model.landmark_products());
        for &v in missing {
            products.to_mut().add_vertex(&model.packed, v, -1.0);
        }
        FixedProducts { count, products }
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

/// `(H, g)` with `H = J^T W J` and `g = J^T W r`: `r` the residuals (image point minus
/// projection, along the normal for sliding outline points; lower minus upper lip vertex in
/// 3D for closed lips), `J` their derivative with respect to `params`. A Gauss-Newton step is
/// `H delta = g`.
pub(super) fn normal_equations<C: Camera>(
    model: &SurreyModel,
    corr: &[Correspondence],
    closed_lips: &[(usize, usize)],
    at: &At<C>,
    params: Params,
    weights: Weights,
    fixed: Option<&FixedProducts>,
) -> (Vec<f64>, Vec<f64>) {
    #[cfg(target_arch = "x86_64")]
    if linalg::has_avx2_fma() {
        // SAFETY: the CPU supports the features this function is compiled for (checked above).
        return unsafe {
            normal_equations_avx2(model, corr, closed_lips, at, params, weights, fixed)
        };
    }
    normal_equations_generic(model, corr, closed_lips, at, params, weights, fixed)
}

/// [`normal_equations`] compiled for AVX2 and FMA (4-wide arithmetic in the per-landmark loops
/// and the basis-product sums).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn normal_equations_avx2<C: Camera>(
    model: &SurreyModel,
    corr: &[Correspondence],
    closed_lips: &[(usize, usize)],
    at: &At<C>,
    params: Params,
    weights: Weights,
    fixed: Option<&FixedProducts>,
) -> (Vec<f64>, Vec<f64>) {
    normal_equations_generic(model, corr, closed_lips, at, params, weights, fixed)
}

#[inline(always)]
fn normal_equations_generic<C: Camera>(
    model: &SurreyModel,
    corr: &[Correspondence],
    closed_lips: &[(usize, usize)],
    at: &At<C>,
    params: Params,
    weights: Weights,
    fixed: Option<&FixedProducts>,
) -> (Vec<f64>, Vec<f64>) {
    let p = params.len();
    let mut h = vec![0f64; p * p];
    let mut g = vec![0f64; p];
    let k = Coefficients::new(model, at.shape, at.expression);
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
                &fixed.products,
                &jx,
                &mut h,
                &mut g,
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
    );
    (h, g)
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
    let [s0, s1, s2, s3, s4, s5] = s.map(|s| &s[..n]);
    for j in 0..n {
        d[j] += ((f[0] * s0[j] + f[1] * s1[j]) + (f[2] * s2[j] + f[3] * s3[j]))
            + (f[4] * s4[j] + f[5] * s5[j]);
    }
}

/// The mapped landmarks' part through the basis products (see the module doc).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn add_fixed<C: Camera>(
    model: &SurreyModel,
    corr: &[Correspondence],
    at: &At<C>,
    coefficients: &Coefficients,
    params: Params,
    w: f64,
    products: &BasisProducts,
    jx: &Matrix2x3<f64>,
    h: &mut [f64],
    g: &mut [f64],
) {
    let p = params.len();
    let cams = params.cameras();
    let k = model.packed.identity;
    let runs = coefficient_runs(params, k);
    // Coefficient block: sum over axis pairs of (J^T J)_ab Q_ab.
    let jj = jx.transpose() * jx * w;
    let pair_weights = AXIS_PAIRS.map(|(a, b)| jj[(a, b)]);
    let cols = products.columns;
    for &(row_param, row_col, rows) in &runs {
        for r in 0..rows {
            let dst = &mut h[(row_param + r) * p..(row_param + r + 1) * p];
            let at_col = |col: usize| (row_col + r) * cols + col;
            for &(param, col, len) in &merge_runs(&runs) {
                let s = &products.sums;
                let src = [0, 1, 2, 3, 4, 5].map(|t| &s[t][at_col(col)..at_col(col) + len]);
                combine6(&mut dst[param..param + len], src, pair_weights);
            }
        }
    }
    // Per landmark: the coefficients' gradient, and the camera's rows and cross terms.
    let j = [
        jx[(0, 0)],
        jx[(1, 0)],
        jx[(0, 1)],
        jx[(1, 1)],
        jx[(0, 2)],
        jx[(1, 2)],
    ];
    let n = params.coefficients();
    let (mut b0, mut b1) = (vec![0f64; n], vec![0f64; n]);
    for c in corr {
        debug_assert!(c.blend.is_none() && c.normal.is_none());
        let x = model.point(c.vertex, coefficients);
        let r = (c.image_up - at.camera.project_up(&x)) * w;
        // B = J M_v over the coefficient columns, identity and expressions in turn.
        let rows = [0, 1, 2].map(|axis| model.packed.row(3 * c.vertex + axis));
        let runs = [
            (0, params.identity, 1usize),
            (params.identity, params.expressions, 2usize),
        ];
        for (start, len, part) in runs {
            let pick = |axis: usize| {
                let (_, identity, expr) = rows[axis];
                &(if part == 1 { identity } else { expr })[..len]
            };
            let (m0, m1, m2) = (pick(0), pick(1), pick(2));
            let (u, v) = (&mut b0[start..start + len], &mut b1[start..start + len]);
            let [j00, j10, j01, j11, j02, j12] = j;
            for j in 0..len {
                let m = [m0[j] as f64, m1[j] as f64, m2[j] as f64];
                u[j] = j00 * m[0] + j01 * m[1] + j02 * m[2];
                v[j] = j10 * m[0] + j11 * m[1] + j12 * m[2];
            }
        }
        for ((gk, u), v) in g[cams..].iter_mut().zip(&b0).zip(&b1) {
            *gk += u * r.x + v * r.y;
        }
        if params.camera {
            let jp = at.camera.parameter_jacobian(&x);
            for i in 0..6 {
                let (u, v) = (w * jp[(0, i)], w * jp[(1, i)]);
                g[i] += jp[(0, i)] * r.x + jp[(1, i)] * r.y;
                for j in i..6 {
                    h[i * p + j] += u * jp[(0, j)] + v * jp[(1, j)];
                }
                for ((d, s0), s1) in h[i * p + 6..(i + 1) * p].iter_mut().zip(&b0).zip(&b1) {
                    *d += u * s0 + v * s1;
                }
            }
        }
    }
    // The camera rows were filled on and above the diagonal only.
    for i in 0..cams {
        for j in i + 1..p {
            h[j * p + i] = h[i * p + j];
        }
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
) {
    add_lips(model, closed_lips, coefficients, params, weights.lips, h, g);
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
) {
    let (p, cams, n) = (params.len(), params.cameras(), params.coefficients());
    let mut d = vec![0f64; n];
    for &(upper, lower) in closed_lips {
        let gap = model.point(upper, coefficients) - model.point(lower, coefficients);
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
                let f = weight * di;
                let row = &mut h[(cams + i) * p + cams..(cams + i + 1) * p];
                row.iter_mut().zip(&d).for_each(|(hk, dk)| *hk += f * dk);
            }
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
