//! The headless renderer on a synthetic cameo: an oval ground with an ellipsoidal "head" relief
//! (its upper part marked as hair) inside a raised gold bezel with a gold back.
//!
//! One test function, one device: opening a device and compiling the pipelines is the expensive
//! part on a CPU rasteriser, and parallel tests would each pay it. Images go to
//! `<root>/target/test-out/` for inspection.
//! Why one long file: the synthetic cameo and its checks belong to that one function.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use glyptic_render::sss::SssParams;
use glyptic_render::surface::EngravingParams;
use glyptic_render::{Lamp, Material, Mesh, Region, RenderError, RenderParams, Renderer, Vertex};

/// Semi-axes of the ground field (mm); the bezel adds `BEZEL_WIDTH` all round: 44 x 56 overall.
const FIELD: (f32, f32) = (19.6, 25.6);
/// Width and height (mm) of the half-round gold bezel.
const BEZEL_WIDTH: f32 = 2.4;
const BEZEL_HEIGHT: f32 = 1.5;
/// The back plate's plane (mm).
const BACK: f32 = -3.0;

/// Height of the relief above the ground at (x, y): a rounded ellipsoidal dome.
fn relief_height(x: f32, y: f32) -> f32 {
    let q = (x / 11.0).powi(2) + ((y + 1.0) / 15.0).powi(2);
    if q >= 1.0 { 0.0 } else { 7.0 * (1.0 - q) }
}

fn region_at(x: f32, y: f32) -> Region {
    let h = relief_height(x, y);
    if h <= 0.0 {
        Region::Ground
    } else if y > 4.0 + 0.15 * x {
        Region::Hair
    } else {
        Region::Relief
    }
}

struct Builder {
    mesh: Mesh,
}

impl Builder {
    fn vertex(&mut self, position: [f32; 3], normal: [f32; 3], relief: f32, region: Region) -> u32 {
        self.mesh
            .vertices
            .push(Vertex::open(position, normal, relief, region));
        (self.mesh.vertices.len() - 1) as u32
    }

    /// Quads between consecutive rows of a (rows x cols) grid whose columns wrap around.
    fn grid(&mut self, first: u32, rows: u32, cols: u32) {
        for r in 0..rows - 1 {
            for c in 0..cols {
                let a = first + r * cols + c;
                let b = first + r * cols + (c + 1) % cols;
                let d = a + cols;
                let e = b + cols;
                self.mesh.indices.extend_from_slice(&[a, b, e, a, e, d]);
            }
        }
    }
}

/// The test cameo, `rings` x `segments` on the ground field.
fn cameo(rings: u32, segments: u32) -> Mesh {
    let mut b = Builder {
        mesh: Mesh::default(),
    };
    let angle = |s: u32| s as f32 / segments as f32 * std::f32::consts::TAU;
    // Ground field and relief: one continuous height field over the oval.
    let first = b.mesh.vertices.len() as u32;
    for ring in 0..=rings {
        let t = ring as f32 / rings as f32;
        for s in 0..segments {
            let (x, y) = (FIELD.0 * t * angle(s).cos(), FIELD.1 * t * angle(s).sin());
            let h = relief_height(x, y);
            let e = 0.02;
            let dx = (relief_height(x + e, y) - relief_height(x - e, y)) / (2.0 * e);
            let dy = (relief_height(x, y + e) - relief_height(x, y - e)) / (2.0 * e);
            b.vertex([x, y, h], [-dx, -dy, 1.0], h, region_at(x, y));
        }
    }
    b.grid(first, rings + 1, segments);

    // The field's edge and its outward normal (in the plane) at segment s.
    let edge = |s: u32| {
        let (c, si) = (angle(s).cos(), angle(s).sin());
        let n = [c / FIELD.0, si / FIELD.1];
        let len = (n[0] * n[0] + n[1] * n[1]).sqrt();
        ([FIELD.0 * c, FIELD.1 * si], [n[0] / len, n[1] / len])
    };
    // Bezel: a half-round gold wire around the field, then a vertical outer wall.
    let steps = 12;
    let first = b.mesh.vertices.len() as u32;
    for k in 0..=steps {
        let phi = k as f32 / steps as f32 * std::f32::consts::PI;
        let radial = 0.5 * BEZEL_WIDTH * (1.0 - phi.cos());
        let z = BEZEL_HEIGHT * phi.sin();
        let (nr, nz) = (-BEZEL_HEIGHT * phi.cos(), 0.5 * BEZEL_WIDTH * phi.sin());
        for s in 0..segments {
            let (p, n) = edge(s);
            b.vertex(
                [p[0] + n[0] * radial, p[1] + n[1] * radial, z],
                [n[0] * nr, n[1] * nr, nz],
                0.0,
                Region::Gold,
            );
        }
    }
    b.grid(first, steps + 1, segments);
    let first = b.mesh.vertices.len() as u32;
    for z in [0.0, BACK] {
        for s in 0..segments {
            let (p, n) = edge(s);
            b.vertex(
                [p[0] + n[0] * BEZEL_WIDTH, p[1] + n[1] * BEZEL_WIDTH, z],
                [n[0], n[1], 0.0],
                0.0,
                Region::Gold,
            );
        }
    }
    b.grid(first, 2, segments);
    // Back plate.
    let centre = b.vertex([0.0, 0.0, BACK], [0.0, 0.0, -1.0], 0.0, Region::Gold);
    let first = b.mesh.vertices.len() as u32;
    for s in 0..segments {
        let (p, n) = edge(s);
        b.vertex(
            [p[0] + n[0] * BEZEL_WIDTH, p[1] + n[1] * BEZEL_WIDTH, BACK],
            [0.0, 0.0, -1.0],
            0.0,
            Region::Gold,
        );
    }
    for s in 0..segments {
        b.mesh
            .indices
            .extend_from_slice(&[centre, first + (s + 1) % segments, first + s]);
    }
    b.mesh
}

/// A 40 x 40 mm square of ground with a 6 x 6 mm gold plate floating 8 mm above it at
/// (`x`, `y`): the plate's shadow under a lamp, and nothing else, moves with it.
fn plate_scene(x: f32, y: f32) -> Mesh {
    let mut b = Builder {
        mesh: Mesh::default(),
    };
    let n = 21;
    for j in 0..n {
        for i in 0..n {
            let (gx, gy) = (
                -20.0 + 40.0 * i as f32 / 20.0,
                -20.0 + 40.0 * j as f32 / 20.0,
            );
            b.vertex([gx, gy, 0.0], [0.0, 0.0, 1.0], 0.0, Region::Ground);
        }
    }
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = j * n + i;
            b.mesh
                .indices
                .extend_from_slice(&[a, a + 1, a + n + 1, a, a + n + 1, a + n]);
        }
    }
    let first = b.mesh.vertices.len() as u32;
    for (dx, dy) in [(-3.0, -3.0), (3.0, -3.0), (3.0, 3.0), (-3.0, 3.0)] {
        b.vertex([x + dx, y + dy, 8.0], [0.0, 0.0, 1.0], 8.0, Region::Gold);
    }
    b.mesh
        .indices
        .extend_from_slice(&[first, first + 1, first + 2, first, first + 2, first + 3]);
    b.mesh
}

/// A mesh that rasterises nothing (one zero-area triangle): the bare backdrop.
fn speck() -> Mesh {
    Mesh {
        vertices: vec![Vertex::open([0.0; 3], [0.0, 0.0, 1.0], 0.0, Region::Ground); 3],
        indices: vec![0, 1, 2],
    }
}

fn luma(p: &image::Rgba<u8>) -> f32 {
    0.2126 * f32::from(p[0]) + 0.7152 * f32::from(p[1]) + 0.0722 * f32::from(p[2])
}

fn params(width: u32, height: u32, material: Material) -> RenderParams {
    RenderParams {
        width,
        height,
        material,
        ..RenderParams::default()
    }
}

fn out_dir() -> PathBuf {
    let dir = crate::common::test_out();
    std::fs::create_dir_all(&dir).expect("create target/test-out");
    dir
}

fn save(image: &image::RgbaImage, name: &str) {
    let path = out_dir().join(name);
    image
        .save(&path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
}

fn channel_diff(a: &image::Rgba<u8>, b: &image::Rgba<u8>) -> u32 {
    (0..3)
        .map(|c| a[c].abs_diff(b[c]) as u32)
        .max()
        .unwrap_or(0)
}

/// Mean absolute difference per channel over the whole image.
fn mean_abs_diff(a: &image::RgbaImage, b: &image::RgbaImage) -> f64 {
    let total: u64 = a
        .as_raw()
        .iter()
        .zip(b.as_raw())
        .map(|(x, y)| x.abs_diff(*y) as u64)
        .sum();
    total as f64 / a.as_raw().len() as f64
}

/// Pixels that differ from the backdrop-only image by more than the dither could.
fn object_mask(image: &image::RgbaImage, backdrop: &image::RgbaImage) -> Vec<bool> {
    image
        .pixels()
        .zip(backdrop.pixels())
        .map(|(p, q)| channel_diff(p, q) > 4)
        .collect()
}

fn fraction(mask: &[bool], image: &image::RgbaImage, pred: impl Fn([u8; 3]) -> bool) -> f64 {
    let on: Vec<[u8; 3]> = image
        .pixels()
        .zip(mask)
        .filter(|(_, m)| **m)
        .map(|(p, _)| [p[0], p[1], p[2]])
        .collect();
    on.iter().filter(|p| pred(**p)).count() as f64 / on.len().max(1) as f64
}

fn is_gold(p: [u8; 3]) -> bool {
    let [r, g, b] = p.map(i32::from);
    r > 70 && r > b + 45 && g > b + 25 && r >= g
}

fn time_frames(renderer: &mut Renderer, mesh: &Mesh, p: &RenderParams, frames: usize) -> Duration {
    let mut times: Vec<Duration> = (0..frames)
        .map(|_| {
            let start = Instant::now();
            renderer.render(mesh, p).expect("timed frame");
            start.elapsed()
        })
        .collect();
    times.sort();
    times[times.len() / 2]
}

#[test]
fn renderer_end_to_end() {
    // Look checks are collected and asserted at the end, so every image is written first.
    let mut failed: Vec<String> = Vec::new();
    let mut check = |ok: bool, what: String| {
        if !ok {
            failed.push(what);
        }
    };
    let start = Instant::now();
    let mut renderer = crate::renderer();
    // The start's stages are timed (the instance on the primary backends, Vulkan here).
    let init = renderer.init_times();
    println!("start: {init}");
    assert!(
        init.instance_ms > 0.0 && init.device_ms > 0.0 && init.pipelines_ms > 0.0,
        "{init:?}"
    );
    println!(
        "adapter: {} (device in {:?})",
        renderer.adapter_info(),
        start.elapsed()
    );

    let mesh = cameo(96, 160);
    println!(
        "test mesh: {} vertices, {} triangles",
        mesh.vertices.len(),
        mesh.indices.len() / 3
    );
    let (w, h) = (160, 200);

    let t = Instant::now();
    let backdrop = renderer
        .render(&speck(), &params(w, h, Material::Marble))
        .expect("backdrop");
    println!("first frame (pipeline warm-up) {w}x{h}: {:?}", t.elapsed());
    save(&backdrop, "backdrop.png");
    let corner = backdrop.get_pixel(0, 0);
    let middle = backdrop.get_pixel(w / 2, h / 2);
    assert!(
        middle[0] > corner[0],
        "backdrop is lighter in the middle than in the corners"
    );

    // --- Marble and agate, front view.
    let marble = renderer
        .render(&mesh, &params(w, h, Material::Marble))
        .expect("marble");
    let agate = renderer
        .render(&mesh, &params(w, h, Material::Agate))
        .expect("agate");
    save(&marble, "marble_front.png");
    save(&agate, "agate_front.png");

    let mask = object_mask(&marble, &backdrop);
    let coverage = mask.iter().filter(|m| **m).count() as f64 / mask.len() as f64;
    println!("object covers {:.1} % of the frame", coverage * 100.0);
    assert!((0.25..0.8).contains(&coverage), "coverage {coverage}");
    assert_eq!(
        object_mask(&agate, &backdrop),
        mask,
        "both materials cover the same pixels"
    );

    let gold_m = fraction(&mask, &marble, is_gold);
    let stone_light = fraction(&mask, &marble, |[r, g, b]| {
        r > 140 && g > 135 && b > 125 && r.abs_diff(b) < 30
    });
    println!("marble: gold {:.2}, light stone {:.2}", gold_m, stone_light);
    check(
        gold_m > 0.05,
        format!("marble bezel reads as gold ({gold_m:.2})"),
    );
    check(
        stone_light > 0.5,
        format!("marble is mostly white ({stone_light:.2})"),
    );

    let red = fraction(&mask, &agate, |[r, g, b]| {
        r > g + 8 && r > b + 8 && r < 110 && g < 60
    });
    let white = fraction(&mask, &agate, |[r, g, b]| {
        r > 120 && g > 120 && b > 115 && r.abs_diff(g) < 25
    });
    let gold_a = fraction(&mask, &agate, is_gold);
    println!("agate: red ground {red:.2}, white relief {white:.2}, gold {gold_a:.2}");
    check(red > 0.1, format!("agate ground is dark red ({red:.2})"));
    check(
        white > 0.1,
        format!("agate relief is grey-white ({white:.2})"),
    );
    check(gold_a > 0.05, format!("agate bezel is gold ({gold_a:.2})"));

    let d_material = mean_abs_diff(&marble, &agate);
    println!("marble vs agate: mean |diff| {d_material:.1}");
    check(
        d_material > 15.0,
        format!("marble and agate differ clearly ({d_material:.1})"),
    );

    // --- Other views.
    let mut turned = params(w, h, Material::Marble);
    turned.yaw_deg = 30.0;
    let marble_30 = renderer.render(&mesh, &turned).expect("yaw 30");
    save(&marble_30, "marble_yaw30.png");
    let d_yaw = mean_abs_diff(&marble, &marble_30);
    println!("yaw 0 vs 30: mean |diff| {d_yaw:.1}");
    check(
        d_yaw > 3.0,
        format!("yaw 30 differs from yaw 0 ({d_yaw:.1})"),
    );

    let mut view = params(w, h, Material::Agate);
    view.yaw_deg = -35.0;
    view.pitch_deg = 20.0;
    save(
        &renderer.render(&mesh, &view).expect("agate 3/4"),
        "agate_yaw-35_pitch20.png",
    );
    view.yaw_deg = 90.0;
    view.pitch_deg = 0.0;
    save(
        &renderer.render(&mesh, &view).expect("agate side"),
        "agate_side.png",
    );
    view.yaw_deg = 180.0;
    save(
        &renderer.render(&mesh, &view).expect("agate back"),
        "agate_back.png",
    );

    // The strongest, thinnest veins (softness and lightness 0) against the default ones.
    let mut original = params(w, h, Material::Marble);
    original.marble.vein_softness = 0.0;
    original.marble.vein_lightness = 0.0;
    let marble_2021 = renderer.render(&mesh, &original).expect("strong veins");
    save(&marble_2021, "marble_strong_veins.png");
    let mut plain = params(w, h, Material::Marble);
    plain.marble.vein_lightness = 1.0;
    let plain = renderer.render(&mesh, &plain).expect("plain marble");
    let (d_veins, d_default) = (
        mean_abs_diff(&plain, &marble_2021),
        mean_abs_diff(&marble, &marble_2021),
    );
    check(
        d_veins > 0.25 && d_default > 0.05,
        format!(
            "vein parameters have an effect ({d_veins:.2} plain vs strongest, {d_default:.2} default vs strongest)"
        ),
    );

    // --- Subsurface scattering.
    let mut off = params(w, h, Material::Marble);
    off.sss = None;
    let marble_off = renderer.render(&mesh, &off).expect("sss off");
    save(&marble_off, "marble_sss_off.png");
    // Strength 0 makes the kernel "centre 1, others 0": the two blur passes then return the
    // scene's diffuse exactly, so the image equals SSS off bit for bit.
    let mut zero = params(w, h, Material::Marble);
    zero.sss = Some(SssParams {
        strength: [0.0; 3],
        ..SssParams::default()
    });
    let marble_zero = renderer.render(&mesh, &zero).expect("sss strength 0");
    assert!(
        marble_zero.as_raw() == marble_off.as_raw(),
        "SSS with strength 0 equals SSS off"
    );
    // On, it changes the stone but never the backdrop (no coverage: copied) nor where the
    // backdrop shows next to the gem; gold is never blurred (mask 0: copied).
    let mut strong = params(w, h, Material::Marble);
    strong.sss = Some(SssParams {
        strength: [1.0; 3],
        width_mm: 2.0,
        ..SssParams::default()
    });
    let marble_strong = renderer.render(&mesh, &strong).expect("sss strong");
    // Pass times (timestamp queries; lavapipe has them, other devices may not).
    if let Some(t) = renderer.last_pass_times().cloned() {
        println!("pass times with SSS: {t:?}");
        assert!(t.scene_ms > 0.0 && t.composite_ms > 0.0 && t.sss_ms.is_some_and(|s| s > 0.0));
        renderer.render(&mesh, &off).expect("sss off again");
        let t = renderer.last_pass_times().expect("times again");
        assert!(t.sss_ms.is_none() && t.scene_ms > 0.0, "{t:?}");
    }
    save(&marble_strong, "marble_sss_strong.png");
    let outside_same = marble_strong
        .pixels()
        .zip(marble_off.pixels())
        .zip(&mask)
        .filter(|(_, m)| !**m)
        .all(|((a, b), _)| a == b);
    assert!(outside_same, "SSS changes no pixel off the gem");
    let gold_px: Vec<usize> = marble_off
        .pixels()
        .enumerate()
        .filter(|(_, p)| is_gold([p[0], p[1], p[2]]))
        .map(|(i, _)| i)
        .collect();
    let gold_same = gold_px
        .iter()
        .filter(|&&i| {
            let (x, y) = ((i as u32) % w, (i as u32) / w);
            marble_strong.get_pixel(x, y) == marble_off.get_pixel(x, y)
        })
        .count() as f64
        / gold_px.len().max(1) as f64;
    println!("SSS: {:.1} % of gold pixels untouched", 100.0 * gold_same);
    check(
        gold_same > 0.9,
        format!("gold pixels untouched by SSS ({:.1} %)", 100.0 * gold_same),
    );
    // Stone: the veins' local contrast drops (mean |Laplacian| of grey over stone pixels).
    let laplacian = |img: &image::RgbaImage| {
        let g = |x: u32, y: u32| {
            let p = img.get_pixel(x, y);
            (p[0] as f64 + p[1] as f64 + p[2] as f64) / 3.0
        };
        let (mut sum, mut n) = (0.0, 0usize);
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                let p = marble_off.get_pixel(x, y);
                if !mask[(y * w + x) as usize] || is_gold([p[0], p[1], p[2]]) {
                    continue;
                }
                sum +=
                    (4.0 * g(x, y) - g(x - 1, y) - g(x + 1, y) - g(x, y - 1) - g(x, y + 1)).abs();
                n += 1;
            }
        }
        sum / n.max(1) as f64
    };
    let (l_off, l_on) = (laplacian(&marble_off), laplacian(&marble_strong));
    println!("SSS: stone mean |laplacian| {l_off:.2} off, {l_on:.2} on");
    check(
        l_on < 0.9 * l_off,
        format!("SSS softens the stone ({l_off:.2} -> {l_on:.2})"),
    );
    // A flat, plain stone (no veins) stays within 1 % where it is flat: the kernel sums to 1.
    let mut plain_off = params(w, h, Material::Marble);
    plain_off.marble.vein_lightness = 1.0;
    plain_off.sss = None;
    let mut plain_on = plain_off.clone();
    plain_on.sss = strong.sss;
    let (a, b) = (
        renderer.render(&mesh, &plain_off).expect("plain off"),
        renderer.render(&mesh, &plain_on).expect("plain on"),
    );
    let r = 8i64;
    let (mut flat, mut worst) = (0usize, 0.0f64);
    for y in r..h as i64 - r {
        for x in r..w as i64 - r {
            let c = a.get_pixel(x as u32, y as u32);
            let near_flat = (-r..=r).all(|dy| {
                (-r..=r)
                    .all(|dx| channel_diff(a.get_pixel((x + dx) as u32, (y + dy) as u32), c) <= 2)
            });
            if !near_flat || !mask[(y * w as i64 + x) as usize] {
                continue;
            }
            flat += 1;
            let d = b.get_pixel(x as u32, y as u32);
            for k in 0..3 {
                // Relative to the stone's display value (dither adds +-1 level).
                let rel = (f64::from(d[k]) - f64::from(c[k])).abs() / f64::from(c[k]).max(1.0);
                worst = worst.max(rel);
            }
        }
    }
    println!(
        "SSS on a flat plain stone: {flat} pixels, worst change {:.2} %",
        100.0 * worst
    );
    assert!(flat > 500, "flat stone pixels found: {flat}");
    assert!(worst <= 0.01, "flat colour kept within 1 % ({worst})");
    // Bad kernel parameters are errors naming the problem.
    let mut bad = params(w, h, Material::Marble);
    bad.sss = Some(SssParams {
        taps: 4,
        ..SssParams::default()
    });
    match renderer.render(&mesh, &bad) {
        Err(RenderError::InvalidParams(m)) => assert!(m.contains("taps"), "{m}"),
        other => panic!("even taps accepted: {other:?}"),
    }

    // --- Determinism: the same frame twice is bit-identical.
    let again = renderer
        .render(&mesh, &params(w, h, Material::Agate))
        .expect("agate again");
    assert!(
        again.as_raw() == agate.as_raw(),
        "rendering twice gives identical images"
    );

    // --- Invalid input gives errors, not panics, and leaves the renderer usable.
    let p = params(w, h, Material::Marble);
    let empty = renderer.render(&Mesh::default(), &p);
    assert!(
        matches!(empty, Err(RenderError::EmptyMesh { .. })),
        "{empty:?}"
    );
    let mut bad = mesh.clone();
    bad.indices[5] = bad.vertices.len() as u32;
    let out_of_range = renderer.render(&bad, &p);
    assert!(
        matches!(out_of_range, Err(RenderError::IndexOutOfRange { .. })),
        "{out_of_range:?}"
    );
    let mut bad = mesh.clone();
    bad.vertices[7].position[1] = f32::NAN;
    let nan = renderer.render(&bad, &p);
    assert!(
        matches!(nan, Err(RenderError::NonFiniteVertex { index: 7 })),
        "{nan:?}"
    );
    let mut bad = mesh.clone();
    bad.indices.pop();
    assert!(matches!(
        renderer.render(&bad, &p),
        Err(RenderError::IndicesNotTriangles { .. })
    ));
    let mut bad = mesh.clone();
    bad.vertices[3].region = 17;
    assert!(matches!(
        renderer.render(&bad, &p),
        Err(RenderError::InvalidRegion { .. })
    ));
    for (bw, bh) in [(0, 200), (160, 0), (1_000_000, 10), (4097, 4097)] {
        let sized = renderer.render(&mesh, &params(bw, bh, Material::Marble));
        assert!(
            matches!(sized, Err(RenderError::InvalidSize { .. })),
            "{bw}x{bh}: {sized:?}"
        );
    }
    let mut nan_yaw = p.clone();
    nan_yaw.yaw_deg = f32::NAN;
    assert!(matches!(
        renderer.render(&mesh, &nan_yaw),
        Err(RenderError::InvalidParams(_))
    ));
    let after = renderer
        .render(&mesh, &params(w, h, Material::Agate))
        .expect("still usable");
    assert!(after.as_raw() == agate.as_raw());

    // --- Surface effects. The lamp's shadow: a plate floating over the ground at the centre
    // against the same plate moved to a corner (same bounds, so the same camera). With the
    // lamp at the left, the only pixels the centre plate darkens are its shadow's, to the
    // right of it.
    let lamp = Lamp {
        offset_mm: [-30.0, 0.0, 44.0],
        ..Lamp::default()
    };
    let lit = RenderParams {
        lamp: Some(lamp),
        sss: None,
        ..params(240, 240, Material::Marble)
    };
    let centre_plate = renderer
        .render(&plate_scene(0.0, 0.0), &lit)
        .expect("plate");
    let corner_plate = renderer
        .render(&plate_scene(-14.0, -14.0), &lit)
        .expect("corner plate");
    save(&centre_plate, "lamp_plate.png");
    let times = renderer.last_pass_times().cloned();
    let mut shadow_cols = Vec::new();
    for (k, (a, b)) in centre_plate.pixels().zip(corner_plate.pixels()).enumerate() {
        let gold = |p: &image::Rgba<u8>| is_gold([p[0], p[1], p[2]]);
        if !gold(a) && !gold(b) && luma(a) < luma(b) - 25.0 {
            shadow_cols.push((k % 240) as f32);
        }
    }
    let gold_px = centre_plate
        .pixels()
        .filter(|p| is_gold([p[0], p[1], p[2]]))
        .count();
    let mean_col = shadow_cols.iter().sum::<f32>() / shadow_cols.len().max(1) as f32;
    let left = shadow_cols.iter().filter(|&&c| c < 110.0).count();
    println!(
        "lamp: {} shadow pixels, mean column {mean_col:.0} of 240, {left} left of the centre; plate {gold_px} gold pixels; times {times:?}",
        shadow_cols.len()
    );
    assert!(
        gold_px > 200,
        "the plate is not seen as gold ({gold_px} pixels)"
    );
    assert!(
        shadow_cols.len() > 300 && mean_col > 130.0 && left * 50 < shadow_cols.len(),
        "no shadow to the right of the plate: {} pixels, mean column {mean_col}, {left} on the left",
        shadow_cols.len()
    );
    if let Some(t) = times {
        assert!(t.shadow_ms.is_some_and(|ms| ms > 0.0), "{t:?}");
    }
    // Without the lamp there is no shadow at all.
    let unlit = params(240, 240, Material::Marble);
    let a = renderer
        .render(
            &plate_scene(0.0, 0.0),
            &RenderParams {
                sss: None,
                ..unlit.clone()
            },
        )
        .expect("plate");
    assert!(
        renderer
            .last_pass_times()
            .is_none_or(|t| t.shadow_ms.is_none())
    );
    let b = renderer
        .render(
            &plate_scene(-14.0, -14.0),
            &RenderParams { sss: None, ..unlit },
        )
        .expect("corner");
    let darker = a
        .pixels()
        .zip(b.pixels())
        .filter(|(p, q)| {
            !is_gold([p[0], p[1], p[2]]) && !is_gold([q[0], q[1], q[2]]) && luma(p) < luma(q) - 25.0
        })
        .count();
    assert!(darker < 20, "{darker} pixels darkened without a lamp");

    // The engraving: a border round the ground, nowhere else (not on the relief in the middle,
    // not on the gold), and no NaN from the relief's walls at a steep angle.
    let plain = params(320, 400, Material::Marble);
    let engraved_params = RenderParams {
        engraving: Some(EngravingParams::default()),
        ..plain.clone()
    };
    let flat = renderer.render(&mesh, &plain).expect("plain");
    let engraved = renderer.render(&mesh, &engraved_params).expect("engraved");
    save(&engraved, "marble_engraved_320x400.png");
    let (mut changed, mut middle, mut on_gold) = (0, 0, 0);
    for (k, (p, q)) in engraved.pixels().zip(flat.pixels()).enumerate() {
        if channel_diff(p, q) <= 6 {
            continue;
        }
        changed += 1;
        let (x, y) = (
            (k % 320) as f32 / 320.0 - 0.5,
            (k / 320) as f32 / 400.0 - 0.5,
        );
        middle += usize::from(x.abs() < 0.15 && y.abs() < 0.15);
        on_gold += usize::from(is_gold([q[0], q[1], q[2]]) && is_gold([p[0], p[1], p[2]]));
    }
    println!("engraving: {changed} pixels changed, {middle} in the middle, {on_gold} on gold");
    assert!(changed > 1000 && middle == 0 && on_gold < changed / 100);
    // The renderer keeps the engraving's per-mesh data while the mesh stays the same: another
    // mesh in between must not leave it stale (its triangle order would draw the wrong mesh).
    let other = cameo(48, 96);
    let other_engraved = renderer
        .render(&other, &engraved_params)
        .expect("other engraved");
    let other_flat = renderer.render(&other, &plain).expect("other plain");
    // Its engraving is its own: nothing changed in the middle, the border drawn.
    let (mut other_changed, mut other_middle) = (0, 0);
    for (k, (p, q)) in other_engraved.pixels().zip(other_flat.pixels()).enumerate() {
        if channel_diff(p, q) > 6 {
            other_changed += 1;
            let (x, y) = (
                (k % 320) as f32 / 320.0 - 0.5,
                (k / 320) as f32 / 400.0 - 0.5,
            );
            other_middle += usize::from(x.abs() < 0.15 && y.abs() < 0.15);
        }
    }
    println!(
        "engraving on another mesh: {other_changed} pixels changed, {other_middle} in the middle"
    );
    assert!(other_changed > 1000 && other_middle == 0);
    let again = renderer
        .render(&mesh, &engraved_params)
        .expect("engraved again");
    assert!(
        again.as_raw() == engraved.as_raw(),
        "the first mesh changed on its second draw"
    );
    for yaw in [-70.0, 65.0] {
        let steep = renderer
            .render(
                &mesh,
                &RenderParams {
                    yaw_deg: yaw,
                    pitch_deg: 30.0,
                    ..engraved_params.clone()
                },
            )
            .expect("steep engraving");
        let plain_steep = renderer
            .render(
                &mesh,
                &RenderParams {
                    yaw_deg: yaw,
                    pitch_deg: 30.0,
                    ..plain.clone()
                },
            )
            .expect("steep plain");
        // A NaN normal or texture coordinate would show as black (or garbage) pixels.
        let black = steep
            .pixels()
            .zip(plain_steep.pixels())
            .filter(|(p, q)| luma(p) < 8.0 && luma(q) > 40.0)
            .count();
        assert_eq!(
            black, 0,
            "yaw {yaw}: {black} black pixels with the engraving"
        );
    }
    // Bad surface parameters are refused by name.
    for bad in [
        RenderParams {
            engraving: Some(EngravingParams {
                depth_mm: f32::NAN,
                ..EngravingParams::default()
            }),
            ..plain.clone()
        },
        RenderParams {
            engraving: Some(EngravingParams {
                inset_mm: [6.0, 2.0],
                ..EngravingParams::default()
            }),
            ..plain.clone()
        },
        RenderParams {
            lamp: Some(Lamp {
                offset_mm: [0.0, f32::INFINITY, 0.0],
                ..Lamp::default()
            }),
            ..plain.clone()
        },
        RenderParams {
            lamp: Some(Lamp {
                intensity: -1.0,
                ..Lamp::default()
            }),
            ..plain.clone()
        },
    ] {
        let err = renderer.render(&mesh, &bad);
        assert!(
            matches!(&err, Err(RenderError::InvalidParams(m)) if m.contains("engraving") || m.contains("lamp")),
            "{err:?}"
        );
    }

    // --- Frame times (mesh upload, both passes, readback).
    for (tw, th) in [(640, 400), (1280, 800)] {
        for material in [Material::Marble, Material::Agate] {
            let p = params(tw, th, material);
            let first = Instant::now();
            let image = renderer.render(&mesh, &p).expect("timing frame");
            let first = first.elapsed();
            let median = time_frames(&mut renderer, &mesh, &p, 5);
            println!(
                "{tw}x{th} {material:?}: median {median:?} per frame (first at this size {first:?})"
            );
            save(
                &image,
                &format!("{}_{tw}x{th}.png", format!("{material:?}").to_lowercase()),
            );
        }
    }
    // A big, portrait frame for looking at.
    let mut big = params(640, 800, Material::Agate);
    big.yaw_deg = -20.0;
    save(
        &renderer.render(&mesh, &big).expect("agate 640x800"),
        "agate_640x800_yaw-20.png",
    );
    big.material = Material::Marble;
    save(
        &renderer.render(&mesh, &big).expect("marble 640x800"),
        "marble_640x800_yaw-20.png",
    );

    assert!(
        failed.is_empty(),
        "look checks failed:\n{}",
        failed.join("\n")
    );
}

/// Share of the rows crossing the object whose first object pixel from the left is a blend:
/// nearer the backdrop than the object two pixels further in is (a hard edge jumps at once).
fn blended_edge_rows(image: &image::RgbaImage, backdrop: &image::RgbaImage) -> f64 {
    let mask = object_mask(image, backdrop);
    let w = image.width() as usize;
    let (mut rows, mut blended) = (0, 0);
    for y in 0..image.height() {
        let Some(x) = (0..w.saturating_sub(2)).find(|&x| mask[y as usize * w + x]) else {
            continue;
        };
        let (x, inner) = (x as u32, x as u32 + 2);
        let bg = luma(backdrop.get_pixel(x, y));
        let full = luma(image.get_pixel(inner, y)) - bg;
        if full.abs() < 30.0 {
            continue;
        }
        rows += 1;
        if (luma(image.get_pixel(x, y)) - bg) / full < 0.85 {
            blended += 1;
        }
    }
    blended as f64 / rows.max(1) as f64
}

#[test]
fn one_sample_frames_get_their_edges_smoothed() {
    let mut renderer = crate::renderer();
    let mesh = cameo(96, 160);
    let p = params(160, 200, Material::Marble);
    let msaa = renderer.render(&mesh, &p).expect("4x frame");
    let one = RenderParams {
        antialias: false,
        ..p.clone()
    };
    let smoothed = renderer.render(&mesh, &one).expect("one-sample frame");
    let times = renderer.last_pass_times().cloned();
    let empty = renderer.render(&speck(), &p).expect("backdrop frame");
    save(&smoothed, "edge-aa.png");
    let (m, s) = (
        blended_edge_rows(&msaa, &empty),
        blended_edge_rows(&smoothed, &empty),
    );
    println!("blended edge rows: 4x MSAA {m:.2}, one sample with edge AA {s:.2}; {times:?}");
    assert!(
        s >= 0.5,
        "one-sample frame's outline is not smoothed: {s:.2} (MSAA {m:.2})"
    );
    if let Some(t) = times {
        assert!(
            t.edge_aa_ms.is_some(),
            "no edge antialiasing pass timed: {t:?}"
        );
    }
}

/// The noise baked over the mesh (marble's cloudiness, gold's ripple) is made at a mesh's second
/// frame and again when a mesh leaves its box; a mesh drawn after that looks as it did before
/// (the volume is never read outside the box it was baked for), and the baked noise is close to
/// the computed noise of a first frame.
#[test]
fn the_noise_volume_follows_the_mesh() {
    let mut renderer = crate::renderer();
    // Away from the other tests' gems, whose volume may be there already.
    let shifted = |dx: f32| {
        let mut m = cameo(48, 80);
        for v in &mut m.vertices {
            v.position[0] += dx;
            v.position[1] += 100.0;
        }
        m
    };
    let (mesh, moved) = (shifted(0.0), shifted(40.0));
    let p = params(80, 100, Material::Marble);
    let mut twice = |m: &Mesh| {
        let first = renderer.render(m, &p).expect("gem");
        let second = renderer.render(m, &p).expect("gem again");
        (first, second)
    };
    let (computed, baked) = twice(&mesh);
    let (_, elsewhere) = twice(&moved);
    let (_, again) = twice(&mesh);
    // The camera frames each mesh alike, so only the noise (sampled where the mesh is) differs.
    let bake_diff = mean_abs_diff(&computed, &baked);
    let moved_diff = mean_abs_diff(&baked, &elsewhere);
    let again_diff = mean_abs_diff(&baked, &again);
    println!(
        "mean channel difference: baked vs computed noise {bake_diff:.4}, moved gem {moved_diff:.4}, the gem again {again_diff:.4}"
    );
    assert!(
        bake_diff > 0.0 && bake_diff < 0.1,
        "the baked noise is not read, or far from the computed one: {bake_diff:.4}"
    );
    assert!(
        moved_diff > 0.01,
        "the moved gem's noise did not change ({moved_diff:.4})"
    );
    assert_eq!(again_diff, 0.0, "the gem drawn again differs from before");
}

/// A transparent backdrop: alpha is the gem's coverage (0 round it, 255 inside, blended along
/// the outline, with and without MSAA), the gem's colour as on the studio backdrop; styles are
/// refused. Studio frames stay opaque.
#[test]
fn a_transparent_backdrop_leaves_only_the_gem() {
    let mut renderer = crate::renderer();
    let mesh = cameo(48, 80);
    let studio = params(80, 100, Material::Marble);
    let opaque = renderer.render(&mesh, &studio).expect("studio frame");
    assert!(
        opaque.pixels().all(|p| p[3] == 255),
        "a studio frame has alpha"
    );
    for antialias in [true, false] {
        let p = RenderParams {
            transparent: true,
            antialias,
            ..studio.clone()
        };
        let img = renderer.render(&mesh, &p).expect("transparent frame");
        let share = |pred: &dyn Fn(u8) -> bool| {
            img.pixels().filter(|px| pred(px[3])).count() as f64 / f64::from(80 * 100)
        };
        let (clear, solid, edge) = (
            share(&|a| a == 0),
            share(&|a| a == 255),
            share(&|a| a > 0 && a < 255),
        );
        println!(
            "transparent, antialias {antialias}: clear {clear:.3}, solid {solid:.3}, edge {edge:.4}"
        );
        assert_eq!(img.get_pixel(0, 0)[3], 0, "the corner is not clear");
        assert!(
            clear > 0.3 && solid > 0.3 && edge > 0.002,
            "{clear} {solid} {edge}"
        );
        // Inside the gem, the colour is the studio frame's (within the dither).
        let (a, b) = (img.get_pixel(40, 50), opaque.get_pixel(40, 50));
        assert_eq!(a[3], 255);
        assert!(channel_diff(a, b) <= 2, "{a:?} vs {b:?}");
    }
    let styled = RenderParams {
        transparent: true,
        styles: vec![glyptic_render::styles::Style::Toon],
        ..studio
    };
    assert!(matches!(
        renderer.render(&mesh, &styled),
        Err(RenderError::InvalidParams(_))
    ));
}

#[test]
fn a_warm_up_frame_leaves_the_real_frame_as_it_was() {
    let mut renderer = crate::renderer();
    // The noise bake (a mesh drawn twice) would change the second frame: off for the test.
    renderer.set_noise_baking(false);
    let mesh = cameo(48, 80);
    let p = RenderParams {
        lamp: Some(glyptic_render::Lamp::default()),
        ..params(96, 120, Material::Shell)
    };
    let before = renderer.render(&mesh, &p).expect("frame");
    let warmed = renderer.init_times().warm_up_ms;
    renderer.warm_up(&p).expect("warm-up frame");
    let after = renderer.render(&mesh, &p).expect("frame after the warm-up");
    renderer.set_noise_baking(true);
    assert!(
        renderer.init_times().warm_up_ms > warmed,
        "the warm-up's time is reported"
    );
    assert!(before == after, "the warm-up changed the frame");
}
