//! The real cameo (the Surrey mean face and synthetic identities) through the headless renderer:
//! no holes inside the gem's silhouette from any view, a relief that is one height field (no
//! triangle can poke through another), and golden images per stone with SSS on and off,
//! compared with NVIDIA's FLIP so that lavapipe (Vulkan) and llvmpipe (GL) both pass.
//!
//! The settings (milgrain with a bail, rope) against goldens of their own.
//!
//! The binary's one device (see main.rs). `GLYPTIC_BLESS=1` rewrites the golden
//! images in tests/golden/ (then look at them before committing).

use glyptic_core::gem::{self, CameoBuilder, CameoParams};
use glyptic_core::shapemodel::SurreyModel;
use glyptic_render::{Material, Mesh, Region, RenderParams};

use crate::golden::{GOLDEN_MEAN, GOLDEN_P99, check_golden, flip_mean};

/// A backdrop no stone or gold colour comes near: hue magenta.
const BACKDROP: [f32; 3] = [0.9, 0.0, 0.9];

fn is_backdrop(p: &image::Rgba<u8>) -> bool {
    let [r, g, b] = [p[0], p[1], p[2]].map(i32::from);
    r > 2 * g + 20 && b > 2 * g + 20
}

/// Backdrop pixels that cannot be reached from the image border through other backdrop pixels:
/// the background showing through a hole in the gem.
fn enclosed_backdrop(img: &image::RgbaImage) -> usize {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let back: Vec<bool> = img.pixels().map(is_backdrop).collect();
    let mut seen = vec![false; w * h];
    let mut stack: Vec<usize> = (0..w)
        .flat_map(|x| [x, (h - 1) * w + x])
        .chain((0..h).flat_map(|y| [y * w, y * w + w - 1]))
        .filter(|&i| back[i])
        .collect();
    while let Some(i) = stack.pop() {
        if seen[i] {
            continue;
        }
        seen[i] = true;
        let (x, y) = (i % w, i / w);
        for (nx, ny) in [
            (x.wrapping_sub(1), y),
            (x + 1, y),
            (x, y.wrapping_sub(1)),
            (x, y + 1),
        ] {
            if nx < w && ny < h && back[ny * w + nx] && !seen[ny * w + nx] {
                stack.push(ny * w + nx);
            }
        }
    }
    back.iter().zip(&seen).filter(|(b, s)| **b && !**s).count()
}

/// The stone's top is one height field without holes: seen from above (+Z) every triangle of it
/// keeps its orientation (nothing folds over), and sample points spread over the grid's cells
/// fall in exactly one triangle each (none overlaps another, so nothing can poke through; none
/// is missing). Samples sit at an irrational offset in each cell, off every triangle edge.
fn assert_height_field(mesh: &Mesh, name: &str) {
    let p = CameoParams::default();
    let cols = (2.0 * p.half_width / p.cell).round() as usize + 1;
    let rows = (2.0 * p.half_height / p.cell).round() as usize + 1;
    let (ox, oy) = (-p.half_width, -p.half_height);
    let mut hits = vec![0u8; cols * rows];
    for t in mesh.indices.chunks_exact(3) {
        let v: [glyptic_render::Vertex; 3] = std::array::from_fn(|k| mesh.vertices[t[k] as usize]);
        if v.iter().any(|v| v.region == Region::Gold as u32) {
            continue;
        }
        // In cell units.
        let [a, b, c] = v.map(|v| [(v.position[0] - ox) / p.cell, (v.position[1] - oy) / p.cell]);
        let signed = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
        assert!(
            signed > 0.0,
            "{name}: a relief triangle folds over ({signed})"
        );
        let lo = [
            a[0].min(b[0]).min(c[0]).floor() as usize,
            a[1].min(b[1]).min(c[1]).floor() as usize,
        ];
        let hi = [
            a[0].max(b[0]).max(c[0]).ceil() as usize,
            a[1].max(b[1]).max(c[1]).ceil() as usize,
        ];
        for y in lo[1]..hi[1].min(rows) {
            for x in lo[0]..hi[0].min(cols) {
                let q = [x as f32 + 0.3137, y as f32 + 0.4241];
                let side = |p: [f32; 2], r: [f32; 2]| {
                    (r[0] - p[0]) * (q[1] - p[1]) - (q[0] - p[0]) * (r[1] - p[1])
                };
                if side(a, b) > 0.0 && side(b, c) > 0.0 && side(c, a) > 0.0 {
                    hits[y * cols + x] += 1;
                }
            }
        }
    }
    // Nodes on the oval itself may round either way: cells touching one are not judged.
    let r2 = |x: usize, y: usize| {
        let (gx, gy) = (ox + x as f32 * p.cell, oy + y as f32 * p.cell);
        (gx / p.half_width).powi(2) + (gy / p.half_height).powi(2)
    };
    let inside = |x: usize, y: usize| r2(x, y) <= 1.0;
    let borderline = |x: usize, y: usize| (r2(x, y) - 1.0).abs() < 1e-5;
    let (mut cells, mut wrong) = (0, 0);
    for y in 0..rows - 1 {
        for x in 0..cols - 1 {
            let whole =
                inside(x, y) && inside(x + 1, y) && inside(x, y + 1) && inside(x + 1, y + 1);
            let h = hits[y * cols + x];
            if [(x, y), (x + 1, y), (x, y + 1), (x + 1, y + 1)]
                .iter()
                .any(|&(a, b)| borderline(a, b))
            {
                continue;
            }
            if whole {
                cells += 1;
            }
            if h != u8::from(whole) {
                wrong += 1;
                println!("{name}: cell ({x}, {y}) hit {h} times, inside the oval: {whole}");
            }
        }
    }
    assert_eq!(
        wrong, 0,
        "{name}: {wrong} of {cells} cells not covered exactly once"
    );
}

#[test]
fn cameo_has_no_holes_and_matches_its_golden_images() {
    let model =
        SurreyModel::load_dir(&crate::common::sfm_dir()).expect("run scripts/setup.sh first");
    let mut renderer = crate::renderer();
    let builder = CameoBuilder::new(&CameoParams::default()).expect("builder");
    let n = model.shape.num_components();
    let faces: Vec<(&str, Vec<f32>)> = vec![
        ("mean", model.instance(&[], &[])),
        ("+2 SD", model.instance(&vec![2.0; n], &[])),
        (
            "mixed, smiling",
            model.instance(
                &(0..n)
                    .map(|i| if i % 2 == 0 { 1.5 } else { -1.5 })
                    .collect::<Vec<_>>(),
                &[0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
            ),
        ),
    ];

    // --- No holes: profile and frontal portraits, from the front and turned far to each side,
    // above and below.
    let frontal = CameoBuilder::new(&CameoParams::frontal()).expect("frontal builder");
    let mut worst = 0usize;
    let cases = faces.iter().flat_map(|(name, face)| {
        [
            (*name, "profile", face, &builder),
            (*name, "frontal", face, &frontal),
        ]
    });
    for (face_name, view, face, b) in cases {
        let name = format!("{face_name} ({view})");
        let name = name.as_str();
        let mesh = b.build(face, &model.shape.triangles).expect("cameo");
        assert_height_field(&mesh, name);
        for (yaw, pitch) in [
            (0.0, 0.0),
            (-60.0, 0.0),
            (60.0, 10.0),
            (25.0, -40.0),
            (-30.0, 50.0),
        ] {
            let p = RenderParams {
                width: 120,
                height: 150,
                yaw_deg: yaw,
                pitch_deg: pitch,
                background: BACKDROP,
                sss: None,
                ..RenderParams::default()
            };
            let img = renderer.render(&mesh, &p).expect("render");
            let holes = enclosed_backdrop(&img);
            let backdrop = img.pixels().filter(|p| is_backdrop(p)).count();
            assert!(
                backdrop > 1000,
                "{name} yaw {yaw} pitch {pitch}: the backdrop test colour is not recognised"
            );
            worst = worst.max(holes);
            assert_eq!(
                holes, 0,
                "{name} yaw {yaw} pitch {pitch}: {holes} hole pixels"
            );
        }
    }
    println!(
        "no holes: {} faces x 2 portraits x 5 views, worst {worst}",
        faces.len()
    );

    // The hole detector finds a real hole: cut triangles out of the relief's middle.
    let mut holed = builder
        .build(&faces[0].1, &model.shape.triangles)
        .expect("cameo");
    let cut: Vec<u32> = holed
        .indices
        .chunks_exact(3)
        .filter(|t| {
            !t.iter().all(|&i| {
                let p = holed.vertices[i as usize].position;
                p[0].abs() < 3.0 && (p[1] - 5.0).abs() < 3.0
            })
        })
        .flatten()
        .copied()
        .collect();
    // The back plate would show through: drop the gold too, so the backdrop does.
    let gold_free: Vec<u32> = cut
        .chunks_exact(3)
        .filter(|t| {
            !t.iter()
                .any(|&i| holed.vertices[i as usize].region == Region::Gold as u32)
        })
        .flatten()
        .copied()
        .collect();
    holed.indices = gold_free;
    let p = RenderParams {
        width: 120,
        height: 150,
        background: BACKDROP,
        sss: None,
        ..RenderParams::default()
    };
    let holes = enclosed_backdrop(&renderer.render(&holed, &p).expect("holed"));
    println!("a 6 x 6 mm cut shows {holes} hole pixels");
    assert!(holes > 20, "the hole detector missed a 6 mm hole ({holes})");

    // --- Golden images.
    let mean = gem::build_cameo(&faces[0].1, &model.shape.triangles, &CameoParams::default())
        .expect("mean cameo");
    let mut renders = Vec::new();
    let mut failures = Vec::new();
    for material in Material::ALL {
        let mname = material.name();
        for (sss, sname) in [(true, "sss"), (false, "nosss")] {
            let p = RenderParams {
                width: 160,
                height: 200,
                material,
                yaw_deg: -15.0,
                sss: sss.then(glyptic_render::sss::SssParams::default),
                ..RenderParams::default()
            };
            let img = renderer.render(&mean, &p).expect("golden render");
            if let Err(e) = check_golden(&img, &format!("cameo-{mname}-{sname}")) {
                failures.push(e);
            }
            renders.push(((mname, sname), img));
        }
    }
    // The full-screen passes (SSS blur, composite) as compute passes and as fragment passes:
    // the same image (the golden above was drawn with whichever this device uses by default).
    let default_compute = renderer.compute_passes();
    let opaque = RenderParams {
        width: 160,
        height: 200,
        yaw_deg: -15.0,
        ..RenderParams::default()
    };
    // Transparent (the composite's other variant), without SSS.
    let clear = RenderParams {
        transparent: true,
        sss: None,
        ..opaque.clone()
    };
    for (what, p) in [("opaque, SSS", &opaque), ("transparent, no SSS", &clear)] {
        let mut by_pass = Vec::new();
        for compute in [true, false] {
            let used = renderer.set_compute_passes(compute);
            by_pass.push((used, renderer.render(&mean, p).expect("pass render")));
        }
        println!(
            "{what}: compute passes {} on this device (default {default_compute})",
            by_pass[0].0
        );
        assert!(!by_pass[1].0, "the fragment passes can always be chosen");
        let (a, b) = (&by_pass[0].1, &by_pass[1].1);
        let worst = a
            .as_raw()
            .iter()
            .zip(b.as_raw())
            .map(|(x, y)| x.abs_diff(*y))
            .max()
            .unwrap_or(0);
        println!("{what}: compute vs fragment passes, largest difference {worst} of 255");
        assert!(
            worst <= 1,
            "{what}: the compute passes differ from the fragment passes by {worst}"
        );
    }
    renderer.set_compute_passes(default_compute);
    // The scene pass in its compute form (a visibility image, its pixels shaded in a compute
    // pass) and as a fragment pass: the same picture within the goldens' tolerance, with MSAA
    // and without, on a layered stone with its hair layer, with the engraving and the lamp.
    let default_scene = renderer.compute_scene();
    let scene_cases = [
        ("marble, SSS, 4x MSAA", opaque.clone()),
        (
            "one sample a pixel",
            RenderParams {
                antialias: false,
                ..opaque.clone()
            },
        ),
        (
            "agate with its hair layer",
            RenderParams {
                material: Material::Agate,
                hair_layer: true,
                ..opaque.clone()
            },
        ),
        (
            "engraving and lamp",
            RenderParams {
                width: 320,
                height: 400,
                engraving: Some(glyptic_render::surface::EngravingParams::default()),
                lamp: Some(glyptic_render::Lamp::default()),
                ..opaque.clone()
            },
        ),
    ];
    for (what, p) in &scene_cases {
        if !renderer.set_compute_scene(true) {
            println!("scene pass: no compute form on this device (it lacks the primitive index)");
            break;
        }
        let compute = renderer.render(&mean, p).expect("compute scene render");
        assert!(!renderer.set_compute_scene(false));
        let fragment = renderer.render(&mean, p).expect("fragment scene render");
        let (flip, p99) = flip_mean(&fragment, &compute);
        let differing = compute
            .as_raw()
            .iter()
            .zip(fragment.as_raw())
            .filter(|(x, y)| x.abs_diff(**y) > 2)
            .count();
        println!(
            "scene pass, compute vs fragment form, {what}: FLIP mean {flip:.5}, p99 {p99:.4}, \
             {differing} channels off by more than 2 of 255"
        );
        let dead = glyptic_render::inspect::dead_pixels(&compute);
        assert!(
            dead.is_empty(),
            "{what}: the compute form left dead pixels at {dead:?}"
        );
        assert!(
            flip <= GOLDEN_MEAN && p99 <= GOLDEN_P99,
            "{what}: the scene pass's compute form differs from its fragment form \
             (FLIP mean {flip}, p99 {p99})"
        );
    }
    renderer.set_compute_scene(default_scene);
    // The surface effects (engraved border, lamp with shadows) at twice the size: the border's
    // grooves are a fraction of a millimetre.
    let surface = RenderParams {
        width: 320,
        height: 400,
        material: Material::Marble,
        yaw_deg: -15.0,
        engraving: Some(glyptic_render::surface::EngravingParams::default()),
        lamp: Some(glyptic_render::Lamp::default()),
        ..RenderParams::default()
    };
    let with_effects = renderer.render(&mean, &surface).expect("surface golden");
    if let Err(e) = check_golden(&with_effects, "cameo-marble-engraving-lamp") {
        failures.push(e);
    }
    let without = renderer
        .render(
            &mean,
            &RenderParams {
                engraving: None,
                lamp: None,
                ..surface.clone()
            },
        )
        .expect("surface golden's plain twin");
    let (effects, _) = flip_mean(&without, &with_effects);
    println!("FLIP mean, engraving and lamp on vs off {effects:.4}");
    assert!(
        effects > 2.0 * GOLDEN_MEAN,
        "the golden tolerance would not notice the surface effects ({effects})"
    );
    println!("golden renders on {}", renderer.adapter_info());
    // The tolerance is tight enough to see the changes that matter: SSS on against off, and
    // one stone against the other.
    let find = |m: &str, s: &str| {
        &renders
            .iter()
            .find(|((a, b), _)| *a == m && *b == s)
            .expect("rendered")
            .1
    };
    let (sss_vs_off, _) = flip_mean(find("marble", "nosss"), find("marble", "sss"));
    // Every stone apart from every other.
    let mut stones = f32::MAX;
    for (i, a) in Material::ALL.iter().enumerate() {
        for b in &Material::ALL[i + 1..] {
            let (d, _) = flip_mean(find(a.name(), "sss"), find(b.name(), "sss"));
            println!("FLIP mean, {} vs {} {d:.4}", a.name(), b.name());
            stones = stones.min(d);
        }
    }
    println!("FLIP mean, marble SSS on vs off {sss_vs_off:.4}; the nearest two stones {stones:.4}");
    assert!(
        sss_vs_off > 2.0 * GOLDEN_MEAN && stones > 2.0 * GOLDEN_MEAN,
        "the golden tolerance would not notice SSS ({sss_vs_off}) or the material ({stones})"
    );
    assert!(
        failures.is_empty(),
        "golden images differ:\n{}",
        failures.join("\n")
    );
}

/// The settings (milgrain collet with a bail, rope twist) on the mean face, at a size where a
/// bead is a few pixels across: each against its golden, and each far enough from the plain
/// bezel that the tolerance would see it go.
#[test]
fn settings_match_their_golden_images() {
    let model =
        SurreyModel::load_dir(&crate::common::sfm_dir()).expect("run scripts/setup.sh first");
    let mean = model.instance(&[], &[]);
    let mut renderer = crate::renderer();
    let p = RenderParams {
        width: 320,
        height: 400,
        yaw_deg: -15.0,
        pitch_deg: 10.0,
        ..RenderParams::default()
    };
    let render = |renderer: &mut glyptic_render::Renderer, setting, bail| {
        let cameo = CameoParams {
            setting,
            bail,
            ..CameoParams::default()
        };
        let mesh = gem::build_cameo(&mean, &model.shape.triangles, &cameo).expect("cameo");
        renderer.render(&mesh, &p).expect("render")
    };
    let plain = render(&mut renderer, gem::Setting::Plain, false);
    let mut failures = Vec::new();
    for (setting, bail, name) in [
        (gem::Setting::Milgrain, true, "cameo-milgrain-bail"),
        (gem::Setting::Rope, false, "cameo-rope"),
    ] {
        let img = render(&mut renderer, setting, bail);
        if let Err(e) = check_golden(&img, name) {
            failures.push(e);
        }
        let (apart, _) = flip_mean(&plain, &img);
        println!("FLIP mean, {name} vs the plain bezel {apart:.4}");
        assert!(
            apart > 2.0 * GOLDEN_MEAN,
            "{name}: the golden tolerance would not notice the setting ({apart})"
        );
    }
    assert!(
        failures.is_empty(),
        "golden images differ:\n{}",
        failures.join("\n")
    );
}
