//! How far is the fit from what the landmarks allow? 40 synthetic faces (yaw N(0, 35 deg),
//! 3 px/mm, the mapped landmarks only, no contours), fitted with a fixed landmark noise (lambda 1) and with the
//! noise estimated from the residuals (lambda 1, 3, 10); against a floor: identity and
//! expressions solved linearly with the TRUE pose (lambda 0.1-30), which no fitter can beat
//! by much. Run: `cargo run --release --example fit_floor`.
#![allow(clippy::needless_range_loop)]
use glyptic::fit::{self, Camera, FitOptions, Pose};
use nalgebra::{DMatrix, DVector};
fn main() {
    let m = glyptic::shapemodel::SurreyModel::load_dir(&glyptic::assets::sfm_dir()).unwrap();
    let mut state = 7u64;
    let mut uni = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut g = move || {
        let (u1, u2) = (uni().max(1e-12), uni());
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    };
    let mut cases = Vec::new();
    for _ in 0..40 {
        let shape: Vec<f32> = (0..63).map(|_| g() as f32).collect();
        let expr: Vec<f32> = (0..6).map(|_| (g().abs() * 0.3) as f32).collect();
        let yaw = g().clamp(-2.0, 2.0) * 35.0;
        let pitch = g().clamp(-2.0, 2.0) * 10.0;
        let roll = g().clamp(-2.0, 2.0) * 10.0;
        let noise: Vec<[f64; 2]> = (0..68).map(|_| [g(), g()]).collect();
        cases.push((shape, expr, yaw, pitch, roll, noise));
    }
    let ne = m.packed.expressions;
    for sigma_px in [0.0, 1.0, 3.0] {
        let mut fit_e = [0.0; 4];
        let mut floor = [0.0; 5];
        let lams = [0.1, 1.0, 3.0, 10.0, 30.0];
        for (shape, expr, yaw, pitch, roll, noise) in &cases {
            let rot = nalgebra::Rotation3::from_euler_angles(
                pitch.to_radians(),
                yaw.to_radians(),
                roll.to_radians(),
            )
            .into_inner();
            let pose = Pose {
                rotation: rot,
                scale: 3.0,
                translation: nalgebra::Vector2::new(400.0, -500.0),
            };
            let mut lm = vec![[f32::NAN; 2]; 68];
            for (&l, &v) in &m.mapping.to_vertex {
                let p = pose.project(&m.vertex(v as usize, shape, expr));
                let nz = noise[l as usize - 1];
                lm[l as usize - 1] = [
                    (p.x + sigma_px * nz[0]) as f32,
                    (p.y + sigma_px * nz[1]) as f32,
                ];
            }
            let truth = m.instance(shape, expr);
            for (k, (j, lam)) in [(false, 1.0), (true, 1.0), (true, 3.0), (true, 10.0)]
                .iter()
                .enumerate()
            {
                let f = fit::fit(
                    &m,
                    &lm,
                    &FitOptions {
                        contour: false,
                        estimate_noise: *j,
                        lambda_shape: *lam,
                        tolerance: 0.0,
                        ..FitOptions::default()
                    },
                )
                .unwrap();
                fit_e[k] += fit::mesh_rms_mm(&m.instance(&f.shape, &f.expression), &truth)
                    / cases.len() as f64;
            }
            // True pose: linear LS on shape+expr, residual in mm.
            let corr: Vec<(usize, [f64; 2])> = m
                .mapping
                .to_vertex
                .iter()
                .map(|(&l, &v)| {
                    let p = lm[l as usize - 1];
                    (v as usize, [p[0] as f64, -(p[1] as f64)])
                })
                .collect();
            let n = 63 + ne;
            let mut a = DMatrix::<f64>::zeros(2 * corr.len(), n);
            let mut b = DVector::<f64>::zeros(2 * corr.len());
            for (i, (v, t)) in corr.iter().enumerate() {
                let mean = m.vertex(*v, &[], &[]);
                let pm = pose.project_up(&mean);
                b[2 * i] = (t[0] - pm.x) / 3.0;
                b[2 * i + 1] = (t[1] - pm.y) / 3.0;
                for k in 0..n {
                    let mut col = [0f64; 3];
                    for ax in 0..3 {
                        let (_, id, ex) = m.packed.row(3 * v + ax);
                        col[ax] = if k < 63 { id[k] } else { ex[k - 63] } as f64;
                    }
                    let c = rot * nalgebra::Vector3::from(col);
                    a[(2 * i, k)] = c.x;
                    a[(2 * i + 1, k)] = c.y;
                }
            }
            for (li, lam) in lams.iter().enumerate() {
                let mut ata = a.transpose() * &a;
                for k in 0..n {
                    ata[(k, k)] += if k < 63 { *lam } else { 0.1 };
                }
                let x = ata.cholesky().unwrap().solve(&(a.transpose() * &b));
                let s: Vec<f32> = x.iter().take(63).map(|&v| v as f32).collect();
                let e: Vec<f32> = x.iter().skip(63).map(|&v| v as f32).collect();
                floor[li] += fit::mesh_rms_mm(&m.instance(&s, &e), &truth) / cases.len() as f64;
            }
        }
        println!(
            "noise {sigma_px} px: fixed1 {:.2} est1 {:.2} est3 {:.2} est10 {:.2} | true pose lam 0.1 {:.2} 1 {:.2} 3 {:.2} 10 {:.2} 30 {:.2}",
            fit_e[0],
            fit_e[1],
            fit_e[2],
            fit_e[3],
            floor[0],
            floor[1],
            floor[2],
            floor[3],
            floor[4]
        );
    }
}
