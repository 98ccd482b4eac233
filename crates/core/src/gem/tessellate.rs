//! The relief's height field into triangles: the stone's top simplified into square blocks
//! where it is flat or evenly sloped (a fan's pattern would show in the shading first), and
//! the portrait's wall cut along its outline's contour, between the grid's nodes (the gold
//! setting is [`super::setting`]'s). Gem millimetres.

use std::collections::HashMap;

use super::{GROUND_EPS, OUTLINE_LEVEL, Relief};
use crate::scene::{Mesh, Region, Vertex};

/// Largest square of grid cells the stone's top is simplified to, how far (gem mm) a
/// simplified square's grid heights may stray from the bilinear patch of its corners, and how
/// far their slopes may (shading follows the interpolated normals, which show a fan's pattern
/// long before its heights do).
const MAX_BLOCK: usize = 8;
const FLAT_TOLERANCE_MM: f32 = 0.004;
const SLOPE_TOLERANCE: f32 = 0.004;
/// How far the hair layer's weight may stray from the corners' bilinear patch in a merged square.
const HAIR_TOLERANCE: f32 = 0.02;
/// How far the cast shadows' and the cavity's light (0..1) may stray: the renderer
/// interpolates them like the heights, and a merged square that flattens a penumbra shows as a
/// rectangular patch at 3840 px.
const LIGHT_TOLERANCE: f32 = 0.015;

/// The wall's batter: how far it leans back from the vertical (radians). A little, as a
/// cutter's wheel leaves it, so that the wall shows as a thin lit or shaded line along the
/// outline (a truly vertical one is seen edge-on from the front).
const WALL_BATTER: f32 = 0.14;

/// One square element of the stone's top: `size` x `size` cells from node (`x`, `y`).
#[derive(Clone, Copy, Debug)]
struct Element {
    x: usize,
    y: usize,
    size: usize,
}

/// The stone's top before triangulation: per node its material region and slope, and the
/// quadtree's elements.
#[derive(Clone, Debug, Default)]
pub(super) struct SurfacePlan {
    region: Vec<Region>,
    slope: Vec<[f32; 2]>,
    elements: Vec<Element>,
}

/// The stone's top, with detail only where the surface needs it: the grid's cells are merged
/// (quadtree fashion, up to [`MAX_BLOCK`] cells a side) wherever the heights stay within
/// [`FLAT_TOLERANCE_MM`] of a plane and the material does not change, so the flat ground and
/// smooth slopes take a few triangles and the face keeps every cell. Cells need all four
/// corners inside the oval; the bezel's inner foot covers the stepped outline.
pub(super) fn plan_surface(relief: &Relief, inside: &[bool]) -> SurfacePlan {
    let (cols, rows) = (relief.cols, relief.rows);
    let mut region = vec![Region::Ground; cols * rows];
    let mut slope = vec![[0.0; 2]; cols * rows];
    for row in 0..rows {
        for col in 0..cols {
            let i = row * cols + col;
            region[i] = if relief.height[i] < GROUND_EPS {
                Region::Ground
            } else if relief.hair[i] > 0.5 {
                Region::Hair
            } else {
                Region::Relief
            };
            // The portrait's nodes take the top's slope (continued past the outline), the ground's the ground's (the wall is
            // cut between the nodes, so neither slope sees the step).
            let on_portrait = portrait(relief, i);
            slope[i] =
                central_difference(relief, i, |j| match (on_portrait, portrait(relief, j)) {
                    (true, _) => relief.top[j],
                    (false, true) => 0.0,
                    (false, false) => relief.height[j],
                });
        }
    }
    let (blocks_x, blocks_y) = (
        (cols - 1).div_ceil(MAX_BLOCK),
        (rows - 1).div_ceil(MAX_BLOCK),
    );
    // Summed-area table of nodes that are not bare ground (inside, height, slope and hair 0):
    // a square without any is merged without looking at its nodes (most of the field).
    let sat_w = cols + 1;
    let mut busy = vec![0u32; sat_w * (rows + 1)];
    for y in 0..rows {
        let mut run = 0;
        for x in 0..cols {
            let i = y * cols + x;
            let bare = inside[i]
                && relief.height[i] == 0.0
                && slope[i] == [0.0, 0.0]
                && relief.hair[i] == 0.0;
            run += u32::from(!bare);
            busy[(y + 1) * sat_w + x + 1] = busy[y * sat_w + x + 1] + run;
        }
    }
    let busy_in = |e: Element| {
        let (x0, y0) = (e.x, e.y);
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
        let key = c.map(|i| relief.key_light[i]);
        let cavity = c.map(|i| relief.occlusion[i]);
        let through = c.map(|i| relief.transmit[i]);
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
                && (relief.key_light[i] - bilinear(key, u, w)).abs() <= LIGHT_TOLERANCE
                && (relief.occlusion[i] - bilinear(cavity, u, w)).abs() <= LIGHT_TOLERANCE
                && (relief.transmit[i] - bilinear(through, u, w)).abs() <= LIGHT_TOLERANCE
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
    let mut elements = Vec::with_capacity(cols * rows / 16);
    // Last block first (the order of a stack of all blocks).
    for b in (0..blocks_x * blocks_y).rev() {
        let (bx, by) = (b % blocks_x, b / blocks_x);
        split(
            Element {
                x: bx * MAX_BLOCK,
                y: by * MAX_BLOCK,
                size: MAX_BLOCK,
            },
            &mut elements,
        );
    }
    SurfacePlan {
        region,
        slope,
        elements,
    }
}

/// Gem position of node `i`, mm.
fn node_xy(relief: &Relief, i: usize) -> [f32; 2] {
    [
        relief.origin[0] + (i % relief.cols) as f32 * relief.cell,
        relief.origin[1] + (i / relief.cols) as f32 * relief.cell,
    ]
}

/// The slope of `field` (per node index) at node `i`, per mm: central differences, one-sided
/// at the grid's edge.
fn central_difference(relief: &Relief, i: usize, field: impl Fn(usize) -> f32) -> [f32; 2] {
    let (cols, rows, cell) = (relief.cols, relief.rows, relief.cell);
    let (col, row) = (i % cols, i / cols);
    let (left, right) = (col.saturating_sub(1), (col + 1).min(cols - 1));
    let (up, down) = (row.saturating_sub(1), (row + 1).min(rows - 1));
    [
        (field(row * cols + right) - field(row * cols + left))
            / (cell * (right - left).max(1) as f32),
        (field(down * cols + col) - field(up * cols + col)) / (cell * (down - up).max(1) as f32),
    ]
}

/// Whether node `i` stands on the portrait (inside its outline's contour).
fn portrait(relief: &Relief, i: usize) -> bool {
    relief.outline[i] >= OUTLINE_LEVEL
}

/// Adds the stone's top as planned: a merged square is a fan around its centre node through
/// every node on its border that a neighbour uses as a corner, so the surface stays watertight
/// (no T-junctions).
pub(super) fn add_relief_surface(mesh: &mut Mesh, relief: &Relief, plan: &SurfacePlan) {
    let (cols, rows) = (relief.cols, relief.rows);
    let (elements, region, slope) = (&plan.elements, &plan.region, &plan.slope);
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
    for i in (0..cols * rows).filter(|&i| used[i]) {
        let [x, y] = node_xy(relief, i);
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
            occlusion: relief.occlusion[i],
            key_light: relief.key_light[i],
            transmit: relief.transmit[i],
        });
    }

    // Counter-clockwise seen from +Z (y up), like the bezel's.
    let mut wall = WallCut {
        relief,
        index: &index,
        crossings: HashMap::new(),
    };
    let mut border = Vec::with_capacity(4 * MAX_BLOCK);
    for e in elements {
        let at = |dx: usize, dy: usize| (e.y + dy) * cols + e.x + dx;
        if e.size == 1 {
            let [a, b, c, d] = [at(0, 0), at(1, 0), at(1, 1), at(0, 1)];
            let on = [a, b, c, d].map(|i| portrait(relief, i));
            if on.iter().all(|&o| o == on[0]) {
                let [a, b, c, d] = [a, b, c, d].map(|i| index[i]);
                mesh.indices.extend_from_slice(&[a, b, c, a, c, d]);
            } else {
                wall.triangle(mesh, [a, b, c]);
                wall.triangle(mesh, [a, c, d]);
            }
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

/// Where the outline's contour crosses a grid edge: the top's vertex there, the ground's at
/// the wall's foot a little outside ([`WALL_BATTER`]), and the wall's own two (its normals).
#[derive(Clone, Copy, Debug)]
struct Crossing {
    top: u32,
    ground: u32,
    wall_top: u32,
    foot: u32,
}

/// The cells that the outline's contour crosses, cut along it (marching triangles on the
/// smoothed coverage): the top on the portrait's side, the ground on the other, the wall
/// between. Crossings are shared by the cells on either side of their edge, so the top, the
/// ground and the wall stay watertight.
struct WallCut<'a> {
    relief: &'a Relief,
    index: &'a [u32],
    crossings: HashMap<(usize, usize), Crossing>,
}

impl WallCut<'_> {
    /// The crossing on the edge between a node on the portrait and one off it.
    fn crossing(&mut self, mesh: &mut Mesh, a: usize, b: usize) -> Crossing {
        let (inner, outer) = if portrait(self.relief, a) {
            (a, b)
        } else {
            (b, a)
        };
        if let Some(c) = self.crossings.get(&(inner, outer)) {
            return *c;
        }
        let r = self.relief;
        let (fi, fo) = (r.outline[inner], r.outline[outer]);
        // (Kept off the nodes, so the wall's foot has room on the edge.)
        let t = ((fi - OUTLINE_LEVEL) / (fi - fo).max(1e-6)).clamp(0.01, 0.99);
        let lerp = |p: f32, q: f32| p + t * (q - p);
        let (pi, po) = (node_xy(r, inner), node_xy(r, outer));
        let [x, y] = [lerp(pi[0], po[0]), lerp(pi[1], po[1])];
        let z = lerp(r.top[inner], r.top[outer]).max(GROUND_EPS);
        let edge = [po[0] - pi[0], po[1] - pi[1]];
        let edge_len = edge[0].hypot(edge[1]).max(1e-9);
        let along = [edge[0] / edge_len, edge[1] / edge_len];
        // Outward: down the coverage's slope (smooth along the contour, so the wall's shading
        // has no facets); along the edge where the slope vanishes.
        let outline = |j: usize| r.outline[j];
        let (gi, go) = (
            central_difference(r, inner, outline),
            central_difference(r, outer, outline),
        );
        let g = [-lerp(gi[0], go[0]), -lerp(gi[1], go[1])];
        let len = g[0].hypot(g[1]);
        let out = if len > 1e-6 && len.is_finite() {
            [g[0] / len, g[1] / len]
        } else {
            along
        };
        let (sin, cos) = WALL_BATTER.sin_cos();
        let wall_normal = [out[0] * cos, out[1] * cos, sin];
        // The foot: the batter's run out from the contour projected onto the grid edge (so the
        // ground, the wall and the top tile the plane seen from above, nothing folds or
        // overlaps; an edge across the outline takes all of it, an oblique one less, and
        // none is pushed sideways along the outline, which would serrate it), within the
        // edge's outer part.
        let run = (z * WALL_BATTER.tan() * (along[0] * out[0] + along[1] * out[1]).max(0.0))
            .clamp(0.005 * edge_len, 0.8 * (1.0 - t) * edge_len);
        let foot_xy = [x + along[0] * run, y + along[1] * run];
        let on = mesh.vertices[self.index[inner] as usize];
        let off = mesh.vertices[self.index[outer] as usize];
        let top = Vertex {
            position: [x, y, z],
            relief: z,
            ..on
        };
        let ground = Vertex {
            position: [foot_xy[0], foot_xy[1], 0.0],
            relief: 0.0,
            ..off
        };
        let wall_top = Vertex {
            normal: wall_normal,
            ..top
        };
        let foot = Vertex {
            normal: wall_normal,
            occlusion: off.occlusion,
            key_light: off.key_light,
            transmit: off.transmit,
            hair: on.hair,
            region: on.region,
            ..ground
        };
        let first = mesh.vertices.len() as u32;
        mesh.vertices
            .extend_from_slice(&[top, ground, wall_top, foot]);
        let c = Crossing {
            top: first,
            ground: first + 1,
            wall_top: first + 2,
            foot: first + 3,
        };
        self.crossings.insert((inner, outer), c);
        c
    }

    /// One grid triangle (counter-clockwise nodes), cut where the contour crosses it.
    fn triangle(&mut self, mesh: &mut Mesh, nodes: [usize; 3]) {
        let on = nodes.map(|i| portrait(self.relief, i));
        let Some(k) = (0..3).find(|&k| on[k] != on[(k + 1) % 3] && on[k] != on[(k + 2) % 3]) else {
            let [a, b, c] = nodes.map(|i| self.index[i]);
            mesh.indices.extend_from_slice(&[a, b, c]);
            return;
        };
        // The lone node first, the order kept.
        let (l, m, n) = (nodes[k], nodes[(k + 1) % 3], nodes[(k + 2) % 3]);
        let (lm, ln) = (self.crossing(mesh, l, m), self.crossing(mesh, l, n));
        let [il, im, inn] = [l, m, n].map(|i| self.index[i]);
        if on[k] {
            mesh.indices.extend_from_slice(&[il, lm.top, ln.top]);
            mesh.indices
                .extend_from_slice(&[lm.ground, im, inn, lm.ground, inn, ln.ground]);
        } else {
            mesh.indices.extend_from_slice(&[il, lm.ground, ln.ground]);
            mesh.indices
                .extend_from_slice(&[lm.top, im, inn, lm.top, inn, ln.top]);
        }
        // The wall between the two crossings, wound counter-clockwise seen from above (it
        // leans back, so that is its outer face).
        let p = |v: u32| mesh.vertices[v as usize].position;
        let (a, b, c) = (p(lm.wall_top), p(ln.wall_top), p(ln.foot));
        let up = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
        if up >= 0.0 {
            mesh.indices.extend_from_slice(&[
                lm.wall_top,
                ln.wall_top,
                ln.foot,
                lm.wall_top,
                ln.foot,
                lm.foot,
            ]);
        } else {
            mesh.indices.extend_from_slice(&[
                ln.wall_top,
                lm.wall_top,
                lm.foot,
                ln.wall_top,
                lm.foot,
                ln.foot,
            ]);
        }
    }
}
