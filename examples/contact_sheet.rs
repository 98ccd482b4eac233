//! Tiles pictures into one: `cargo run --release --example contact_sheet -- OUT.png COLUMNS
//! TILE_WxTILE_H IMAGE...`. Each picture is scaled to fit its tile (keeping its proportions)
//! and centred on the dark backdrop the renders use; rows fill left to right. Used by
//! `scripts/gallery.sh` to lay photos beside their gems.

use anyhow::{Context, Result, bail};

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 4 {
        bail!("usage: contact_sheet OUT.png COLUMNS TILE_WxTILE_H IMAGE...");
    }
    let columns: u32 = args[1].parse().context("COLUMNS")?;
    let (w, h) = args[2]
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
        .context("TILE_WxTILE_H")?;
    if columns == 0 || w == 0 || h == 0 {
        bail!("columns and tile size must be positive");
    }
    let images = &args[3..];
    let rows = (images.len() as u32).div_ceil(columns);
    let backdrop = image::Rgb([41u8, 46, 56]);
    let mut sheet = image::RgbImage::from_pixel(columns * w, rows * h, backdrop);
    for (k, path) in images.iter().enumerate() {
        let (path, crop) = match path.rsplit_once('@') {
            Some((file, rect)) if !std::path::Path::new(path).exists() => {
                let r: Vec<u32> = rect
                    .split(',')
                    .map(str::parse)
                    .collect::<Result<_, _>>()
                    .with_context(|| format!("{path}: @X,Y,W,H"))?;
                match r[..] {
                    [x, y, w, h] if w > 0 && h > 0 => (file, Some((x, y, w, h))),
                    _ => bail!("{path}: @X,Y,W,H with a positive width and height"),
                }
            }
            _ => (path.as_str(), None),
        };
        let mut img = image::open(path)
            .with_context(|| path.to_string())?
            .to_rgb8();
        if let Some((x, y, cw, ch)) = crop {
            if x.saturating_add(cw) > img.width() || y.saturating_add(ch) > img.height() {
                bail!("{path}: the part {cw}x{ch} at {x},{y} leaves the picture");
            }
            img = image::imageops::crop_imm(&img, x, y, cw, ch).to_image();
        }
        let scale = (w as f32 / img.width() as f32).min(h as f32 / img.height() as f32);
        let (tw, th) = (
            ((img.width() as f32 * scale).round() as u32).max(1),
            ((img.height() as f32 * scale).round() as u32).max(1),
        );
        let tile = image::imageops::resize(&img, tw, th, image::imageops::FilterType::Lanczos3);
        let (col, row) = (k as u32 % columns, k as u32 / columns);
        let (x, y) = (col * w + (w - tw) / 2, row * h + (h - th) / 2);
        image::imageops::replace(&mut sheet, &tile, i64::from(x), i64::from(y));
    }
    sheet.save(&args[0]).with_context(|| args[0].clone())?;
    Ok(())
}
