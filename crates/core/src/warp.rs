//! The landmarks the shape model could not reach, carried onto the face: 63 shape components
//! under an identity prior fit the 68 points to within a few pixels, and what is left over is
//! partly noise and partly the person (the eyes' own shape, a mouth wider than the model
//! allows, a broad jaw, a brow's arch). Here the fitted face's landmark vertices are moved
//! across the camera's view onto the photo's landmarks, and the motion spread to the vertices
//! around them by a smooth interpolation that fades away from the landmarks (the ears, the
//! crown and the neck stay where the model put them).
//!
//! The control points: every mapped landmark of the brows, eyes and nose (iBUG 9 and 18-48)
//! at its vertex; the outer lips' (49-60) at half their pull (their residual is partly the
//! photo's expression, and the portrait carves half of it); not the inner lips (how far the
//! mouth is open); and each outline landmark (iBUG 1-8, 10-17) on a side of the face turned to
//! the camera at the nearest vertex of the model's outline, where only the motion across the
//! outline counts (a jaw point marks the outline, not a place along it), spread wider than the
//! features' (a jaw moved alone folds the cheek beside it). Residuals longer than
//! [`WarpParams::max_iod`] are cut back (a landmark gone astray should not tear the face). The
//! interpolation: Gaussian radial basis functions in the model's 3D frame, regularised (a
//! landmark's noise is not followed exactly).
//!
//! Measured (BENCHMARKS.md, issue #37): the gems' own person ranked first more often by a
//! recognition network glyptic never runs, on two of three photo sets; defaults chosen by
//! looking (a narrower basis or the whole mouth pursed the lips, a narrow outline creased the
//! jaw).
//!
//! Units: photo pixels (x right, y down) in; the displacement per vertex in model millimetres,
//! model frame, perpendicular to the camera's axis of the fit's pose (so it can be added to
//! any pose-free mesh of the fitted face's topology, the portrait included, like
//! [`crate::photometric::displacement`]). Pure computation.

use nalgebra::{DMatrix, Matrix3, Vector2, Vector3};

use crate::fit::Pose;
use crate::shapemodel::SurreyModel;

/// How far the face follows its landmarks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WarpParams {
    /// The motion times this (0: none; 1: the landmark vertices onto the photo's points, less
    /// the regularisation's shortfall).
    pub strength: f32,
    /// The basis functions' width (standard deviation), inter-ocular distances.
    pub sigma_iod: f32,
    /// Ridge term of the interpolation, relative to the kernel's diagonal (1).
    pub smoothing: f32,
    /// Residuals are cut back to this length, inter-ocular distances.
    pub max_iod: f32,
    /// The outline's landmarks (the jaw, across the outline only) pull with basis functions
    /// this wide (inter-ocular distances; 0: they do not pull). Wider than the features':
    /// a jaw moved in or out alone folds the cheek beside it.
    pub outline_sigma_iod: f32,
    /// The outer lips' (iBUG 49-60) motion times this: their residual is partly the photo's
    /// expression, which the portrait carves only in part
    /// (`FacePipeline::portrait_expression`). The inner lips (61-68: how far the mouth is
    /// open) never pull.
    pub lips: f32,
}

impl Default for WarpParams {
    fn default() -> Self {
        WarpParams {
            strength: 1.0,
            sigma_iod: 0.2,
            smoothing: 0.1,
            max_iod: 0.15,
            outline_sigma_iod: 0.5,
            lips: 0.5,
        }
    }
}

/// A landmark's pull: the vertex it acts at (model mm) and its motion (model mm).
#[derive(Clone, Copy, Debug)]
struct Control {
    at: Vector3<f64>,
    motion: Vector3<f64>,
    /// The basis function's width, model mm.
    sigma: f64,
}

/// What the warp did, for the report.
#[derive(Clone, Debug, PartialEq)]
pub struct Warp {
    /// Per vertex x, y, z (model mm, model frame): add to the fitted mesh or the portrait.
    pub displacement: Vec<f32>,
    /// Landmarks that pulled (inner and outline).
    pub controls: usize,
    /// Mean landmark residual before, pixels (the pulling landmarks; outline ones across the
    /// outline).
    pub residual_px: f32,
    /// Largest vertex motion, model mm.
    pub largest_mm: f32,
}

/// The displacement that carries `mesh` (the fitted face, model mm, pose-free, `model`'s
/// topology) onto the photo's `landmarks` (68, pixels) seen under `pose`. `None` when the
/// landmarks are not 68 finite points, the mesh is not the model's, the parameters are out of
/// range (a width, cut or ridge not positive, a share not finite), or nothing pulls.
pub fn landmark_warp(
    model: &SurreyModel,
    mesh: &[f32],
    landmarks: &[[f32; 2]],
    pose: &Pose,
    params: &WarpParams,
) -> Option<Warp> {
    let n = mesh.len() / 3;
    if landmarks.len() != 68
        || landmarks.iter().flatten().any(|v| !v.is_finite())
        || mesh.len() != 3 * model.shape.num_vertices()
        || !(pose.scale.is_finite() && pose.scale > 0.0)
        || !(params.strength.is_finite()
            && params.sigma_iod > 0.0
            && params.smoothing >= 0.0
            && params.max_iod > 0.0
            && params.outline_sigma_iod >= 0.0
            && params.lips.is_finite())
    {
        return None;
    }
    let iod_px = f64::from(crate::identity::eye_distance(landmarks)?);
    if iod_px.is_nan() || iod_px <= 1.0 {
        return None;
    }
    let vertex = |v: usize| {
        Vector3::new(
            f64::from(mesh[3 * v]),
            f64::from(mesh[3 * v + 1]),
            f64::from(mesh[3 * v + 2]),
        )
    };
    let landmark = |i: usize| Vector2::new(f64::from(landmarks[i][0]), f64::from(landmarks[i][1]));
    let max_px = f64::from(params.max_iod) * iod_px;
    let (sigma, outline_sigma) = (
        f64::from(params.sigma_iod) * iod_px / pose.scale,
        f64::from(params.outline_sigma_iod) * iod_px / pose.scale,
    );
    let cut = |r: Vector2<f64>| {
        let len = r.norm();
        if len > max_px { r * (max_px / len) } else { r }
    };
    // Image pixels (y down) across the camera's view -> model mm.
    let rt: Matrix3<f64> = pose.rotation.transpose();
    let to_model = |r: Vector2<f64>| rt * Vector3::new(r.x, -r.y, 0.0) / pose.scale;

    let mut controls = Vec::new();
    let (mut residual_sum, mut residuals) = (0.0, 0usize);
    for (&lm, &v) in &model.mapping.to_vertex {
        let (i, v) = (lm as usize - 1, v as usize);
        if i >= 60 || v >= n {
            continue;
        }
        let share = if i >= 48 { f64::from(params.lips) } else { 1.0 };
        let at = vertex(v);
        let r = landmark(i) - pose.project(&at);
        residual_sum += r.norm();
        residuals += 1;
        if share > 0.0 {
            controls.push(Control {
                at,
                motion: to_model(cut(r)) * share,
                sigma,
            });
        }
    }
    if outline_sigma > 0.0 {
        let normals = crate::raster::vertex_normals(mesh, &model.shape.triangles);
        let axis = pose.rotation.row(2).transpose();
        let sides = [
            (&model.mapping.contour_right, &model.contour.right),
            (&model.mapping.contour_left, &model.contour.left),
        ];
        for (lms, verts) in sides {
            let verts: Vec<usize> = verts
                .iter()
                .map(|&v| v as usize)
                .filter(|&v| v < n)
                .collect();
            if verts.is_empty() {
                continue;
            }
            // A side turned away from the camera shows its outline elsewhere than the
            // model's contour: its landmarks say nothing about these vertices.
            let facing = verts
                .iter()
                .map(|&v| {
                    let m = normals[v];
                    axis.dot(&Vector3::new(
                        f64::from(m[0]),
                        f64::from(m[1]),
                        f64::from(m[2]),
                    ))
                })
                .sum::<f64>()
                / verts.len() as f64;
            if facing < 0.0 {
                continue;
            }
            let projected: Vec<Vector2<f64>> =
                verts.iter().map(|&v| pose.project(&vertex(v))).collect();
            for &lm in lms.iter() {
                let i = lm as usize - 1;
                if i >= 17 {
                    continue;
                }
                let p = landmark(i);
                let Some((k, _)) = projected
                    .iter()
                    .enumerate()
                    .map(|(k, q)| (k, (q - p).norm_squared()))
                    .min_by(|a, b| a.1.total_cmp(&b.1))
                else {
                    continue;
                };
                // Across the landmarks' outline: its direction from the neighbours.
                let (a, b) = (landmark(i.saturating_sub(1)), landmark((i + 1).min(16)));
                let along = b - a;
                if along.norm() < 1e-6 {
                    continue;
                }
                let across = Vector2::new(-along.y, along.x).normalize();
                let r = p - projected[k];
                let r = across * r.dot(&across);
                residual_sum += r.norm();
                residuals += 1;
                controls.push(Control {
                    at: vertex(verts[k]),
                    motion: to_model(cut(r)),
                    sigma: outline_sigma,
                });
            }
        }
    }
    if controls.is_empty() {
        return None;
    }
    let residual_px = (residual_sum / residuals as f64) as f32;

    // Gaussian basis functions at the controls (each its own width), weights by a
    // ridge-regularised solve.
    let basis = |x: &Vector3<f64>, c: &Control| {
        (-(x - c.at).norm_squared() / (2.0 * c.sigma * c.sigma)).exp()
    };
    let m = controls.len();
    let mut gram = DMatrix::<f64>::zeros(m, m);
    for i in 0..m {
        for j in 0..m {
            gram[(i, j)] = basis(&controls[i].at, &controls[j]);
        }
        gram[(i, i)] += f64::from(params.smoothing);
    }
    let mut rhs = DMatrix::<f64>::zeros(m, 3);
    for (i, c) in controls.iter().enumerate() {
        for a in 0..3 {
            rhs[(i, a)] = c.motion[a];
        }
    }
    let weights = gram.lu().solve(&rhs)?;
    let strength = f64::from(params.strength);

    let mut displacement = vec![0f32; mesh.len()];
    let mut largest = 0f64;
    for v in 0..n {
        let x = vertex(v);
        let mut d = Vector3::zeros();
        for (i, c) in controls.iter().enumerate() {
            if (x - c.at).abs().max() > 4.0 * c.sigma {
                continue;
            }
            let w = basis(&x, c);
            d += Vector3::new(weights[(i, 0)], weights[(i, 1)], weights[(i, 2)]) * w;
        }
        d *= strength;
        if d.iter().all(|c| c.is_finite()) {
            largest = largest.max(d.norm());
            for a in 0..3 {
                displacement[3 * v + a] = d[a] as f32;
            }
        }
    }
    Some(Warp {
        displacement,
        controls: m,
        residual_px,
        largest_mm: largest as f32,
    })
}
