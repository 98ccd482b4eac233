//! Small dense kernels for the fitter's normal equations (at most ~80 unknowns, ~150 rows),
//! written for that size: nalgebra's generic Gram product and Cholesky were two thirds of a
//! fit's time here (callgrind, `glyptic fit --no-contour --repeat 100`).

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

/// The upper-triangle 4x4 blocks of `A^T A` from the packed columns, mirrored into `g`. With
/// AVX2 and FMA (checked at run time; the build targets baseline x86-64) the same code compiles
/// to 4-wide fused multiply-adds, about twice as fast here.
fn block_products(packed: &[f64], rows: usize, n: usize, g: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
        // SAFETY: the CPU supports the features this function is compiled for (checked above).
        unsafe { block_products_avx2(packed, rows, n, g) };
        return;
    }
    block_products_generic(packed, rows, n, g);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn block_products_avx2(packed: &[f64], rows: usize, n: usize, g: &mut [f64]) {
    block_products_generic(packed, rows, n, g);
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

/// Dot product with four partial sums, so it vectorises.
#[inline(always)]
fn dot(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len().min(y.len());
    let (x, y) = (&x[..n], &y[..n]);
    let mut acc = [0f64; 4];
    let (cx, cy) = (x.chunks_exact(4), y.chunks_exact(4));
    let tail: f64 = cx
        .remainder()
        .iter()
        .zip(cy.remainder())
        .map(|(p, q)| p * q)
        .sum();
    for (p, q) in cx.zip(cy) {
        for i in 0..4 {
            acc[i] += p[i] * q[i];
        }
    }
    acc[0] + acc[1] + acc[2] + acc[3] + tail
}

/// Cholesky factorisation in place: the lower triangle of the row-major `n x n` matrix `m`
/// becomes `L` with `M = L L^T`. `false` if `M` is not numerically positive definite.
pub(crate) fn cholesky(m: &mut [f64], n: usize) -> bool {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
        // SAFETY: the CPU supports the features this function is compiled for (checked above).
        return unsafe { cholesky_avx2(m, n) };
    }
    cholesky_generic(m, n)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn cholesky_avx2(m: &mut [f64], n: usize) -> bool {
    cholesky_generic(m, n)
}

#[inline(always)]
fn cholesky_generic(m: &mut [f64], n: usize) -> bool {
    debug_assert_eq!(m.len(), n * n);
    // L[i][j] = (M[i][j] - L[i][..j] . L[j][..j]) / L[j][j].
    for i in 0..n {
        for j in 0..=i {
            let s = m[i * n + j] - dot(&m[i * n..i * n + j], &m[j * n..j * n + j]);
            if i == j {
                if !(s > 0.0 && s.is_finite()) {
                    return false;
                }
                m[i * n + i] = s.sqrt();
            } else {
                m[i * n + j] = s / m[j * n + j];
            }
        }
    }
    true
}

/// Solves `L L^T x = b` with the factor from [`cholesky`]. `None` if `x` is not finite.
pub(crate) fn cholesky_substitute(l: &[f64], n: usize, b: &[f64]) -> Option<Vec<f64>> {
    let mut x = b.to_vec();
    for i in 0..n {
        x[i] = (x[i] - dot(&l[i * n..i * n + i], &x[..i])) / l[i * n + i];
    }
    for i in (0..n).rev() {
        let mut s = x[i];
        for k in i + 1..n {
            s -= l[k * n + i] * x[k];
        }
        x[i] = s / l[i * n + i];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// The diagonal of `M^-1` from the factor of [`cholesky`]: `(M^-1)_kk = sum_j (L^-1)_jk^2`.
pub(crate) fn inverse_diagonal(l: &[f64], n: usize) -> Vec<f64> {
    let mut diag = vec![0f64; n];
    let mut col = vec![0f64; n];
    for k in 0..n {
        // Column k of L^-1 by forward substitution on e_k (zero above row k).
        col[..k].iter_mut().for_each(|v| *v = 0.0);
        for i in k..n {
            let rhs = if i == k { 1.0 } else { 0.0 };
            col[i] = (rhs - dot(&l[i * n + k..i * n + i], &col[k..i])) / l[i * n + i];
        }
        diag[k] = col[k..].iter().map(|v| v * v).sum();
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
        let x_ref = expect.cholesky().expect("spd").solve(&expect_rhs);
        for i in 0..n {
            assert!((x[i] - x_ref[i]).abs() < 1e-9 * (1.0 + x_ref[i].abs()));
        }
        // Singular and non-finite matrices are refused.
        assert!(cholesky_solve(&mut [1.0, 1.0, 1.0, 1.0], 2, &[1.0, 2.0]).is_none());
        assert!(cholesky_solve(&mut [f64::NAN, 0.0, 0.0, 1.0], 2, &[1.0, 2.0]).is_none());
    }
}
