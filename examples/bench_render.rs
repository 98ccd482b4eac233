//! Renderer benchmark: GPU time per pass (timestamp queries) of the cameo with the Surrey mean
//! face, SSS on (21 taps) and off, at 640x400 and 1280x800, marble and agate; the SSS pass's cost
//! as a share of the scene pass; and the relief rebuild after a fit (mean and a fitted-like
//! varied face). Prints a Markdown report.
//!
//! `cargo run --release --example bench_render -- [FRAMES]` (scripts/bench-render.sh runs it and
//! writes bench/results/render.md). Needs the Surrey model from scripts/setup.sh.
//! `GLYPTIC_BENCH_SIZES=1920x1080,3840x2160` adds frame sizes to the passes' table (on a GPU).

use std::time::Instant;

use glyptic::gem::{self, CameoParams};
use glyptic::render::{Material, RenderParams, Renderer};
use glyptic::sss::SssParams;

/// Relief rebuilds timed per face (after three untimed ones).
const BUILDS: usize = 41;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The median wall time of `BUILDS` calls of `f`, ms.
fn median_ms<T>(mut f: impl FnMut() -> T) -> f64 {
    median(
        (0..BUILDS)
            .map(|_| {
                let t = Instant::now();
                std::hint::black_box(f());
                t.elapsed().as_secs_f64() * 1e3
            })
            .collect(),
    )
}

/// One frame: its wall time (ms) and its passes' GPU times.
fn timed_frame(
    renderer: &mut Renderer,
    mesh: &glyptic::render::Mesh,
    p: &RenderParams,
) -> Result<(f64, glyptic::render::PassTimes), Box<dyn std::error::Error>> {
    let t = Instant::now();
    renderer.render(mesh, p)?;
    let wall = t.elapsed().as_secs_f64() * 1e3;
    let times = renderer
        .last_pass_times()
        .cloned()
        .ok_or("this device has no timestamp queries")?;
    Ok((wall, times))
}

/// One warm-up frame, then the medians over `frames` of the scene, SSS, composite and edge
/// antialiasing passes' GPU times and the frame's wall time, ms.
fn pass_medians(
    renderer: &mut Renderer,
    mesh: &glyptic::render::Mesh,
    p: &RenderParams,
    frames: usize,
) -> Result<[f64; 5], Box<dyn std::error::Error>> {
    renderer.render(mesh, p)?;
    let (mut scene, mut blur, mut comp, mut edge, mut wall) =
        (vec![], vec![], vec![], vec![], vec![]);
    for _ in 0..frames {
        let (ms, times) = timed_frame(renderer, mesh, p)?;
        wall.push(ms);
        scene.push(times.scene_ms);
        blur.push(times.sss_ms.unwrap_or(0.0));
        comp.push(times.composite_ms);
        edge.push(times.edge_aa_ms.unwrap_or(0.0));
    }
    Ok([
        median(scene),
        median(blur),
        median(comp),
        median(edge),
        median(wall),
    ])
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let frames: usize = std::env::args().nth(1).map_or(Ok(9), |s| s.parse())?;
    let model = glyptic::shapemodel::SurreyModel::load_dir(&glyptic::assets::sfm_dir())?;
    let mean = model.instance(&[], &[]);
    let tris = &model.shape.triangles;

    // Relief rebuild: what the pipeline thread does after each new fit.
    let shape: Vec<f32> = (0..model.shape.num_components())
        .map(|i| if i % 2 == 0 { 1.0 } else { -1.0 })
        .collect();
    let varied = model.instance(&shape, &[0.5, 0.0, 0.0, 0.3, 0.0, 0.0]);
    let t = Instant::now();
    let builder = gem::CameoBuilder::new(&CameoParams::default())?;
    let builder_ms = t.elapsed().as_secs_f64() * 1e3;
    let mut rebuild = Vec::new();
    for face in [&mean, &varied] {
        for _ in 0..3 {
            builder.build(face, tris)?;
        }
        let times: Vec<f64> = (0..BUILDS)
            .map(|_| {
                let t = Instant::now();
                let m = builder.build(face, tris);
                let ms = t.elapsed().as_secs_f64() * 1e3;
                std::hint::black_box(m).map(|_| ms)
            })
            .collect::<Result<_, _>>()?;
        rebuild.push(median(times));
    }
    let mesh = gem::build_cameo(&mean, tris, &CameoParams::default())?;

    let mut renderer = Renderer::new_headless()?;
    println!("# Renderer passes\n");
    println!(
        "Adapter: {}. Mesh: {} vertices, {} triangles (mean face). Median of {frames} frames after one warm-up; GPU times from timestamp queries, frame = wall time of `render` (upload, passes, readback).\n",
        renderer.adapter_info(),
        mesh.vertices.len(),
        mesh.indices.len() / 3
    );
    // The noise volume's bake (at a mesh's second frame; again only when a mesh leaves the
    // volume), by wall time: 64x64 frames of the gem and of the gem moved 30 mm, two of each in
    // turn (each second one bakes), against frames of the gem alone (none does). lavapipe's
    // timestamps do not cover a compute pass's work.
    let mut moved = mesh.clone();
    for v in &mut moved.vertices {
        v.position[0] += 30.0;
    }
    let tiny = RenderParams {
        width: 64,
        height: 64,
        sss: None,
        ..RenderParams::default()
    };
    renderer.render(&mesh, &tiny)?;
    let mut kept = Vec::new();
    let mut baked = Vec::new();
    for i in 0..2 * frames {
        let t = Instant::now();
        renderer.render(&mesh, &tiny)?;
        kept.push(t.elapsed().as_secs_f64() * 1e3);
        let other = if i % 2 == 0 { &moved } else { &mesh };
        renderer.render(other, &tiny)?;
        let t = Instant::now();
        renderer.render(other, &tiny)?;
        baked.push(t.elapsed().as_secs_f64() * 1e3);
    }
    let (lo, hi) = mesh
        .vertices
        .iter()
        .fold(([f32::MAX; 3], [f32::MIN; 3]), |(lo, hi), v| {
            (
                [0, 1, 2].map(|k| lo[k].min(v.position[k])),
                [0, 1, 2].map(|k| hi[k].max(v.position[k])),
            )
        });
    let volume = glyptic::render::surface::NoiseVolume::covering(lo, hi)
        .ok_or("the mesh has no finite box")?;
    let (kept, baked) = (median(kept), median(baked));
    println!(
        "Noise volume (marble's cloudiness, gold's ripple): {}x{}x{} voxels of {} mm, baked in about {:.1} ms (64x64 frame {baked:.1} ms with the bake, {kept:.1} ms without).\n",
        volume.dims[0],
        volume.dims[1],
        volume.dims[2],
        volume.voxel_mm,
        baked - kept
    );
    println!(
        "| size | material | SSS | scene ms | SSS ms | composite ms | frame ms | SSS / scene |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    // Larger frames where a GPU can afford them: `GLYPTIC_BENCH_SIZES=1920x1080,3840x2160`.
    let mut sizes = vec![(640u32, 400u32), (1280, 800)];
    for item in std::env::var("GLYPTIC_BENCH_SIZES")
        .unwrap_or_default()
        .split(',')
        .filter(|s| !s.trim().is_empty())
    {
        let parsed = item
            .trim()
            .split_once('x')
            .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)));
        sizes.push(parsed.ok_or_else(|| format!("GLYPTIC_BENCH_SIZES: {item:?} is not WxH"))?);
    }
    for &(w, h) in &sizes {
        for material in [Material::Marble, Material::Agate] {
            for sss in [None, Some(SssParams::default())] {
                let p = RenderParams {
                    width: w,
                    height: h,
                    material,
                    sss,
                    ..RenderParams::default()
                };
                let [scene, blur, comp, _, wall] = pass_medians(&mut renderer, &mesh, &p, frames)?;
                let share = match sss {
                    Some(_) => format!("{:.0} %", 100.0 * blur / scene),
                    None => "-".into(),
                };
                println!(
                    "| {w}x{h} | {material:?} | {} | {scene:.1} | {} | {:.1} | {:.1} | {share} |",
                    sss.map_or("off".to_string(), |s| format!("{} taps", s.taps)),
                    if sss.is_some() {
                        format!("{blur:.1}")
                    } else {
                        "-".into()
                    },
                    comp,
                    wall,
                );
            }
        }
    }
    // Where the scene pass's time goes at the sizes added for a GPU: the four stones with
    // and without MSAA, the lamp's shadowed light, and the gem at half its size (a quarter
    // of the fragments, every triangle still drawn).
    if sizes.len() > 2 {
        println!(
            "\n# The scene pass by what it draws (SSS 21 taps)\n\n| size | material | MSAA | lamp | zoom | scene ms | frame ms |\n|---|---|---|---|---|---|---|"
        );
    }
    for &(w, h) in &sizes[2..] {
        let mut rows = Vec::new();
        for material in [
            Material::Marble,
            Material::Agate,
            Material::Shell,
            Material::Jasperware,
        ] {
            for antialias in [true, false] {
                rows.push((material, antialias, false, 1.0));
            }
        }
        rows.push((Material::Marble, true, true, 1.0));
        rows.push((Material::Marble, true, false, 0.5));
        rows.push((Material::Marble, false, false, 0.5));
        for (material, antialias, lamp, zoom) in rows {
            let p = RenderParams {
                width: w,
                height: h,
                material,
                antialias,
                lamp: lamp.then(glyptic::render::Lamp::default),
                zoom,
                ..RenderParams::default()
            };
            let [scene, _, _, _, wall] = pass_medians(&mut renderer, &mesh, &p, frames)?;
            println!(
                "| {w}x{h} | {material:?} | {} | {} | {zoom} | {scene:.2} | {wall:.1} |",
                if antialias { "4x" } else { "off" },
                if lamp { "on" } else { "off" },
            );
        }
    }
    // The full-screen passes (the SSS blur, the composite) as fragment passes against compute
    // passes, frame by frame in turn at each size (marble, 21 taps).
    // Where the device has compute at all (on a CPU rasteriser too, though it is not the
    // default there); the device's default is restored after.
    let default_compute = renderer.compute_passes();
    if renderer.set_compute_passes(true) {
        println!(
            "\n# Full-screen passes: fragment against compute (marble, 21-tap SSS, 4x MSAA)\n\nThe same pixels (`cameo` test). GPU times from timestamp queries (lavapipe stamps a compute pass before its work is done: compare the frames there).\n\n| size | SSS ms, fragment | SSS ms, compute | composite ms, fragment | composite ms, compute | frame ms, fragment | frame ms, compute |\n|---|---|---|---|---|---|---|"
        );
        for &(w, h) in &sizes {
            let p = RenderParams {
                width: w,
                height: h,
                ..RenderParams::default()
            };
            let mut out = [[0.0; 5]; 2];
            for (k, compute) in [false, true].into_iter().enumerate() {
                renderer.set_compute_passes(compute);
                out[k] = pass_medians(&mut renderer, &mesh, &p, frames)?;
            }
            println!(
                "| {w}x{h} | {:.2} | {:.2} | {:.2} | {:.2} | {:.1} | {:.1} |",
                out[0][1], out[1][1], out[0][2], out[1][2], out[0][4], out[1][4]
            );
        }
    }
    renderer.set_compute_passes(default_compute);
    // The scene pass's two forms, frame by frame in turn at each size: drawn and shaded by
    // the fragment stage into three multisampled targets, or a visibility image drawn and its
    // pixels shaded in a compute pass. Where the device has the compute form (the primitive
    // index); the defaults are restored after.
    let default_scene = renderer.compute_scene();
    if renderer.set_compute_scene(true) {
        println!(
            "\n# The scene pass: fragment form against compute form (21-tap SSS)\n\nThe same picture within the goldens' tolerance (`cameo` test). Scene ms from timestamp queries: in the compute form the visibility image's draw plus its shading (shading alone in brackets); lavapipe stamps a compute pass before its work is done, so compare the frames there.\n\n| size | material | MSAA | scene ms, fragment | scene ms, compute (shading) | frame ms, fragment | frame ms, compute |\n|---|---|---|---|---|---|---|"
        );
        for &(w, h) in &sizes {
            for (material, antialias) in [
                (Material::Marble, true),
                (Material::Marble, false),
                (Material::Agate, true),
            ] {
                let p = RenderParams {
                    width: w,
                    height: h,
                    material,
                    antialias,
                    ..RenderParams::default()
                };
                let mut out = [[0.0; 5]; 2];
                let mut shading = 0.0;
                for (k, compute) in [false, true].into_iter().enumerate() {
                    renderer.set_compute_scene(compute);
                    out[k] = pass_medians(&mut renderer, &mesh, &p, frames)?;
                    if compute {
                        shading = renderer
                            .last_pass_times()
                            .and_then(|t| t.scene_shade_ms)
                            .unwrap_or(0.0);
                    }
                }
                println!(
                    "| {w}x{h} | {material:?} | {} | {:.2} | {:.2} ({shading:.2}) | {:.1} | {:.1} |",
                    if antialias { "4x" } else { "off" },
                    out[0][0],
                    out[1][0],
                    out[0][4],
                    out[1][4]
                );
            }
        }
    }
    renderer.set_compute_scene(default_scene);
    // Antialiasing and size: 4x MSAA against one sample a pixel, and the kiosk's frames (the
    // still gem at 800x1000 with MSAA; while it moves, half the size per side without MSAA,
    // egui scaling the layer up). Frames per second from the frame's wall time.
    let moving = glyptic::kiosk::MOVING;
    let t = Instant::now();
    let coarse = mesh.simplified(moving.max_triangles);
    let simplify_ms = t.elapsed().as_secs_f64() * 1e3;
    println!(
        "\n# Antialiasing and frame size (marble, SSS)\n\nThe kiosk's moving frames draw the mesh simplified to {} triangles or fewer in {simplify_ms:.1} ms: {} vertices, {} triangles, of {} and {}. Frames with one sample a pixel get the edge antialiasing pass.",
        moving.max_triangles,
        coarse.vertices.len(),
        coarse.indices.len() / 3,
        mesh.vertices.len(),
        mesh.indices.len() / 3
    );
    println!(
        "\n| frame | size | MSAA | SSS taps | scene ms | SSS ms | composite ms | edge AA ms | frame ms | frames/s |\n|---|---|---|---|---|---|---|---|---|---|"
    );
    for (what, (w, h), antialias, taps) in [
        ("photo / bench", (1280, 800), true, 21),
        ("photo / bench", (1280, 800), false, 21),
        ("photo default", (640, 800), true, 21),
        ("photo default", (640, 800), false, 21),
        ("kiosk, still", (800, 1000), true, 21),
        (
            "kiosk, moving",
            (
                (800.0 * moving.scale).round() as u32,
                (1000.0 * moving.scale).round() as u32,
            ),
            false,
            moving.sss_taps,
        ),
    ] {
        let p = RenderParams {
            width: w,
            height: h,
            antialias,
            sss: Some(SssParams {
                taps,
                ..SssParams::default()
            }),
            ..RenderParams::default()
        };
        let drawn = if what == "kiosk, moving" {
            &coarse
        } else {
            &mesh
        };
        let [scene, blur, comp, edge, wall] = pass_medians(&mut renderer, drawn, &p, frames)?;
        println!(
            "| {what} | {w}x{h} | {} | {taps} | {scene:.1} | {blur:.1} | {comp:.1} | {edge:.1} | {wall:.1} | {:.1} |",
            if antialias { "4x" } else { "off" },
            1e3 / wall
        );
    }
    // Gallery styles: each alone after the 1280x800 marble frame with SSS. A GPU style's cost
    // is its pass's timestamps, a CPU one's its wall time after the readback (median of the
    // frames), beside the same frame's scene pass; the frame's wall time less the plain
    // frame's is shown too (it carries the wall-time noise).
    println!(
        "\n# Gallery styles at 1280x800 (marble, 21-tap SSS)\n\n| style | where | style ms | scene pass ms | style / scene | frame ms | frame less plain ms |\n|---|---|---|---|---|---|---|"
    );
    let base = RenderParams {
        width: 1280,
        height: 800,
        ..RenderParams::default()
    };
    // (frame wall ms, scene pass ms, style ms), medians.
    let timed = |renderer: &mut Renderer,
                 p: &RenderParams|
     -> Result<(f64, f64, f64), Box<dyn std::error::Error>> {
        renderer.render(&mesh, p)?;
        let (mut wall, mut scene, mut style) = (vec![], vec![], vec![]);
        for _ in 0..frames {
            let (ms, times) = timed_frame(renderer, &mesh, p)?;
            wall.push(ms);
            scene.push(times.scene_ms);
            style.push(times.styles_ms.iter().map(|(_, ms)| ms).sum());
        }
        Ok((median(wall), median(scene), median(style)))
    };
    let (plain, _, _) = timed(&mut renderer, &base)?;
    for style in glyptic::styles::Style::ALL {
        let p = RenderParams {
            styles: vec![style],
            ..base.clone()
        };
        let (wall, scene, cost) = timed(&mut renderer, &p)?;
        let place = if style.is_serial() {
            "CPU, after the readback"
        } else {
            "GPU pass"
        };
        println!(
            "| {} | {place} | {cost:.1} | {scene:.1} | {:.1} % | {wall:.1} | {:.1} |",
            style.name(),
            100.0 * cost / scene,
            wall - plain
        );
    }
    println!("\nWithout a style the frame took {plain:.1} ms.");

    // Surface effects: the engraving (its maps are made once per cameo shape; the tangent
    // frames per mesh) and the lamp (six shadow-cube faces per frame), at 1280x800.
    println!(
        "\n# Surface effects at 1280x800 (marble, 21-tap SSS)\n\n| effects | shadow pass ms | scene pass ms | scene / plain scene | frame ms |\n|---|---|---|---|---|"
    );
    let lamp = Some(glyptic::render::Lamp::default());
    let engraving = Some(glyptic::render::surface::EngravingParams::default());
    // The four set-ups frame by frame in turn, so that the VM's drift (the scene pass wanders
    // by a third between runs) falls on all of them alike.
    let setups = [
        ("none", None, None),
        ("engraving", engraving.clone(), None),
        ("lamp", None, lamp),
        ("engraving + lamp", engraving.clone(), lamp),
    ]
    .map(|(name, engraving, lamp)| {
        (
            name,
            RenderParams {
                engraving,
                lamp,
                ..base.clone()
            },
        )
    });
    for (_, p) in &setups {
        renderer.render(&mesh, p)?;
    }
    let mut samples = vec![(vec![], vec![], vec![]); setups.len()];
    for _ in 0..frames {
        for ((_, p), (wall, scene, shadow)) in setups.iter().zip(samples.iter_mut()) {
            let (ms, times) = timed_frame(&mut renderer, &mesh, p)?;
            wall.push(ms);
            scene.push(times.scene_ms);
            shadow.push(times.shadow_ms.unwrap_or(0.0));
        }
    }
    let medians: Vec<(f64, f64, f64)> = samples
        .into_iter()
        .map(|(wall, scene, shadow)| (median(wall), median(scene), median(shadow)))
        .collect();
    let plain_scene = medians[0].1;
    for ((name, _), (wall, scene, shadow)) in setups.iter().zip(medians) {
        println!(
            "| {name} | {shadow:.1} | {scene:.1} | {:.2} | {wall:.1} |",
            scene / plain_scene
        );
    }
    let planar = glyptic::render::surface::PlanarFrame {
        centre: [0.0, 0.0],
        half: [23.6, 29.6],
    };
    let t = Instant::now();
    let maps = glyptic::render::surface::engraving(&planar, &Default::default());
    let maps_ms = t.elapsed().as_secs_f64() * 1e3;
    let tangent_ms = median_ms(|| {
        glyptic::render::surface::tangents(&mesh.vertices, &mesh.indices, |p| planar.uv(p))
    });
    let band_ms = median_ms(|| {
        glyptic::render::surface::band_last(&mesh.vertices, &mesh.indices, &planar, [2.35, 6.25])
    });
    let fingerprint_ms = median_ms(|| mesh.fingerprint());
    println!(
        "\nOn the CPU: the engraving's maps ({0} x {0} and mip chains, once per cameo shape) {maps_ms:.1} ms; per mesh (medians of {BUILDS}), its tangent frames {tangent_ms:.2} ms and the split of its triangles into the band's and the rest {band_ms:.2} ms, both kept while the mesh's fingerprint ({fingerprint_ms:.2} ms a frame) stays the same.",
        maps.size
    );
    println!(
        "\nRelief rebuild after a fit (`CameoBuilder::build`: height field + cameo mesh, one thread): mean face {:.2} ms, a varied face {:.2} ms (median of {} builds); the builder itself (head, hair and bezel, once per cameo shape) {builder_ms:.1} ms.",
        rebuild[0], rebuild[1], BUILDS
    );
    Ok(())
}
