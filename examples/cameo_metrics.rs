//! The cameo's relief measured on real photos (issue #16's acceptance numbers): for each photo
//! the face is found, fitted and carved (profile), then
//!
//! * the profile line: distance from the fitted face's own profile (brow to chin) to the
//!   relief's outline, gem mm (mean and largest);
//! * the face leads: the share of the face's footprint where the portrait is the face;
//! * detail kept: slopes and fine detail against a uniform scale-down of the face to the same
//!   depth (and against one of the whole portrait, bust included);
//! * the rebuild time (median of 21 builds of the whole cameo mesh);
//!
//! and, over every pair of photos, the share of the relief that differs by more than 0.1 mm
//! (the whole relief, and the face's footprints alone).
//!
//! `cargo run --release --example cameo_metrics -- PHOTO...` (after `scripts/setup.sh`).

use std::path::PathBuf;

use anyhow::Result;
use glyptic::gem::{self, CameoParams, measure};
use glyptic::pipeline::FacePipeline;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<()> {
    let photos: Vec<PathBuf> = std::env::args().skip(1).map(PathBuf::from).collect();
    anyhow::ensure!(!photos.is_empty(), "usage: cameo_metrics PHOTO...");
    let mut pipeline = FacePipeline::load(&glyptic::assets::ModelPaths::locate())?;
    let params = CameoParams::default();
    let builder = gem::CameoBuilder::new(&params)?;
    let triangles = pipeline.model.shape.triangles.clone();
    println!(
        "| photo | profile line mean / max (mm) | face leads | slopes kept (face / portrait) | fine detail kept (face / portrait) | rebuild median (ms) |"
    );
    println!("|---|---|---|---|---|---|");
    let mut reliefs = Vec::new();
    for photo in &photos {
        let name = photo
            .file_stem()
            .map_or("?".into(), |s| s.to_string_lossy().into_owned());
        let face = match pipeline.photo(photo) {
            Ok((_, f)) => f,
            Err(e) => {
                println!("| {name} | no gem: {e} | | | | |");
                continue;
            }
        };
        let relief = builder.relief(&face.mesh, &triangles)?;
        let line = measure::profile_line(&relief, &face.mesh, &triangles);
        let portrait: Vec<bool> = relief.portrait.iter().map(|h| *h > 0.0).collect();
        let strict = measure::detail_kept(&relief, params.wall, params.relief_depth, &relief.face);
        let loose = measure::detail_kept(&relief, params.wall, params.relief_depth, &portrait);
        let leads = measure::face_leads(&relief);
        let times: Vec<f64> = (0..21)
            .map(|_| {
                let t = std::time::Instant::now();
                let mesh = builder.build(&face.mesh, &triangles);
                std::hint::black_box(mesh.is_ok());
                t.elapsed().as_secs_f64() * 1e3
            })
            .collect();
        println!(
            "| {name} | {} | {:.1} % | {:.2} / {:.2} | {:.2} / {:.2} | {:.1} |",
            line.map_or("-".into(), |l| format!(
                "{:.3} / {:.3}",
                l.mean_mm, l.max_mm
            )),
            100.0 * leads,
            strict.slopes,
            loose.slopes,
            strict.fine,
            loose.fine,
            median(times)
        );
        reliefs.push((name, relief));
    }
    let mut all = Vec::new();
    let mut faces = Vec::new();
    for i in 0..reliefs.len() {
        for j in i + 1..reliefs.len() {
            let d = measure::difference(&reliefs[i].1, &reliefs[j].1);
            if d < 0.15 {
                println!(
                    "pair {} / {}: {:.1} % differs",
                    reliefs[i].0,
                    reliefs[j].0,
                    100.0 * d
                );
            }
            all.push(f64::from(d));
            faces.push(f64::from(measure::face_difference(
                &reliefs[i].1,
                &reliefs[j].1,
            )));
        }
    }
    if !all.is_empty() {
        let stats = |v: &[f64]| {
            let mut s = v.to_vec();
            s.sort_by(f64::total_cmp);
            (s[0], s[s.len() / 2], s[s.len() - 1])
        };
        let (lo, mid, hi) = stats(&all);
        let (flo, fmid, fhi) = stats(&faces);
        println!(
            "\nRelief area differing by more than {} mm over {} pairs: min {:.1} %, median {:.1} %, max {:.1} % (the faces' footprints alone: min {:.1} %, median {:.1} %, max {:.1} %)",
            measure::DIFFERENCE_MM,
            all.len(),
            100.0 * lo,
            100.0 * mid,
            100.0 * hi,
            100.0 * flo,
            100.0 * fmid,
            100.0 * fhi
        );
    }
    Ok(())
}
