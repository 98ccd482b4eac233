//! Small dense solvers for the fit's blocks: a symmetric positive (semi)definite system with a
//! pseudo-inverse fallback, and non-negative least squares for the expressions.

// The fit's shared types, constants and helpers (this file is a part of `fit`, split out).
use super::{DMatrix, DVector, FitError, linalg};

/// Solves a symmetric positive (semi)definite system (row-major `a`); falls back to a
/// pseudo-inverse solve.
pub(super) fn solve_spd(mut a: Vec<f64>, b: &[f64]) -> Result<Vec<f64>, FitError> {
    let n = b.len();
    let matrix = DMatrix::from_row_slice(n, n, &a);
    if let Some(x) = linalg::cholesky_solve(&mut a, n, b) {
        return Ok(x);
    }
    let svd = matrix.svd(true, true);
    let x = svd
        .solve(&DVector::from_column_slice(b), 1e-12)
        .map_err(|e| FitError::Degenerate(e.into()))?;
    if x.iter().all(|v| v.is_finite()) {
        Ok(x.as_slice().to_vec())
    } else {
        Err(FitError::NotFinite)
    }
}

/// Non-negative least squares on normal equations `Q x = q` (row-major `Q`), `x >= 0`:
/// Lawson and Hanson's active set, exact in at most a few small solves for the six
/// expressions (cyclic coordinate descent, the fallback if a subsystem will not factor, took
/// hundreds of sweeps on correlated blendshapes).
pub(super) fn nnls(q: &[f64], rhs: &[f64]) -> Result<Vec<f64>, FitError> {
    let n = rhs.len();
    let scale = (0..n)
        .map(|j| q[j * n + j].abs())
        .fold(0.0, f64::max)
        .max(1e-300);
    let tol = 1e-12 * scale;
    let mut x = vec![0f64; n];
    let mut free = vec![false; n];
    // Solves Q_FF z_F = q_F on the free set; z is 0 elsewhere.
    let solve_free = |free: &[bool]| -> Option<Vec<f64>> {
        let idx: Vec<usize> = (0..n).filter(|&j| free[j]).collect();
        let k = idx.len();
        let mut m: Vec<f64> = idx
            .iter()
            .flat_map(|&i| idx.iter().map(move |&j| q[i * n + j]))
            .collect();
        let b: Vec<f64> = idx.iter().map(|&i| rhs[i]).collect();
        let zf = linalg::cholesky_solve(&mut m, k, &b)?;
        let mut z = vec![0f64; n];
        for (&i, v) in idx.iter().zip(zf) {
            z[i] = v;
        }
        Some(z)
    };
    for _ in 0..3 * n + 3 {
        // The most promising variable at its bound: largest decrease of the objective.
        let w: Vec<f64> = (0..n)
            .map(|j| rhs[j] - (0..n).map(|k| q[j * n + k] * x[k]).sum::<f64>())
            .collect();
        let Some(enter) = (0..n)
            .filter(|&j| !free[j] && w[j] > tol)
            .max_by(|&a, &b| w[a].total_cmp(&w[b]))
        else {
            return Ok(x);
        };
        free[enter] = true;
        for _ in 0..=n {
            let Some(z) = solve_free(&free) else {
                return nnls_descent(q, rhs);
            };
            if (0..n).all(|j| !free[j] || z[j] > 0.0) {
                x = z;
                break;
            }
            // Move towards z until the first free variable reaches 0; it leaves the set.
            let alpha = (0..n)
                .filter(|&j| free[j] && z[j] <= 0.0)
                .map(|j| x[j] / (x[j] - z[j]))
                .filter(|a| a.is_finite())
                .fold(1.0f64, f64::min);
            for j in 0..n {
                x[j] += alpha * (z[j] - x[j]);
                if free[j] && x[j] <= tol {
                    x[j] = 0.0;
                    free[j] = false;
                }
            }
        }
    }
    if x.iter().all(|v| v.is_finite()) {
        Ok(x)
    } else {
        nnls_descent(q, rhs)
    }
}

/// Cyclic coordinate descent for [`nnls`]: slower, but needs no factorisation.
pub(super) fn nnls_descent(q: &[f64], rhs: &[f64]) -> Result<Vec<f64>, FitError> {
    let n = rhs.len();
    let mut x = vec![0f64; n];
    for _ in 0..500 {
        let mut change = 0f64;
        for j in 0..n {
            let d = q[j * n + j];
            if d <= 0.0 || !d.is_finite() {
                continue;
            }
            let row = &q[j * n..(j + 1) * n];
            let g = row.iter().zip(&x).map(|(a, b)| a * b).sum::<f64>() - rhs[j];
            let new = (x[j] - g / d).max(0.0);
            change = change.max((new - x[j]).abs());
            x[j] = new;
        }
        if change < 1e-10 {
            break;
        }
    }
    if x.iter().all(|v| v.is_finite()) {
        Ok(x)
    } else {
        Err(FitError::NotFinite)
    }
}
