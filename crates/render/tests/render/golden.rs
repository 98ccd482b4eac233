//! Golden images, compared with NVIDIA's FLIP (a perceptual difference), not byte for byte:
//! lavapipe and llvmpipe differ in the last bits.

use std::path::Path;

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

/// Compares `img` with crates/render/tests/golden/`name`.png (which `GLYPTIC_BLESS=1` rewrites first).
/// Err names the failure and where the image was written (target/test-out/`name`.png).
pub fn check_golden(img: &image::RgbaImage, name: &str) -> Result<(), String> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join("golden");
    let path = dir.join(format!("{name}.png"));
    if std::env::var_os("GLYPTIC_BLESS").is_some() {
        std::fs::create_dir_all(&dir).expect("golden dir");
        img.save(&path).expect("save golden");
    }
    // The styles draw black dots and lines on purpose (dither, toon's outlines).
    if !name.starts_with("style-") {
        let dead = glyptic_render::inspect::dead_pixels(img);
        if !dead.is_empty() {
            return Err(format!(
                "{name}: {} isolated dead pixels, first at {:?}",
                dead.len(),
                &dead[..dead.len().min(5)]
            ));
        }
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
        let out = crate::common::test_out().join(format!("{name}.png"));
        let _ = std::fs::create_dir_all(out.parent().expect("parent"));
        let _ = img.save(&out);
        return Err(format!(
            "{name}: FLIP mean {mean:.4} (max {GOLDEN_MEAN}), 99th percentile {p99:.3} (max {GOLDEN_P99}); image in {}",
            out.display()
        ));
    }
    Ok(())
}

/// No golden image holds a dead pixel (blessing one would make it the reference); the
/// styles' goldens are left out, their black dots and lines are the style.
#[test]
fn no_golden_image_has_a_dead_pixel() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join("golden");
    let mut checked = 0;
    for entry in std::fs::read_dir(&dir).expect("golden dir") {
        let path = entry.expect("entry").path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if !name.ends_with(".png") || name.starts_with("style-") {
            continue;
        }
        let img = image::open(&path).expect("golden").to_rgba8();
        let dead = glyptic_render::inspect::dead_pixels(&img);
        assert!(dead.is_empty(), "{name}: dead pixels at {dead:?}");
        checked += 1;
    }
    assert!(checked >= 10, "only {checked} goldens found");
}
