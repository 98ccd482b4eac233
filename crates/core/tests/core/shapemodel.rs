//! The Surrey Face Model loaders, on the real files that set-up copies (scripts/setup.sh).
//! Known values were read independently from the binary files with Python's `struct`.

use glyptic_core::shapemodel::{self, ModelError, SurreyModel};

fn model() -> SurreyModel {
    SurreyModel::load_dir(&crate::common::sfm_dir()).expect("run scripts/setup.sh first")
}

/// A fresh copy of the model folder (`tag` names it) with `file` written as `contents`.
fn model_with(tag: &str, file: &str, contents: &[u8]) -> std::path::PathBuf {
    let src = crate::common::sfm_dir();
    let tmp = std::env::temp_dir().join(format!("glyptic-sfm-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).unwrap();
    for f in [
        shapemodel::SHAPE_FILE,
        shapemodel::BLENDSHAPES_FILE,
        shapemodel::MAPPING_FILE,
        shapemodel::CONTOURS_FILE,
        shapemodel::EDGE_TOPOLOGY_FILE,
    ] {
        std::fs::copy(src.join(f), tmp.join(f)).unwrap();
    }
    std::fs::write(tmp.join(file), contents).unwrap();
    tmp
}

#[test]
fn loads_the_real_model_with_known_values() {
    let m = model();
    assert_eq!(m.shape.num_vertices(), 3448);
    assert_eq!(m.shape.triangles.len(), 6736);
    assert_eq!(m.shape.num_components(), 63);
    assert_eq!(m.blendshapes.offsets.ncols(), 6);
    assert_eq!(
        m.blendshapes.names,
        [
            "anger",
            "disgust",
            "fear",
            "happiness",
            "sadness",
            "surprise"
        ]
    );
    assert_eq!(m.shape.texcoords.len(), 3448);
    // Known values.
    let close = |a: f32, b: f32| (a - b).abs() < 1e-4;
    assert!(close(m.shape.mean[0], -54.126328));
    assert!(close(m.shape.mean[2], -71.2307));
    assert_eq!(
        m.shape.mean_vertex(114).map(|v| (v * 1e3).round() / 1e3),
        [-0.288, -2.02, 3.337]
    );
    assert!(close(m.shape.orthonormal_basis[(2, 0)], -0.029617684));
    assert!((m.shape.eigenvalues[0] - 56502.367).abs() < 0.01);
    assert!((m.shape.eigenvalues[62] - 45.57958).abs() < 1e-3);
    assert_eq!(m.shape.triangles[0], [845, 1724, 346]);
    assert!(close(m.blendshapes.offsets[(1, 0)], 3.15016));
    // The basis is orthonormal and the rescaled basis carries sqrt(eigenvalue).
    let b = &m.shape.orthonormal_basis;
    let g = b.transpose() * b;
    for i in 0..63 {
        for j in 0..63 {
            let want = if i == j { 1.0 } else { 0.0 };
            assert!(
                (g[(i, j)] - want).abs() < 1e-3,
                "basis not orthonormal at {i},{j}"
            );
        }
    }
    assert!((m.shape.rescaled_basis[(2, 0)] - b[(2, 0)] * 56502.367f32.sqrt()).abs() < 1e-3);
    // Mapping, contours, edges.
    assert_eq!(m.mapping.to_vertex.len(), 50);
    assert_eq!(m.mapping.to_vertex[&31], 114, "nose tip");
    assert_eq!(m.mapping.to_vertex[&9], 33, "chin");
    assert_eq!(m.mapping.contour_right, (1..=8).collect::<Vec<_>>());
    assert_eq!(m.mapping.contour_left, (10..=17).collect::<Vec<_>>());
    assert_eq!(m.contour.right.len(), 17);
    assert_eq!(m.contour.left[0], 795);
    assert_eq!(m.edges.adjacent_faces.len(), 10184);
    assert_eq!(m.edges.adjacent_vertices.len(), 10184);
    // Mean face bounding box, mm (reference.md: x +-74, y -83..105, z -104..3.4).
    let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
    for v in 0..3448 {
        let p = m.shape.mean_vertex(v);
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    assert!(
        (hi[0] - 74.0).abs() < 2.0 && (lo[0] + 74.0).abs() < 2.0,
        "{lo:?} {hi:?}"
    );
    assert!(
        (lo[1] + 83.0).abs() < 2.0 && (hi[1] - 105.0).abs() < 2.0,
        "{lo:?} {hi:?}"
    );
    assert!(
        (lo[2] + 104.0).abs() < 2.0 && (hi[2] - 3.4).abs() < 0.5,
        "{lo:?} {hi:?}"
    );
}

#[test]
fn truncated_or_corrupt_files_give_typed_errors() {
    let dir = crate::common::sfm_dir();
    let bytes = std::fs::read(dir.join(shapemodel::SHAPE_FILE)).unwrap();
    for cut in [0, 3, 4, 11, 1000, 41_396, 2_000_000, bytes.len() - 1] {
        let err = shapemodel::parse_shape_model(&bytes[..cut], "shape.bin").unwrap_err();
        assert!(err.to_string().starts_with("shape.bin: "), "{err}");
    }
    let mut wrong_version = bytes.clone();
    wrong_version[0] = 7;
    let err = shapemodel::parse_shape_model(&wrong_version, "shape.bin").unwrap_err();
    assert!(err.to_string().contains("class version"), "{err}");
    let mut huge = bytes.clone();
    huge[4..8].copy_from_slice(&i32::MAX.to_le_bytes());
    assert!(shapemodel::parse_shape_model(&huge, "shape.bin").is_err());
    let mut nan = bytes.clone();
    nan[12..16].copy_from_slice(&f32::NAN.to_le_bytes());
    assert!(
        shapemodel::parse_shape_model(&nan, "shape.bin")
            .unwrap_err()
            .to_string()
            .contains("NaN")
    );

    let blend = std::fs::read(dir.join(shapemodel::BLENDSHAPES_FILE)).unwrap();
    for cut in [0, 8, 20, 30, blend.len() / 2, blend.len() - 1] {
        assert!(shapemodel::parse_blendshapes(&blend[..cut], "b.bin").is_err());
    }

    let map = std::fs::read_to_string(dir.join(shapemodel::MAPPING_FILE)).unwrap();
    assert!(
        shapemodel::parse_mapping(&map.replace("[landmark_mappings]", "[x]"), "m.txt").is_err()
    );
    assert!(shapemodel::parse_mapping(&map.replace("31 =   114", "31 =  -114"), "m.txt").is_err());
    assert!(shapemodel::parse_mapping(&map.replace("31 =   114", "99 =   114"), "m.txt").is_err());
    assert!(shapemodel::parse_edge_topology("{\"edge_topology\": {}}", "e.json").is_err());
    assert!(shapemodel::parse_model_contour("not json", "c.json").is_err());
}

#[test]
fn a_mapping_to_a_missing_vertex_is_rejected_with_file_and_field() {
    let src = crate::common::sfm_dir();
    let map = std::fs::read_to_string(src.join(shapemodel::MAPPING_FILE)).unwrap();
    let tmp = model_with(
        "vertex",
        shapemodel::MAPPING_FILE,
        map.replace("31 =   114", "31 =  9999").as_bytes(),
    );
    let err = SurreyModel::load_dir(&tmp).unwrap_err();
    assert!(matches!(err, ModelError::Invalid { .. }));
    let text = err.to_string();
    assert!(
        text.contains("ibug_to_sfm.txt") && text.contains("landmark_mappings.31"),
        "{text}"
    );
    std::fs::remove_file(tmp.join(shapemodel::SHAPE_FILE)).unwrap();
    let err = SurreyModel::load_dir(&tmp).unwrap_err();
    assert!(
        matches!(err, ModelError::Missing { .. }) && err.to_string().contains("non-commercial"),
        "{err}"
    );
    std::fs::remove_dir_all(&tmp).ok();
}

/// A well-formed blendshapes file for another model (its rows disagree with the shape
/// model's coordinates) is a typed error naming the file, not a panic while the model's rows
/// are packed (issue #19).
#[test]
fn blendshapes_of_another_size_are_refused_by_name() {
    // One blendshape of three rows: cereal's u64 count, then a u64-prefixed name and an Eigen
    // matrix (int32 rows, int32 cols, column-major floats).
    let mut blend = Vec::new();
    blend.extend_from_slice(&1u64.to_le_bytes());
    blend.extend_from_slice(&5u64.to_le_bytes());
    blend.extend_from_slice(b"smile");
    blend.extend_from_slice(&3i32.to_le_bytes());
    blend.extend_from_slice(&1i32.to_le_bytes());
    for v in [0.5f32, -0.5, 1.0] {
        blend.extend_from_slice(&v.to_le_bytes());
    }
    assert!(shapemodel::parse_blendshapes(&blend, "b.bin").is_ok());
    let tmp = model_with("rows", shapemodel::BLENDSHAPES_FILE, &blend);
    let loaded = std::panic::catch_unwind(|| SurreyModel::load_dir(&tmp));
    std::fs::remove_dir_all(&tmp).ok();
    let err = loaded.expect("no panic").unwrap_err();
    let text = err.to_string();
    assert!(
        matches!(err, ModelError::Invalid { .. })
            && text.contains(shapemodel::BLENDSHAPES_FILE)
            && text.contains("3 rows"),
        "{text}"
    );
}

/// A landmark mapping cut off half-way still parses as TOML; it is refused when the model is
/// put together, by name, instead of fitting 22 landmarks without a word (issue #19).
#[test]
fn a_cut_off_landmark_mapping_is_refused() {
    let src = crate::common::sfm_dir();
    let map = std::fs::read_to_string(src.join(shapemodel::MAPPING_FILE)).unwrap();
    let cut = map.find("40 =").expect("landmark 40 is mapped");
    let tmp = model_with("cut", shapemodel::MAPPING_FILE, &map.as_bytes()[..cut]);
    let loaded = SurreyModel::load_dir(&tmp);
    std::fs::remove_dir_all(&tmp).ok();
    let text = loaded.unwrap_err().to_string();
    assert!(
        text.contains("ibug_to_sfm.txt") && text.contains("cut off"),
        "{text}"
    );
}

/// The caricature: none leaves the face alone; the gain scales the difference from the mean
/// face; the detail grows the small components' millimetres towards the first's; the mean face
/// stays the mean face; nonsense leaves the coefficients alone.
#[test]
fn caricature_exaggerates_the_difference_from_the_mean_face() {
    use shapemodel::Caricature;
    let m = model();
    let shape: Vec<f32> = (0..63)
        .map(|k| if k % 2 == 0 { 0.8 } else { -0.5 })
        .collect();
    assert_eq!(m.shape.caricature(&shape, Caricature::NONE), shape);
    let doubled = m.shape.caricature(
        &shape,
        Caricature {
            gain: 2.0,
            detail: 0.0,
        },
    );
    assert!(
        doubled
            .iter()
            .zip(&shape)
            .all(|(d, s)| (d - 2.0 * s).abs() < 1e-6)
    );
    // Millimetres of component k: coefficient times sqrt(variance).
    let mm = |c: &[f32], k: usize| (c[k] * m.shape.eigenvalues[k].sqrt()).abs();
    let full = m.shape.caricature(
        &shape,
        Caricature {
            gain: 1.0,
            detail: 1.0,
        },
    );
    // Detail 1: every component as many millimetres per standard deviation as the first.
    let first = m.shape.eigenvalues[0].sqrt();
    for k in [0, 1, 10, 62] {
        assert!(
            (mm(&full, k) - shape[k].abs() * first).abs() < 1e-3 * first,
            "{k}"
        );
    }
    let half = m.shape.caricature(&shape, Caricature::PORTRAIT);
    for k in 1..63 {
        assert!(half[k].abs() > shape[k].abs() && half[k].abs() < full[k].abs() + 1e-6);
        assert_eq!(half[k].signum(), shape[k].signum());
    }
    assert!(
        m.shape
            .caricature(&[0.0; 63], Caricature::PORTRAIT)
            .iter()
            .all(|&v| v == 0.0)
    );
    assert!(m.shape.caricature(&[], Caricature::PORTRAIT).is_empty());
    for bad in [
        Caricature {
            gain: f32::NAN,
            detail: 0.5,
        },
        Caricature {
            gain: 1.0,
            detail: -0.1,
        },
        Caricature {
            gain: 9.0,
            detail: 0.5,
        },
    ] {
        assert!(!bad.is_valid());
        assert_eq!(m.shape.caricature(&shape, bad), shape);
    }
}
