//! Wavefront OBJ in and out: a face mesh read (model millimetres, the file's vertex order
//! kept) and written, and the whole cameo written (gem millimetres, with normals).

use std::fmt::Write as _;

use crate::scene::Mesh;

/// Why an OBJ face mesh could not be read.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ObjError {
    #[error("line {line}: {problem}")]
    Line { line: usize, problem: String },
}

/// Reads the positions and faces of Wavefront OBJ text (`v x y z`, `f a b c ...` with any of
/// the `a/t/n` forms and negative indices; polygons as fans; everything else ignored),
/// keeping the vertices in the file's order: a Surrey face keeps its vertex numbers, which
/// place it in the portrait (a general loader renumbers them by first use).
pub fn parse_obj(text: &str) -> Result<(Vec<f32>, Vec<[u32; 3]>), ObjError> {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let bad = |problem: String| ObjError::Line {
            line: k + 1,
            problem,
        };
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let xyz: Vec<f32> = words
                    .take(3)
                    .map(|w| {
                        w.parse::<f32>().map_err(|_| {
                            bad(format!(
                                "bad coordinate {}",
                                crate::landmarks::pts::excerpt(w)
                            ))
                        })
                    })
                    .collect::<Result<_, _>>()?;
                if xyz.len() != 3 {
                    return Err(bad("a vertex needs three coordinates".into()));
                }
                if xyz.iter().any(|v| !v.is_finite()) {
                    return Err(bad("a vertex coordinate is NaN or infinite".into()));
                }
                positions.extend_from_slice(&xyz);
            }
            Some("f") => {
                let count = positions.len() / 3;
                let ids: Vec<u32> = words
                    .map(|w| {
                        let first = w.split('/').next().unwrap_or("");
                        let i: i64 = first.parse().map_err(|_| {
                            bad(format!(
                                "bad vertex reference {}",
                                crate::landmarks::pts::excerpt(w)
                            ))
                        })?;
                        let index = if i < 0 { count as i64 + i } else { i - 1 };
                        if index < 0 || index >= count as i64 {
                            return Err(bad(format!("vertex {i} does not exist ({count} so far)")));
                        }
                        Ok(index as u32)
                    })
                    .collect::<Result<_, _>>()?;
                if ids.len() < 3 {
                    return Err(bad("a face needs three vertices".into()));
                }
                for j in 1..ids.len() - 1 {
                    triangles.push([ids[0], ids[j], ids[j + 1]]);
                }
            }
            _ => {}
        }
    }
    Ok((positions, triangles))
}

/// Wavefront OBJ text of a triangle mesh (positions `[x0, y0, z0, ...]`, 0-based triangles).
pub fn to_obj(positions: &[f32], triangles: &[[u32; 3]], comment: &str) -> String {
    let mut s = String::with_capacity(positions.len() * 12 + triangles.len() * 20);
    for line in comment.lines() {
        let _ = writeln!(s, "# {line}");
    }
    for v in positions.chunks_exact(3) {
        let _ = writeln!(s, "v {:.4} {:.4} {:.4}", v[0], v[1], v[2]);
    }
    for t in triangles {
        let _ = writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    s
}

/// OBJ text of a render mesh (positions, normals, triangles).
pub fn mesh_to_obj(mesh: &Mesh, comment: &str) -> String {
    let mut s = String::with_capacity(mesh.vertices.len() * 60 + mesh.indices.len() * 8);
    for line in comment.lines() {
        let _ = writeln!(s, "# {line}");
    }
    for v in &mesh.vertices {
        let _ = writeln!(
            s,
            "v {:.4} {:.4} {:.4}",
            v.position[0], v.position[1], v.position[2]
        );
    }
    for v in &mesh.vertices {
        let _ = writeln!(
            s,
            "vn {:.4} {:.4} {:.4}",
            v.normal[0], v.normal[1], v.normal[2]
        );
    }
    for t in mesh.indices.chunks_exact(3) {
        let _ = writeln!(
            s,
            "f {0}//{0} {1}//{1} {2}//{2}",
            t[0] + 1,
            t[1] + 1,
            t[2] + 1
        );
    }
    s
}
