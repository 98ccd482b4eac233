//! Scaled-orthographic camera from 2D-3D correspondences.
//!
//! Frames: model points in mm (y up, face along +z); image points in pixels with y down. The
//! camera works in a y-up image frame (x, -y), so a pose maps a model point X to
//! `s * (R X)[0..2] + t` in that frame; [`Pose::project`] returns ordinary image pixels.

use nalgebra::{Matrix3, Matrix6, Rotation3, SVD, Vector2, Vector3, Vector6};

use super::{Camera, FitError};

/// Smallest ratio of the affine camera's two singular values that we accept: below it the
/// landmarks are (nearly) collinear and no rotation can be recovered from them.
const MIN_AFFINE_CONDITION: f64 = 1e-3;

/// A scaled-orthographic camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Model-to-camera rotation.
    pub rotation: Matrix3<f64>,
    /// Pixels per millimetre.
    pub scale: f64,
    /// Translation in the y-up image frame, pixels.
    pub translation: Vector2<f64>,
}

impl Pose {
    /// Projects a model point (mm) to image pixels (x right, y down).
    pub fn project(&self, x: &Vector3<f64>) -> Vector2<f64> {
        let p = self.project_up(x);
        Vector2::new(p.x, -p.y)
    }

    /// Projection into the y-up image frame.
    pub(crate) fn project_up(&self, x: &Vector3<f64>) -> Vector2<f64> {
        let r = self.rotation * x;
        Vector2::new(
            self.scale * r.x + self.translation.x,
            self.scale * r.y + self.translation.y,
        )
    }

    /// Yaw (about y), pitch (about x), roll (about z) in degrees, for `R = Rz(roll) Ry(yaw) Rx(pitch)`.
    /// Positive yaw turns the face towards its own left (the viewer sees more of its right cheek).
    pub fn yaw_pitch_roll_deg(&self) -> [f64; 3] {
        let (pitch, yaw, roll) = Rotation3::from_matrix_unchecked(self.rotation).euler_angles();
        [yaw.to_degrees(), pitch.to_degrees(), roll.to_degrees()]
    }

    /// The rotation with these angles (the inverse of [`Pose::yaw_pitch_roll_deg`]).
    pub fn rotation_from_yaw_pitch_roll_deg([yaw, pitch, roll]: [f64; 3]) -> Matrix3<f64> {
        Rotation3::from_euler_angles(pitch.to_radians(), yaw.to_radians(), roll.to_radians())
            .into_inner()
    }
}

/// Centroid and RMS distance from it, for Hartley-style normalisation.
fn normalisation<const D: usize>(
    pts: &[nalgebra::SVector<f64, D>],
) -> (nalgebra::SVector<f64, D>, f64) {
    let n = pts.len() as f64;
    let c = pts
        .iter()
        .fold(nalgebra::SVector::<f64, D>::zeros(), |a, p| a + p)
        / n;
    let rms = (pts.iter().map(|p| (p - c).norm_squared()).sum::<f64>() / n).sqrt();
    (c, rms)
}

/// Linear estimate: affine camera by least squares on normalised coordinates, then the nearest
/// rotation (SVD, determinant fixed) and the mean of the two row norms as scale (as eos does).
///
/// `image_up` are image points in the y-up frame.
pub fn estimate_linear(
    model: &[Vector3<f64>],
    image_up: &[Vector2<f64>],
) -> Result<Pose, FitError> {
    let n = model.len();
    if n < 4 || image_up.len() != n {
        return Err(FitError::TooFewLandmarks {
            usable: n.min(image_up.len()),
            needed: 4,
        });
    }
    let (cm, sm) = normalisation(model);
    let (ci, si) = normalisation(image_up);
    if !(sm > 1e-12 && si > 1e-12 && sm.is_finite() && si.is_finite()) {
        return Err(FitError::Degenerate(
            "all landmarks fall on one point".into(),
        ));
    }
    // Normal equations of the 4-parameter problem per image axis: M^T M a = M^T u.
    let mut mtm = nalgebra::Matrix4::<f64>::zeros();
    let mut mtx = nalgebra::Vector4::<f64>::zeros();
    let mut mty = nalgebra::Vector4::<f64>::zeros();
    for (x, u) in model.iter().zip(image_up) {
        let xn = (x - cm) / sm;
        let un = (u - ci) / si;
        let row = nalgebra::Vector4::new(xn.x, xn.y, xn.z, 1.0);
        mtm += row * row.transpose();
        mtx += row * un.x;
        mty += row * un.y;
    }
    let svd = SVD::new(mtm, true, true);
    let smax = svd.singular_values.max();
    if svd.singular_values.min() < 1e-9 * smax {
        return Err(FitError::Degenerate(
            "the mapped model points are coplanar".into(),
        ));
    }
    let ax = svd
        .solve(&mtx, 1e-12)
        .map_err(|e| FitError::Degenerate(e.into()))?;
    let ay = svd
        .solve(&mty, 1e-12)
        .map_err(|e| FitError::Degenerate(e.into()))?;
    // Undo the normalisation: u = si * (A (X - cm)/sm + a) + ci.
    let k = si / sm;
    let l0 = Vector3::new(ax[0], ax[1], ax[2]) * k;
    let l1 = Vector3::new(ay[0], ay[1], ay[2]) * k;
    let t = Vector2::new(
        si * ax[3] + ci.x - l0.dot(&cm),
        si * ay[3] + ci.y - l1.dot(&cm),
    );
    let (n0, n1) = (l0.norm(), l1.norm());
    let affine = nalgebra::Matrix2x3::from_rows(&[l0.transpose(), l1.transpose()]);
    let sv = affine.singular_values();
    // Written so that NaN singular values also count as degenerate.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(sv.min() > MIN_AFFINE_CONDITION * sv.max()) {
        return Err(FitError::Degenerate(
            "the landmarks are (nearly) collinear: no head rotation fits them".into(),
        ));
    }
    let r0 = l0 / n0;
    let r1 = l1 / n1;
    let r = Matrix3::from_rows(&[r0.transpose(), r1.transpose(), r0.cross(&r1).transpose()]);
    let rotation = nearest_rotation(&r);
    Ok(Pose {
        rotation,
        scale: 0.5 * (n0 + n1),
        translation: t,
    })
}

/// The rotation nearest to `m` in the Frobenius norm.
pub fn nearest_rotation(m: &Matrix3<f64>) -> Matrix3<f64> {
    let svd = SVD::new(*m, true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Matrix3::identity();
    };
    let mut r = u * v_t;
    if r.determinant() < 0.0 {
        let mut d = Matrix3::identity();
        d[(2, 2)] = -1.0;
        r = u * d * v_t;
    }
    r
}

/// Levenberg-damped Gauss-Newton on a camera's six parameters ([`Camera::update`]),
/// minimising the squared reprojection error of `model` points onto `image_up`; shared by the
/// cameras' pose polish. Stops at the first step that does not lower the cost (so the result
/// is never worse than `start`), at a negligible gain, or after `iterations`. Returns the
/// camera and its cost.
pub(crate) fn damped_gauss_newton<C: Camera + Copy>(
    start: C,
    model: &[Vector3<f64>],
    image_up: &[Vector2<f64>],
    iterations: usize,
) -> (C, f64) {
    let cost = |p: &C| -> f64 {
        model
            .iter()
            .zip(image_up)
            .map(|(x, u)| (p.project_up(x) - u).norm_squared())
            .sum()
    };
    let mut best = start;
    let mut best_cost = cost(&start);
    for _ in 0..iterations {
        let mut jtj = Matrix6::<f64>::zeros();
        let mut jtr = Vector6::<f64>::zeros();
        for (x, u) in model.iter().zip(image_up) {
            let j = best.parameter_jacobian(x);
            jtj += j.transpose() * j;
            jtr += j.transpose() * (best.project_up(x) - u);
        }
        // Levenberg damping keeps the step sane when the problem is poorly conditioned.
        let damping = 1e-6 * jtj.trace().max(1e-12);
        let Some(delta) = (jtj + Matrix6::identity() * damping)
            .cholesky()
            .map(|c| c.solve(&(-jtr)))
        else {
            break;
        };
        let Some(candidate) = best.update(&delta) else {
            break;
        };
        let c = cost(&candidate);
        // A NaN cost stops the search too.
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        if !(c < best_cost) {
            break;
        }
        let gain = best_cost - c;
        best = candidate;
        best_cost = c;
        if gain < 1e-10 * (1.0 + c) {
            break;
        }
    }
    (best, best_cost)
}

/// Gauss-Newton on rotation, scale and translation, minimising the reprojection error.
/// Starts from `pose`; never returns a worse pose than it was given.
pub fn refine(
    pose: Pose,
    model: &[Vector3<f64>],
    image_up: &[Vector2<f64>],
    iterations: usize,
) -> Pose {
    damped_gauss_newton(pose, model, image_up, iterations).0
}
