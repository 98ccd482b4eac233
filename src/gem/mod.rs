//! The cameo: a portrait relief on an oval stone, a gold bezel around it and a gold back.
//!
//! Units: gem millimetres. The cameo lies in the XY plane facing +Z, centred on the origin;
//! the ground (the stone's top where nothing is carved) is at z = 0 and the relief rises above
//! it. The portrait is a profile facing left, built by [`relief`] from the fitted face (model
//! millimetres) and a generated head, then scaled into the oval and compressed in depth as in
//! a carved cameo. Everything here is pure computation: no files, no GPU.

pub mod relief;

use std::fmt::Write as _;

use crate::render::{Mesh, Region, Vertex};
use relief::{HeadShape, HeightField};

/// Why a cameo could not be built.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum GemError {
    #[error("the face mesh is empty or has no triangles")]
    EmptyFace,
    #[error("the face mesh has non-finite coordinates")]
    NonFinite,
    #[error("invalid cameo parameter: {0}")]
    BadParams(String),
}

/// Shape of the cameo.
#[derive(Clone, Debug)]
pub struct CameoParams {
    /// Semi-axes of the stone oval, gem mm.
    pub half_width: f32,
    pub half_height: f32,
    /// Grid spacing of the relief, gem mm.
    pub cell: f32,
    /// Highest point of the relief above the ground, gem mm.
    pub relief_depth: f32,
    /// Gem mm per model mm in the plane.
    pub portrait_scale: f32,
    /// Model point (u, v) of the portrait plane placed at the oval's centre.
    pub portrait_centre: [f32; 2],
    /// Gem y below which the bust is cut off (the truncation line).
    pub truncation_y: f32,
    pub head: HeadShape,
}

impl Default for CameoParams {
    fn default() -> Self {
        CameoParams {
            half_width: 22.0,
            half_height: 28.0,
            cell: 0.2,
            relief_depth: 5.0,
            portrait_scale: 0.155,
            portrait_centre: [97.0, 16.0],
            truncation_y: -20.0,
            head: HeadShape::default(),
        }
    }
}

/// Bezel cross-section: (offset along the oval's outward normal, height), gem mm, from the
/// inner foot over the crown to the outer foot.
const BEZEL_PROFILE: [[f32; 2]; 7] = [
    [-0.7, -0.3],
    [-0.7, 0.9],
    [-0.3, 1.6],
    [0.4, 1.9],
    [1.2, 1.55],
    [1.6, 0.6],
    [1.6, -3.0],
];
/// Segments around the oval for the bezel and the back.
const RING_SEGMENTS: usize = 360;
/// Depth of the gold back below the ground, gem mm.
const BACK_Z: f32 = -3.0;
/// How far the portrait's outline stands above the ground, model mm, and over what height
/// of the underlying surface the edge rises.
const PORTRAIT_LIFT_MM: f32 = 8.0;
const LIFT_RAMP_MM: f32 = 2.5;
/// Relief below this height (gem mm) counts as ground.
const GROUND_EPS: f32 = 0.03;

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The finished relief in gem units, kept for tests and for inspection.
#[derive(Clone, Debug)]
pub struct Relief {
    /// Height above the ground per grid node, gem mm (row-major, `cols` x `rows`).
    pub height: Vec<f32>,
    pub hair: Vec<f32>,
    pub cols: usize,
    pub rows: usize,
    /// Gem position of node (0, 0) and the spacing, gem mm.
    pub origin: [f32; 2],
    pub cell: f32,
}

impl Relief {
    /// Height at a grid node.
    pub fn at(&self, col: usize, row: usize) -> f32 {
        self.height[row * self.cols + col]
    }
}

fn check_params(p: &CameoParams) -> Result<(), GemError> {
    let pos = [
        p.half_width,
        p.half_height,
        p.cell,
        p.relief_depth,
        p.portrait_scale,
    ];
    if pos.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
        return Err(GemError::BadParams(
            "sizes and scales must be positive".into(),
        ));
    }
    let nodes = (2.0 * p.half_width / p.cell + 1.0) * (2.0 * p.half_height / p.cell + 1.0);
    if nodes > 4.0e6 {
        return Err(GemError::BadParams(format!(
            "{nodes:.0} grid nodes: the cell is too small"
        )));
    }
    Ok(())
}

/// Builds the relief height field (gem mm) from a face mesh in model mm.
pub fn build_relief(
    positions: &[f32],
    triangles: &[[u32; 3]],
    p: &CameoParams,
) -> Result<Relief, GemError> {
    check_params(p)?;
    if positions.len() < 9 || triangles.is_empty() {
        return Err(GemError::EmptyFace);
    }
    if positions.iter().any(|v| !v.is_finite()) {
        return Err(GemError::NonFinite);
    }
    let cols = (2.0 * p.half_width / p.cell).round() as usize + 1;
    let rows = (2.0 * p.half_height / p.cell).round() as usize + 1;
    let origin = [-p.half_width, -p.half_height];
    let k = p.portrait_scale;
    let model_origin = [
        origin[0] / k + p.portrait_centre[0],
        origin[1] / k + p.portrait_centre[1],
    ];
    let field: HeightField = relief::portrait(
        positions,
        triangles,
        &p.head,
        model_origin,
        p.cell / k,
        cols,
        rows,
        6.0,
        15.0,
    );

    // Depth compression: an exponential roll-off whose asymptote is `relief_depth`, so the
    // profile's outline keeps its detail, the cheek flattens, and nothing exceeds the depth.
    // At the head's half-breadth the relief reaches 80 % of the depth.
    let reference = p.head.cranium_axes[2].max(1.0);
    let rolloff = 1.6f32;
    let mut height = vec![0f32; cols * rows];
    let mut hair = vec![0f32; cols * rows];
    for row in 0..rows {
        for col in 0..cols {
            let i = row * cols + col;
            let (x, y) = (
                origin[0] + col as f32 * p.cell,
                origin[1] + row as f32 * p.cell,
            );
            let (u, v) = (x / k + p.portrait_centre[0], y / k + p.portrait_centre[1]);
            let w = field.hair[i];
            // Lift the portrait off the ground, as carvers do, so its outline is a steep edge
            // instead of fading into the ground along the profile's centre line.
            let mut h =
                field.height[i] + PORTRAIT_LIFT_MM * smoothstep(0.0, LIFT_RAMP_MM, field.height[i]);
            // Carved hair: wavy strands sweeping back around the ear.
            if w > 0.0 {
                let [eu, ev] = p.head.ear_centre;
                let (du, dv) = (u - eu, v - ev - 25.0);
                let r = (du * du + dv * dv).sqrt();
                let a = dv.atan2(du);
                let strands = 0.5 + 0.5 * (r / 4.0 + 1.8 * (a * 4.0).sin()).sin();
                h += w * 3.0 * strands;
            }
            let t = (h / reference).max(0.0);
            let mut gem_h = p.relief_depth * (1.0 - (-rolloff * t).exp());
            // The bust's truncation line and a margin inside the bezel.
            gem_h *= smoothstep(p.truncation_y - 2.5, p.truncation_y, y);
            let r = ((x / p.half_width).powi(2) + (y / p.half_height).powi(2)).sqrt();
            gem_h *= 1.0 - smoothstep(0.86, 0.94, r);
            height[i] = gem_h;
            hair[i] = w;
        }
    }
    Ok(Relief {
        height,
        hair,
        cols,
        rows,
        origin,
        cell: p.cell,
    })
}

/// Builds the whole cameo mesh from a face mesh in model mm (`[x0, y0, z0, ...]`).
pub fn build_cameo(
    positions: &[f32],
    triangles: &[[u32; 3]],
    p: &CameoParams,
) -> Result<Mesh, GemError> {
    let relief = build_relief(positions, triangles, p)?;
    let mut mesh = Mesh::default();
    add_relief_surface(&mut mesh, &relief, p);
    add_bezel_and_back(&mut mesh, p);
    Ok(mesh)
}

/// The stone's top: one vertex per grid node inside the oval, two triangles per cell whose
/// four corners are inside. The bezel's inner foot covers the stepped outline.
fn add_relief_surface(mesh: &mut Mesh, relief: &Relief, p: &CameoParams) {
    let (cols, rows, cell) = (relief.cols, relief.rows, relief.cell);
    let mut index = vec![u32::MAX; cols * rows];
    for row in 0..rows {
        for col in 0..cols {
            let (x, y) = (
                relief.origin[0] + col as f32 * cell,
                relief.origin[1] + row as f32 * cell,
            );
            let r2 = (x / p.half_width).powi(2) + (y / p.half_height).powi(2);
            if r2 > 1.0 {
                continue;
            }
            let h = relief.at(col, row);
            let hx = |c: usize| relief.at(c.min(cols - 1), row);
            let hy = |r: usize| relief.at(col, r.min(rows - 1));
            let dzdx = (hx(col + 1) - hx(col.saturating_sub(1)))
                / (cell * ((col + 1).min(cols - 1) - col.saturating_sub(1)) as f32);
            let dzdy = (hy(row + 1) - hy(row.saturating_sub(1)))
                / (cell * ((row + 1).min(rows - 1) - row.saturating_sub(1)) as f32);
            let n = [-dzdx, -dzdy, 1.0];
            let len = (n[0] * n[0] + n[1] * n[1] + 1.0).sqrt();
            let region = if h < GROUND_EPS {
                Region::Ground
            } else if relief.hair[row * cols + col] > 0.5 {
                Region::Hair
            } else {
                Region::Relief
            };
            index[row * cols + col] = mesh.vertices.len() as u32;
            mesh.vertices.push(Vertex {
                position: [x, y, h],
                normal: [n[0] / len, n[1] / len, n[2] / len],
                relief: h,
                region: region as u32,
            });
        }
    }
    for row in 0..rows - 1 {
        for col in 0..cols - 1 {
            let a = index[row * cols + col];
            let b = index[row * cols + col + 1];
            let c = index[(row + 1) * cols + col + 1];
            let d = index[(row + 1) * cols + col];
            if [a, b, c, d].contains(&u32::MAX) {
                continue;
            }
            mesh.indices.extend_from_slice(&[a, b, c, a, c, d]);
        }
    }
}

/// The gold bezel swept around the oval (flat across each profile segment, smooth along the
/// oval) and the gold back.
fn add_bezel_and_back(mesh: &mut Mesh, p: &CameoParams) {
    let (a, b) = (p.half_width, p.half_height);
    let frame = |i: usize| {
        let t = i as f32 / RING_SEGMENTS as f32 * std::f32::consts::TAU;
        let (s, c) = t.sin_cos();
        let n = [b * c, a * s];
        let l = (n[0] * n[0] + n[1] * n[1]).sqrt();
        ([a * c, b * s], [n[0] / l, n[1] / l])
    };
    let gold = |position: [f32; 3], normal: [f32; 3]| Vertex {
        position,
        normal,
        relief: 0.0,
        region: Region::Gold as u32,
    };
    for seg in BEZEL_PROFILE.windows(2) {
        let ([d0, z0], [d1, z1]) = (seg[0], seg[1]);
        let (td, tz) = (d1 - d0, z1 - z0);
        let l = (td * td + tz * tz).sqrt();
        let (nd, nz) = (-tz / l, td / l);
        let base = mesh.vertices.len() as u32;
        for i in 0..=RING_SEGMENTS {
            let (e, n) = frame(i % RING_SEGMENTS);
            let normal = [n[0] * nd, n[1] * nd, nz];
            for (d, z) in [(d0, z0), (d1, z1)] {
                mesh.vertices
                    .push(gold([e[0] + n[0] * d, e[1] + n[1] * d, z], normal));
            }
        }
        for i in 0..RING_SEGMENTS as u32 {
            let (p0, p1) = (base + 2 * i, base + 2 * i + 1);
            let (q0, q1) = (p0 + 2, p1 + 2);
            // Counter-clockwise seen from the side the normal points to.
            mesh.indices.extend_from_slice(&[p0, q0, q1, p0, q1, p1]);
        }
    }
    let outer = BEZEL_PROFILE[BEZEL_PROFILE.len() - 1][0];
    let centre = mesh.vertices.len() as u32;
    mesh.vertices
        .push(gold([0.0, 0.0, BACK_Z], [0.0, 0.0, -1.0]));
    for i in 0..RING_SEGMENTS {
        let (e, n) = frame(i);
        mesh.vertices.push(gold(
            [e[0] + n[0] * outer, e[1] + n[1] * outer, BACK_Z],
            [0.0, 0.0, -1.0],
        ));
    }
    for i in 0..RING_SEGMENTS as u32 {
        let next = (i + 1) % RING_SEGMENTS as u32;
        mesh.indices
            .extend_from_slice(&[centre, centre + 1 + next, centre + 1 + i]);
    }
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
