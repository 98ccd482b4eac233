//! How the stone and the light show the relief (issue #16), measured on a rendered gem:
//!
//! * the marble's veins against the relief's own shading: the spread (standard deviation over
//!   mean) of the stone's brightness ratio with and without veins, against the spread of the
//!   plain stone's brightness (shading alone);
//! * how much subsurface scattering changes the picture: mean and 95th percentile of the grey
//!   level change over the stone, SSS on against off.
//!
//! `cargo run --release --example stone_metrics -- [FACE.obj] [WIDTHxHEIGHT]` (default: the
//! Surrey mean face, 640x800); a face from `glyptic photo --obj`.

use anyhow::{Context, Result};
use glyptic::gem::{self, CameoParams};
use glyptic::render::{Material, RenderParams, Renderer};

/// A backdrop no stone or gold comes near (magenta).
const BACKDROP: [f32; 3] = [0.9, 0.0, 0.9];

fn luminance(p: &image::Rgba<u8>) -> f64 {
    0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2])
}

/// Stone pixels: neither the magenta backdrop nor gold (the marble is near neutral).
fn is_stone(p: &image::Rgba<u8>) -> bool {
    let [r, g, b] = [p[0], p[1], p[2]].map(i32::from);
    let backdrop = r > 2 * g + 20 && b > 2 * g + 20;
    !backdrop && (r - b).abs() < 25 && (r - g).abs() < 25
}

fn spread(v: &[f64]) -> f64 {
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len() as f64;
    var.sqrt() / mean
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (mut face, mut size) = (None, (640u32, 800u32));
    for a in &args {
        if let Some((w, h)) = a
            .split_once('x')
            .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
        {
            size = (w, h);
        } else {
            face = Some(a.clone());
        }
    }
    let (positions, triangles) = match &face {
        Some(path) => {
            gem::parse_obj(&std::fs::read_to_string(path).with_context(|| path.clone())?)?
        }
        None => {
            let model = glyptic::shapemodel::SurreyModel::load_dir(&glyptic::assets::sfm_dir())?;
            (model.instance(&[], &[]), model.shape.triangles.clone())
        }
    };
    let mesh = gem::build_cameo(&positions, &triangles, &CameoParams::default())?;
    let mut renderer = Renderer::new_headless()?;
    let base = RenderParams {
        width: size.0,
        height: size.1,
        material: Material::Marble,
        background: BACKDROP,
        ..RenderParams::default()
    };
    let no_sss = RenderParams {
        sss: None,
        ..base.clone()
    };
    let mut plain = no_sss.clone();
    plain.marble.vein_lightness = 1.0;
    let veined = renderer.render(&mesh, &no_sss)?;
    let flat = renderer.render(&mesh, &plain)?;
    let scattered = renderer.render(&mesh, &base)?;
    let (mut ratio, mut shading, mut change) = (Vec::new(), Vec::new(), Vec::new());
    for ((v, p), s) in veined.pixels().zip(flat.pixels()).zip(scattered.pixels()) {
        if !(is_stone(v) && is_stone(p)) {
            continue;
        }
        let (lv, lp) = (luminance(v), luminance(p));
        if lp > 8.0 {
            ratio.push(lv / lp);
            shading.push(lp);
        }
        change.push((luminance(s) - lv).abs());
    }
    anyhow::ensure!(!ratio.is_empty(), "no stone pixels found");
    change.sort_by(f64::total_cmp);
    println!(
        "{} stone pixels at {}x{} ({}):",
        ratio.len(),
        size.0,
        size.1,
        face.as_deref().unwrap_or("the mean face")
    );
    println!(
        "  veins: brightness spread {:.1} %; the relief's own shading: {:.1} %",
        100.0 * spread(&ratio),
        100.0 * spread(&shading)
    );
    println!(
        "  SSS on vs off: mean change {:.2} grey levels, 95th percentile {:.1}, max {:.0}",
        change.iter().sum::<f64>() / change.len() as f64,
        change[change.len() * 95 / 100],
        change[change.len() - 1]
    );
    Ok(())
}
