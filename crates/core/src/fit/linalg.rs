//! Small dense kernels for the fitter's normal equations (at most ~80 unknowns, ~150 rows),
//! written for that size: nalgebra's generic Gram product and Cholesky were two thirds of a
//! fit's time here (callgrind, `glyptic fit --no-contour --repeat 100`).

use crate::simd::with_avx2;

/// `(A^T A, A^T t)` for a column-major `rows x n` matrix `a`, as a full symmetric row-major
/// `n x n` matrix and a vector. Blocks of 4x4 output entries share each row's loads, so the
/// kernel does 16 multiply-adds per 8 loads instead of 1 per 2.
pub(crate) fn gram(a: &[f64], rows: usize, n: usize, t: &[f64]) -> (Vec<f64>, Vec<f64>) {
    debug_assert_eq!(a.len(), rows * n);
    let col = |j: usize| &a[j * rows..(j + 1) * rows];
    // Columns packed four at a time, interleaved by row: [c0[k], c1[k], c2[k], c3[k]] ...
    let blocks = n.div_ceil(4);
    let mut packed = vec![0f64; blocks * rows * 4];
    for (b, block) in packed.chunks_exact_mut(rows * 4).enumerate() {
        for q in 0..4.min(n - 4 * b) {
            for (k, v) in col(4 * b + q).iter().enumerate() {
                block[4 * k + q] = *v;
            }
        }
    }
    let mut g = vec![0f64; n * n];
    block_products(&packed, rows, n, &mut g);
    let rhs = (0..n).map(|j| dot(col(j), t)).collect();
    (g, rhs)
}

with_avx2! {
    /// The upper-triangle 4x4 blocks of `A^T A` from the packed columns, mirrored into `g`. With
    /// AVX2 and FMA (checked at run time; the build targets baseline x86-64) the same code compiles
    /// to 4-wide fused multiply-adds, about twice as fast here.
    fn block_products / block_products_avx2 => block_products_generic
        (packed: &[f64], rows: usize, n: usize, g: &mut [f64]) -> ()
}

#[inline(always)]
fn block_products_generic(packed: &[f64], rows: usize, n: usize, g: &mut [f64]) {
    let blocks = n.div_ceil(4);
    for bi in 0..blocks {
        let pi = &packed[bi * rows * 4..(bi + 1) * rows * 4];
        for bj in bi..blocks {
            let pj = &packed[bj * rows * 4..(bj + 1) * rows * 4];
            let mut acc = [[0f64; 4]; 4];
            for (x, y) in pi.chunks_exact(4).zip(pj.chunks_exact(4)) {
                for p in 0..4 {
                    for q in 0..4 {
                        acc[p][q] += x[p] * y[q];
                    }
                }
            }
            for (p, row) in acc.iter().enumerate() {
                let i = 4 * bi + p;
                for (q, v) in row.iter().enumerate() {
                    let j = 4 * bj + q;
                    if i < n && j < n && j >= i {
                        g[i * n + j] = *v;
                        g[j * n + i] = *v;
                    }
                }
            }
        }
    }
}

/// Dot product with eight partial sums (two vector registers with AVX2), so that it
/// vectorises and its additions form two independent chains instead of one.
#[inline(always)]
fn dot(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len().min(y.len());
    let (x8, xr) = x[..n].as_chunks::<8>();
    let (y8, yr) = y[..n].as_chunks::<8>();
    let y8 = &y8[..x8.len()];
    let mut acc = [0f64; 8];
    for j in 0..x8.len() {
        let (p, q) = (x8[j], y8[j]);
        for i in 0..8 {
            acc[i] += p[i] * q[i];
        }
    }
    let tail: f64 = xr.iter().zip(yr).map(|(p, q)| p * q).sum();
    ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7])) + tail
}

/// `d -= f a`, on whole lanes of four (`[f64; 4]`, one vector register with AVX2) so that
/// short rows do not fall back to scalar code.
#[inline(always)]
fn axpy(d: &mut [f64], a: &[f64], f: f64) {
    let n = d.len().min(a.len());
    let (d4, dr) = d[..n].as_chunks_mut::<4>();
    let (a4, ar) = a[..n].as_chunks::<4>();
    let a4 = &a4[..d4.len()];
    for j in 0..d4.len() {
        for q in 0..4 {
            d4[j][q] -= f * a4[j][q];
        }
    }
    for (d, a) in dr.iter_mut().zip(ar) {
        *d -= f * a;
    }
}

/// `d -= sum_q f[q] a[q]` for four rows at once (each element of `d` read and written once).
#[inline(always)]
fn axpy4(d: &mut [f64], a: [&[f64]; 4], f: [f64; 4]) {
    let n = a.iter().fold(d.len(), |n, a| n.min(a.len()));
    let (d4, dr) = d[..n].as_chunks_mut::<4>();
    let c = d4.len();
    let (a0, r0) = a[0][..n].as_chunks::<4>();
    let (a1, r1) = a[1][..n].as_chunks::<4>();
    let (a2, r2) = a[2][..n].as_chunks::<4>();
    let (a3, r3) = a[3][..n].as_chunks::<4>();
    let (a0, a1, a2, a3) = (&a0[..c], &a1[..c], &a2[..c], &a3[..c]);
    for j in 0..c {
        let (x0, x1, x2, x3) = (a0[j], a1[j], a2[j], a3[j]);
        let mut v = d4[j];
        for q in 0..4 {
            v[q] -= (f[0] * x0[q] + f[1] * x1[q]) + (f[2] * x2[q] + f[3] * x3[q]);
        }
        d4[j] = v;
    }
    let r = dr.len();
    let (r0, r1, r2, r3) = (&r0[..r], &r1[..r], &r2[..r], &r3[..r]);
    for j in 0..r {
        dr[j] -= (f[0] * r0[j] + f[1] * r1[j]) + (f[2] * r2[j] + f[3] * r3[j]);
    }
}

/// `d -= sum_q f[q] a[q]` for eight rows at once.
#[inline(always)]
fn axpy8(d: &mut [f64], a: [&[f64]; 8], f: [f64; 8]) {
    let n = a.iter().fold(d.len(), |n, a| n.min(a.len()));
    let (d4, dr) = d[..n].as_chunks_mut::<4>();
    let c = d4.len();
    let (a0, r0) = a[0][..n].as_chunks::<4>();
    let (a1, r1) = a[1][..n].as_chunks::<4>();
    let (a2, r2) = a[2][..n].as_chunks::<4>();
    let (a3, r3) = a[3][..n].as_chunks::<4>();
    let (a4, r4) = a[4][..n].as_chunks::<4>();
    let (a5, r5) = a[5][..n].as_chunks::<4>();
    let (a6, r6) = a[6][..n].as_chunks::<4>();
    let (a7, r7) = a[7][..n].as_chunks::<4>();
    let (a0, a1, a2, a3) = (&a0[..c], &a1[..c], &a2[..c], &a3[..c]);
    let (a4, a5, a6, a7) = (&a4[..c], &a5[..c], &a6[..c], &a7[..c]);
    for j in 0..c {
        let (x0, x1, x2, x3) = (a0[j], a1[j], a2[j], a3[j]);
        let (x4, x5, x6, x7) = (a4[j], a5[j], a6[j], a7[j]);
        let mut v = d4[j];
        for q in 0..4 {
            v[q] -= ((f[0] * x0[q] + f[1] * x1[q]) + (f[2] * x2[q] + f[3] * x3[q]))
                + ((f[4] * x4[q] + f[5] * x5[q]) + (f[6] * x6[q] + f[7] * x7[q]));
        }
        d4[j] = v;
    }
    let r = dr.len();
    let (r0, r1, r2, r3) = (&r0[..r], &r1[..r], &r2[..r], &r3[..r]);
    let (r4, r5, r6, r7) = (&r4[..r], &r5[..r], &r6[..r], &r7[..r]);
    for j in 0..r {
        dr[j] -= ((f[0] * r0[j] + f[1] * r1[j]) + (f[2] * r2[j] + f[3] * r3[j]))
            + ((f[4] * r4[j] + f[5] * r5[j]) + (f[6] * r6[j] + f[7] * r7[j]));
    }
}

/// Cholesky factorisation in place: the upper triangle of the row-major symmetric `n x n`
/// matrix `m` becomes `U` with `M = U^T U` (the lower triangle is left as it was). `false` if
/// `M` is not numerically positive definite.
pub(crate) fn cholesky(m: &mut [f64], n: usize) -> bool {
    cholesky_pivots(m, n, 0..n)
}

with_avx2! {
    /// Pivots `range` of [`cholesky`]: after `0..k`, rows `..k` of `m` hold those rows of `U` and
    /// the trailing block the Schur complement, which `k..n` then factors. Callers can change the
    /// trailing block in between (fix a variable) without redoing the leading pivots.
    pub(crate) fn cholesky_pivots / cholesky_avx2 => cholesky_generic
        (m: &mut [f64], n: usize, range: std::ops::Range<usize>) -> bool
}

/// Scales row `k` of the trailing matrix into row `k` of `U`; `false` if its pivot is not
/// positive.
#[inline(always)]
fn cholesky_pivot(m: &mut [f64], n: usize, k: usize) -> bool {
    let d = m[k * n + k];
    if !(d > 0.0 && d.is_finite()) {
        return false;
    }
    let u = d.sqrt();
    m[k * n + k] = u;
    let inv = 1.0 / u;
    m[k * n + k + 1..(k + 1) * n]
        .iter_mut()
        .for_each(|v| *v *= inv);
    true
}

#[inline(always)]
fn cholesky_generic(m: &mut [f64], n: usize, range: std::ops::Range<usize>) -> bool {
    debug_assert_eq!(m.len(), n * n);
    let end = range.end.min(n);
    // Right-looking in blocks of eight pivots (each factored as two blocks of four): every
    // trailing row segment `M[i][i..]` then takes the block's eight rows of U at once, in
    // contiguous multiply-adds read and written once per block (no short dot products, no
    // strided access).
    let mut k = range.start;
    while k < end {
        let b = 8.min(end - k);
        if !cholesky_block(m, n, k, k + b, k + b) {
            return false;
        }
        let (head, tail) = m.split_at_mut((k + b) * n);
        for (r, row) in tail.chunks_exact_mut(n).enumerate() {
            update_row(row, &head[k * n..], n, b, k + b + r);
        }
        k += b;
    }
    true
}

/// Pivots `start..stop` in blocks of four, updating rows up to `rows` (exclusive) only.
#[inline(always)]
fn cholesky_block(m: &mut [f64], n: usize, start: usize, stop: usize, rows: usize) -> bool {
    let mut k = start;
    while k < stop {
        let b = 4.min(stop - k);
        for piv in k..k + b {
            if !cholesky_pivot(m, n, piv) {
                return false;
            }
            for i in piv + 1..k + b {
                let (head, tail) = m.split_at_mut(i * n);
                let u = &head[piv * n..(piv + 1) * n];
                axpy(&mut tail[i..n], &u[i..n], u[i]);
            }
        }
        let (head, tail) = m.split_at_mut((k + b) * n);
        for (r, row) in tail.chunks_exact_mut(n).take(rows - k - b).enumerate() {
            update_row(row, &head[k * n..], n, b, k + b + r);
        }
        k += b;
    }
    true
}

/// Row `i` of the trailing matrix, `row[i..] -= sum_q U[q][i] U[q][i..]` over the `b` rows of
/// U in `block` (row stride `n`): eight or four at once where the block is that tall.
#[inline(always)]
fn update_row(row: &mut [f64], block: &[f64], n: usize, b: usize, i: usize) {
    let u = |q: usize| &block[q * n + i..(q + 1) * n];
    match b {
        8 => {
            let rows = [u(0), u(1), u(2), u(3), u(4), u(5), u(6), u(7)];
            let f = [
                rows[0][0], rows[1][0], rows[2][0], rows[3][0], rows[4][0], rows[5][0], rows[6][0],
                rows[7][0],
            ];
            axpy8(&mut row[i..], rows, f);
        }
        4 => {
            let rows = [u(0), u(1), u(2), u(3)];
            axpy4(
                &mut row[i..],
                rows,
                [rows[0][0], rows[1][0], rows[2][0], rows[3][0]],
            );
        }
        _ => {
            for q in 0..b {
                axpy(&mut row[i..], u(q), u(q)[0]);
            }
        }
    }
}

with_avx2! {
    /// Solves `U^T U x = b` with the factor from [`cholesky`]. `None` if `x` is not finite.
    pub(crate) fn cholesky_substitute / cholesky_substitute_avx2 => cholesky_substitute_generic
        (u: &[f64], n: usize, b: &[f64]) -> Option<Vec<f64>>
}

#[inline(always)]
fn cholesky_substitute_generic(u: &[f64], n: usize, b: &[f64]) -> Option<Vec<f64>> {
    let mut x = b.to_vec();
    // Reciprocals first: a division's latency would otherwise sit in each step's chain.
    let inv: Vec<f64> = (0..n).map(|k| 1.0 / u[k * n + k]).collect();
    // U^T y = b, column by column of U^T (rows of U, contiguous).
    for k in 0..n {
        let y = x[k] * inv[k];
        x[k] = y;
        axpy(&mut x[k + 1..], &u[k * n + k + 1..(k + 1) * n], y);
    }
    for i in (0..n).rev() {
        x[i] = (x[i] - dot(&u[i * n + i + 1..(i + 1) * n], &x[i + 1..])) * inv[i];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Entries `from..n` of the diagonal of `M^-1` from the factor of [`cholesky`]. They depend
/// on the trailing block of `U` only (`U^-1` is upper triangular and its trailing block is
/// the inverse of `U`'s), so leading unknowns whose entries are not needed cost nothing.
pub(crate) fn inverse_diagonal_from(u: &[f64], n: usize, from: usize) -> Vec<f64> {
    let from = from.min(n);
    let m = n - from;
    let mut trailing = vec![0f64; m * m];
    for (i, row) in trailing.chunks_exact_mut(m.max(1)).take(m).enumerate() {
        let src = (from + i) * n + from;
        row[i..].copy_from_slice(&u[src + i..src + m]);
    }
    inverse_diagonal(&trailing, m)
}

with_avx2! {
    /// The diagonal of `M^-1` from the factor of [`cholesky`]: with `X = U^-T` (lower
    /// triangular), `(M^-1)_kk = sum_i X_ik^2`.
    pub(crate) fn inverse_diagonal / inverse_diagonal_avx2 => inverse_diagonal_generic
        (u: &[f64], n: usize) -> Vec<f64>
}

#[inline(always)]
fn inverse_diagonal_generic(u: &[f64], n: usize) -> Vec<f64> {
    // U^T X = I, right-looking in blocks of four like the factorisation: row j of X is final
    // once divided by U_jj; later rows i then subtract U_ji times it (only its first j+1
    // entries are non-zero).
    let mut x = vec![0f64; n * n];
    for i in 0..n {
        x[i * n + i] = 1.0;
    }
    let mut k = 0;
    while k < n {
        let b = 4.min(n - k);
        let width = k + b;
        for j in k..k + b {
            let inv = 1.0 / u[j * n + j];
            x[j * n..j * n + j + 1].iter_mut().for_each(|v| *v *= inv);
            for i in j + 1..k + b {
                let (head, tail) = x.split_at_mut(i * n);
                axpy(
                    &mut tail[..j + 1],
                    &head[j * n..j * n + j + 1],
                    u[j * n + i],
                );
            }
        }
        let (head, tail) = x.split_at_mut(width * n);
        for (r, row) in tail.chunks_exact_mut(n).enumerate() {
            let i = width + r;
            if b == 4 {
                let rows = [
                    &head[k * n..k * n + width],
                    &head[(k + 1) * n..(k + 1) * n + width],
                    &head[(k + 2) * n..(k + 2) * n + width],
                    &head[(k + 3) * n..(k + 3) * n + width],
                ];
                let f = [
                    u[k * n + i],
                    u[(k + 1) * n + i],
                    u[(k + 2) * n + i],
                    u[(k + 3) * n + i],
                ];
                axpy4(&mut row[..width], rows, f);
            } else {
                for q in 0..b {
                    axpy(
                        &mut row[..width],
                        &head[(k + q) * n..][..width],
                        u[(k + q) * n + i],
                    );
                }
            }
        }
        k += b;
    }
    let mut diag = vec![0f64; n];
    for (i, row) in x.chunks_exact(n).enumerate() {
        diag[..=i]
            .iter_mut()
            .zip(&row[..=i])
            .for_each(|(d, v)| *d += v * v);
    }
    diag
}

/// Solves `M x = b` for a symmetric positive definite row-major `n x n` matrix (`m` is
/// overwritten by its factor). `None` if `M` is not numerically positive definite or the
/// result is not finite.
pub(crate) fn cholesky_solve(m: &mut [f64], n: usize, b: &[f64]) -> Option<Vec<f64>> {
    if !cholesky(m, n) {
        return None;
    }
    cholesky_substitute(m, n, b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gram_and_solve_match_nalgebra() {
        let (rows, n) = (23, 11);
        let mut state = 1u64;
        let mut r = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1);
            ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let a = nalgebra::DMatrix::<f64>::from_fn(rows, n, |_, _| r());
        let t = nalgebra::DVector::<f64>::from_fn(rows, |_, _| r());
        let (g, rhs) = gram(a.as_slice(), rows, n, t.as_slice());
        let expect = a.transpose() * &a;
        let expect_rhs = a.transpose() * &t;
        for i in 0..n {
            assert!((rhs[i] - expect_rhs[i]).abs() < 1e-12);
            for j in 0..n {
                assert!((g[i * n + j] - expect[(i, j)]).abs() < 1e-12);
            }
        }
        let mut m = g.clone();
        let x = cholesky_solve(&mut m, n, &rhs).expect("positive definite");
        let inv = expect.clone().try_inverse().expect("invertible");
        for (k, d) in inverse_diagonal(&m, n).iter().enumerate() {
            assert!((d - inv[(k, k)]).abs() < 1e-9 * inv[(k, k)].abs().max(1.0));
        }
        for (k, d) in inverse_diagonal_from(&m, n, 4).iter().enumerate() {
            let e = inv[(k + 4, k + 4)];
            assert!((d - e).abs() < 1e-9 * e.abs().max(1.0));
        }
        let x_ref = expect.cholesky().expect("spd").solve(&expect_rhs);
        for i in 0..n {
            assert!((x[i] - x_ref[i]).abs() < 1e-9 * (1.0 + x_ref[i].abs()));
        }
        // Singular and non-finite matrices are refused.
        assert!(cholesky_solve(&mut [1.0, 1.0, 1.0, 1.0], 2, &[1.0, 2.0]).is_none());
        assert!(cholesky_solve(&mut [f64::NAN, 0.0, 0.0, 1.0], 2, &[1.0, 2.0]).is_none());
    }
}
