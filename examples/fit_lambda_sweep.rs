//! Sweeps the identity prior weight on synthetic faces with known truth (40 faces, yaw
//! N(0, 35 deg), 0/2/6 px landmark noise at 3 px/mm) and prints the 3D error of each setting.
//! Run: `cargo run --release --example fit_lambda_sweep`.
use glyptic::fit::{self, FitOptions, Pose};
fn main() {
    let m = glyptic::shapemodel::SurreyModel::load_dir(&glyptic::assets::sfm_dir()).unwrap();
    let mut state = 7u64;
    let mut uni = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut cases = Vec::new();
    let mut g = move || {
        let (u1, u2) = (uni().max(1e-12), uni());
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    };
    for _ in 0..40 {
        let shape: Vec<f32> = (0..63).map(|_| g() as f32).collect();
        let expr: Vec<f32> = (0..6).map(|_| (g().abs() * 0.3) as f32).collect();
        let yaw = g().clamp(-2.0, 2.0) * 35.0;
        let pitch = g().clamp(-2.0, 2.0) * 10.0;
        let roll = g().clamp(-2.0, 2.0) * 10.0;
        let noise: Vec<[f64; 2]> = (0..68).map(|_| [g(), g()]).collect();
        cases.push((shape, expr, yaw, pitch, roll, noise));
    }
    let mean = m.instance(&[], &[]);
    let rms = |a: &[f32], b: &[f32]| {
        let n = a.len() / 3;
        let mut o = [0f64; 3];
        for i in 0..n {
            for k in 0..3 {
                o[k] += (a[3 * i + k] - b[3 * i + k]) as f64 / n as f64;
            }
        }
        let mut s = 0.0;
        for i in 0..n {
            for k in 0..3 {
                s += ((a[3 * i + k] - b[3 * i + k]) as f64 - o[k]).powi(2);
            }
        }
        (s / n as f64).sqrt()
    };
    for sigma_px in [0.0, 2.0, 6.0] {
        for lam in [3.0, 10.0, 30.0] {
            let (mut e, mut e0) = (0.0, 0.0);
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
                let f = fit::fit(
                    &m,
                    &lm,
                    &FitOptions {
                        lambda_shape: lam,
                        contour: false,
                        ..FitOptions::default()
                    },
                )
                .unwrap();
                let truth = m.instance(shape, expr);
                e += rms(&m.instance(&f.shape, &f.expression), &truth) / cases.len() as f64;
                e0 += rms(&mean, &truth) / cases.len() as f64;
            }
            println!(
                "noise {sigma_px} px (scale 3 px/mm), lambda {lam:4}: 3D RMS {e:.2} mm, mean face {e0:.2} mm, ratio {:.2}",
                e / e0
            );
        }
    }
}
