//! The first iteration's block solves, as eos does them: identity alone (regularised linear
//! least squares) or expressions alone (non-negative least squares), the other held fixed.

// The fit's shared types, constants and helpers (this file is a part of `fit`, split out).
use super::{
    At, Camera, Correspondence, FitError, MAX_SHAPE_SD, Params, Problem, Weights, absolute_rhs,
    mirror_upper, nnls, normal, normal_equations, solve_spd,
};

/// One block solve's inputs: the problem, the correspondences, the current solution (the
/// other block held there) and the landmarks' noise (mm).
pub(super) struct Block<'a, C> {
    problem: &'a Problem<'a>,
    corr: &'a [Correspondence],
    at: At<'a, C>,
    sigma_mm: f64,
}

impl<'a, C: Camera> Block<'a, C> {
    /// At the current solution `(pose, shape, expression)`.
    pub(super) fn new(
        problem: &'a Problem<'a>,
        corr: &'a [Correspondence],
        (camera, shape, expression): (&'a C, &'a [f32], &'a [f32]),
        sigma_mm: f64,
    ) -> Self {
        let at = At {
            camera,
            shape,
            expression,
        };
        Block {
            problem,
            corr,
            at,
            sigma_mm,
        }
    }

    /// Normal equations for identity alone or expressions alone at the current solution, as
    /// `(H, H x + g)`, i.e. for the block's coefficients `x` outright (see [`absolute_rhs`]).
    fn equations(&self, params: Params) -> (Vec<f64>, Vec<f64>) {
        let Block {
            problem,
            corr,
            ref at,
            sigma_mm,
        } = *self;
        let (pose, shape, expression) = (at.camera, at.shape, at.expression);
        let opts = problem.opts;
        let weights = Weights {
            landmarks: 1.0 / (pose.scale() * sigma_mm).powi(2),
            lips: 1.0 / opts.sigma_closed_mm.powi(2),
        };
        let normal::Linearised { mut h, g, .. } = normal_equations(
            problem.model,
            corr,
            &problem.closed_lips,
            at,
            params,
            weights,
            problem.fixed.as_ref(),
            Vec::new(),
        );
        mirror_upper(&mut h, params.len());
        let current = if params.identity > 0 {
            &shape[..params.identity]
        } else {
            &expression[..params.expressions]
        };
        let rhs = absolute_rhs(&h, &g, current);
        (h, rhs)
    }

    /// Identity by regularised linear least squares, with the expressions held fixed.
    pub fn shape(&self) -> Result<Vec<f32>, FitError> {
        let problem = self.problem;
        let n = problem.opts.shape_coefficients;
        if n == 0 {
            return Ok(Vec::new());
        }
        let params = Params {
            camera: false,
            identity: n,
            expressions: 0,
        };
        let (ata, atb) = self.equations(params);
        // Trust region on the prior: inconsistent landmarks (duplicates, outliers) can ask for an
        // implausible face; raise the prior weight until every coefficient is within the bound.
        let mut lambda = problem.opts.lambda_shape.max(1e-6);
        for _ in 0..40 {
            let mut a = ata.clone();
            for i in 0..n {
                a[i * n + i] += lambda;
            }
            let x = solve_spd(a, &atb)?;
            if x.iter().all(|v| v.abs() <= MAX_SHAPE_SD) {
                return Ok(x.iter().map(|&v| v as f32).collect());
            }
            lambda *= 2.0;
        }
        Err(FitError::NotFinite)
    }

    /// Expressions by non-negative least squares with a small ridge, identity held fixed.
    pub fn expressions(&self) -> Result<Vec<f32>, FitError> {
        let problem = self.problem;
        let n = self.at.expression.len();
        if n == 0 {
            return Ok(Vec::new());
        }
        let params = Params {
            camera: false,
            identity: 0,
            expressions: n,
        };
        let (mut ata, atb) = self.equations(params);
        for i in 0..n {
            ata[i * n + i] += problem.opts.lambda_expression;
        }
        let x = nnls(&ata, &atb)?;
        Ok(x.iter().map(|&v| v as f32).collect())
    }
}
