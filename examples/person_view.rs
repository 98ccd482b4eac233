//! What [`glyptic::person`] finds on photos, as pictures: each photo with its hair tinted
//! orange, the skin model's skin left as it is, background dimmed; and the traits as a table
//! (hair, its kind and texture (`person::Texture`), the beard's, jaw's and moustache's shares, whether glasses were found (1 or 0) and
//! their measures: the bridge's line, the lenses' darkness, the dark bar's dip), and how well
//! the frontal gem's hair outline matches the photo's hair (intersection over union in the
//! head frame, `glyptic::gem::measure::frontal_hair_iou`; `--iou` draws it as NAME.iou.png:
//! both green, the photo's hair only red, the gem's only blue).
//!
//! `cargo run --release --example person_view -- OUT_DIR [--labels] PHOTO...` writes
//! OUT_DIR/NAME.png (360 pixels high) and prints a Markdown table.
//!
//! The person segmentation network helps (set-up installs it); `--colour-only` leaves it out,
//! as before it was there. The light on the fitted face (`glyptic::photometric`) tells a
//! shadowed jaw from a beard; `--unshaded` leaves it out.
//!
//! `--labels` draws the labels alone, without the photo's pixels (hair orange, skin beige,
//! background slate, beyond the canvas dark; the 68 landmarks white), and puts them side by
//! side in OUT_DIR/labels.png: a picture of what was found that holds nothing of the photo
//! (scripts/gallery.sh makes docs/person-labels.png so, from photos it only links to).
//!
//! `--mask` also writes OUT_DIR/NAME.mask.png: what the segmentation network says, the photo
//! in grey with the person tinted green by its probability (beyond the network's window dark).

use std::path::PathBuf;

use anyhow::{Context, Result};
use glyptic::detect::PersonSegmenter;
use glyptic::person::{self, Label};
use glyptic::pipeline::FacePipeline;

/// `view` scaled to 360 pixels high.
fn small(view: &image::RgbImage) -> image::RgbImage {
    let scale = 360.0 / view.height() as f32;
    image::imageops::resize(
        view,
        ((view.width() as f32 * scale).round() as u32).max(1),
        360,
        image::imageops::FilterType::Triangle,
    )
}

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let out = PathBuf::from(args.next().context("usage: person_view OUT_DIR PHOTO...")?);
    let (mut labels_only, mut colour_only, mut mask_only) = (false, false, false);
    let (mut unshaded, mut iou_pictures) = (false, false);
    let photos: Vec<PathBuf> = args
        .filter(|a| {
            unshaded |= a == "--unshaded";
            iou_pictures |= a == "--iou";
            labels_only |= a == "--labels";
            mask_only |= a == "--mask";
            colour_only |= a == "--colour-only";
            !a.starts_with("--")
        })
        .map(PathBuf::from)
        .collect();
    let mut sheet: Vec<image::RgbImage> = Vec::new();
    std::fs::create_dir_all(&out)?;
    let mut pipeline = FacePipeline::load(&glyptic::assets::ModelPaths::locate())?;
    let mut segmenter = if colour_only {
        None
    } else {
        Some(PersonSegmenter::load(
            &glyptic::assets::segmenter_model(),
            &glyptic::assets::onnxruntime_lib(),
        )?)
    };
    let header = "| photo | hair | crown | top | sides | length | curl | brightness | beard | jaw | moustache | glasses | curtain | ms | bridge | lenses | dip | hair iou | kind | coherence | iod px | hat | stubble | chin detail | lip stubble |";
    println!("{header}");
    println!("{}|", "|---".repeat(header.matches('|').count() - 1));
    for photo in &photos {
        let name = photo
            .file_stem()
            .map_or("?".into(), |s| s.to_string_lossy().into_owned());
        let (img, face) = match pipeline.photo(photo) {
            Ok(found) => found,
            Err(e) => {
                println!("| {name} | no face: {e} |");
                continue;
            }
        };
        // The light on the fitted face, as the photo path reads it (not timed here: the
        // `shading` stage's).
        let grey = image::imageops::grayscale(&img);
        let shading = (!unshaded)
            .then(|| {
                glyptic::photometric::fit(
                    &grey,
                    &face.landmarks,
                    &face.mesh,
                    &pipeline.model.shape.triangles,
                    &face.fit.pose,
                    &glyptic::photometric::ShadingParams::light_only(),
                )
                .ok()
            })
            .flatten();
        let t = std::time::Instant::now();
        let mask = segmenter
            .as_mut()
            .map(|s| s.segment(&img, &face.landmarks))
            .transpose()?;
        let p = person::analyse_shaded(
            &img,
            &face.landmarks,
            mask.as_ref(),
            shading
                .as_ref()
                .map(|f| &f.expected as &dyn person::Shading),
        )?;
        let ms = t.elapsed().as_secs_f64() * 1e3;
        if let (true, Some(m)) = (mask_only, &mask) {
            // The segmentation's verdict: the photo in grey, the person tinted green by its
            // probability, off the network's window dark.
            let mut view = img.clone();
            for (x, y, px) in view.enumerate_pixels_mut() {
                let [r, g, b] = px.0.map(f32::from);
                let grey = 0.3 * r + 0.59 * g + 0.11 * b;
                let c = match m.at([x as f32 + 0.5, y as f32 + 0.5]) {
                    Some(q) => [
                        grey * (1.0 - 0.5 * q),
                        grey * (1.0 - 0.5 * q) + 140.0 * q,
                        grey * (1.0 - 0.5 * q),
                    ],
                    None => [0.2 * grey; 3],
                };
                px.0 = c.map(|v| v.clamp(0.0, 255.0) as u8);
            }
            small(&view).save(out.join(format!("{name}.mask.png")))?;
        }
        let mut view = img.clone();
        // The box the labels' canvas covers (`--labels` crops to it: a big photo's head is
        // small in it).
        let (mut x0, mut y0, mut x1, mut y1) = (u32::MAX, u32::MAX, 0, 0);
        for (x, y, px) in view.enumerate_pixels_mut() {
            let [r, g, b] = px.0.map(f32::from);
            let label = p.labels.at_pixel(x as f32, y as f32);
            if label != Label::Outside {
                (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
            }
            let c = if labels_only {
                match label {
                    Label::Hair => [235.0, 120.0, 30.0],
                    Label::Skin => [232.0, 200.0, 170.0],
                    Label::Background => [70.0, 84.0, 110.0],
                    Label::Outside => [25.0, 25.0, 30.0],
                    Label::Hat => [150.0, 60.0, 170.0],
                }
            } else {
                match label {
                    Label::Hair => [0.35 * r + 0.65 * 255.0, 0.35 * g + 0.65 * 120.0, 0.35 * b],
                    Label::Skin => [r, g, b],
                    Label::Background => [0.35 * r, 0.35 * g, 0.35 * b + 60.0],
                    Label::Outside => [0.2 * r, 0.2 * g, 0.2 * b],
                    Label::Hat => [
                        0.35 * r + 0.65 * 150.0,
                        0.35 * g + 0.65 * 60.0,
                        0.35 * b + 0.65 * 170.0,
                    ],
                }
            };
            px.0 = c.map(|v| v.clamp(0.0, 255.0) as u8);
        }
        if labels_only {
            // The landmarks, a dot each, sized to the face (IOD / 25).
            let iod = (face.landmarks[45][0] - face.landmarks[36][0])
                .hypot(face.landmarks[45][1] - face.landmarks[36][1]);
            let r = (iod / 25.0).max(1.5) as i64;
            for q in &face.landmarks {
                let (cx, cy) = (q[0] as i64, q[1] as i64);
                for y in cy - r..=cy + r {
                    for x in cx - r..=cx + r {
                        let inside = (x - cx).pow(2) + (y - cy).pow(2) <= r * r;
                        if inside
                            && x >= 0
                            && y >= 0
                            && (x as u32) < view.width()
                            && (y as u32) < view.height()
                        {
                            view.put_pixel(x as u32, y as u32, image::Rgb([255, 255, 255]));
                        }
                    }
                }
            }
            if x1 > x0 && y1 > y0 {
                view =
                    image::imageops::crop_imm(&view, x0, y0, x1 - x0 + 1, y1 - y0 + 1).to_image();
            }
        }
        let small = small(&view);
        small.save(out.join(format!("{name}.png")))?;
        if labels_only {
            sheet.push(small);
        }
        // Where the gem's face covers its hair (the portrait mesh as the gem places it).
        let gem_face = glyptic::gem::measure::frontal_face_outline(&face.portrait);
        let style = glyptic::gem::hair_style(&p);
        let hair = p.hair.map_or("bald".to_string(), |_| "yes".into());
        let f = |v: Option<f32>| v.map_or("-".into(), |v| format!("{v:.2}"));
        let h = p.hair;
        let h_mask = h.map(|h| h.mask);
        println!(
            "| {name} | {hair} | {} | {} | {} | {} | {} | {} | {:.2} | {:.2} | {:.2} | {} | {} | {ms:.0} | {:.1} | {:.2} | {:.2} | {} | {} | {} | {} | {:.0} | {:.2} | {:.4} | {:.2} |",
            f(h.map(|h| h.crown)),
            f(h.map(|h| h.top)),
            f(h.map(|h| h.sides)),
            f(h.map(|h| h.length)),
            f(h.map(|h| h.curl)),
            f(h.map(|h| h.brightness)),
            p.beard,
            p.beard_jaw,
            p.moustache,
            u8::from(p.has_glasses()),
            f(h.map(|h| h.curtain)),
            p.glasses.bridge,
            p.glasses.lenses,
            p.glasses.dip,
            f(glyptic::gem::measure::frontal_hair_iou(
                &p.labels,
                &style,
                gem_face.as_deref()
            )),
            p.hair_kind().as_str(),
            f(h.map(|h| h.texture.coherence)),
            f(h.map(|h| h.texture.iod)),
            p.hat,
            p.stubble.ratio(),
            p.stubble.chin,
            p.stubble.lip_ratio(),
        );
        if iou_pictures {
            // The frontal gem's hair against the photo's, in the head frame scaled by the
            // face's length: both green, the photo's only red, the gem's only blue, the face
            // and beyond the photo grey.
            use glyptic::gem::measure::{HairCell, frontal_hair_cells};
            let (cells, w) = frontal_hair_cells(&p.labels, &style, gem_face.as_deref());
            let h = cells.len() / w;
            let pic = image::RgbImage::from_fn(w as u32, h as u32, |x, y| {
                image::Rgb(match cells[y as usize * w + x as usize] {
                    HairCell::Ignored => [90, 90, 90],
                    HairCell::Neither => [255, 255, 255],
                    HairCell::PhotoOnly => [220, 40, 40],
                    HairCell::GemOnly => [40, 80, 220],
                    HairCell::Both => [40, 170, 60],
                })
            });
            pic.save(out.join(format!("{name}.iou.png")))?;
            // The silhouette the gem's hair follows: the cleaned mask's hair white, its
            // neither black, unknown grey; the gem's outline (signed distance 0) red.
            if let (Some(hair), Some(sil)) = (h_mask, style.silhouette.as_ref()) {
                use glyptic::person::{HairMask, MASK_COLS, MASK_ROWS};
                let k = 4u32;
                let pic =
                    image::RgbImage::from_fn(MASK_COLS as u32 * k, MASK_ROWS as u32 * k, |x, y| {
                        let (r, c) = ((y / k) as usize, (x / k) as usize);
                        let [s, t] = HairMask::centre(r, c);
                        let fine = |dx: f32, dy: f32| {
                            let (u, v) = (
                                (s + dx) * glyptic::gem::FACE_LENGTH_MM,
                                glyptic::gem::EYES_V - (t + dy) * glyptic::gem::FACE_LENGTH_MM,
                            );
                            sil.at(u, v)
                        };
                        let step = glyptic::person::MASK_STEP / k as f32;
                        let (dx, dy) =
                            (((x % k) as f32 - 1.5) * step, ((y % k) as f32 - 1.5) * step);
                        if fine(dx, dy).abs() < 2.0 {
                            return image::Rgb([220, 40, 40]);
                        }
                        let share = hair.share[r][c];
                        image::Rgb(if share.is_nan() {
                            [120, 120, 120]
                        } else if share >= 0.5 {
                            [255, 255, 255]
                        } else {
                            [0, 0, 0]
                        })
                    });
                pic.save(out.join(format!("{name}.mask.png")))?;
            }
        }
    }
    if !sheet.is_empty() {
        let gap = 8;
        let width = sheet.iter().map(|i| i.width() + gap).sum::<u32>() - gap;
        let mut all = image::RgbImage::from_pixel(width, 360, image::Rgb([255, 255, 255]));
        let mut x = 0;
        for i in &sheet {
            image::imageops::replace(&mut all, i, i64::from(x), 0);
            x += i.width() + gap;
        }
        all.save(out.join("labels.png"))?;
    }
    Ok(())
}
