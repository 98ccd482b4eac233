//! What a kiosk rebuild costs (issue #37: "time added to a kiosk rebuild measured"): the gem
//! thread's `CameoBuilder::build_after` (warm-started, the builder made once) for each photo's
//! fitted face, frontal, with the photo's detail as the kiosk carves it, the same without the
//! tone's match to the photo under the stone's light, without the
//! darks sunk into the key light's shadow, without the engraved lines, with its detail but no
//! stipple and no lines (the relief's grid stays at the solve grid's 0.2 mm), and without any
//! detail.
//! The variants are timed in turn, `--rounds` alternations of `--builds` builds after 3 warm-up
//! builds each, and their medians printed with the meshes' sizes.
//!
//! `cargo run --release --example gem_rebuild -- PHOTO... [--builds 21] [--rounds 4]
//! [--only K]` (`--only K`: time the K-th variant alone, 0-5, for a profiler)

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use glyptic::gem::{CameoBuilder, DetailParams, FaceDetail};
use glyptic::pipeline::gem::{GemPipeline, LoadOptions};

#[path = "common/stats.rs"]
mod stats;
use stats::median;

fn main() -> Result<()> {
    let mut photos = Vec::new();
    let (mut builds, mut rounds, mut only) = (21usize, 4usize, None);
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--builds" => builds = args.next().context("--builds N")?.parse()?,
            "--rounds" => rounds = args.next().context("--rounds N")?.parse()?,
            "--only" => only = Some(args.next().context("--only K")?.parse::<usize>()?),
            _ => photos.push(PathBuf::from(a)),
        }
    }
    anyhow::ensure!(
        !photos.is_empty(),
        "usage: gem_rebuild PHOTO... [--builds N] [--rounds N]"
    );
    let models = glyptic::assets::ModelPaths::locate();
    let mut pipeline = GemPipeline::load_with(
        &models,
        glyptic::gem::View::Frontal.cameo(),
        glyptic::pipeline::gem::Hair::Photo,
        LoadOptions::default(),
    )?;
    let triangles = pipeline.face.model.shape.triangles.clone();
    println!("| photo | variant | median ms | rounds' medians | vertices | triangles | grid mm |");
    println!("|---|---|---|---|---|---|---|");
    for path in &photos {
        pipeline.detail = Some(DetailParams::default());
        let pg = pipeline
            .photo(path)
            .with_context(|| format!("{}", path.display()))?;
        pipeline.detail = Some(DetailParams {
            stipple_mm: 0.0,
            engraved_lines_mm: 0.0,
            shadows: 0.0,
            ..DetailParams::default()
        });
        let smooth = pipeline.photo(path)?.detail;
        pipeline.detail = Some(DetailParams::default().with_shadows(0.0));
        let unshadowed = pipeline.photo(path)?.detail;
        pipeline.detail = Some(DetailParams::default().with_tone_match(0.0));
        let unmatched = pipeline.photo(path)?.detail;
        pipeline.detail = Some(DetailParams::default().engraved_lines_scaled(0.0));
        let unlined = pipeline.photo(path)?.detail;
        let builder = CameoBuilder::new(&pg.cameo)?;
        let face = &pg.face.portrait;
        let variants: [(&str, Option<&FaceDetail>); 6] = [
            ("detail, stippled", pg.detail.as_ref()),
            ("detail, stippled, no tone match", unmatched.as_ref()),
            ("detail, stippled, no shadows", unshadowed.as_ref()),
            ("detail, stippled, no engraved lines", unlined.as_ref()),
            ("detail, no stipple or lines", smooth.as_ref()),
            ("no detail", None),
        ];
        let mut times = vec![Vec::new(); variants.len()];
        let mut per_round = vec![Vec::new(); variants.len()];
        for _ in 0..rounds {
            for (k, (_, detail)) in variants.iter().enumerate() {
                if only.is_some_and(|o| o != k) {
                    continue;
                }
                let mut warm = Vec::new();
                for _ in 0..3 {
                    builder.build_after(face, &triangles, &mut warm, *detail)?;
                }
                let mut these = Vec::new();
                for _ in 0..builds {
                    let t = Instant::now();
                    builder.build_after(face, &triangles, &mut warm, *detail)?;
                    these.push(t.elapsed().as_secs_f64() * 1e3);
                }
                times[k].extend(these.iter().copied());
                per_round[k].push(median(these));
            }
        }
        let name = path.file_name().map_or_else(
            || path.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        for (k, (label, detail)) in variants.iter().enumerate() {
            if only.is_some_and(|o| o != k) {
                continue;
            }
            let relief = builder.relief_detailed(face, &triangles, &[], *detail)?;
            let mesh = builder.mesh_of(&relief);
            let rounds: Vec<String> = per_round[k].iter().map(|m| format!("{m:.1}")).collect();
            println!(
                "| {name} | {label} | {:.1} | {} | {} | {} | {} |",
                median(times[k].clone()),
                rounds.join(" / "),
                mesh.vertices.len(),
                mesh.indices.len() / 3,
                relief.cell
            );
        }
    }
    Ok(())
}
