//! The Surrey model's files read: the shape model and blendshapes in eos's binary (cereal)
//! format, the landmark mapping, the model contour and the edge topology as text. Each error
//! names the file and the field.

// The model's types (this file is a part of `shapemodel`, split out).
use super::{
    BTreeMap, Blendshapes, CerealError, DMatrix, DVector, EdgeTopology, LandmarkMapping,
    ModelContour, ModelError, ShapeModel, cereal,
};

/// Maps a byte-level error to one naming the file and the field being read.
fn binary_error<'a>(file: &'a str, field: &'static str) -> impl Fn(CerealError) -> ModelError + 'a {
    move |source| ModelError::Binary {
        file: file.to_string(),
        field,
        source,
    }
}

/// Parses eos's `MorphableModel` (cereal portable binary, class version 1): shape PCA model,
/// an (empty) colour model and texture coordinates.
pub fn parse_shape_model(bytes: &[u8], file: &str) -> Result<ShapeModel, ModelError> {
    let mut r = cereal::Reader::new(bytes);
    let bin = |field: &'static str| binary_error(file, field);
    let version = r.u32().map_err(bin("class version"))?;
    if version != 1 {
        return Err(ModelError::invalid(
            file,
            "class version",
            format!("{version} (expected 1: an eos MorphableModel without expressions)"),
        ));
    }
    let (mean_rows, mean_cols, mean) = r.f32_matrix().map_err(bin("shape mean"))?;
    if mean_cols != 1 || mean_rows % 3 != 0 || mean_rows == 0 {
        return Err(ModelError::invalid(
            file,
            "shape mean",
            format!("{mean_rows} x {mean_cols} (expected 3N x 1)"),
        ));
    }
    let (b_rows, b_cols, basis) = r.f32_matrix().map_err(bin("shape basis"))?;
    if b_rows != mean_rows || b_cols == 0 {
        return Err(ModelError::invalid(
            file,
            "shape basis",
            format!("{b_rows} x {b_cols} (expected {mean_rows} x K)"),
        ));
    }
    let (e_rows, e_cols, eig) = r.f32_matrix().map_err(bin("shape eigenvalues"))?;
    if e_rows != b_cols || e_cols != 1 {
        return Err(ModelError::invalid(
            file,
            "shape eigenvalues",
            format!("{e_rows} x {e_cols} (expected {b_cols} x 1)"),
        ));
    }
    if let Some(bad) = eig.iter().position(|e| !(e.is_finite() && *e > 0.0)) {
        return Err(ModelError::invalid(
            file,
            format!("shape eigenvalues[{bad}]"),
            format!("{} is not a positive finite variance", eig[bad]),
        ));
    }
    if mean.iter().chain(basis.iter()).any(|v| !v.is_finite()) {
        return Err(ModelError::invalid(
            file,
            "shape mean/basis",
            "contains NaN or infinity",
        ));
    }
    let n_vertices = mean_rows / 3;
    let triangles = r.triangles().map_err(bin("shape triangles"))?;
    if let Some((i, t)) = triangles
        .iter()
        .enumerate()
        .find(|(_, t)| t.iter().any(|&v| v >= n_vertices))
    {
        return Err(ModelError::invalid(
            file,
            format!("shape triangles[{i}]"),
            format!("{t:?} refers to a vertex beyond {n_vertices}"),
        ));
    }
    // The colour PCA model: empty in the shape-only SFM, but parsed to reach the texcoords.
    r.f32_matrix().map_err(bin("colour mean"))?;
    r.f32_matrix().map_err(bin("colour basis"))?;
    r.f32_matrix().map_err(bin("colour eigenvalues"))?;
    r.triangles().map_err(bin("colour triangles"))?;
    let texcoords = r.texcoords().map_err(bin("texture coordinates"))?;
    if !texcoords.is_empty() && texcoords.len() != n_vertices as usize {
        return Err(ModelError::invalid(
            file,
            "texture coordinates",
            format!("{} pairs for {n_vertices} vertices", texcoords.len()),
        ));
    }
    if r.remaining() != 0 {
        return Err(ModelError::invalid(
            file,
            "end",
            format!("{} unexpected bytes after the model", r.remaining()),
        ));
    }
    let rows = mean_rows as usize;
    let cols = b_cols as usize;
    let orthonormal_basis = DMatrix::from_column_slice(rows, cols, &basis);
    let eigenvalues = DVector::from_vec(eig);
    let mut rescaled_basis = orthonormal_basis.clone();
    for (k, mut col) in rescaled_basis.column_iter_mut().enumerate() {
        col *= eigenvalues[k].sqrt();
    }
    Ok(ShapeModel {
        mean: DVector::from_vec(mean),
        orthonormal_basis,
        eigenvalues,
        rescaled_basis,
        triangles,
        texcoords,
    })
}

/// Parses eos's expression blendshapes: a vector of (name, 3N x 1 offset).
pub fn parse_blendshapes(bytes: &[u8], file: &str) -> Result<Blendshapes, ModelError> {
    let mut r = cereal::Reader::new(bytes);
    let bin = |field: &'static str| binary_error(file, field);
    // Each blendshape needs at least a name length and two dims: bounds the count.
    let count = r.len_prefix(16).map_err(bin("count"))?;
    if count == 0 {
        return Err(ModelError::invalid(file, "count", "no blendshapes"));
    }
    let mut names = Vec::with_capacity(count);
    let mut columns: Vec<Vec<f32>> = Vec::with_capacity(count);
    for i in 0..count {
        let name = r.string().map_err(bin("name"))?;
        let (rows, cols, data) = r.f32_matrix().map_err(bin("offsets"))?;
        if cols != 1 || rows == 0 || columns.first().is_some_and(|c| c.len() != data.len()) {
            return Err(ModelError::invalid(
                file,
                format!("blendshape[{i}] ({name})"),
                format!("{rows} x {cols} does not match the others"),
            ));
        }
        if data.iter().any(|v| !v.is_finite()) {
            return Err(ModelError::invalid(
                file,
                format!("blendshape[{i}] ({name})"),
                "contains NaN or infinity",
            ));
        }
        names.push(name);
        columns.push(data);
    }
    if r.remaining() != 0 {
        return Err(ModelError::invalid(
            file,
            "end",
            format!("{} unexpected bytes after the blendshapes", r.remaining()),
        ));
    }
    let rows = columns[0].len();
    let flat: Vec<f32> = columns.concat();
    Ok(Blendshapes {
        names,
        offsets: DMatrix::from_column_slice(rows, count, &flat),
    })
}

/// Parses `ibug_to_sfm.txt` (TOML): `[landmark_mappings]` and `[contour_landmarks]`.
pub fn parse_mapping(text: &str, file: &str) -> Result<LandmarkMapping, ModelError> {
    let doc: toml::Table = text
        .parse()
        .map_err(|e: toml::de::Error| ModelError::invalid(file, "toml", e.message().to_string()))?;
    let table = doc
        .get("landmark_mappings")
        .and_then(|v| v.as_table())
        .ok_or_else(|| ModelError::invalid(file, "landmark_mappings", "missing table"))?;
    let mut to_vertex = BTreeMap::new();
    for (key, value) in table {
        let lm: u32 = key
            .trim()
            .parse()
            .ok()
            .filter(|n| (1..=68).contains(n))
            .ok_or_else(|| {
                ModelError::invalid(
                    file,
                    format!("landmark_mappings.{key}"),
                    "not an iBUG landmark number 1..68",
                )
            })?;
        let v = value
            .as_integer()
            .and_then(|v| u32::try_from(v).ok())
            .ok_or_else(|| {
                ModelError::invalid(file, format!("landmark_mappings.{key}"), "not a vertex id")
            })?;
        to_vertex.insert(lm, v);
    }
    if to_vertex.is_empty() {
        return Err(ModelError::invalid(file, "landmark_mappings", "empty"));
    }
    let side = |name: &str| -> Result<Vec<u32>, ModelError> {
        let Some(list) = doc.get("contour_landmarks").and_then(|t| t.get(name)) else {
            return Ok(Vec::new());
        };
        let arr = list.as_array().ok_or_else(|| {
            ModelError::invalid(file, format!("contour_landmarks.{name}"), "not a list")
        })?;
        arr.iter()
            .map(|v| {
                v.as_integer()
                    .and_then(|v| u32::try_from(v).ok())
                    .filter(|n| (1..=68).contains(n))
                    .ok_or_else(|| {
                        ModelError::invalid(
                            file,
                            format!("contour_landmarks.{name}"),
                            format!("{v} is not an iBUG landmark number"),
                        )
                    })
            })
            .collect()
    };
    Ok(LandmarkMapping {
        to_vertex,
        contour_right: side("right")?,
        contour_left: side("left")?,
    })
}

/// Parses `sfm_model_contours.json` (`model_contour.{right,left}_contour`, 0-based vertex ids).
pub fn parse_model_contour(text: &str, file: &str) -> Result<ModelContour, ModelError> {
    let v: serde_json::Value =
        serde_json::from_str(text).map_err(|e| ModelError::invalid(file, "json", e.to_string()))?;
    let list = |name: &str| -> Result<Vec<u32>, ModelError> {
        v.get("model_contour")
            .and_then(|m| m.get(name))
            .and_then(|l| l.as_array())
            .ok_or_else(|| {
                ModelError::invalid(file, format!("model_contour.{name}"), "missing list")
            })?
            .iter()
            .map(|x| {
                x.as_u64()
                    .and_then(|x| u32::try_from(x).ok())
                    .ok_or_else(|| {
                        ModelError::invalid(
                            file,
                            format!("model_contour.{name}"),
                            format!("{x} is not a vertex id"),
                        )
                    })
            })
            .collect()
    };
    Ok(ModelContour {
        right: list("right_contour")?,
        left: list("left_contour")?,
    })
}

/// Parses `sfm_3448_edge_topology.json` (1-based ids, 0 = boundary) into 0-based options.
pub fn parse_edge_topology(text: &str, file: &str) -> Result<EdgeTopology, ModelError> {
    let v: serde_json::Value =
        serde_json::from_str(text).map_err(|e| ModelError::invalid(file, "json", e.to_string()))?;
    let pairs = |name: &str| -> Result<Vec<[Option<u32>; 2]>, ModelError> {
        let arr = v
            .get("edge_topology")
            .and_then(|m| m.get(name))
            .and_then(|l| l.as_array())
            .ok_or_else(|| {
                ModelError::invalid(file, format!("edge_topology.{name}"), "missing list")
            })?;
        arr.iter()
            .enumerate()
            .map(|(i, p)| {
                let get = |k: &str| {
                    p.get(k)
                        .and_then(|x| x.as_u64())
                        .and_then(|x| u32::try_from(x).ok())
                        .map(|x| x.checked_sub(1))
                        .ok_or_else(|| {
                            ModelError::invalid(
                                file,
                                format!("edge_topology.{name}[{i}].{k}"),
                                "not an id",
                            )
                        })
                };
                Ok([get("value0")?, get("value1")?])
            })
            .collect()
    };
    let adjacent_faces = pairs("adjacent_faces")?;
    let adjacent_vertices = pairs("adjacent_vertices")?;
    if adjacent_faces.len() != adjacent_vertices.len() {
        return Err(ModelError::invalid(
            file,
            "edge_topology",
            format!(
                "{} face pairs but {} vertex pairs",
                adjacent_faces.len(),
                adjacent_vertices.len()
            ),
        ));
    }
    Ok(EdgeTopology {
        adjacent_faces,
        adjacent_vertices,
    })
}
