//! The cameo geometry built from the Surrey mean face and from fitted faces.

mod common;

use glyptic::gem::{self, CameoParams, GemError};
use glyptic::render::Region;
use glyptic::shapemodel::SurreyModel;

fn model() -> SurreyModel {
    SurreyModel::load_dir(&glyptic::assets::sfm_dir()).expect("run scripts/setup.sh first")
}

fn out_dir() -> std::path::PathBuf {
    let d = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/test-out");
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Writes a relief as a hillshade lit from the upper left, for looking at.
fn save_relief(r: &gem::Relief, name: &str) {
    let img = image::GrayImage::from_fn(r.cols as u32, r.rows as u32, |x, y| {
        let (c, row) = (x as usize, r.rows - 1 - y as usize);
        let dx = r.at((c + 1).min(r.cols - 1), row) - r.at(c.saturating_sub(1), row);
        let dy = r.at(c, (row + 1).min(r.rows - 1)) - r.at(c, row.saturating_sub(1));
        let n = [-dx / (2.0 * r.cell), -dy / (2.0 * r.cell), 1.0];
        let l = [-0.5f32, 0.5, 0.7];
        let d = (n[0] * l[0] + n[1] * l[1] + n[2] * l[2])
            / (n[0] * n[0] + n[1] * n[1] + 1.0).sqrt()
            / 0.9899;
        image::Luma([(d.clamp(0.0, 1.0) * 235.0 + 20.0 * (r.at(c, row) > 0.03) as u8 as f32) as u8])
    });
    image::imageops::resize(
        &img,
        img.width() * 3,
        img.height() * 3,
        image::imageops::FilterType::Triangle,
    )
    .save(out_dir().join(name))
    .unwrap();
}

#[test]
fn relief_is_continuous_bounded_and_shows_a_profile() {
    let m = model();
    let p = CameoParams::default();
    let mean = m.instance(&[], &[]);
    let t = std::time::Instant::now();
    let r = gem::build_relief(&mean, &m.shape.triangles, &p).unwrap();
    println!(
        "relief {}x{} in {:.2} ms",
        r.cols,
        r.rows,
        t.elapsed().as_secs_f64() * 1e3
    );
    save_relief(&r, "relief_mean.png");
    let max = r.height.iter().cloned().fold(0f32, f32::max);
    assert!(
        max > 0.6 * p.relief_depth && max <= p.relief_depth + 1e-3,
        "max height {max}"
    );
    assert!(r.height.iter().all(|h| h.is_finite() && *h >= 0.0));
    // The outline, where the portrait rises from the ground, is steep on purpose (a carved
    // edge) but still a surface, not a wall.
    let mut outline = 0f32;
    for row in 0..r.rows - 1 {
        for col in 0..r.cols - 1 {
            let h = r.at(col, row);
            outline = outline
                .max((r.at(col + 1, row) - h).abs())
                .max((r.at(col, row + 1) - h).abs());
        }
    }
    println!("steepest slope {:.2}", outline / r.cell);
    assert!(
        outline / r.cell < 8.0,
        "the relief drops like a wall: slope {}",
        outline / r.cell
    );
    // The profile faces left: the relief's left edge at eye height is in the left half, and
    // there is relief (the face) left of centre and relief (the head) right of centre.
    let row = r.rows / 2;
    let first = (0..r.cols).find(|&c| r.at(c, row) > 0.1).unwrap();
    let last = (0..r.cols).rev().find(|&c| r.at(c, row) > 0.1).unwrap();
    assert!(
        first < r.cols / 4 && last > 3 * r.cols / 4,
        "portrait spans {first}..{last} of {}",
        r.cols
    );
}

/// Largest height step between neighbouring cells on opposite sides of the face's footprint.
fn step_across_face_edge(f: &glyptic::gem::relief::HeightField) -> f32 {
    let mut worst = 0f32;
    for row in 0..f.rows - 1 {
        for col in 0..f.cols - 1 {
            let i = row * f.cols + col;
            for j in [i + 1, i + f.cols] {
                if f.face_mask[i] != f.face_mask[j] {
                    worst = worst.max((f.height[i] - f.height[j]).abs());
                }
            }
        }
    }
    worst
}

#[test]
fn face_and_head_join_without_a_seam() {
    // A gap or an overlap between face and head is a jump in height across the face's edge
    // that stays when the grid is refined. A continuous surface's step shrinks with the cell:
    // by half where it is smooth, by 1/sqrt(2) at a rim where it turns tangent to the view.
    let m = model();
    let head = glyptic::gem::relief::HeadShape::default();
    for (name, shape) in [
        ("mean", vec![0f32; 63]),
        ("+2 SD", vec![2f32; 63]),
        ("-2 SD", vec![-2f32; 63]),
    ] {
        let mesh = m.instance(&shape, &[]);
        // The join widths (fade outside, blend inside); near zero means no join at all: the
        // face merely placed on the head, as the 2021 exhibit did (the negative control).
        let steps_for = |fade: f32, blend: f32| -> Vec<f32> {
            [1.2f32, 0.6, 0.3]
                .iter()
                .map(|&cell| {
                    let cols = (300.0 / cell) as usize;
                    let rows = (400.0 / cell) as usize;
                    let layer =
                        glyptic::gem::relief::head_layer(&head, [-50.0, -250.0], cell, cols, rows);
                    let f = glyptic::gem::relief::portrait(
                        &mesh,
                        &m.shape.triangles,
                        glyptic::gem::relief::View::Profile,
                        &layer,
                        [-50.0, -250.0],
                        cell,
                        cols,
                        rows,
                        fade,
                        blend,
                    );
                    assert!(f.face_mask.iter().any(|&b| b), "{name}: no face footprint");
                    step_across_face_edge(&f)
                })
                .collect()
        };
        let steps = steps_for(6.0, 15.0);
        let unjoined = steps_for(1e-3, 1e-3);
        println!(
            "{name}: largest step across the face's edge at cells 1.2 / 0.6 / 0.3 mm: {steps:.3?} mm (unjoined: {unjoined:.3?})"
        );
        assert!(
            steps[2] < 0.7 * steps[0],
            "{name}: the step does not shrink with the cell: {steps:?}"
        );
        assert!(
            unjoined[2] > 0.7 * unjoined[0],
            "{name}: the seam detector missed an unjoined face: {unjoined:?}"
        );
    }
}

#[test]
fn cameo_mesh_is_valid_and_has_every_part() {
    let m = model();
    let mean = m.instance(&[], &[]);
    let mesh = gem::build_cameo(&mean, &m.shape.triangles, &CameoParams::default()).unwrap();
    let n = mesh.vertices.len() as u32;
    assert!(mesh.indices.len().is_multiple_of(3) && mesh.indices.iter().all(|&i| i < n));
    assert!(
        mesh.vertices
            .iter()
            .all(|v| v.position.iter().chain(&v.normal).all(|c| c.is_finite()))
    );
    for region in [Region::Ground, Region::Relief, Region::Hair, Region::Gold] {
        let count = mesh
            .vertices
            .iter()
            .filter(|v| v.region == region as u32)
            .count();
        assert!(count > 100, "{region:?}: {count} vertices");
    }
    println!(
        "cameo: {} vertices, {} triangles",
        mesh.vertices.len(),
        mesh.indices.len() / 3
    );
}

/// The cameo and the face written as OBJ read back with `tobj` to the same vertices (within the
/// 4 decimals written), normals and triangles; a builder reused for a second face gives what a
/// one-off build gives.
#[test]
fn obj_export_round_trips_through_tobj() {
    let m = model();
    let mean = m.instance(&[], &[]);
    let mesh = gem::build_cameo(&mean, &m.shape.triangles, &CameoParams::default()).unwrap();
    let text = gem::mesh_to_obj(&mesh, "round trip\nsecond comment line");
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    let (models, _) =
        tobj::load_obj_buf(&mut text.as_bytes(), &opts, |_| Ok(Default::default())).unwrap();
    assert_eq!(models.len(), 1);
    let read = &models[0].mesh;
    // tobj drops vertices no triangle uses (a few grid nodes at the oval's edge), so compare
    // triangle corners.
    assert_eq!(read.indices.len(), mesh.indices.len());
    for (&ours, &theirs) in mesh.indices.iter().zip(&read.indices) {
        let v = &mesh.vertices[ours as usize];
        let t = 3 * theirs as usize;
        let (p, n) = (&read.positions[t..t + 3], &read.normals[t..t + 3]);
        for k in 0..3 {
            assert!((v.position[k] - p[k]).abs() <= 1e-4, "{v:?} vs {p:?}");
            assert!((v.normal[k] - n[k]).abs() <= 1e-4, "{v:?} vs {n:?}");
        }
    }
    let face_text = gem::to_obj(&mean, &m.shape.triangles, "face");
    let (faces, _) =
        tobj::load_obj_buf(&mut face_text.as_bytes(), &opts, |_| Ok(Default::default())).unwrap();
    // tobj numbers vertices in order of first use: compare triangle corners.
    let read = &faces[0].mesh;
    assert_eq!(read.positions.len(), mean.len());
    let flat: Vec<u32> = m.shape.triangles.iter().flatten().copied().collect();
    assert_eq!(read.indices.len(), flat.len());
    for (&ours, &theirs) in flat.iter().zip(&read.indices) {
        let (a, b) = (3 * ours as usize, 3 * theirs as usize);
        for k in 0..3 {
            assert!((mean[a + k] - read.positions[b + k]).abs() <= 1e-4);
        }
    }

    // One builder, two faces, equals two one-off builds.
    let builder = gem::CameoBuilder::new(&CameoParams::default()).unwrap();
    let other = m.instance(&[1.5; 10], &[]);
    for face in [&other, &mean] {
        let a = builder.build(face, &m.shape.triangles).unwrap();
        let b = gem::build_cameo(face, &m.shape.triangles, &CameoParams::default()).unwrap();
        assert_eq!(a.indices, b.indices);
        assert!(
            a.vertices
                .iter()
                .zip(&b.vertices)
                .all(|(p, q)| p.position == q.position && p.region == q.region)
        );
    }
}

/// The frontal portrait looks out of the stone: its highest point on the face is the nose tip
/// (the mean face's vertex furthest along +z), where the profile's is not.
#[test]
fn frontal_portrait_faces_the_viewer() {
    let m = model();
    let mean = m.instance(&[], &[]);
    let tip = mean
        .chunks_exact(3)
        .max_by(|a, b| a[2].total_cmp(&b[2]))
        .map(|v| [v[0], v[1]])
        .unwrap();
    for (params, frontal) in [
        (CameoParams::frontal(), true),
        (CameoParams::default(), false),
    ] {
        let r = gem::build_relief(&mean, &m.shape.triangles, &params).unwrap();
        let (i, _) = r
            .height
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .unwrap();
        // Grid node -> gem mm -> model mm (frontal plane: u = x, v = y).
        let gx = r.origin[0] + (i % r.cols) as f32 * r.cell;
        let gy = r.origin[1] + (i / r.cols) as f32 * r.cell;
        let k = params.portrait_scale;
        let (u, v) = (
            gx / k + params.portrait_centre[0],
            gy / k + params.portrait_centre[1],
        );
        let d = ((u - tip[0]).powi(2) + (v - tip[1]).powi(2)).sqrt();
        println!(
            "frontal {frontal}: highest point at model ({u:.1}, {v:.1}), nose tip {tip:?}, {d:.1} mm away"
        );
        if frontal {
            assert!(
                d < 8.0,
                "the frontal relief's top is {d} mm from the nose tip"
            );
        } else {
            assert!(
                d > 30.0,
                "the profile relief peaks at the nose tip's frontal position"
            );
        }
        let max = r.height.iter().cloned().fold(0f32, f32::max);
        assert!(max > 3.0 && max <= params.relief_depth, "{max}");
    }
}

#[test]
fn bad_input_is_an_error() {
    let m = model();
    let mut mean = m.instance(&[], &[]);
    assert_eq!(
        gem::build_cameo(&[], &m.shape.triangles, &CameoParams::default()).unwrap_err(),
        GemError::EmptyFace
    );
    mean[5] = f32::NAN;
    assert_eq!(
        gem::build_cameo(&mean, &m.shape.triangles, &CameoParams::default()).unwrap_err(),
        GemError::NonFinite
    );
    let tiny = CameoParams {
        cell: 1e-4,
        ..CameoParams::default()
    };
    assert!(matches!(
        gem::build_relief(&m.instance(&[], &[]), &m.shape.triangles, &tiny),
        Err(GemError::BadParams(_))
    ));
    // Triangles pointing past the vertex list are skipped, not a panic.
    let bogus = vec![[0u32, 1, 99_999]];
    assert!(gem::build_relief(&m.instance(&[], &[]), &bogus, &CameoParams::default()).is_ok());
}
