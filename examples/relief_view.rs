//! Relief height fields as hillshades, for looking at the cameo's geometry without the renderer.
//!
//! `cargo run --release --example relief_view -- OUT.png [profile|frontal] FACE...`: each FACE
//! is `mean` (the Surrey mean face) or an OBJ written by `glyptic photo --obj`; the reliefs are
//! lit from the upper left at 20 degrees and laid side by side. FACE `template` is the
//! sculpted head and bust alone before the compression (canonical mm, 1 px a mm), to look at
//! the template's anatomy as sculpted.

use std::path::Path;

use anyhow::{Context, Result};
use glyptic::gem::{self, CameoParams};
use glyptic::shapemodel::SurreyModel;

fn load_obj(path: &Path) -> Result<(Vec<f32>, Vec<[u32; 3]>)> {
    let text = std::fs::read_to_string(path).with_context(|| format!("{}", path.display()))?;
    Ok(gem::parse_obj(&text)?)
}

/// Lambert light on a surface of slope (`sx`, `sy`) (height per unit, y up) from the upper
/// left, 20 degrees above the stone.
fn lit(sx: f32, sy: f32) -> f32 {
    let (az, el) = (135f32.to_radians(), 20f32.to_radians());
    let l = [az.cos() * el.cos(), az.sin() * el.cos(), el.sin()];
    let n = [-sx, -sy, 1.0];
    let len = (n[0] * n[0] + n[1] * n[1] + 1.0).sqrt();
    ((n[0] * l[0] + n[1] * l[1] + n[2] * l[2]) / len).max(0.0)
}

/// Hillshade of a relief: light from the upper left, 20 degrees above the stone.
pub fn hillshade(r: &gem::Relief) -> image::GrayImage {
    image::GrayImage::from_fn(r.cols as u32, r.rows as u32, |x, y| {
        let (c, row) = (x as usize, r.rows - 1 - y as usize);
        let dx = r.at((c + 1).min(r.cols - 1), row) - r.at(c.saturating_sub(1), row);
        let dy = r.at(c, (row + 1).min(r.rows - 1)) - r.at(c, row.saturating_sub(1));
        let d = lit(dx / (2.0 * r.cell), dy / (2.0 * r.cell));
        let ao = r.occlusion[row * r.cols + c];
        let v = 30.0 + 200.0 * d * (0.6 + 0.4 * ao) + 25.0 * ao;
        image::Luma([v.clamp(0.0, 255.0) as u8])
    })
}

/// Hillshade of the template's own heights (canonical mm, 1 px a mm, u -200..200,
/// v -340..200), lit as [`hillshade`] lights a relief.
fn template_hillshade(view: gem::View) -> image::GrayImage {
    let style = gem::HairStyle::default();
    let (w, h) = (401u32, 541u32);
    let at = |x: u32, y: u32| {
        gem::template::sample(view, &style, x as f32 - 200.0, 200.0 - y as f32).height
    };
    image::GrayImage::from_fn(w, h, |x, y| {
        let dx = at((x + 1).min(w - 1), y) - at(x.saturating_sub(1), y);
        let dy = at(x, y.saturating_sub(1)) - at(x, (y + 1).min(h - 1));
        let d = lit(dx / 2.0, dy / 2.0);
        image::Luma([(30.0 + 220.0 * d).clamp(0.0, 255.0) as u8])
    })
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (out, rest) = args
        .split_first()
        .context("usage: OUT.png [profile|frontal] FACE...")?;
    let (params, faces) = match rest.first().map(String::as_str) {
        Some("frontal") => (CameoParams::frontal(), &rest[1..]),
        Some("profile") => (CameoParams::default(), &rest[1..]),
        _ => (CameoParams::default(), rest),
    };
    let model = SurreyModel::load_dir(&glyptic::assets::sfm_dir())?;
    let builder = gem::CameoBuilder::new(&params)?;
    let mut tiles = Vec::new();
    for face in faces {
        if face == "template" {
            tiles.push(template_hillshade(params.view));
            continue;
        }
        let (pos, tris) = if face == "mean" {
            (model.instance(&[], &[]), model.shape.triangles.clone())
        } else {
            load_obj(Path::new(face))?
        };
        let t = std::time::Instant::now();
        let r = builder.relief(&pos, &tris)?;
        println!(
            "{face}: relief {:.1} ms, solve {:?}, placement {:?}",
            t.elapsed().as_secs_f64() * 1e3,
            r.solve,
            r.placement
        );
        if let Ok(dir) = std::env::var("RELIEF_DUMP") {
            // Raw f32 heights, portrait and face mask for offline inspection.
            let name = Path::new(face)
                .file_stem()
                .map_or("face".into(), |s| s.to_string_lossy().into_owned());
            let mut bytes = Vec::new();
            for v in r.height.iter().chain(&r.portrait) {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
            for f in &r.face {
                bytes.extend_from_slice(&(u8::from(*f) as f32).to_le_bytes());
            }
            std::fs::write(
                Path::new(&dir).join(format!("{name}_{}x{}.f32", r.cols, r.rows)),
                bytes,
            )?;
        }
        tiles.push(hillshade(&r));
    }
    let w = tiles.iter().map(|t| t.width()).max().unwrap_or(1);
    let h = tiles.iter().map(|t| t.height()).max().unwrap_or(1);
    let mut sheet = image::GrayImage::new(w * tiles.len() as u32, h);
    for (i, t) in tiles.iter().enumerate() {
        image::imageops::replace(&mut sheet, t, i as i64 * w as i64, 0);
    }
    sheet.save(out)?;
    Ok(())
}
