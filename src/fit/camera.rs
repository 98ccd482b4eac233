//! Cameras the fitter can use: scaled orthographic ([`Pose`]) and pinhole perspective
//! ([`PerspectivePose`]), behind one small trait so that the linearised identity and expression
//! solves are the same for both.
//!
//! Frames: model points in mm (y up, face along +z). Camera space: x right, y up, the camera at
//! the origin looking along -z (so a visible point has z < 0, depth `d = -z`). Image points in
//! the y-up frame `(x, -y)`, pixels.

use nalgebra::{Matrix2x3, Matrix3, Matrix6, Rotation3, Vector2, Vector3, Vector6};

use super::pose::damped_gauss_newton;
use super::{FitError, Pose, nearest_rotation};

/// What the fitting loop needs from a camera.
pub trait Camera {
    /// Projection of a model point into the y-up image frame, pixels.
    fn project_up(&self, x: &Vector3<f64>) -> Vector2<f64>;
    /// Derivative of [`Camera::project_up`] with respect to the model point, pixels per mm.
    fn jacobian(&self, x: &Vector3<f64>) -> Matrix2x3<f64>;
    /// Model-to-camera rotation.
    fn rotation(&self) -> &Matrix3<f64>;
    /// Pixels per model millimetre at the face (weights and distance thresholds).
    fn scale(&self) -> f64;
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

    fn rotation(&self) -> &Matrix3<f64> {
        &self.rotation
    }

    fn scale(&self) -> f64 {
        self.scale
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
    let cost = |p: &PerspectivePose| -> f64 {
        model
            .iter()
            .zip(image_up)
            .map(|(x, u)| (p.project_up(x) - u).norm_squared())
            .sum()
    };
    let normal = |p: &PerspectivePose| {
        let mut jtj = Matrix6::<f64>::zeros();
        let mut jtr = Vector6::<f64>::zeros();
        for (x, u) in model.iter().zip(image_up) {
            let rx = p.rotation * x;
            let dproj = p.projection_derivative(&(rx + p.translation));
            let res = p.project_up(x) - u;
            // d(c)/d(w) = -[R x]_x for a rotation increment applied on the left; d(c)/d(t) = I.
            let skew = Matrix3::new(0.0, rx.z, -rx.y, -rx.z, 0.0, rx.x, rx.y, -rx.x, 0.0);
            let jw = dproj * skew;
            for row in 0..2 {
                let j = Vector6::new(
                    jw[(row, 0)],
                    jw[(row, 1)],
                    jw[(row, 2)],
                    dproj[(row, 0)],
                    dproj[(row, 1)],
                    dproj[(row, 2)],
                );
                jtj += j * j.transpose();
                jtr += j * res[row];
            }
        }
        (jtj, jtr)
    };
    let step = |p: &PerspectivePose, d: &Vector6<f64>| {
        let w = Vector3::new(d[0], d[1], d[2]);
        let candidate = PerspectivePose {
            rotation: nearest_rotation(&(Rotation3::new(w).into_inner() * p.rotation)),
            translation: p.translation + Vector3::new(d[3], d[4], d[5]),
            intrinsics: p.intrinsics,
        };
        (candidate.depth_mm() > MIN_DEPTH_MM).then_some(candidate)
    };
    let (best, best_cost) = damped_gauss_newton(start, iterations, cost, normal, step);
    if !(best.depth_mm() > MIN_DEPTH_MM && best_cost.is_finite()) {
        return Err(FitError::Degenerate(
            "the face would be behind the camera".into(),
        ));
    }
    Ok(best)
}
