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
    /// Highest point of the relief above the ground, gem mm (the compression's asymptote).
    pub relief_depth: f32,
    /// Depth compression: gem height = `relief_depth` (1 - e^(-rolloff t)), t = model height
    /// over the cranium's depth. Large: strong flattening (a profile keeps its outline and
    /// loses the cheek's bulk); small: nearly linear (a frontal face keeps its features).
    pub rolloff: f32,
    /// Gem mm per model mm in the plane.
    pub portrait_scale: f32,
    /// Model point (u, v) of the portrait plane placed at the oval's centre.
    pub portrait_centre: [f32; 2],
    /// Gem y below which the bust is cut off (the truncation line).
    pub truncation_y: f32,
    pub head: HeadShape,
}

impl CameoParams {
    /// A frontal portrait (the face looks out of the stone) on the default stone.
    pub fn frontal() -> Self {
        CameoParams {
            portrait_centre: [0.0, 12.0],
            head: HeadShape::frontal(),
            // Nearly linear, reaching 5 mm at the face's front (t = 1).
            rolloff: 0.6,
            relief_depth: 5.0 / (1.0 - (-0.6f32).exp()),
            ..CameoParams::default()
        }
    }
}

impl Default for CameoParams {
    /// A profile portrait facing left, the classic cameo.
    fn default() -> Self {
        CameoParams {
            half_width: 22.0,
            half_height: 28.0,
            cell: 0.2,
            relief_depth: 5.0,
            rolloff: 1.6,
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
/// How far the face's edge height fades out beyond its footprint, and how far inside it the
/// face blends into the head, model mm.
const FADE_MM: f32 = 6.0;
const BLEND_MM: f32 = 15.0;
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
        p.rolloff,
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
    /// Per node: inside the oval (the stone's top is made of cells with four such corners).
    inside: Vec<bool>,
    /// The portrait field of the head alone, and its gem heights: a face changes only the
    /// window around it.
    base_field: HeightField,
    base_height: Vec<f32>,
    /// The stone's top planned for the head alone: a face replans only its window.
    base_plan: SurfacePlan,
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
        let (ia, ib) = (1.0 / p.half_width, 1.0 / p.half_height);
        let inside = (0..cols * rows)
            .map(|i| {
                let x = origin[0] + (i % cols) as f32 * p.cell;
                let y = origin[1] + (i / cols) as f32 * p.cell;
                (x * ia).powi(2) + (y * ib).powi(2) <= 1.0
            })
            .collect();
        let base_field = relief::head_only(&head, model_origin, p.cell / k, cols, rows);
        let mut builder = Self {
            params: p.clone(),
            cols,
            rows,
            origin,
            head,
            strands,
            allowed,
            base,
            inside,
            base_field,
            base_height: Vec::new(),
            base_plan: SurfacePlan::default(),
        };
        builder.base_height = (0..cols * rows)
            .map(|i| builder.gem_height(&builder.base_field, i))
            .collect();
        let base = Relief {
            height: builder.base_height.clone(),
            hair: builder.base_field.hair.clone(),
            cols,
            rows,
            origin,
            cell: p.cell,
        };
        builder.base_plan = plan_surface(&base, &builder.inside, None);
        Ok(builder)
    }

    pub fn params(&self) -> &CameoParams {
        &self.params
    }

    /// The relief height field (gem mm) for a face mesh in model mm.
    pub fn relief(&self, positions: &[f32], triangles: &[[u32; 3]]) -> Result<Relief, GemError> {
        self.relief_in(positions, triangles)
            .map(|(relief, _)| relief)
    }

    /// [`Self::relief`] and the window outside which it is the head alone's.
    fn relief_in(
        &self,
        positions: &[f32],
        triangles: &[[u32; 3]],
    ) -> Result<(Relief, Option<relief::Window>), GemError> {
        if positions.len() < 9 || triangles.is_empty() {
            return Err(GemError::EmptyFace);
        }
        if positions.iter().any(|v| !v.is_finite()) {
            return Err(GemError::NonFinite);
        }
        let (p, cols, rows, origin) = (&self.params, self.cols, self.rows, self.origin);
        let (field, window) = relief::portrait_over(
            positions,
            triangles,
            p.head.view,
            &self.head,
            &self.base_field,
            FADE_MM,
            BLEND_MM,
        );
        let mut height = self.base_height.clone();
        if let Some(w) = window {
            for y in w.y0..=w.y1 {
                for x in w.x0..=w.x1 {
                    let i = y * cols + x;
                    height[i] = self.gem_height(&field, i);
                }
            }
        }
        let hair = field.hair;
        let relief = Relief {
            height,
            hair,
            cols,
            rows,
            origin,
            cell: p.cell,
        };
        Ok((relief, window))
    }

    /// Gem height (mm) of node `i` of a portrait field: the lift off the ground, the carved
    /// hair strands and the depth compression, an exponential roll-off whose asymptote is
    /// `relief_depth` (the profile's outline keeps its detail, the cheek flattens, nothing
    /// exceeds the depth; at the head's half-breadth the relief reaches 80 % of the depth).
    fn gem_height(&self, field: &HeightField, i: usize) -> f32 {
        let p = &self.params;
        let reference = p.head.cranium_axes[2].max(1.0);
        // Lift the portrait off the ground, as carvers do, so its outline is a steep edge
        // instead of fading into the ground along the profile's centre line.
        let f = field.height[i];
        let mut h = f + PORTRAIT_LIFT_MM * smoothstep(0.0, LIFT_RAMP_MM, f);
        let w = field.hair[i];
        if w > 0.0 {
            h += w * self.strands[i];
        }
        let t = (h / reference).max(0.0);
        p.relief_depth * (1.0 - (-p.rolloff * t).exp()) * self.allowed[i]
    }

    /// The whole cameo mesh for a face mesh in model mm (`[x0, y0, z0, ...]`).
    pub fn build(&self, positions: &[f32], triangles: &[[u32; 3]]) -> Result<Mesh, GemError> {
        let (relief, window) = self.relief_in(positions, triangles)?;
        let mut mesh = Mesh::default();
        match window {
            Some(w) => {
                let plan = plan_surface(&relief, &self.inside, Some((&self.base_plan, w)));
                add_relief_surface(&mut mesh, &relief, &plan);
            }
            None => add_relief_surface(&mut mesh, &relief, &self.base_plan),
        }
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

/// Largest square of grid cells the stone's top is simplified to, how far (gem mm) a
/// simplified square's grid heights may stray from the bilinear patch of its corners, and how
/// far their slopes may (shading follows the interpolated normals, which show a fan's pattern
/// long before its heights do).
const MAX_BLOCK: usize = 8;
const FLAT_TOLERANCE_MM: f32 = 0.004;
const SLOPE_TOLERANCE: f32 = 0.004;
/// How far the hair layer's weight may stray from the corners' bilinear patch in a merged square.
const HAIR_TOLERANCE: f32 = 0.02;

/// One square element of the stone's top: `size` x `size` cells from node (`x`, `y`).
#[derive(Clone, Copy, Debug)]
struct Element {
    x: usize,
    y: usize,
    size: usize,
}

/// The stone's top before triangulation: per node its material region and slope, and the
/// quadtree's elements, grouped by top-level block (blocks of [`MAX_BLOCK`] cells, row-major;
/// block `b`'s elements are `elements[block[b]]`).
#[derive(Clone, Debug, Default)]
struct SurfacePlan {
    region: Vec<Region>,
    slope: Vec<[f32; 2]>,
    elements: Vec<Element>,
    block: Vec<std::ops::Range<usize>>,
}

/// The stone's top, with detail only where the surface needs it: the grid's cells are merged
/// (quadtree fashion, up to [`MAX_BLOCK`] cells a side) wherever the heights stay within
/// [`FLAT_TOLERANCE_MM`] of a plane and the material does not change, so the flat ground and
/// smooth slopes take a few triangles and the face keeps every cell. Cells need all four
/// corners inside the oval; the bezel's inner foot covers the stepped outline.
///
/// With `base` = (the plan of another relief, the window outside which both reliefs are
/// equal), only the window's nodes and the blocks that reach it are planned again: the rest is
/// the base's (the same result as planning everything).
fn plan_surface(
    relief: &Relief,
    inside: &[bool],
    base: Option<(&SurfacePlan, relief::Window)>,
) -> SurfacePlan {
    let (cols, rows, cell) = (relief.cols, relief.rows, relief.cell);
    // Nodes to compute again: the window, one node wider for the slopes' differences.
    let all = relief::Window {
        x0: 0,
        y0: 0,
        x1: cols - 1,
        y1: rows - 1,
    };
    let dirty = base.map_or(all, |(_, w)| relief::Window {
        x0: w.x0.saturating_sub(1),
        y0: w.y0.saturating_sub(1),
        x1: (w.x1 + 1).min(cols - 1),
        y1: (w.y1 + 1).min(rows - 1),
    });
    let (mut region, mut slope) = match base {
        Some((b, _)) => (b.region.clone(), b.slope.clone()),
        None => (
            vec![Region::Ground; cols * rows],
            vec![[0.0; 2]; cols * rows],
        ),
    };
    for row in dirty.y0..=dirty.y1 {
        for col in dirty.x0..=dirty.x1 {
            let i = row * cols + col;
            region[i] = if relief.height[i] < GROUND_EPS {
                Region::Ground
            } else if relief.hair[i] > 0.5 {
                Region::Hair
            } else {
                Region::Relief
            };
            // Central differences, one-sided at the grid's edge.
            let (left, right) = (col.saturating_sub(1), (col + 1).min(cols - 1));
            let (up, down) = (row.saturating_sub(1), (row + 1).min(rows - 1));
            slope[i] = [
                (relief.height[row * cols + right] - relief.height[row * cols + left])
                    / (cell * (right - left) as f32),
                (relief.height[down * cols + col] - relief.height[up * cols + col])
                    / (cell * (down - up) as f32),
            ];
        }
    }

    // Top-level blocks that reach a dirty node (block (bx, by) spans nodes bx * MAX_BLOCK to
    // bx * MAX_BLOCK + MAX_BLOCK) are planned again; the rest keep the base's elements.
    let (blocks_x, blocks_y) = (
        (cols - 1).div_ceil(MAX_BLOCK),
        (rows - 1).div_ceil(MAX_BLOCK),
    );
    let bx0 = dirty.x0.saturating_sub(1) / MAX_BLOCK;
    let by0 = dirty.y0.saturating_sub(1) / MAX_BLOCK;
    let bx1 = (dirty.x1 / MAX_BLOCK).min(blocks_x - 1);
    let by1 = (dirty.y1 / MAX_BLOCK).min(blocks_y - 1);
    // Summed-area table, over the replanned blocks' nodes, of nodes that are not bare ground
    // (inside, height, slope and hair 0): a square without any is merged without looking at its
    // nodes (most of the field).
    let (nx0, ny0) = (bx0 * MAX_BLOCK, by0 * MAX_BLOCK);
    let nx1 = ((bx1 + 1) * MAX_BLOCK).min(cols - 1);
    let ny1 = ((by1 + 1) * MAX_BLOCK).min(rows - 1);
    let sat_w = nx1 - nx0 + 2;
    let mut busy = vec![0u32; sat_w * (ny1 - ny0 + 2)];
    for y in ny0..=ny1 {
        let mut run = 0;
        for x in nx0..=nx1 {
            let i = y * cols + x;
            let bare = inside[i]
                && relief.height[i] == 0.0
                && slope[i] == [0.0, 0.0]
                && relief.hair[i] == 0.0;
            run += u32::from(!bare);
            let (ly, lx) = (y - ny0, x - nx0);
            busy[(ly + 1) * sat_w + lx + 1] = busy[ly * sat_w + lx + 1] + run;
        }
    }
    let busy_in = |e: Element| {
        let (x0, y0) = (e.x - nx0, e.y - ny0);
        let (x1, y1) = (x0 + e.size + 1, y0 + e.size + 1);
        busy[y1 * sat_w + x1] + busy[y0 * sat_w + x0]
            - busy[y0 * sat_w + x1]
            - busy[y1 * sat_w + x0]
    };
    // A square may be one element if every node is inside, of one region, and near the
    // bilinear patch of its corners in height, slope and hair weight.
    let mergeable = |e: Element| {
        if busy_in(e) == 0 {
            return true;
        }
        let at = |dx: usize, dy: usize| (e.y + dy) * cols + e.x + dx;
        let c = [at(0, 0), at(e.size, 0), at(0, e.size), at(e.size, e.size)];
        let bilinear = |v: [f32; 4], u: f32, w: f32| {
            (v[0] * (1.0 - u) + v[1] * u) * (1.0 - w) + (v[2] * (1.0 - u) + v[3] * u) * w
        };
        let heights = c.map(|i| relief.height[i]);
        let sx = c.map(|i| slope[i][0]);
        let sy = c.map(|i| slope[i][1]);
        let hair = c.map(|i| relief.hair[i]);
        let first = region[c[0]];
        let scale = 1.0 / e.size as f32;
        let node_ok = |dx: usize, dy: usize| {
            let i = at(dx, dy);
            let (u, w) = (dx as f32 * scale, dy as f32 * scale);
            inside[i]
                && region[i] == first
                && (relief.height[i] - bilinear(heights, u, w)).abs() <= FLAT_TOLERANCE_MM
                && (slope[i][0] - bilinear(sx, u, w)).abs() <= SLOPE_TOLERANCE
                && (slope[i][1] - bilinear(sy, u, w)).abs() <= SLOPE_TOLERANCE
                && (relief.hair[i] - bilinear(hair, u, w)).abs() <= HAIR_TOLERANCE
        };
        // The centre and the edges' midpoints stray first on a curved surface: try them first.
        let h = e.size / 2;
        [(h, h), (h, 0), (0, h), (e.size, h), (h, e.size)]
            .iter()
            .all(|&(dx, dy)| node_ok(dx, dy))
            && (0..=e.size).all(|dy| (0..=e.size).all(|dx| node_ok(dx, dy)))
    };
    let split = |root: Element, elements: &mut Vec<Element>| {
        let mut stack = vec![root];
        while let Some(e) = stack.pop() {
            if e.x >= cols - 1 || e.y >= rows - 1 {
                continue;
            }
            let fits = e.x + e.size < cols && e.y + e.size < rows;
            if e.size == 1 {
                let corners = [(0, 0), (1, 0), (0, 1), (1, 1)];
                if corners
                    .iter()
                    .all(|&(dx, dy)| inside[(e.y + dy) * cols + e.x + dx])
                {
                    elements.push(e);
                }
            } else if fits && mergeable(e) {
                elements.push(e);
            } else {
                let h = e.size / 2;
                for (dx, dy) in [(0, 0), (h, 0), (0, h), (h, h)] {
                    stack.push(Element {
                        x: e.x + dx,
                        y: e.y + dy,
                        size: h,
                    });
                }
            }
        }
    };
    let mut elements = Vec::with_capacity(base.map_or(0, |(b, _)| b.elements.len() + 1024));
    let mut block = vec![0..0; blocks_x * blocks_y];
    // Last block first (the order of a stack of all blocks, as before planning by block).
    for b in (0..blocks_x * blocks_y).rev() {
        let start = elements.len();
        let (bx, by) = (b % blocks_x, b / blocks_x);
        match base {
            Some((plan, _)) if !((bx0..=bx1).contains(&bx) && (by0..=by1).contains(&by)) => {
                elements.extend_from_slice(&plan.elements[plan.block[b].clone()]);
            }
            _ => split(
                Element {
                    x: bx * MAX_BLOCK,
                    y: by * MAX_BLOCK,
                    size: MAX_BLOCK,
                },
                &mut elements,
            ),
        }
        block[b] = start..elements.len();
    }
    SurfacePlan {
        region,
        slope,
        elements,
        block,
    }
}

/// Adds the stone's top as planned: a merged square is a fan around its centre node through
/// every node on its border that a neighbour uses as a corner, so the surface stays watertight
/// (no T-junctions).
fn add_relief_surface(mesh: &mut Mesh, relief: &Relief, plan: &SurfacePlan) {
    let (cols, rows, cell) = (relief.cols, relief.rows, relief.cell);
    let (elements, region, slope) = (&plan.elements, &plan.region, &plan.slope);
    let node_xy = |col: usize, row: usize| {
        (
            relief.origin[0] + col as f32 * cell,
            relief.origin[1] + row as f32 * cell,
        )
    };
    // Nodes in use: every element's corners, and merged squares' centres.
    let mut corner = vec![false; cols * rows];
    let mut used = vec![false; cols * rows];
    for e in elements {
        for (dx, dy) in [(0, 0), (e.size, 0), (0, e.size), (e.size, e.size)] {
            corner[(e.y + dy) * cols + e.x + dx] = true;
            used[(e.y + dy) * cols + e.x + dx] = true;
        }
        if e.size > 1 {
            used[(e.y + e.size / 2) * cols + e.x + e.size / 2] = true;
        }
    }

    let mut index = vec![u32::MAX; cols * rows];
    let count = used.iter().filter(|u| **u).count();
    mesh.vertices.reserve(count);
    for (i, (x, y)) in (0..rows)
        .flat_map(|row| (0..cols).map(move |col| (row * cols + col, col, row)))
        .filter(|&(i, _, _)| used[i])
        .map(|(i, col, row)| (i, node_xy(col, row)))
    {
        let h = relief.height[i];
        let [dzdx, dzdy] = slope[i];
        let inv_len = 1.0 / (dzdx * dzdx + dzdy * dzdy + 1.0).sqrt();
        index[i] = mesh.vertices.len() as u32;
        mesh.vertices.push(Vertex {
            position: [x, y, h],
            normal: [-dzdx * inv_len, -dzdy * inv_len, inv_len],
            relief: h,
            region: region[i] as u32,
            hair: relief.hair[i].clamp(0.0, 1.0),
        });
    }

    // Counter-clockwise seen from +Z (y up), like the bezel's.
    let mut border = Vec::with_capacity(4 * MAX_BLOCK);
    for e in elements {
        let at = |dx: usize, dy: usize| (e.y + dy) * cols + e.x + dx;
        if e.size == 1 {
            let [a, b, c, d] = [at(0, 0), at(1, 0), at(1, 1), at(0, 1)].map(|i| index[i]);
            mesh.indices.extend_from_slice(&[a, b, c, a, c, d]);
            continue;
        }
        let n = e.size;
        border.clear();
        border.extend((0..n).map(|k| at(k, 0)));
        border.extend((0..n).map(|k| at(n, k)));
        border.extend((0..n).map(|k| at(n - k, n)));
        border.extend((0..n).map(|k| at(0, n - k)));
        border.retain(|&i| corner[i]);
        let centre = index[at(n / 2, n / 2)];
        for k in 0..border.len() {
            let (a, b) = (border[k], border[(k + 1) % border.len()]);
            mesh.indices
                .extend_from_slice(&[centre, index[a], index[b]]);
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
        hair: 0.0,
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
