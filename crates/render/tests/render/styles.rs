//! The gallery styles' GPU passes against their CPU references (`glyptic_render::styles`), on the
//! cameo with the Surrey mean face: each pass alone, a GPU chain, and a chain that continues on
//! the CPU after dithering; golden images of each style alone (`GLYPTIC_BLESS=1` rewrites them).
//! One test function, one device.

use glyptic_core::gem::{self, CameoParams};
use glyptic_render::styles::{self, Style};
use glyptic_render::{Material, RenderParams};

use crate::golden::{GOLDEN_MEAN, check_golden, flip_mean};

/// Pixels whose channels differ by more than one level, and the largest difference.
fn compare(a: &image::RgbaImage, b: &image::RgbaImage) -> (usize, u8) {
    assert_eq!(a.dimensions(), b.dimensions());
    let mut off = 0;
    let mut worst = 0u8;
    for (p, q) in a.pixels().zip(b.pixels()) {
        let d = (0..4).map(|c| p[c].abs_diff(q[c])).max().unwrap_or(0);
        worst = worst.max(d);
        off += usize::from(d > 1);
    }
    (off, worst)
}

#[test]
fn gpu_style_passes_match_the_cpu_references() {
    let model = glyptic_core::shapemodel::SurreyModel::load_dir(&crate::common::sfm_dir())
        .expect("the Surrey model (scripts/setup.sh)");
    let mesh = gem::build_cameo(
        &model.instance(&[], &[]),
        &model.shape.triangles,
        &CameoParams::default(),
    )
    .unwrap();
    let mut renderer = crate::renderer();
    let base = RenderParams {
        width: 160,
        height: 200,
        material: Material::Agate,
        yaw_deg: -15.0,
        style_time_s: 1.3,
        ..RenderParams::default()
    };
    let plain = renderer.render(&mesh, &base).unwrap();
    let out = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/test-out");
    std::fs::create_dir_all(&out).unwrap();

    let chains: [&[Style]; 7] = [
        &[Style::Toon],
        &[Style::FishEye],
        &[Style::Chromatic],
        &[Style::Toon, Style::FishEye, Style::Chromatic],
        // Dithering is done on the CPU, and so is whatever follows it.
        &[Style::FishEye, Style::Dither, Style::Chromatic],
        &[Style::Painterly],
        &[Style::Painterly, Style::FishEye],
    ];
    for chain in chains {
        let name: Vec<&str> = chain.iter().map(|s| s.name()).collect();
        let name = name.join("+");
        let params = RenderParams {
            styles: chain.to_vec(),
            ..base.clone()
        };
        let gpu = renderer.render(&mesh, &params).unwrap();
        gpu.save(out.join(format!("style-{name}.png"))).unwrap();
        // The GPU part (the styles before the first CPU one) against the CPU references:
        // float rounding may tip a handful of pixels (a toon edge, a level boundary).
        let split = chain
            .iter()
            .position(|s| s.is_serial())
            .unwrap_or(chain.len());
        let prefix = renderer
            .render(
                &mesh,
                &RenderParams {
                    styles: chain[..split].to_vec(),
                    ..base.clone()
                },
            )
            .unwrap();
        let cpu = chain[..split].iter().fold(plain.clone(), |img, &s| {
            styles::apply(&img, s, base.style_time_s)
        });
        let (off, worst) = compare(&prefix, &cpu);
        let allowed = gpu.pixels().len() / 200;
        println!("{name}: {off} pixels off the CPU reference by more than a level (worst {worst})");
        assert!(
            off <= allowed,
            "{name}: {off} pixels differ from the CPU reference (worst {worst} levels; allowed {allowed})"
        );
        // The rest runs on the CPU after the readback, exactly (dithering would amplify any
        // difference in its input, so it is checked on the GPU's own image).
        let rest = chain[split..]
            .iter()
            .fold(prefix, |img, &s| styles::apply(&img, s, base.style_time_s));
        assert!(rest == gpu, "{name}: the CPU part differs");
        // And the style did something.
        let (changed, _) = compare(&gpu, &plain);
        assert!(changed > 500, "{name}: only {changed} pixels changed");
    }
    // Golden images of each style alone (what a look change would show). Dithering and
    // painterly amplify a rounding difference in their input into a different pattern (the
    // error diffusion; the seed read from the picture), so they style the committed golden of this very render
    // (the cameo module keeps the render itself to its golden); the chains above check that the
    // renderer runs them exactly on its own image.
    let plain_golden = image::open(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests")
            .join("golden")
            .join("cameo-agate-sss.png"),
    )
    .expect("the cameo golden")
    .to_rgba8();
    assert!(
        flip_mean(&plain_golden, &plain).0 <= GOLDEN_MEAN,
        "the plain render is not the cameo golden's"
    );
    let mut failures = Vec::new();
    for style in Style::ALL {
        // Dithering and painterly change their whole pattern for a rounding difference.
        let img = if matches!(style, Style::Dither | Style::Painterly) {
            styles::apply(&plain_golden, style, base.style_time_s)
        } else {
            renderer
                .render(
                    &mesh,
                    &RenderParams {
                        styles: vec![style],
                        ..base.clone()
                    },
                )
                .unwrap()
        };
        if let Err(e) = check_golden(&img, &format!("style-{}", style.name())) {
            failures.push(e);
        }
        // The tolerance sees the style: the plain render is far from its golden.
        let (from_plain, _) = flip_mean(&img, &plain);
        assert!(
            from_plain > 5.0 * GOLDEN_MEAN,
            "{}: FLIP mean {from_plain} from the plain render",
            style.name()
        );
    }
    assert!(
        failures.is_empty(),
        "golden images differ:\n{}",
        failures.join("\n")
    );
    // Each style is timed, in the chain's order: GPU passes by timestamps, the rest on the CPU.
    let chain = vec![Style::Toon, Style::Chromatic, Style::Dither, Style::FishEye];
    renderer
        .render(
            &mesh,
            &RenderParams {
                styles: chain.clone(),
                ..base.clone()
            },
        )
        .unwrap();
    if let Some(times) = renderer.last_pass_times() {
        println!("pass times with a style chain: {times:?}");
        let timed: Vec<Style> = times.styles_ms.iter().map(|&(s, _)| s).collect();
        assert_eq!(timed, chain);
        assert!(times.styles_ms.iter().all(|&(_, ms)| ms > 0.0 && ms < 1e4));
        assert!(times.scene_ms > 0.0 && times.composite_ms > 0.0);
    }
    // The mean face was a face: the plain render is not uniform.
    assert!(compare(&plain, &styles::apply(&plain, Style::Toon, 0.0)).0 > 500);
}
