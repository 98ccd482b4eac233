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

/// Builds cameos for one set of [`CameoParams`]: everything that does not depend on the face
/// (the generated head and its hair on the relief grid, the bezel and the back) is computed once
/// in [`CameoBuilder::new`], so rebuilding after each new fit only does the face's part.
#[derive(Clone, Debug)]
pub struct CameoBuilder {
    params: CameoParams,
    cols: usize,
    rows: usize,
    /// Gem position of grid node (0, 0), gem mm.
    origin: [f32; 2],
    /// Per node: head height (model mm) and hair weight.
    head: Vec<(f32, f32)>,
    /// Per node: height of the carved hair strands (model mm, before the hair weight).
    strands: Vec<f32>,
    /// Per node: 1 where the relief may rise, falling to 0 below the bust's truncation line and
    /// in a margin inside the bezel.
    allowed: Vec<f32>,
    /// Bezel and back.
    base: Mesh,
}

impl CameoBuilder {
    pub fn new(p: &CameoParams) -> Result<Self, GemError> {
        check_params(p)?;
        let cols = (2.0 * p.half_width / p.cell).round() as usize + 1;
        let rows = (2.0 * p.half_height / p.cell).round() as usize + 1;
        let origin = [-p.half_width, -p.half_height];
        let k = p.portrait_scale;
        let model_origin = [
            origin[0] / k + p.portrait_centre[0],
            origin[1] / k + p.portrait_centre[1],
        ];
        let head = relief::head_layer(&p.head, model_origin, p.cell / k, cols, rows);
        // Carved hair: wavy strands sweeping back around the ear.
        let [eu, ev] = p.head.ear_centre;
        let strands = (0..cols * rows)
            .map(|i| {
                let (col, row) = (i % cols, i / cols);
                let u = (origin[0] + col as f32 * p.cell) / k + p.portrait_centre[0];
                let v = (origin[1] + row as f32 * p.cell) / k + p.portrait_centre[1];
                let (du, dv) = (u - eu, v - ev - 25.0);
                let r = (du * du + dv * dv).sqrt();
                let a = dv.atan2(du);
                3.0 * (0.5 + 0.5 * (r / 4.0 + 1.8 * (a * 4.0).sin()).sin())
            })
            .collect();
        let allowed = (0..cols * rows)
            .map(|i| {
                let x = origin[0] + (i % cols) as f32 * p.cell;
                let y = origin[1] + (i / cols) as f32 * p.cell;
                let r = ((x / p.half_width).powi(2) + (y / p.half_height).powi(2)).sqrt();
                smoothstep(p.truncation_y - 2.5, p.truncation_y, y)
                    * (1.0 - smoothstep(0.86, 0.94, r))
            })
            .collect();
        let mut base = Mesh::default();
        add_bezel_and_back(&mut base, p);
        Ok(Self {
            params: p.clone(),
            cols,
            rows,
            origin,
            head,
            strands,
            allowed,
            base,
        })
    }

    pub fn params(&self) -> &CameoParams {
        &self.params
    }

    /// The relief height field (gem mm) for a face mesh in model mm.
    pub fn relief(&self, positions: &[f32], triangles: &[[u32; 3]]) -> Result<Relief, GemError> {
        if positions.len() < 9 || triangles.is_empty() {
            return Err(GemError::EmptyFace);
        }
        if positions.iter().any(|v| !v.is_finite()) {
            return Err(GemError::NonFinite);
        }
        let (p, cols, rows, origin) = (&self.params, self.cols, self.rows, self.origin);
        let k = p.portrait_scale;
        let model_origin = [
            origin[0] / k + p.portrait_centre[0],
            origin[1] / k + p.portrait_centre[1],
        ];
        let field: HeightField = relief::portrait(
            positions,
            triangles,
            &self.head,
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
        for (i, gem_h) in height.iter_mut().enumerate() {
            // Lift the portrait off the ground, as carvers do, so its outline is a steep edge
            // instead of fading into the ground along the profile's centre line.
            let f = field.height[i];
            let mut h = f + PORTRAIT_LIFT_MM * smoothstep(0.0, LIFT_RAMP_MM, f);
            let w = field.hair[i];
            if w > 0.0 {
                h += w * self.strands[i];
            }
            let t = (h / reference).max(0.0);
            *gem_h = p.relief_depth * (1.0 - (-rolloff * t).exp()) * self.allowed[i];
        }
        let hair = field.hair;
        Ok(Relief {
            height,
            hair,
            cols,
            rows,
            origin,
            cell: p.cell,
        })
    }

    /// The whole cameo mesh for a face mesh in model mm (`[x0, y0, z0, ...]`).
    pub fn build(&self, positions: &[f32], triangles: &[[u32; 3]]) -> Result<Mesh, GemError> {
        let relief = self.relief(positions, triangles)?;
        let mut mesh = Mesh::default();
        add_relief_surface(&mut mesh, &relief, &self.params);
        let first = mesh.vertices.len() as u32;
        mesh.vertices.extend_from_slice(&self.base.vertices);
        mesh.indices
            .extend(self.base.indices.iter().map(|&i| i + first));
        Ok(mesh)
    }
}

/// Builds the relief height field (gem mm) from a face mesh in model mm (one-off: see
/// [`CameoBuilder`] to rebuild for many faces).
pub fn build_relief(
    positions: &[f32],
    triangles: &[[u32; 3]],
    p: &CameoParams,
) -> Result<Relief, GemError> {
    CameoBuilder::new(p)?.relief(positions, triangles)
}

/// Builds the whole cameo mesh from a face mesh in model mm (`[x0, y0, z0, ...]`; one-off: see
/// [`CameoBuilder`]).
pub fn build_cameo(
    positions: &[f32],
    triangles: &[[u32; 3]],
    p: &CameoParams,
) -> Result<Mesh, GemError> {
    CameoBuilder::new(p)?.build(positions, triangles)
}

/// The stone's top: one vertex per grid node inside the oval, two triangles per cell whose
/// four corners are inside. The bezel's inner foot covers the stepped outline.
fn add_relief_surface(mesh: &mut Mesh, relief: &Relief, p: &CameoParams) {
    let (cols, rows, cell) = (relief.cols, relief.rows, relief.cell);
    let mut index = vec![u32::MAX; cols * rows];
    // About pi/4 of the grid lies inside the oval.
    mesh.vertices.reserve(cols * rows * 4 / 5);
    mesh.indices.reserve(cols * rows * 6 * 4 / 5);
    let (ia, ib) = (1.0 / p.half_width, 1.0 / p.half_height);
    for row in 0..rows {
        let y = relief.origin[1] + row as f32 * cell;
        let (up, down) = (row.saturating_sub(1), (row + 1).min(rows - 1));
        let inv_dy = 1.0 / (cell * (down - up) as f32);
        for col in 0..cols {
            let x = relief.origin[0] + col as f32 * cell;
            let r2 = (x * ia).powi(2) + (y * ib).powi(2);
            if r2 > 1.0 {
                continue;
            }
            let i = row * cols + col;
            let h = relief.height[i];
            // Central differences (one-sided at the grid's edge).
            let (left, right) = (col.saturating_sub(1), (col + 1).min(cols - 1));
            let dzdx = (relief.height[row * cols + right] - relief.height[row * cols + left])
                / (cell * (right - left) as f32);
            let dzdy = (relief.height[down * cols + col] - relief.height[up * cols + col]) * inv_dy;
            let inv_len = 1.0 / (dzdx * dzdx + dzdy * dzdy + 1.0).sqrt();
            let region = if h < GROUND_EPS {
                Region::Ground
            } else if relief.hair[i] > 0.5 {
                Region::Hair
            } else {
                Region::Relief
            };
            index[i] = mesh.vertices.len() as u32;
            mesh.vertices.push(Vertex {
                position: [x, y, h],
                normal: [-dzdx * inv_len, -dzdy * inv_len, inv_len],
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
