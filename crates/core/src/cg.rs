//! Conjugate gradients on a symmetric positive definite operator given as a closure (the
//! photometric depth correction's normal equations, the tone's slope fit). Pure computation.

/// Solves `A x = b` from `x = 0`, `apply(p, out)` writing `A p` into `out`; stops after
/// `iterations` or when the residual falls to `tolerance` of `b`'s (both Euclidean), or when
/// the operator stops being positive along a direction (NaN or non-positive curvature).
pub(crate) fn conjugate_gradient(
    mut apply: impl FnMut(&[f32], &mut [f32]),
    b: &[f32],
    iterations: usize,
    tolerance: f32,
) -> Vec<f32> {
    let n = b.len();
    let mut x = vec![0f32; n];
    let mut r = b.to_vec();
    let mut p = r.clone();
    let mut ap = vec![0f32; n];
    let dot = |a: &[f32], b: &[f32]| -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| f64::from(*x) * f64::from(*y))
            .sum()
    };
    let mut rr = dot(&r, &r);
    let stop = rr * f64::from(tolerance * tolerance);
    for _ in 0..iterations {
        if rr <= stop || rr == 0.0 {
            break;
        }
        apply(&p, &mut ap);
        let pap = dot(&p, &ap);
        if pap.is_nan() || pap <= 0.0 {
            break;
        }
        let alpha = (rr / pap) as f32;
        for i in 0..n {
            x[i] += alpha * p[i];
            r[i] -= alpha * ap[i];
        }
        let rr_new = dot(&r, &r);
        let beta = (rr_new / rr) as f32;
        for i in 0..n {
            p[i] = r[i] + beta * p[i];
        }
        rr = rr_new;
    }
    x
}
