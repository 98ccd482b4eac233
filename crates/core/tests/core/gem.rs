//! The cameo geometry built from the Surrey mean face and from fitted faces.
//!
//! Length: about 890 lines, the cameo's tests sharing the model's loading, the mean and fitted
//! faces and the mesh measures (watertightness, heights, outline) at the top.

use glyptic_core::gem::{self, CameoParams, GemError, View, measure};
use glyptic_core::scene::Region;
use glyptic_core::shapemodel::SurreyModel;

fn model() -> SurreyModel {
    SurreyModel::load_dir(&crate::common::sfm_dir()).expect("run scripts/setup.sh first")
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

/// Synthetic identities: the mean, +-2 SD along every shape component, a mixed face that
/// smiles.
fn identities(m: &SurreyModel) -> Vec<(&'static str, Vec<f32>)> {
    let n = m.shape.num_components();
    vec![
        ("mean", m.instance(&[], &[])),
        ("+2 SD", m.instance(&vec![2.0; n], &[])),
        ("-2 SD", m.instance(&vec![-2.0; n], &[])),
        (
            "mixed, smiling",
            m.instance(
                &(0..n)
                    .map(|i| if i % 2 == 0 { 1.5 } else { -1.5 })
                    .collect::<Vec<_>>(),
                &[0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
            ),
        ),
    ]
}

#[test]
fn relief_is_bounded_and_shows_a_profile_with_a_steep_outline() {
    let m = model();
    let p = CameoParams::default();
    let mean = m.instance(&[], &[]);
    let t = std::time::Instant::now();
    let r = gem::build_relief(&mean, &m.shape.triangles, &p).unwrap();
    println!(
        "relief {}x{} in {:.2} ms, {:?}",
        r.cols,
        r.rows,
        t.elapsed().as_secs_f64() * 1e3,
        r.solve
    );
    save_relief(&r, "relief_mean.png");
    let max = r.height.iter().cloned().fold(0f32, f32::max);
    assert!(
        max > 0.9 * p.relief_depth && max <= p.relief_depth + 1e-4,
        "max height {max}"
    );
    assert!(r.height.iter().all(|h| h.is_finite() && *h >= 0.0));
    assert!(r.occlusion.iter().all(|o| (0.0..=1.0).contains(o)));
    assert!(r.key_light.iter().all(|o| (0.0..=1.0).contains(o)));
    // The outline is a steep wall (a carved edge, as cutters leave it), not a ramp: where the
    // relief leaves the ground along a row, it climbs from 0.1 mm to 0.7 of the wall within two
    // cells (0.4 mm) nearly everywhere.
    let (mut rises, mut steep) = (0, 0);
    for row in 0..r.rows {
        for col in 1..r.cols - 4 {
            if r.at(col - 1, row) < 0.1 && r.at(col, row) >= 0.1 {
                rises += 1;
                if (col..col + 3).any(|c| r.at(c, row) >= 0.7 * p.wall) {
                    steep += 1;
                }
            }
        }
    }
    println!("outline: {steep} of {rises} rises climb 0.7 of the wall within two cells");
    assert!(rises > 100 && steep as f32 > 0.9 * rises as f32);
    // The profile faces left: the face's footprint lies left of the head's middle and there is
    // relief (the head) right of it.
    let row = r.rows / 2 + 20;
    let first = (0..r.cols).find(|&c| r.at(c, row) > 0.1).unwrap();
    let last = (0..r.cols).rev().find(|&c| r.at(c, row) > 0.1).unwrap();
    let face_cols: Vec<usize> = (0..r.cols).filter(|&c| r.face[row * r.cols + c]).collect();
    assert!(!face_cols.is_empty());
    assert!(
        face_cols[0] <= first + 1 && last > face_cols[face_cols.len() - 1] + 30,
        "portrait spans {first}..{last}, face {:?}..",
        face_cols.first()
    );
}

/// The face leads: its own profile line is the relief's outline (within 0.3 mm on the stone)
/// over brow, nose, lips and chin, for faces far from the mean too (nothing of the sculpted
/// head stands in front of it).
#[test]
fn the_face_leads_the_profile_line() {
    let m = model();
    let p = CameoParams::default();
    let builder = gem::CameoBuilder::new(&p).unwrap();
    for (name, face) in identities(&m) {
        let r = builder.relief(&face, &m.shape.triangles).unwrap();
        let line = measure::profile_line(&r, &face, &m.shape.triangles).expect("measured");
        println!("{name}: profile line {line:?}");
        assert!(line.samples > 150, "{name}: {line:?}");
        assert!(
            line.max_mm < 0.3 && line.mean_mm < 0.1,
            "{name}: the outline strays from the face's profile: {line:?}"
        );
    }
    // A control: the same relief measured against a face moved 1 mm (model) forward misses.
    let mean = m.instance(&[], &[]);
    let r = builder.relief(&mean, &m.shape.triangles).unwrap();
    let moved: Vec<f32> = mean
        .chunks_exact(3)
        .flat_map(|v| [v[0], v[1], v[2] + 6.0])
        .collect();
    let off = measure::profile_line(&r, &moved, &m.shape.triangles).unwrap();
    println!("control, face moved 6 mm: {off:?}");
    assert!(off.mean_mm > 0.4, "{off:?}");
}

/// Face slopes and fine detail keep at least 70 % of what a uniform scale-down to the same depth
/// keeps: the stricter scale-down, which gives the face's own height range the whole depth
/// (a scale-down of the whole portrait, bust included, keeps less and is reported beside it).
#[test]
fn the_relief_keeps_the_face_detail() {
    let m = model();
    let p = CameoParams::default();
    let builder = gem::CameoBuilder::new(&p).unwrap();
    for (name, face) in identities(&m) {
        let r = builder.relief(&face, &m.shape.triangles).unwrap();
        let portrait: Vec<bool> = r.portrait.iter().map(|h| *h > 0.0).collect();
        let kept = measure::detail_kept(&r, p.wall, p.relief_depth, &portrait);
        let strict = measure::detail_kept(&r, p.wall, p.relief_depth, &r.face);
        println!("{name}: against the face alone {strict:?}; against the portrait {kept:?}");
        assert!(strict.cells > 1000, "{name}: {strict:?}");
        assert!(
            strict.slopes >= 0.7 && strict.fine >= 0.7,
            "{name}: {strict:?}"
        );
    }
    // Control: the measure catches a relief that flattens the face: the previous relief's
    // compression (an 8 mm lift off the ground, then 5 mm x (1 - e^(-k h / 76 mm))) with a
    // strong roll-off (k = 4; the previous relief had 1.6 on a head that hid the face).
    let mut r = gem::build_relief(&m.instance(&[], &[]), &m.shape.triangles, &p).unwrap();
    for (h, q) in r.height.iter_mut().zip(&r.portrait) {
        if *h > 0.0 {
            let t = (q / 2.5).clamp(0.0, 1.0);
            let lifted = q + 8.0 * t * t * (3.0 - 2.0 * t);
            *h = p.relief_depth * (1.0 - (-4.0 * lifted / 76.0).exp());
        }
    }
    let kept = measure::detail_kept(&r, p.wall, p.relief_depth, &r.face);
    println!("exponential roll-off: {kept:?}");
    assert!(kept.slopes < 0.7, "{kept:?}");
    // ... and one that loses the fine detail: the relief blurred by 0.4 mm.
    let mut r = gem::build_relief(&m.instance(&[], &[]), &m.shape.triangles, &p).unwrap();
    r.height = gem::basrelief::blur(&r.height, r.cols, r.rows, 0.4 / r.cell);
    let kept = measure::detail_kept(&r, p.wall, p.relief_depth, &r.face);
    println!("blurred: {kept:?}");
    assert!(kept.fine < 0.7, "{kept:?}");
}

/// Different faces make different gems: at least 10 % of the relief's area differs by more
/// than 0.1 mm between two identities; the same face twice gives the same relief.
#[test]
fn gems_of_different_faces_differ() {
    let m = model();
    let builder = gem::CameoBuilder::new(&CameoParams::default()).unwrap();
    let faces = identities(&m);
    let reliefs: Vec<_> = faces
        .iter()
        .map(|(_, f)| builder.relief(f, &m.shape.triangles).unwrap())
        .collect();
    for i in 0..faces.len() {
        for j in i + 1..faces.len() {
            let d = measure::difference(&reliefs[i], &reliefs[j]);
            println!(
                "{} vs {}: {:.1} % differs",
                faces[i].0,
                faces[j].0,
                100.0 * d
            );
            assert!(d >= 0.10, "{} vs {}: {d}", faces[i].0, faces[j].0);
        }
    }
    let again = builder.relief(&faces[1].1, &m.shape.triangles).unwrap();
    assert_eq!(measure::difference(&reliefs[1], &again), 0.0);
}

/// Face and head are one surface: across the face's border the relief never steps by more
/// than a carved edge (where the hair or the jaw overlaps, a crisp step of a few tenths of a
/// millimetre), although the portrait before compression jumps by centimetres there.
#[test]
fn face_and_head_join_without_a_seam() {
    let m = model();
    let p = CameoParams::default();
    let builder = gem::CameoBuilder::new(&p).unwrap();
    for (name, face) in identities(&m) {
        let r = builder.relief(&face, &m.shape.triangles).unwrap();
        let (mut step, mut raw, mut pairs) = (0f32, 0f32, 0);
        for row in 0..r.rows - 1 {
            for col in 0..r.cols - 1 {
                let i = row * r.cols + col;
                for j in [i + 1, i + r.cols] {
                    let inside = r.height[i] > p.wall && r.height[j] > p.wall;
                    if r.face[i] != r.face[j] && inside {
                        step = step.max((r.height[i] - r.height[j]).abs());
                        raw = raw.max((r.portrait[i] - r.portrait[j]).abs());
                        pairs += 1;
                    }
                }
            }
        }
        println!(
            "{name}: largest step across the face's border {step:.3} mm over {pairs} neighbour pairs (before compression {raw:.1} canonical mm)"
        );
        assert!(pairs > 100, "{name}: {pairs}");
        assert!(step < 0.6, "{name}: a cliff of {step} mm");
        assert!(raw > 5.0, "{name}: the border has no jump to join ({raw})");
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

/// The portrait's outline is a near-vertical wall cut between the grid's nodes (no ramp): every
/// stone triangle that climbs from the ground to the relief leans less than 20 degrees from
/// the vertical, and the walls run round the whole outline (one a crossing, about 2 a cell).
/// The batter is even (nine in ten facets lean 5-10 degrees, for the 8 built): a foot that
/// strays from a parallel to the top's edge serrates the outline at 3840 px (a foot pushed
/// along each grid edge within the edge had its 5 % lean 0.4 degrees).
#[test]
fn the_outline_is_a_near_vertical_wall() {
    let m = model();
    let mean = m.instance(&[], &[]);
    for view in [View::Profile, View::Frontal] {
        let p = view.cameo();
        let mesh = gem::build_cameo(&mean, &m.shape.triangles, &p).unwrap();
        let (mut walls, mut worst) = (0, 0f32);
        let mut leans = Vec::new();
        for t in mesh.indices.chunks_exact(3) {
            let v = [0, 1, 2].map(|k| mesh.vertices[t[k] as usize]);
            if v.iter().any(|v| v.region == Region::Gold as u32) {
                continue;
            }
            let z = v.map(|v| v.position[2]);
            let (lo, hi) = (z[0].min(z[1]).min(z[2]), z[0].max(z[1]).max(z[2]));
            if lo > 0.03 || hi < 0.3 {
                continue;
            }
            let [a, b, c] = v.map(|v| v.position);
            let n = glyptic_core::vec3::triangle_normal(a, b, c);
            let len = glyptic_core::vec3::length(n);
            if len < 1e-9 {
                continue;
            }
            walls += 1;
            // The wall's lean from the vertical: the facet normal's rise out of the plane.
            let lean = (n[2] / len).abs().asin().to_degrees();
            worst = worst.max(lean);
            leans.push(lean);
        }
        leans.sort_by(f32::total_cmp);
        let q = |f: f32| leans[((leans.len() - 1) as f32 * f) as usize];
        println!(
            "{view:?}: {walls} wall triangles, leaning at most {worst:.1} degrees; 5/50/95 %: {:.1} / {:.1} / {:.1}",
            q(0.05),
            q(0.5),
            q(0.95)
        );
        assert!(walls > 1000, "{view:?}: {walls} wall triangles");
        assert!(worst < 20.0, "{view:?}: a wall leans {worst} degrees");
        assert!(
            q(0.05) >= 5.0 && q(0.95) <= 10.0,
            "{view:?}: the batter is uneven, {:.1} to {:.1} degrees",
            q(0.05),
            q(0.95)
        );
    }
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

/// The frontal portrait looks out of the stone: its highest point on the face is near the nose
/// tip, where the profile's is not.
#[test]
fn frontal_portrait_faces_the_viewer() {
    let m = model();
    let mean = m.instance(&[], &[]);
    let tip = mean
        .chunks_exact(3)
        .max_by(|a, b| a[2].total_cmp(&b[2]))
        .map(|v| [v[0], v[1], v[2]])
        .unwrap();
    for (params, frontal) in [
        (CameoParams::frontal(), true),
        (CameoParams::default(), false),
    ] {
        let r = gem::build_relief(&mean, &m.shape.triangles, &params).unwrap();
        // The highest node of the face.
        let (i, _) = r
            .height
            .iter()
            .enumerate()
            .filter(|(i, _)| r.face[*i])
            .max_by(|a, b| a.1.total_cmp(b.1))
            .unwrap();
        let node = [
            r.origin[0] + (i % r.cols) as f32 * r.cell,
            r.origin[1] + (i / r.cols) as f32 * r.cell,
        ];
        let t = r.model_to_gem(tip);
        let d = (node[0] - t[0]).hypot(node[1] - t[1]);
        println!("frontal {frontal}: the face's highest node is {d:.1} mm from the nose tip");
        if frontal {
            assert!(
                d < 2.0,
                "the frontal relief's top is {d} mm from the nose tip"
            );
        } else {
            assert!(
                d > 3.0,
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
    let wall = CameoParams {
        wall: 6.0,
        ..CameoParams::default()
    };
    assert!(matches!(
        gem::CameoBuilder::new(&wall),
        Err(GemError::BadParams(_))
    ));
    assert!(matches!(
        gem::build_relief(&m.instance(&[], &[]), &m.shape.triangles, &tiny),
        Err(GemError::BadParams(_))
    ));
    // Triangles pointing past the vertex list are skipped, not a panic.
    let mut bogus = m.shape.triangles.clone();
    bogus.push([0u32, 1, 99_999]);
    assert!(gem::build_relief(&m.instance(&[], &[]), &bogus, &CameoParams::default()).is_ok());
    // No face to carve (issue #40: each carved a faceless head): one triangle, a face a
    // hundred thousand billion times too large, a flat face.
    let mean = m.instance(&[], &[]);
    let not_a_face = |positions: &[f32], triangles: &[[u32; 3]]| {
        matches!(
            gem::build_relief(positions, triangles, &CameoParams::default()),
            Err(GemError::NotAFace(_))
        )
    };
    assert!(not_a_face(&mean, &m.shape.triangles[..1]));
    let huge: Vec<f32> = mean.iter().map(|v| v * 1e28).collect();
    assert!(not_a_face(&huge, &m.shape.triangles));
    let flat: Vec<f32> = mean
        .chunks_exact(3)
        .flat_map(|v| [v[0], v[1], 0.0])
        .collect();
    assert!(not_a_face(&flat, &m.shape.triangles));
    // A face in centimetres is still a face (placed by its box).
    let cm: Vec<f32> = mean.iter().map(|v| v * 0.1).collect();
    assert!(gem::build_relief(&cm, &m.shape.triangles, &CameoParams::default()).is_ok());
}

/// Facial hair on the mean face: a beard moves the chin out by its thickness and leaves nose,
/// eyes and lips where they were; a chin beard leaves the jaw's angle alone, a full beard moves
/// it; a moustache moves the upper lip and not the chin; without facial hair, or on a mesh of
/// another topology, nothing is made.
#[test]
fn facial_hair_grows_where_a_beard_and_a_moustache_grow() {
    use gem::face::facial_hair;
    let m = model();
    let mean = m.instance(&[], &[]);
    let tri = &m.shape.triangles;
    let moved = |f: &gem::face::FacialHair, v: usize| {
        (0..3)
            .map(|k| (f.positions[3 * v + k] - mean[3 * v + k]).powi(2))
            .sum::<f32>()
            .sqrt()
    };
    // Chin 33, nose tip 114, an eye's corner 177, lower lip middle 411 (its lower edge: the
    // beard starts just below), upper lip top 329, the jaw's angle 805 / 391, and the upper
    // lip's middle: the vertex nearest the midpoint of the nose's base (270) and the lip's top.
    let mid = [
        0.0,
        0.5 * (mean[3 * 270 + 1] + mean[3 * 329 + 1]),
        0.5 * (mean[3 * 270 + 2] + mean[3 * 329 + 2]),
    ];
    let philtrum = (0..mean.len() / 3)
        .min_by(|&a, &b| {
            let d = |v: usize| {
                (0..3)
                    .map(|k| (mean[3 * v + k] - mid[k]).powi(2))
                    .sum::<f32>()
            };
            d(a).total_cmp(&d(b))
        })
        .unwrap();
    let none = gem::HairStyle::default();
    assert!(facial_hair(&mean, tri, &none).is_none());
    let chin_beard = gem::HairStyle {
        beard: 8.0,
        beard_jaw: 0.0,
        ..none
    };
    let full = gem::HairStyle {
        beard_jaw: 1.0,
        ..chin_beard
    };
    let c = facial_hair(&mean, tri, &chin_beard).expect("a chin beard");
    let f = facial_hair(&mean, tri, &full).expect("a full beard");
    for (name, hair) in [("chin", &c), ("full", &f)] {
        assert!(
            (moved(hair, 33) - 8.0).abs() < 0.5,
            "{name}: chin moved {}",
            moved(hair, 33)
        );
        assert!((hair.thickness[33] - 8.0).abs() < 0.5);
        for v in [114, 177, 329, philtrum] {
            assert!(
                moved(hair, v) < 1e-4,
                "{name}: vertex {v} moved {}",
                moved(hair, v)
            );
        }
        assert!(
            moved(hair, 411) < 2.0,
            "{name}: lower lip moved {}",
            moved(hair, 411)
        );
    }
    for v in [805, 391] {
        assert!(
            moved(&c, v) < 0.5,
            "chin beard moved the jaw's angle {v}: {}",
            moved(&c, v)
        );
        assert!(
            moved(&f, v) > 6.0,
            "full beard left the jaw's angle {v}: {}",
            moved(&f, v)
        );
    }
    let moustache = gem::HairStyle {
        moustache: 3.0,
        ..none
    };
    let mo = facial_hair(&mean, tri, &moustache).expect("a moustache");
    assert!(
        moved(&mo, philtrum) > 2.5,
        "upper lip moved {}",
        moved(&mo, philtrum)
    );
    assert!(moved(&mo, 33) < 1e-4 && moved(&mo, 114) < 1e-4);
    // Another topology: no landmarks to grow it on.
    assert!(facial_hair(&mean[..mean.len() - 3], tri, &full).is_none());

    // On the stone: the bearded profile's chin stands out further, in the hair layer; the
    // brow is the same.
    let builder = |hair| {
        gem::CameoBuilder::new(&CameoParams {
            hair,
            ..CameoParams::default()
        })
        .unwrap()
    };
    let shaven = builder(none).relief(&mean, tri).unwrap();
    let bearded = builder(full).relief(&mean, tri).unwrap();
    save_relief(&bearded, "relief-bearded.png");
    let at = |r: &gem::Relief, v: usize| {
        let g = r.model_to_gem([mean[3 * v], mean[3 * v + 1], mean[3 * v + 2]]);
        let col = ((g[0] - r.origin[0]) / r.cell).round() as usize;
        let row = ((g[1] - r.origin[1]) / r.cell).round() as usize;
        row * r.cols + col
    };
    // The jaw's angle, on the near side (the beard stands on it).
    let jaw = at(&shaven, 805);
    assert!(
        bearded.height[jaw] > shaven.height[jaw] + 0.05,
        "jaw {} vs {}",
        bearded.height[jaw],
        shaven.height[jaw]
    );
    assert!(bearded.hair[jaw] > 0.5, "hair layer {}", bearded.hair[jaw]);
    let brow = at(&shaven, 2842);
    assert!(shaven.hair[brow] == 0.0 && bearded.hair[brow] == 0.0);
    let covered = |r: &gem::Relief| r.portrait.iter().filter(|&&c| c > 0.0).count();
    // The chin's outline moves out: the portrait covers more of the stone.
    assert!(covered(&bearded) > covered(&shaven));
    // The beard hangs below the face under the chin: hair-layer nodes that are not the face,
    // below the chin and within 2 mm of it across.
    let chin = bearded.model_to_gem([mean[3 * 33], mean[3 * 33 + 1], mean[3 * 33 + 2]]);
    let hanging = (0..bearded.cols * bearded.rows)
        .filter(|&i| {
            let x = bearded.origin[0] + (i % bearded.cols) as f32 * bearded.cell;
            let y = bearded.origin[1] + (i / bearded.cols) as f32 * bearded.cell;
            !bearded.face[i] && bearded.hair[i] > 0.3 && y < chin[1] && (x - chin[0]).abs() < 2.0
        })
        .count();
    assert!(hanging > 10, "{hanging} nodes of beard under the chin");
}

/// Glasses carved: frontal, rims round both eyes and the bridge between them raise the face
/// there and nowhere near the chin; in profile the temple runs back from the eye. Without
/// `glasses` the same face is carved as before.
#[test]
fn glasses_are_carved_round_the_eyes() {
    let m = model();
    let mean = m.instance(&[], &[]);
    let tri = &m.shape.triangles;
    for base in [CameoParams::frontal(), CameoParams::default()] {
        let with = |glasses| {
            let p = CameoParams {
                hair: gem::HairStyle {
                    glasses,
                    ..base.hair
                },
                ..base.clone()
            };
            gem::CameoBuilder::new(&p)
                .unwrap()
                .relief(&mean, tri)
                .unwrap()
        };
        let (bare, glasses) = (with(false), with(true));
        let view = base.view;
        let node = |v: usize| {
            let g = bare.model_to_gem([mean[3 * v], mean[3 * v + 1], mean[3 * v + 2]]);
            let col = ((g[0] - bare.origin[0]) / bare.cell).round() as usize;
            let row = ((g[1] - bare.origin[1]) / bare.cell).round() as usize;
            (col, row)
        };
        // The largest rise within 12 mm (gem: about 1.3 mm) of a vertex.
        let rise = |v: usize| {
            let (c, r) = node(v);
            let k = (1.3 / bare.cell).ceil() as usize;
            let mut best = 0f32;
            for y in r.saturating_sub(k)..=(r + k).min(bare.rows - 1) {
                for x in c.saturating_sub(k)..=(c + k).min(bare.cols - 1) {
                    best = best.max(glasses.at(x, y) - bare.at(x, y));
                }
            }
            best
        };
        // Near eye outer corner 610 (the profile's eye), nasion 2842; chin 33.
        let (eye, nasion, chin) = (rise(610), rise(2842), rise(33));
        println!("{view:?}: rise at eye {eye:.3}, nasion {nasion:.3}, chin {chin:.3} mm");
        assert!(eye > 0.05, "{view:?}: no rim by the eye ({eye})");
        if view == gem::View::Frontal {
            assert!(nasion > 0.05, "no bridge ({nasion})");
        }
        assert!(chin < 0.02, "{view:?}: the chin changed ({chin})");
    }
}

/// Every cut along the outline builds, whatever the face, view and hair: the cells the wall
/// crosses take their material from portrait nodes near them, which need not be mesh
/// vertices (inside a merged square); a frontal astronaut's gem once panicked there. Each
/// mesh is valid: every index in range, every position finite.
#[test]
fn every_face_view_and_hair_cuts_a_valid_wall() {
    use glyptic_core::gem::{HairCarving, HairStyle};
    let m = model();
    // Every kind, and hair ending high with a beard, and deep curls ending low.
    let styles: Vec<HairStyle> = HairStyle::gallery()
        .map(|(_, s)| s)
        .into_iter()
        .chain([
            HairStyle {
                ears_shown: true,
                end: -20.0,
                volume: 4.0,
                beard: 6.0,
                moustache: 4.0,
                ..HairStyle::default()
            },
            HairStyle {
                end: -160.0,
                volume: 24.0,
                carving: HairCarving::Curls,
                ..HairStyle::default()
            },
        ])
        .collect();
    for (name, face) in identities(&m) {
        for view in [View::Profile, View::Frontal] {
            for (k, hair) in styles.iter().enumerate() {
                let p = CameoParams {
                    hair: *hair,
                    ..view.cameo()
                };
                let mesh = gem::build_cameo(&face, &m.shape.triangles, &p)
                    .unwrap_or_else(|e| panic!("{name}, {view:?}, style {k}: {e}"));
                let n = mesh.vertices.len() as u32;
                assert!(
                    mesh.indices.iter().all(|&i| i < n),
                    "{name}, {view:?}, style {k}: an index out of range"
                );
                assert!(
                    mesh.vertices.iter().all(|v| v
                        .position
                        .iter()
                        .chain(&v.normal)
                        .all(|c| c.is_finite())),
                    "{name}, {view:?}, style {k}: a vertex not finite"
                );
            }
        }
    }
}

/// A flat top (1 to 4 mm: the wall's run 0.14 to 0.56 mm, up to near three cells) cuts a
/// valid wall: the top merges into squares up to the cut cells, so nodes near the cut need
/// not be mesh vertices (the wall once read its material from such a node and panicked, at
/// 1 mm here and on a frontal astronaut); and the foot runs parallel to the top's edge at
/// the batter's run (every wall vertex on the ground within 20 % of the run from the
/// nearest vertex of the top's edge).
#[test]
fn a_flat_top_cuts_a_wall_with_its_foot_at_the_batters_run() {
    let m = model();
    let mean = m.instance(&[], &[]);
    for view in [View::Profile, View::Frontal] {
        let builder = gem::CameoBuilder::new(&view.cameo()).unwrap();
        let relief = builder.relief(&mean, &m.shape.triangles).unwrap();
        for top in [1.0f32, 2.5, 4.0] {
            let mut r = relief.clone();
            // Flat and evenly lit, so the top merges into squares up to the cut cells.
            for i in 0..r.top.len() {
                r.top[i] = top;
                r.height[i] = if r.outline[i] >= 0.5 { top } else { 0.0 };
                (r.occlusion[i], r.key_light[i], r.transmit[i], r.hair[i]) = (1.0, 1.0, 0.0, 0.0);
            }
            let mesh = builder.mesh_of(&r);
            let n = mesh.vertices.len() as u32;
            assert!(
                mesh.indices.iter().all(|&i| i < n),
                "{view:?}, {top} mm: an index out of range"
            );
            // The top's edge: vertices at the top with a wall's normal; the foot: at 0.
            let wall = |v: &&glyptic_core::scene::Vertex| {
                v.normal[2] < 0.5 && v.region != Region::Gold as u32
            };
            let at = |z: f32| -> Vec<[f32; 2]> {
                mesh.vertices
                    .iter()
                    .filter(wall)
                    .filter(|v| (v.position[2] - z).abs() < 1e-4)
                    .map(|v| [v.position[0], v.position[1]])
                    .collect()
            };
            let (rim, feet) = (at(top), at(0.0));
            assert!(
                rim.len() > 500 && feet.len() > 500,
                "{view:?}, {top} mm: {} / {}",
                rim.len(),
                feet.len()
            );
            let run = top * 0.14f32.tan();
            let mut off: Vec<f32> = feet
                .iter()
                .map(|f| {
                    rim.iter()
                        .map(|p| (p[0] - f[0]).hypot(p[1] - f[1]))
                        .fold(f32::INFINITY, f32::min)
                })
                .collect();
            off.sort_by(f32::total_cmp);
            let q = |f: f32| off[((off.len() - 1) as f32 * f) as usize];
            println!(
                "{view:?}, {top} mm: foot from the top's edge 5/50/95 %: {:.3} / {:.3} / {:.3} mm (run {run:.3})",
                q(0.05),
                q(0.5),
                q(0.95)
            );
            assert!(
                q(0.05) > 0.8 * run && q(0.95) < 1.2 * run,
                "{view:?}, {top} mm: the foot strays from the batter's run"
            );
        }
    }
}

/// In profile the face's front edge rolls into its wall without a groove: along every row the
/// face leads, the top one or two nodes in from the outline never dips (by 0.08 mm) under both
/// the node at the outline and the one three in. The head's share of the face's front node
/// (the part of its cell the face leaves) once raised that node 5-8 canonical mm over the next
/// one in, and the compression kept it as a groove just inside the forehead's wall, with a
/// torn-looking edge (0.25 mm deep on the mean face; now at most 0.05 on these faces).
#[test]
fn the_profile_edge_has_no_groove_inside() {
    let m = model();
    let builder = gem::CameoBuilder::new(&View::Profile.cameo()).unwrap();
    for (name, face) in identities(&m) {
        let r = builder.relief(&face, &m.shape.triangles).unwrap();
        let (mut rows, mut worst) = (0, 0f32);
        for y in 0..r.rows {
            let row = y * r.cols;
            let Some(x0) = (0..r.cols).find(|&x| r.outline[row + x] >= 0.5) else {
                continue;
            };
            if x0 + 3 >= r.cols || !(0..4).all(|k| r.face[row + x0 + k]) {
                continue;
            }
            rows += 1;
            let t = &r.top[row + x0..row + x0 + 4];
            worst = worst.max(t[0].min(t[3]) - t[1].min(t[2]));
        }
        println!("{name}: {rows} rows, deepest groove inside the edge {worst:.3} mm");
        assert!(rows > 50, "{name}: {rows} rows");
        assert!(
            worst < 0.08,
            "{name}: a groove {worst} mm deep inside the edge"
        );
    }
}

/// The frontal shoulders are one rounded mass: walking in from the left shoulder's outline
/// (the mantle hangs on the right), the relief rises and does not fall back by more than
/// 0.12 mm within 4 mm of the edge. A rim rounded over a short quarter-round (its slope
/// steepest at the outline) came out of the compression's detail boost as a raised lip with
/// a trough inside it: a yoke (0.2 mm deep on the mean face).
#[test]
fn the_frontal_shoulders_have_no_trough_inside_their_rim() {
    let m = model();
    let builder = gem::CameoBuilder::new(&View::Frontal.cameo()).unwrap();
    for (name, face) in identities(&m) {
        let r = builder.relief(&face, &m.shape.triangles).unwrap();
        let steps = (4.0 / r.cell) as usize;
        let (mut rows, mut worst) = (0, 0f32);
        for y in 0..r.rows {
            let row = y * r.cols;
            let Some(x0) = (0..r.cols).find(|&x| r.height[row + x] > 0.0) else {
                continue;
            };
            // Rows through the shoulder: the outline well left of the neck.
            if x0 > r.cols / 4 || x0 + steps >= r.cols {
                continue;
            }
            rows += 1;
            let mut high = 0f32;
            for x in x0..x0 + steps {
                let h = r.height[row + x];
                high = high.max(h);
                worst = worst.max(high - h);
            }
        }
        println!("{name}: {rows} rows, deepest trough inside the shoulder {worst:.3} mm");
        assert!(rows > 20, "{name}: {rows} rows");
        assert!(
            worst < 0.12,
            "{name}: a trough {worst} mm deep inside the shoulder"
        );
    }
}
