//! What [`glyptic::person`] finds on photos, as pictures: each photo with its hair tinted
//! orange, the skin model's skin left as it is, background dimmed; and the traits as a table
//! (hair, the beard's, jaw's and moustache's shares, the glasses' dip).
//!
//! `cargo run --release --example person_view -- OUT_DIR PHOTO...` writes OUT_DIR/NAME.png
//! (at most 360 pixels high) and prints a Markdown table.

use std::path::PathBuf;

use anyhow::{Context, Result};
use glyptic::person::{self, Label};
use glyptic::pipeline::FacePipeline;

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let out = PathBuf::from(args.next().context("usage: person_view OUT_DIR PHOTO...")?);
    let photos: Vec<PathBuf> = args.map(PathBuf::from).collect();
    std::fs::create_dir_all(&out)?;
    let mut stages = Vec::new();
    let mut pipeline = FacePipeline::load_default(&mut stages)?;
    println!(
        "| photo | hair | crown | top | sides | length | curl | brightness | beard | jaw | moustache | glasses | ms |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for photo in &photos {
        let name = photo
            .file_stem()
            .map_or("?".into(), |s| s.to_string_lossy().into_owned());
        let img = match glyptic::capture::load_photo(photo) {
            Ok(i) => i,
            Err(e) => {
                println!("| {name} | {e} |");
                continue;
            }
        };
        let face = match pipeline.process(&img, &mut stages) {
            Ok(f) => f,
            Err(e) => {
                println!("| {name} | no face: {e} |");
                continue;
            }
        };
        let t = std::time::Instant::now();
        let p = person::analyse(&img, &face.landmarks)?;
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let mut view = img.clone();
        for (x, y, px) in view.enumerate_pixels_mut() {
            let [r, g, b] = px.0.map(f32::from);
            let c = match p.labels.at_pixel(x as f32, y as f32) {
                Label::Hair => [0.35 * r + 0.65 * 255.0, 0.35 * g + 0.65 * 120.0, 0.35 * b],
                Label::Skin => [r, g, b],
                Label::Background => [0.35 * r, 0.35 * g, 0.35 * b + 60.0],
                Label::Outside => [0.2 * r, 0.2 * g, 0.2 * b],
            };
            px.0 = c.map(|v| v.clamp(0.0, 255.0) as u8);
        }
        let scale = 360.0 / view.height() as f32;
        let small = image::imageops::resize(
            &view,
            ((view.width() as f32 * scale).round() as u32).max(1),
            360,
            image::imageops::FilterType::Triangle,
        );
        small.save(out.join(format!("{name}.png")))?;
        let hair = p.hair.map_or("bald".to_string(), |_| "yes".into());
        let f = |v: Option<f32>| v.map_or("-".into(), |v| format!("{v:.2}"));
        let h = p.hair;
        println!(
            "| {name} | {hair} | {} | {} | {} | {} | {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {ms:.0} |",
            f(h.map(|h| h.crown)),
            f(h.map(|h| h.top)),
            f(h.map(|h| h.sides)),
            f(h.map(|h| h.length)),
            f(h.map(|h| h.curl)),
            f(h.map(|h| h.brightness)),
            p.beard,
            p.beard_jaw,
            p.moustache,
            p.glasses
        );
    }
    Ok(())
}
