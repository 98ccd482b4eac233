//! Cameras the fitter can use: scaled orthographic ([`Pose`]) and pinhole perspective
//! ([`PerspectivePose`]), behind one small trait so that the linearised identity and expression
//! solves are the same for both.
//!
//! Frames: model points in mm (y up, face along +z). Camera space: x right, y up, the camera at
//! the origin looking along -z (so a visible point has z < 0, depth `d = -z`). Image points in
//! the y-up frame `(x, -y)`, pixels.

use nalgebra::{Matrix2x3, Matrix2x6, Matrix3, Rotation3, Vector2, Vector3, Vector6};

use super::pose::damped_gauss_newton;
use super::{FitError, Pose, nearest_rotation};

/// What the fitting loop needs from a camera.
pub trait Camera {
    /// Projection of a model point into the y-up image frame, pixels.
    fn project_up(&self, x: &Vector3<f64>) -> Vector2<f64>;
    /// Derivative of [`Camera::project_up`] with respect to the model point, pixels per mm.
    fn jacobian(&self, x: &Vector3<f64>) -> Matrix2x3<f64>;
    /// The Jacobian when it is the same for every model point (an affine camera), which lets
    /// the fitter use basis products summed once per model.
    fn affine_jacobian(&self) -> Option<Matrix2x3<f64>> {
        None
    }
    /// Model-to-camera rotation.
    fn rotation(&self) -> &Matrix3<f64>;
    /// Pixels per model millimetre at the face (weights and distance thresholds).
    fn scale(&self) -> f64;
    /// Derivative of [`Camera::project_up`] at model point `x` with respect to the camera's six
    /// parameters, in the order [`Camera::update`] takes them.
    fn parameter_jacobian(&self, x: &Vector3<f64>) -> Matrix2x6<f64>;
    /// The camera moved by a parameter increment (rotation increment first, applied on the
    /// left), or `None` if the result is not a valid camera.
    fn update(&self, delta: &Vector6<f64>) -> Option<Self>
    where
        Self: Sized;
}

/// `-[v]_x`: the derivative of `exp([w]_x) v` with respect to `w` at `w = 0`.
fn neg_skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, v.z, -v.y, -v.z, 0.0, v.x, v.y, -v.x, 0.0)
}

impl Camera for Pose {
    fn project_up(&self, x: &Vector3<f64>) -> Vector2<f64> {
        Pose::project_up(self, x)
    }

    fn jacobian(&self, _x: &Vector3<f64>) -> Matrix2x3<f64> {
        let r = self.rotation * self.scale;
        Matrix2x3::new(
            r[(0, 0)],
            r[(0, 1)],
            r[(0, 2)],
            r[(1, 0)],
            r[(1, 1)],
            r[(1, 2)],
        )
    }

    fn affine_jacobian(&self) -> Option<Matrix2x3<f64>> {
        Some(Camera::jacobian(self, &Vector3::zeros()))
    }

    fn rotation(&self) -> &Matrix3<f64> {
        &self.rotation
    }

    fn scale(&self) -> f64 {
        self.scale
    }

    /// Parameters: rotation increment (3), log-scale, translation (2).
    fn parameter_jacobian(&self, x: &Vector3<f64>) -> Matrix2x6<f64> {
        let rx = self.rotation * x;
        let s = self.scale;
        Matrix2x6::new(
            0.0,
            s * rx.z,
            -s * rx.y,
            s * rx.x,
            1.0,
            0.0,
            -s * rx.z,
            0.0,
            s * rx.x,
            s * rx.y,
            0.0,
            1.0,
        )
    }

    fn update(&self, d: &Vector6<f64>) -> Option<Self> {
        let w = Vector3::new(d[0], d[1], d[2]);
        let pose = Pose {
            rotation: nearest_rotation(&(Rotation3::new(w).into_inner() * self.rotation)),
            scale: self.scale * d[3].clamp(-0.5, 0.5).exp(),
            translation: self.translation + Vector2::new(d[4], d[5]),
        };
        (pose.scale.is_finite() && pose.scale > 0.0).then_some(pose)
    }
}

/// Intrinsics of a pinhole camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Intrinsics {
    /// Focal length, pixels.
    pub focal_px: f64,
    /// Principal point, image pixels (x right, y down).
    pub principal: [f64; 2],
}

impl Intrinsics {
    /// A camera whose horizontal field of view is `fov_deg`, centred on a `width` x `height`
    /// image (a typical webcam has 60-70 degrees).
    pub fn from_fov(width: f64, height: f64, fov_deg: f64) -> Self {
        Intrinsics {
            focal_px: 0.5 * width / (0.5 * fov_deg.to_radians()).tan(),
            principal: [0.5 * width, 0.5 * height],
        }
    }
}

/// A pinhole camera's pose: `X_cam = R X + t`, projected as `f * (x, y) / d + c`, `d = -z`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PerspectivePose {
    pub rotation: Matrix3<f64>,
    /// Translation, mm, camera frame.
    pub translation: Vector3<f64>,
    pub intrinsics: Intrinsics,
}

/// Points nearer than this (mm) to the camera plane are treated as behind it.
const MIN_DEPTH_MM: f64 = 1.0;

impl PerspectivePose {
    fn principal_up(&self) -> Vector2<f64> {
        Vector2::new(self.intrinsics.principal[0], -self.intrinsics.principal[1])
    }

    /// Distance of the model origin from the camera along its axis, mm.
    pub fn depth_mm(&self) -> f64 {
        -self.translation.z
    }

    /// The perspective camera that sees the model origin where an orthographic pose does, at
    /// the depth that gives the same scale (`d = f / s`).
    pub fn from_orthographic(pose: &Pose, intrinsics: Intrinsics) -> Self {
        let d = intrinsics.focal_px / pose.scale.max(1e-9);
        let c = Vector2::new(intrinsics.principal[0], -intrinsics.principal[1]);
        let xy = (pose.translation - c) * (d / intrinsics.focal_px);
        PerspectivePose {
            rotation: pose.rotation,
            translation: Vector3::new(xy.x, xy.y, -d),
            intrinsics,
        }
    }

    /// The scaled-orthographic pose that best stands in for this camera at the model origin.
    pub fn to_orthographic(&self) -> Pose {
        Pose {
            rotation: self.rotation,
            scale: self.scale(),
            translation: self.project_up(&Vector3::zeros()),
        }
    }

    /// `d(projection)/d(camera point)` at camera point `c`.
    fn projection_derivative(&self, c: &Vector3<f64>) -> Matrix2x3<f64> {
        let d = (-c.z).max(MIN_DEPTH_MM);
        let f = self.intrinsics.focal_px;
        Matrix2x3::new(f / d, 0.0, f * c.x / (d * d), 0.0, f / d, f * c.y / (d * d))
    }
}

impl Camera for PerspectivePose {
    fn project_up(&self, x: &Vector3<f64>) -> Vector2<f64> {
        let c = self.rotation * x + self.translation;
        let d = (-c.z).max(MIN_DEPTH_MM);
        Vector2::new(c.x, c.y) * (self.intrinsics.focal_px / d) + self.principal_up()
    }

    fn jacobian(&self, x: &Vector3<f64>) -> Matrix2x3<f64> {
        let c = self.rotation * x + self.translation;
        self.projection_derivative(&c) * self.rotation
    }

    fn rotation(&self) -> &Matrix3<f64> {
        &self.rotation
    }

    fn scale(&self) -> f64 {
        self.intrinsics.focal_px / self.depth_mm().max(MIN_DEPTH_MM)
    }

    /// Parameters: rotation increment (3), translation (3, mm).
    fn parameter_jacobian(&self, x: &Vector3<f64>) -> Matrix2x6<f64> {
        let rx = self.rotation * x;
        let dproj = self.projection_derivative(&(rx + self.translation));
        let jw = dproj * neg_skew(&rx);
        Matrix2x6::from_fn(|r, c| if c < 3 { jw[(r, c)] } else { dproj[(r, c - 3)] })
    }

    fn update(&self, d: &Vector6<f64>) -> Option<Self> {
        let w = Vector3::new(d[0], d[1], d[2]);
        let candidate = PerspectivePose {
            rotation: nearest_rotation(&(Rotation3::new(w).into_inner() * self.rotation)),
            translation: self.translation + Vector3::new(d[3], d[4], d[5]),
            intrinsics: self.intrinsics,
        };
        (candidate.depth_mm() > MIN_DEPTH_MM).then_some(candidate)
    }
}

/// Gauss-Newton (Levenberg-damped) on rotation and translation of a perspective camera,
/// minimising the reprojection error of `model` points onto `image_up`. Never returns a worse
/// pose than it was given; errors if the face ends up behind the camera.
pub fn refine_perspective(
    start: PerspectivePose,
    model: &[Vector3<f64>],
    image_up: &[Vector2<f64>],
    iterations: usize,
) -> Result<PerspectivePose, FitError> {
    let (best, best_cost) = damped_gauss_newton(start, model, image_up, iterations);
    if !(best.depth_mm() > MIN_DEPTH_MM && best_cost.is_finite()) {
        return Err(FitError::Degenerate(
            "the face would be behind the camera".into(),
        ));
    }
    Ok(best)
}
