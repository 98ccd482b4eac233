//! The hair's hard cases (issue #38) on test heads painted here, so the picture may be
//! committed: a bald head, a shaved one, a hat over short hair, hair the wall's colour, white
//! hair on pale skin, a hand beside the face, long hair over the shoulders and standing curls.
//! Each head is read by `person::analyse_with` (with a person mask painted alongside, as the
//! segmentation network would give: the person, hat and hand included) from its known 68
//! landmarks, and carved on the Surrey mean face as `gem::hair_style` makes it; the picture
//! has the painted heads above their frontal gems, and a table of the readings is printed.
//!
//! `cargo run --release --example hard_cases -- OUT.png`

use anyhow::{Context, Result};
use glyptic::gem::{self, View};
use glyptic::person::{self, PersonMask};
use glyptic::render::{RenderParams, Renderer};
use image::RgbImage;

#[path = "../crates/core/src/person/test_head.rs"]
mod test_head;
use test_head::landmarks;

const W: u32 = 400;
const H: u32 = 520;
const SKIN: [f32; 3] = [222.0, 172.0, 142.0];
const BROWN: [f32; 3] = [62.0, 42.0, 28.0];

fn head(x: f32, y: f32) -> bool {
    ((x - 200.0) / 72.0).powi(2) + ((y - 205.0) / 125.0).powi(2) < 1.0
}

/// Hair over the crown standing `stand` px out, down the sides to the ears, and falling
/// beside the face to `end` (image y; 0: no fall).
fn hair(stand: f32, end: f32) -> impl Fn(f32, f32) -> bool {
    move |x, y| {
        let outer =
            ((x - 200.0) / (72.0 + stand)).powi(2) + ((y - 205.0) / (125.0 + stand)).powi(2) < 1.0;
        let crown = outer && y < 150.0;
        let sides = outer && !head(x, y) && y < 215.0;
        let fall = (x - 200.0).abs() > 62.0
            && (x - 200.0).abs() < 100.0 + 0.4 * (y - 140.0).max(0.0)
            && y > 140.0
            && y < end;
        crown || sides || fall
    }
}

/// Curls: in each 9 px cell of a staggered grid, rings round its centre (a factor about 1).
fn curls(x: f32, y: f32) -> f32 {
    let row = (y / 9.0).floor();
    let shift = if row as i32 % 2 == 0 { 0.0 } else { 4.5 };
    let (cx, cy) = (
        ((x - shift) / 9.0).floor() * 9.0 + 4.5 + shift,
        row * 9.0 + 4.5,
    );
    1.0 + 0.45 * (std::f32::consts::TAU * (x - cx).hypot(y - cy) / 4.5).cos()
}

/// Strands running down (a factor about 1).
fn strands(x: f32, y: f32) -> f32 {
    1.0 + 0.3 * (std::f32::consts::TAU * (x + 3.0 * (y / 40.0).sin()) / 5.0).sin()
}

/// Where something is painted on the test head (photo pixels).
type Region = Box<dyn Fn(f32, f32) -> bool>;

/// One painted test head.
struct Case {
    name: &'static str,
    skin: [f32; 3],
    wall: [f32; 3],
    hair_colour: [f32; 3],
    hair: Region,
    texture: fn(f32, f32) -> f32,
    /// Something else in front (a hat, a hand): where, and its colour.
    other: Option<(Region, [f32; 3])>,
}

impl Case {
    fn body(x: f32, y: f32) -> bool {
        (x - 200.0).abs() < 45.0 && y > 300.0
            || y > 420.0 && (x - 200.0).abs() < 60.0 + (y - 420.0) * 1.6
    }

    fn paint(&self) -> RgbImage {
        RgbImage::from_fn(W, H, |x, y| {
            let (fx, fy) = (x as f32, y as f32);
            let c = match &self.other {
                Some((on, colour)) if on(fx, fy) => *colour,
                _ if (self.hair)(fx, fy) => self.hair_colour.map(|v| v * (self.texture)(fx, fy)),
                _ if head(fx, fy) || (fx - 200.0).abs() < 45.0 && fy > 300.0 && fy < 420.0 => {
                    self.skin
                }
                _ if Self::body(fx, fy) => [40.0, 48.0, 70.0],
                _ => self.wall,
            };
            let n = ((x.wrapping_mul(73_856_093) ^ y.wrapping_mul(19_349_663)) % 17) as f32 - 8.0;
            image::Rgb(c.map(|v| (v + n).clamp(0.0, 255.0) as u8))
        })
    }

    /// The person as a segmentation network sees it: head, hair, body and whatever is in front.
    fn mask(&self) -> PersonMask {
        PersonMask::from_fn(130, [0.0, 0.0], 4.0, |x, y| {
            let other = self.other.as_ref().is_some_and(|(on, _)| on(x, y));
            f32::from(u8::from(
                head(x, y) || (self.hair)(x, y) || Self::body(x, y) || other,
            ))
        })
    }
}

fn main() -> Result<()> {
    let out = std::env::args()
        .nth(1)
        .context("usage: hard_cases OUT.png")?;
    let plain = |v: f32, _: f32| 1.0 + 0.0 * v;
    let wall = [150.0, 165.0, 185.0];
    let cases = [
        Case {
            name: "bald",
            skin: SKIN,
            wall,
            hair_colour: BROWN,
            hair: Box::new(|_, _| false),
            texture: plain,
            other: None,
        },
        Case {
            name: "shaved",
            skin: SKIN,
            wall,
            hair_colour: [120.0, 95.0, 80.0],
            hair: Box::new(|x, y| head(x, y) && y < 142.0),
            texture: curls,
            other: None,
        },
        Case {
            name: "hat over short hair",
            skin: SKIN,
            wall,
            hair_colour: BROWN,
            hair: Box::new(hair(8.0, 0.0)),
            texture: strands,
            other: Some((
                Box::new(|x, y| {
                    let crown = ((x - 200.0) / 80.0).powi(2) + ((y - 120.0) / 75.0).powi(2) < 1.0
                        && y < 128.0;
                    let brim = (x - 200.0).abs() < 118.0 && (118.0..134.0).contains(&y);
                    crown || brim
                }),
                [150.0, 40.0, 45.0],
            )),
        },
        Case {
            name: "hair the wall's colour",
            skin: SKIN,
            wall: [72.0, 50.0, 34.0],
            hair_colour: BROWN,
            hair: Box::new(hair(14.0, 0.0)),
            texture: strands,
            other: None,
        },
        Case {
            name: "white hair, pale skin",
            skin: [240.0, 214.0, 198.0],
            wall: [120.0, 130.0, 150.0],
            hair_colour: [232.0, 232.0, 228.0],
            hair: Box::new(hair(16.0, 0.0)),
            texture: strands,
            other: None,
        },
        Case {
            name: "a hand beside the face",
            skin: SKIN,
            wall,
            hair_colour: BROWN,
            hair: Box::new(hair(10.0, 0.0)),
            texture: strands,
            other: Some((
                Box::new(|x, y| {
                    let palm = ((x - 112.0) / 26.0).powi(2) + ((y - 300.0) / 40.0).powi(2) < 1.0;
                    let fingers = (x - 112.0).abs() < 22.0 && (220.0..300.0).contains(&y);
                    palm || fingers
                }),
                [214.0, 164.0, 134.0],
            )),
        },
        Case {
            name: "long over the shoulders",
            skin: SKIN,
            wall,
            hair_colour: [110.0, 70.0, 35.0],
            hair: Box::new(hair(14.0, 480.0)),
            texture: strands,
            other: None,
        },
        Case {
            name: "standing curls",
            skin: SKIN,
            wall,
            hair_colour: BROWN,
            hair: Box::new(hair(24.0, 0.0)),
            texture: curls,
            other: None,
        },
    ];
    let model = glyptic::shapemodel::SurreyModel::load_dir(&glyptic::assets::sfm_dir())?;
    let mean = model.instance(&[], &[]);
    let triangles = &model.shape.triangles;
    let lm = landmarks();
    let mut renderer = Renderer::new_headless()?;
    let params = RenderParams {
        width: 200,
        height: 250,
        ..RenderParams::default()
    };
    let (pw, ph) = (params.width, 260);
    let gap = 6;
    let mut sheet = image::RgbImage::from_pixel(
        cases.len() as u32 * (pw + gap) - gap,
        ph + params.height,
        image::Rgb([255, 255, 255]),
    );
    println!(
        "| case | hair | kind | ends (face lengths) | stands | beard | moustache | glasses | hat | hair IoU |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for (k, case) in cases.iter().enumerate() {
        let photo = case.paint();
        let p = person::analyse_with(&photo, &lm, Some(&case.mask()))?;
        let style = gem::hair_style(&p);
        let iou = gem::measure::frontal_hair_iou(&p.labels, &style, None);
        println!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} ({:.0}) | {} |",
            case.name,
            p.hair_length().as_str(),
            p.hair_kind().as_str(),
            p.hair.map_or("-".into(), |h| format!("{:.2}", h.length)),
            p.hair
                .map_or("-".into(), |h| format!("{:.2}", h.top.max(0.7 * h.sides))),
            if p.has_beard() { "yes" } else { "no" },
            if p.has_moustache() { "yes" } else { "no" },
            if p.has_glasses() { "yes" } else { "no" },
            if p.has_hat() { "yes" } else { "no" },
            p.hat,
            iou.map_or("-".into(), |v| format!("{v:.2}")),
        );
        let x0 = i64::from(k as u32 * (pw + gap));
        let small = image::imageops::resize(&photo, pw, ph, image::imageops::FilterType::Triangle);
        image::imageops::replace(&mut sheet, &small, x0, 0);
        let cameo = gem::CameoParams {
            hair: style,
            ..View::Frontal.cameo()
        };
        let mesh = gem::build_cameo(&mean, triangles, &cameo)?;
        let rgb = image::DynamicImage::ImageRgba8(renderer.render(&mesh, &params)?).into_rgb8();
        image::imageops::replace(&mut sheet, &rgb, x0, i64::from(ph));
    }
    sheet.save(&out).with_context(|| out.clone())?;
    println!("\nwrote {out}");
    Ok(())
}
