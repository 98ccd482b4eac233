//! The likeness test's contact sheet (issue #17): can a stranger match gems to people?
//!
//! Top row: one photo of each person (deepface's identities, the first photo of each, in the
//! order of the lists). Below: every person's gems, shuffled (seeded), in rows of as many as
//! there are people. Nothing is written on the sheet: a gem is named by its row and column
//! (1-based, rows counted below the photos), and `OUT.key.txt` says whose it is. The photos
//! may not be redistributed: keep the sheet out of the repository.
//!
//! Gems come from `glyptic batch DATASET_DIR -o GEMS_DIR` (`NAME-gem.png` per photo).
//!
//! `cargo run --release --example likeness_sheet -- DATASET_DIR GEMS_DIR OUT.png`

#[path = "common/identities.rs"]
mod identities;

use std::path::PathBuf;

use anyhow::{Context, Result};
use image::{Rgb, RgbImage, imageops};

const W: u32 = 150;
const H: u32 = 180;
const GAP: u32 = 6;

/// The image scaled to fit W x H, centred on white.
fn tile(img: &RgbImage) -> RgbImage {
    let s = (W as f32 / img.width() as f32).min(H as f32 / img.height() as f32);
    let (w, h) = (
        ((img.width() as f32 * s).round() as u32).clamp(1, W),
        ((img.height() as f32 * s).round() as u32).clamp(1, H),
    );
    let small = imageops::resize(img, w, h, imageops::FilterType::Triangle);
    let mut t = RgbImage::from_pixel(W, H, Rgb([255, 255, 255]));
    imageops::replace(&mut t, &small, ((W - w) / 2).into(), ((H - h) / 2).into());
    t
}

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let usage = "usage: likeness_sheet DATASET_DIR GEMS_DIR OUT.png";
    let dataset = PathBuf::from(args.next().context(usage)?);
    let gems = PathBuf::from(args.next().context(usage)?);
    let out = PathBuf::from(args.next().context(usage)?);
    let ids = identities::identities(&dataset)?;
    let people = ids.values().copied().max().map_or(0, |m| m + 1);
    // One photo per person, and every gem there is.
    let mut faces: Vec<Option<String>> = vec![None; people];
    let mut tiles: Vec<(String, usize)> = Vec::new();
    for (name, &id) in &ids {
        if faces[id].is_none() {
            faces[id] = Some(name.clone());
        }
        let stem = name.rsplit_once('.').map_or(name.as_str(), |(s, _)| s);
        if gems.join(format!("{stem}-gem.png")).exists() {
            tiles.push((format!("{stem}-gem.png"), id));
        }
    }
    // A seeded shuffle (xorshift), so the sheet and its key are reproducible.
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    for i in (1..tiles.len()).rev() {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        tiles.swap(i, (state % (i as u64 + 1)) as usize);
    }
    let cols = people.max(1) as u32;
    let rows = (tiles.len() as u32).div_ceil(cols);
    let mut sheet = RgbImage::from_pixel(
        cols * (W + GAP) + GAP,
        (rows + 1) * (H + GAP) + 3 * GAP,
        Rgb([255, 255, 255]),
    );
    for (k, name) in faces.iter().enumerate() {
        let Some(name) = name else { continue };
        // By content: some of the set's ".jpg" files are WebP.
        let img = image::ImageReader::open(dataset.join(name))?
            .with_guessed_format()?
            .decode()
            .with_context(|| format!("{name}: cannot read"))?
            .to_rgb8();
        let x = GAP + k as u32 * (W + GAP);
        imageops::replace(&mut sheet, &tile(&img), x.into(), GAP.into());
    }
    let mut key =
        String::from("# row col (below the photos) -> person (column of their photo) and gem\n");
    for (k, (gem, id)) in tiles.iter().enumerate() {
        let full = image::open(gems.join(gem))
            .with_context(|| format!("{gem}: cannot read"))?
            .to_rgb8();
        // The head, as the stone's middle shows it (the default framing).
        let (fw, fh) = (full.width() as f32, full.height() as f32);
        let img = imageops::crop_imm(
            &full,
            (0.22 * fw) as u32,
            (0.08 * fh) as u32,
            (0.56 * fw) as u32,
            (0.56 * fh) as u32,
        )
        .to_image();
        let (r, c) = (k as u32 / cols, k as u32 % cols);
        let (x, y) = (GAP + c * (W + GAP), 3 * GAP + (r + 1) * (H + GAP));
        imageops::replace(&mut sheet, &tile(&img), x.into(), y.into());
        key.push_str(&format!("{} {} -> {} {gem}\n", r + 1, c + 1, id + 1));
    }
    sheet
        .save(&out)
        .with_context(|| format!("{}: cannot write", out.display()))?;
    let key_path = out.with_extension("key.txt");
    std::fs::write(&key_path, key)?;
    println!(
        "{}: {} people, {} gems; key in {}",
        out.display(),
        people,
        tiles.len(),
        key_path.display()
    );
    Ok(())
}
