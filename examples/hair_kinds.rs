//! The frontal hair the template carves today, one gem per kind, all on the Surrey mean face
//! (no photo, so the picture may be committed): bald, short hair cut above the ears, hair
//! standing wide, the classical template's hair, long hair falling as a photo's does, curly
//! hair in snail curls (short and long), a crop stippled close to the skull, and a bearded,
//! moustached face with glasses. The styles are what `gem::hair_style` makes of a
//! photo's readings (issue #38); the picture shows what each reading turns into.
//!
//! `cargo run --release --example hair_kinds -- OUT.png` (it prints each kind's builder time:
//! what a new hair style costs a kiosk rebuild).

use anyhow::{Context, Result};
use glyptic::gem::{self, HairStyle, View};
use glyptic::render::{RenderParams, Renderer};

fn main() -> Result<()> {
    let out = std::env::args()
        .nth(1)
        .context("usage: hair_kinds OUT.png")?;
    let model = glyptic::shapemodel::SurreyModel::load_dir(&glyptic::assets::sfm_dir())?;
    let mean = model.instance(&[], &[]);
    let triangles = &model.shape.triangles;
    let kinds = HairStyle::gallery();
    let mut renderer = Renderer::new_headless()?;
    let params = RenderParams {
        width: 240,
        height: 300,
        ..RenderParams::default()
    };
    let gap = 8;
    let mut sheet = image::RgbImage::from_pixel(
        kinds.len() as u32 * (params.width + gap) - gap,
        params.height,
        image::Rgb([255, 255, 255]),
    );
    for (k, (name, style)) in kinds.iter().enumerate() {
        let cameo = gem::CameoParams {
            hair: *style,
            ..View::Frontal.cameo()
        };
        // What a new hair style costs the kiosk: the builder (head, hair and bezel sampled
        // from the template), the median of three, one thread.
        let mut times: Vec<f64> = (0..3)
            .map(|_| {
                let t = std::time::Instant::now();
                let builder = gem::CameoBuilder::new(&cameo);
                std::hint::black_box(builder.is_ok());
                t.elapsed().as_secs_f64() * 1e3
            })
            .collect();
        times.sort_by(f64::total_cmp);
        let mesh = gem::build_cameo(&mean, triangles, &cameo)?;
        let rgba = renderer.render(&mesh, &params)?;
        let rgb = image::DynamicImage::ImageRgba8(rgba).into_rgb8();
        image::imageops::replace(
            &mut sheet,
            &rgb,
            i64::from(k as u32 * (params.width + gap)),
            0,
        );
        println!("{k}: {name} (builder {:.1} ms)", times[1]);
    }
    sheet.save(&out).with_context(|| out.clone())?;
    println!("wrote {out}");
    Ok(())
}
