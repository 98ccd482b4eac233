//! The joint Levenberg-Marquardt step on camera, identity and expressions, and the landmark
//! noise estimate that weighs it. Residuals in model millimetres.

// The fit's shared types, constants and helpers (this file is a part of `fit`, split out).
use super::{
    At, CONVERGED_GAIN, Camera, Coefficients, Correspondence, MAX_SHAPE_SD, Params, Problem,
    Solution, SurreyModel, Weights, linalg, normal, normal_equations,
};

/// The objective the joint step minimises: weighted squared reprojection residuals (model mm,
/// along the normal for sliding outline points), the identity prior, the expression ridge and
/// the closed-lip constraints.
pub(super) struct Objective<'a> {
    model: &'a SurreyModel,
    corr: &'a [Correspondence],
    closed_lips: &'a [(usize, usize)],
    /// `1 / (s sigma)^2`, pixels^-2, frozen for one step so the objective does not move under it.
    weight: f64,
    lambda_shape: f64,
    lambda_expression: f64,
    weight_lips: f64,
}

impl Objective<'_> {
    /// Sum of squared landmark residuals (pixels^2) and how many scalar residuals it holds.
    fn landmark_residuals<C: Camera>(&self, camera: &C, k: &Coefficients) -> (f64, usize) {
        let mut e = 0.0;
        let mut count = 0;
        for c in self.corr {
            let r = c.image_up - camera.project_up(&c.position(self.model, k));
            (e, count) = match c.normal {
                Some(n) => (e + n.dot(&r).powi(2), count + 1),
                None => (e + r.norm_squared(), count + 2),
            };
        }
        (e, count)
    }

    /// The objective, with the landmark residuals it was made of (see `landmark_residuals`).
    fn value<C: Camera>(&self, camera: &C, shape: &[f32], expression: &[f32]) -> (f64, f64, usize) {
        let k = Coefficients::new(self.model, shape, expression);
        let (rss, count) = self.landmark_residuals(camera, &k);
        let lips: f64 = self
            .closed_lips
            .iter()
            .map(|&(u, l)| (self.model.point(u, &k) - self.model.point(l, &k)).norm_squared())
            .sum();
        (self.total(rss, lips, shape, expression), rss, count)
    }

    /// The objective from the squared image residuals (pixels^2) and closed-lip gaps (mm^2).
    fn total(&self, rss_px: f64, lips_mm2: f64, shape: &[f32], expression: &[f32]) -> f64 {
        self.weight * rss_px
            + self.weight_lips * lips_mm2
            + self.lambda_shape * shape.iter().map(|&a| (a as f64).powi(2)).sum::<f64>()
            + self.lambda_expression * expression.iter().map(|&b| (b as f64).powi(2)).sum::<f64>()
    }
}

/// One Levenberg-Marquardt step on camera, identity and expressions together, for fixed
/// correspondences. Alternating blocks crawls along the valley where a turn of the head and a
/// change of face shape explain the landmarks equally well (on 40 synthetic faces 20
/// alternations still had not converged); a joint step follows it. Expressions are projected
/// onto `>= 0` and identity onto `|a| <= MAX_SHAPE_SD`. Never returns a worse solution;
/// `damping` carries the Marquardt parameter from step to step.
#[allow(clippy::too_many_arguments)]
pub(super) fn joint_step<C: Camera + Clone>(
    problem: &Problem,
    corr: &[Correspondence],
    current: Solution<C>,
    hold_identity: bool,
    sigma_mm: &mut f64,
    estimate_noise: bool,
    damping: &mut f64,
) -> (Solution<C>, bool) {
    let Problem {
        model,
        opts,
        ref closed_lips,
        ..
    } = *problem;
    let n_shape = if hold_identity {
        0
    } else {
        current.shape.len()
    };
    let n_expr = current.expression.len();
    let p = 6 + n_shape + n_expr;
    let objective = Objective {
        model,
        corr,
        closed_lips,
        weight: 1.0 / (current.camera.scale() * *sigma_mm).powi(2),
        lambda_shape: opts.lambda_shape,
        lambda_expression: opts.lambda_expression,
        weight_lips: 1.0 / opts.sigma_closed_mm.powi(2),
    };
    let (shape, expr) = (&current.shape[..], &current.expression[..]);
    let params = Params {
        camera: true,
        identity: n_shape,
        expressions: n_expr,
    };
    let at = At {
        camera: &current.camera,
        shape,
        expression: expr,
    };
    let weights = Weights {
        landmarks: objective.weight,
        lips: objective.weight_lips,
    };
    let normal::Linearised {
        h: mut gram,
        g: mut grad,
        rss_px,
        lips_mm2,
    } = normal_equations(
        model,
        corr,
        closed_lips,
        &at,
        params,
        weights,
        problem.fixed.as_ref(),
        problem.scratch.take(),
    );
    // The priors' weights per parameter (none on the camera), their gradient at the current
    // coefficients and their curvature.
    let prior: Vec<f64> = (0..p)
        .map(|k| match k {
            k if k < 6 => 0.0,
            k if k < 6 + n_shape => opts.lambda_shape,
            _ => opts.lambda_expression,
        })
        .collect();
    let coefficient = |k: usize| match k {
        k if k < 6 => 0.0,
        k if k < 6 + n_shape => shape[k - 6] as f64,
        k => expr[k - 6 - n_shape] as f64,
    };
    for (k, w) in prior.iter().enumerate() {
        grad[k] -= w * coefficient(k);
        gram[k * p + k] += w;
    }
    let before = objective.total(rss_px, lips_mm2, shape, expr);
    // Expressions at their bound (0) that the step would push below it are held there (active
    // set) and the step is solved again: a step computed with them free and then clipped loses
    // the coupled identity change that went with it, and can be far worse than no step.
    let mut active: Vec<bool> = (0..n_expr)
        .map(|e| expr[e] <= 1e-6 && grad[6 + n_shape + e] <= 0.0)
        .collect();
    // Camera and identity pivots once; fixing an expression only changes the trailing block.
    let lead = p - n_expr;
    let mut m = gram;
    for k in 0..p {
        let d = m[k * p + k];
        m[k * p + k] += *damping * d.max(1e-9);
    }
    let factored = linalg::cholesky_pivots(&mut m, p, 0..lead);
    // All that the trailing pivots and the fixing below overwrite: columns `lead..` of every
    // row (restored before each solve, instead of copying the whole matrix).
    let saved: Vec<f64> = m
        .chunks_exact(p)
        .flat_map(|row| row[lead..].iter().copied())
        .collect();
    let mut solved = None;
    for _ in 0..=n_expr {
        if !factored {
            break;
        }
        if n_expr > 0 {
            for (row, s) in m.chunks_exact_mut(p).zip(saved.chunks_exact(n_expr)) {
                row[lead..].copy_from_slice(s);
            }
        }
        let mut g = grad.clone();
        for (e, _) in active.iter().enumerate().filter(|(_, a)| **a) {
            // As if the variable's row and column were zero with a unit diagonal: its column
            // of U above the trailing block and its row and column in the Schur complement.
            let k = lead + e;
            for i in 0..lead {
                m[i * p + k] = 0.0;
            }
            for j in lead..p {
                m[k * p + j] = 0.0;
                m[j * p + k] = 0.0;
            }
            m[k * p + k] = 1.0;
            g[k] = 0.0;
        }
        let Some(delta) = linalg::cholesky_pivots(&mut m, p, lead..p)
            .then(|| linalg::cholesky_substitute(&m, p, &g))
            .flatten()
        else {
            break;
        };
        let blocked: Vec<usize> = (0..n_expr)
            .filter(|&e| !active[e] && expr[e] <= 1e-6 && delta[6 + n_shape + e] < 0.0)
            .collect();
        if blocked.is_empty() {
            solved = Some((delta, g));
            break;
        }
        blocked.iter().for_each(|&e| active[e] = true);
    }
    let Some((delta, grad)) = solved else {
        *damping *= 10.0;
        problem.scratch.replace(m);
        return (current, false);
    };
    // The longest step along delta that keeps every coefficient within its bounds.
    let mut longest = 1f64;
    for k in 6..p {
        let (value, bound) = if k < 6 + n_shape {
            let v = shape[k - 6] as f64;
            (
                v,
                if delta[k] > 0.0 {
                    MAX_SHAPE_SD
                } else {
                    -MAX_SHAPE_SD
                },
            )
        } else {
            (expr[k - 6 - n_shape] as f64, 0.0)
        };
        if k < 6 + n_shape || delta[k] < 0.0 {
            let room = (bound - value) / delta[k];
            if room.is_finite() && room >= 0.0 {
                longest = longest.min(room);
            }
        }
    }
    // Predicted decrease, about twice the model's. When it is below CONVERGED_GAIN (or the
    // relative tolerance), this step moves no parameter by more than about one standard error:
    // it is taken, since it is factorised already, and the fit stops after it.
    let predicted: f64 = delta.iter().zip(grad.iter()).map(|(d, g)| d * g).sum();
    // Written so that a NaN prediction also stops.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(predicted > 0.0) {
        problem.scratch.replace(m);
        return (current, true);
    }
    let last = predicted < CONVERGED_GAIN || predicted < opts.tolerance * before;
    // Backtracking on the one factorised step; the damping adapts for the next call.
    for halvings in 0..4 {
        let f = longest * 0.5f64.powi(halvings);
        let step = nalgebra::Vector6::from_fn(|k, _| f * delta[k]);
        let Some(camera) = current.camera.update(&step) else {
            continue;
        };
        let new_shape: Vec<f32> = if hold_identity {
            current.shape.clone()
        } else {
            (0..n_shape)
                .map(|k| {
                    (shape[k] as f64 + f * delta[6 + k]).clamp(-MAX_SHAPE_SD, MAX_SHAPE_SD) as f32
                })
                .collect()
        };
        let new_expr: Vec<f32> = (0..n_expr)
            .map(|k| (expr[k] as f64 + f * delta[6 + n_shape + k]).max(0.0) as f32)
            .collect();
        let (after, rss, count) = objective.value(&camera, &new_shape, &new_expr);
        if after < before {
            if estimate_noise
                && let Some(sigma) = noise_estimate(rss, count, camera.scale(), &m, &prior)
            {
                *sigma_mm = sigma;
            }
            *damping = if halvings == 0 {
                (*damping * 0.3).max(1e-9)
            } else {
                *damping * 10.0
            };
            let solution = Solution {
                camera,
                shape: new_shape,
                expression: new_expr,
            };
            problem.scratch.replace(m);
            return (solution, last);
        }
    }
    *damping *= 10.0;
    problem.scratch.replace(m);
    (current, last)
}

/// Landmark noise (model mm) from the residuals of a fit: `RSS / (m - p_eff)`, with `p_eff`
/// the effective number of parameters, `p - sum_k prior_k (H^-1)_kk` for the Hessian `H` whose
/// Cholesky factor is `factor` (for a linear model this is the unbiased variance estimate).
/// Weighting by it sets the balance between landmarks and the identity prior from the data:
/// noise-free landmarks get followed closely, noisy ones (a small face, a poor detector) get
/// more prior. `None` when too few residuals remain to say; clamped to 0.25-10 mm.
pub(super) fn noise_estimate(
    rss_px: f64,
    count: usize,
    scale: f64,
    factor: &[f64],
    prior: &[f64],
) -> Option<f64> {
    let p = prior.len();
    // Unknowns without a prior (the camera, first) count fully; only the others need their
    // entry of the inverse.
    let from = prior.iter().take_while(|&&l| l == 0.0).count();
    let inverse = linalg::inverse_diagonal_from(factor, p, from);
    let p_eff: f64 = from as f64
        + prior[from..]
            .iter()
            .zip(&inverse)
            .map(|(l, h)| (1.0 - l * h).clamp(0.0, 1.0))
            .sum::<f64>();
    let dof = count as f64 - p_eff;
    if dof < 2.0 {
        return None;
    }
    let sigma = (rss_px / dof).sqrt() / scale;
    sigma.is_finite().then(|| sigma.clamp(0.25, 10.0))
}
