//! The relief's height field into triangles: the stone's top simplified into square blocks
//! where it is flat or evenly sloped (a fan's pattern would show in the shading first), and
//! the portrait's wall cut along its outline's contour, between the grid's nodes (the gold
//! setting is [`super::setting`]'s). Gem millimetres.
//!
//! Length: about 740 lines, the top's block simplification and the wall's cut share the grid's
//! indices and the foot and rim caches of one `WallCut`; apart they would pass both through
//! every call.

use std::collections::HashMap;

use super::{GROUND_EPS, OUTLINE_LEVEL, Relief};
use crate::scene::{Mesh, Region, Vertex};

/// Largest square of grid cells the stone's top is simplified to (on the relief's solve grid;
/// a finer grid's squares are as many times larger, the same millimetres), how far (gem mm) a
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
/// Where a node stands against the portrait's cut: on its top (inside the outline's
/// contour), under its wall (between the contour and the wall's foot, which the batter puts
/// a little outside), or on the ground beyond.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Zone {
    Top,
    Wall,
    Ground,
}

/// One square element of the stone's top: `size` x `size` cells from node (`x`, `y`).
#[derive(Clone, Copy, Debug)]
struct Element {
    x: usize,
    y: usize,
    size: usize,
    /// One cell of the solve grid on a refined one (no stipple in it): cut as that grid's
    /// cell was, two triangles, unless a finer neighbour's node lies on its border.
    whole: bool,
}

/// The stone's top before triangulation: per node its material region and slope, and the
/// quadtree's elements.
#[derive(Clone, Debug, Default)]
pub(super) struct SurfacePlan {
    region: Vec<Region>,
    slope: Vec<[f32; 2]>,
    elements: Vec<Element>,
    zone: Vec<Zone>,
    /// How far (mm) each node off the portrait lies inside the wall's foot: the wall's run
    /// there, `top` x tan([`WALL_BATTER`]), less its distance from the outline's contour.
    /// Its zero contour is the foot, parallel to the top's edge.
    foot: Vec<f32>,
}

/// The stone's top, with detail only where the surface needs it: the grid's cells are merged
/// (quadtree fashion, up to [`MAX_BLOCK`] cells a side) wherever the heights stay within
/// [`FLAT_TOLERANCE_MM`] of a plane and the material does not change, so the flat ground and
/// smooth slopes take a few triangles and the face keeps every cell. Cells need all four
/// corners inside the oval; the bezel's inner foot covers the stepped outline.
/// `subdivision`: the relief's cells per cell of its solve grid (1, or more where the photo's
/// stipple is carved).
pub(super) fn plan_surface(relief: &Relief, inside: &[bool], subdivision: usize) -> SurfacePlan {
    let (cols, rows) = (relief.cols, relief.rows);
    let max_block = MAX_BLOCK * subdivision.clamp(1, 4).next_power_of_two();
    let mut region = vec![Region::Ground; cols * rows];
    let mut slope = vec![[0.0; 2]; cols * rows];
    let mut zone = vec![Zone::Ground; cols * rows];
    let foot = foot_field(relief);
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
            zone[i] = if on_portrait {
                Zone::Top
            } else if foot[i] >= 0.0 {
                Zone::Wall
            } else {
                Zone::Ground
            };
        }
    }
    let (blocks_x, blocks_y) = (
        (cols - 1).div_ceil(max_block),
        (rows - 1).div_ceil(max_block),
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
                && zone[i] != Zone::Wall
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
                && zone[i] != Zone::Wall
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
    // On a refined grid, a square of one solve-grid cell without a stipple's pit is one
    // element, as the solve grid's cell was, whatever its slopes and light (a refined
    // field's central differences are not its corners' bilinear patch, and would keep every
    // fine cell; the tone's slopes there are carved at the cell's corners, as on the solve
    // grid).
    let refined = |e: Element| {
        if subdivision < 2 || e.size != subdivision || relief.stippled.len() != cols * rows {
            return false;
        }
        let at = |dx: usize, dy: usize| (e.y + dy) * cols + e.x + dx;
        let first = region[at(0, 0)];
        (0..=e.size).all(|dy| {
            (0..=e.size).all(|dx| {
                let i = at(dx, dy);
                inside[i] && zone[i] != Zone::Wall && region[i] == first && !relief.stippled[i]
            })
        })
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
            } else if fits && refined(e) {
                elements.push(Element { whole: true, ..e });
            } else {
                let h = e.size / 2;
                for (dx, dy) in [(0, 0), (h, 0), (0, h), (h, h)] {
                    stack.push(Element {
                        x: e.x + dx,
                        y: e.y + dy,
                        size: h,
                        whole: false,
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
                x: bx * max_block,
                y: by * max_block,
                size: max_block,
                whole: false,
            },
            &mut elements,
        );
    }
    SurfacePlan {
        region,
        slope,
        elements,
        zone,
        foot,
    }
}

/// The wall's foot field ([`SurfacePlan::foot`]): each node off the portrait near the
/// outline, its distance to the contour's segments (marching triangles, cut as
/// [`add_relief_surface`] cuts them) against the wall's run there; `-inf` far off. The
/// distance is the true one to the piecewise-straight contour, so the foot runs parallel to
/// the top's edge along curves too (a first-order distance, the coverage over its slope,
/// underestimated the slope off the contour and leaned the wall 3-7 degrees for 8).
fn foot_field(relief: &Relief) -> Vec<f32> {
    let (cols, rows, cell) = (relief.cols, relief.rows, relief.cell);
    // Squared distances while searching.
    let mut dist = vec![f32::INFINITY; cols * rows];
    let run = WALL_BATTER.tan();
    // Only the cells about the portrait's nodes can be cut.
    let (mut x0, mut y0, mut x1, mut y1) = (cols, rows, 0, 0);
    for i in (0..cols * rows).filter(|&i| portrait(relief, i)) {
        let (x, y) = (i % cols, i / cols);
        (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
    }
    if x0 > x1 {
        return vec![f32::NEG_INFINITY; cols * rows];
    }
    for y in y0.saturating_sub(1)..=y1.min(rows - 2) {
        for x in x0.saturating_sub(1)..=x1.min(cols - 2) {
            let at = |dx: usize, dy: usize| (y + dy) * cols + x + dx;
            let [a, b, c, d] = [at(0, 0), at(1, 0), at(1, 1), at(0, 1)];
            for tri in [[a, b, c], [a, c, d]] {
                let on = tri.map(|i| portrait(relief, i));
                if on.iter().all(|&o| o == on[0]) {
                    continue;
                }
                let mut ends = [[0f32; 2]; 2];
                let mut k = 0;
                for e in 0..3 {
                    let (p, q) = (tri[e], tri[(e + 1) % 3]);
                    if on[e] != on[(e + 1) % 3] && k < 2 {
                        let (inner, outer) = if on[e] { (p, q) } else { (q, p) };
                        let t = rim_t(relief, inner, outer);
                        let (pi, po) = (node_xy(relief, inner), node_xy(relief, outer));
                        ends[k] = [pi[0] + t * (po[0] - pi[0]), pi[1] + t * (po[1] - pi[1])];
                        k += 1;
                    }
                }
                // The nodes the wall's run can reach from here (the top is continued over
                // the triangle's nodes, so theirs bounds it).
                let highest = tri.iter().fold(0f32, |m, &i| m.max(relief.top[i]));
                let reach = (highest * run / cell).ceil() as usize + 1;
                let (nx0, ny0) = (x.saturating_sub(reach), y.saturating_sub(reach));
                let (nx1, ny1) = ((x + 1 + reach).min(cols - 1), (y + 1 + reach).min(rows - 1));
                for ny in ny0..=ny1 {
                    for nx in nx0..=nx1 {
                        let j = ny * cols + nx;
                        if !portrait(relief, j) {
                            let d2 = segment_distance2(node_xy(relief, j), ends[0], ends[1]);
                            dist[j] = dist[j].min(d2);
                        }
                    }
                }
            }
        }
    }
    dist.iter()
        .zip(&relief.top)
        .map(|(&d, &top)| {
            if d.is_finite() {
                top.max(0.0) * run - d.sqrt()
            } else {
                f32::NEG_INFINITY
            }
        })
        .collect()
}

/// Squared distance (mm^2) from `p` to the segment `a`-`b`.
fn segment_distance2(p: [f32; 2], a: [f32; 2], b: [f32; 2]) -> f32 {
    let (ab, ap) = ([b[0] - a[0], b[1] - a[1]], [p[0] - a[0], p[1] - a[1]]);
    let len2 = ab[0] * ab[0] + ab[1] * ab[1];
    let t = if len2 > 0.0 {
        ((ap[0] * ab[0] + ap[1] * ab[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let (dx, dy) = (ap[0] - t * ab[0], ap[1] - t * ab[1]);
    dx * dx + dy * dy
}

/// Where the outline's contour crosses the grid edge from `inner` (on the portrait) to
/// `outer`, as a share of the edge (kept off the nodes, so the wall's foot has room).
fn rim_t(relief: &Relief, inner: usize, outer: usize) -> f32 {
    let (fi, fo) = (relief.outline[inner], relief.outline[outer]);
    ((fi - OUTLINE_LEVEL) / (fi - fo).max(1e-6)).clamp(0.01, 0.99)
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
    for e in elements {
        for (dx, dy) in [(0, 0), (e.size, 0), (0, e.size), (e.size, e.size)] {
            corner[(e.y + dy) * cols + e.x + dx] = true;
        }
    }
    let mut used = corner.clone();
    // A merged square's border, its corners and any finer neighbour's corners along it
    // (counter-clockwise from its top-left corner).
    let border_of = |e: &Element, border: &mut Vec<usize>| {
        let at = |dx: usize, dy: usize| (e.y + dy) * cols + e.x + dx;
        let n = e.size;
        border.clear();
        border.extend((0..n).map(|k| at(k, 0)));
        border.extend((0..n).map(|k| at(n, k)));
        border.extend((0..n).map(|k| at(n - k, n)));
        border.extend((0..n).map(|k| at(0, n - k)));
        border.retain(|&i| corner[i]);
    };
    let mut border = Vec::with_capacity(4 * MAX_BLOCK);
    // Whole cells with just their four corners are cut in two; other merged squares are fans
    // round their centre.
    let halved: Vec<bool> = elements
        .iter()
        .map(|e| {
            e.whole && {
                border_of(e, &mut border);
                border.len() == 4
            }
        })
        .collect();
    for (e, _) in elements
        .iter()
        .zip(&halved)
        .filter(|(e, h)| e.size > 1 && !**h)
    {
        used[(e.y + e.size / 2) * cols + e.x + e.size / 2] = true;
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
        plan,
        index: &index,
        rims: HashMap::new(),
        feet: HashMap::new(),
        walls: HashMap::new(),
    };
    for (e, &halved) in elements.iter().zip(&halved) {
        let at = |dx: usize, dy: usize| (e.y + dy) * cols + e.x + dx;
        if halved {
            // As `size == 1`'s below: (0,0) (n,0) (n,n), (0,0) (n,n) (0,n).
            let n = e.size;
            let [a, b, c, d] = [at(0, 0), at(n, 0), at(n, n), at(0, n)].map(|i| index[i]);
            mesh.indices.extend_from_slice(&[a, b, c, a, c, d]);
            continue;
        }
        if e.size == 1 {
            let [a, b, c, d] = [at(0, 0), at(1, 0), at(1, 1), at(0, 1)];
            let zones = [a, b, c, d].map(|i| plan.zone[i]);
            if zones.iter().all(|&z| z == zones[0] && z != Zone::Wall) {
                let [a, b, c, d] = [a, b, c, d].map(|i| index[i]);
                mesh.indices.extend_from_slice(&[a, b, c, a, c, d]);
            } else {
                wall.triangle(mesh, [a, b, c]);
                wall.triangle(mesh, [a, c, d]);
            }
            continue;
        }
        let n = e.size;
        border_of(e, &mut border);
        let centre = index[at(n / 2, n / 2)];
        for k in 0..border.len() {
            let (a, b) = (border[k], border[(k + 1) % border.len()]);
            mesh.indices
                .extend_from_slice(&[centre, index[a], index[b]]);
        }
    }
}

/// Where the outline's contour crosses a grid edge: the top's vertex there and the wall's
/// (the same point, the wall's normal).
#[derive(Clone, Copy, Debug)]
struct Rim {
    top: u32,
    wall: u32,
}

/// Where the wall's foot crosses a grid edge: the wall's vertex there and the ground's.
#[derive(Clone, Copy, Debug)]
struct Foot {
    wall: u32,
    ground: u32,
}

/// A corner of one piece of a cut grid triangle: a node, or where the outline's contour
/// ([`Rim`]) or the wall's foot ([`Foot`]) crosses the grid edge between two nodes.
#[derive(Clone, Copy, Debug)]
enum Corner {
    Node(usize),
    Rim(usize, usize),
    Foot(usize, usize),
}

/// The cells that the portrait's wall crosses, cut along it (marching triangles with two
/// contours): the top inside the outline's contour, the wall between it and its foot, the
/// ground beyond. The foot is a contour of its own ([`SurfacePlan::foot`]), parallel to the
/// top's edge at the batter's run, so the wall's width is even along the outline (a foot
/// pushed along each grid edge from the top's crossing, within the edge, varied with the
/// edge's direction and serrated the outline at 3840 px). Crossings and wall nodes are
/// shared by the cells on either side, so the top, the wall and the ground stay watertight.
struct WallCut<'a> {
    relief: &'a Relief,
    plan: &'a SurfacePlan,
    index: &'a [u32],
    rims: HashMap<(usize, usize), Rim>,
    feet: HashMap<(usize, usize), Foot>,
    walls: HashMap<usize, u32>,
}

impl WallCut<'_> {
    fn on_top(&self, i: usize) -> bool {
        self.plan.zone[i] == Zone::Top
    }

    /// The foot field at a corner: at the rim the wall's whole run (it is on the contour),
    /// never under a hair's breadth, so the foot stays outside the top's edge.
    fn foot_at(&self, c: Corner) -> f32 {
        match c {
            Corner::Node(i) => self.plan.foot[i],
            Corner::Rim(inner, outer) => {
                let r = self.relief;
                let t = rim_t(r, inner, outer);
                let top = r.top[inner] + t * (r.top[outer] - r.top[inner]);
                (top.max(0.0) * WALL_BATTER.tan()).max(1e-4)
            }
            Corner::Foot(..) => 0.0,
        }
    }

    /// The grid edge a piece's side crosses the foot on, as (inside the foot, on the ground),
    /// if the side lies on one: a rim's side runs to its edge's outer node (the contour's
    /// own segment, rim to rim, lies inside the triangle and never crosses the foot).
    fn foot_edge(&self, a: Corner, b: Corner) -> Option<(usize, usize)> {
        match (a, b) {
            (Corner::Node(p), Corner::Node(q)) => Some(if self.foot_at(a) >= 0.0 {
                (p, q)
            } else {
                (q, p)
            }),
            (Corner::Node(_), Corner::Rim(i, o)) | (Corner::Rim(i, o), Corner::Node(_)) => {
                Some((i, o))
            }
            _ => None,
        }
    }

    /// Gem position (x, y) a share `t` along the grid edge from node `p` to node `q`.
    fn position(&self, p: usize, q: usize, t: f32) -> [f32; 2] {
        let (a, b) = (node_xy(self.relief, p), node_xy(self.relief, q));
        [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
    }

    /// The wall's normal where the outline's coverage has slope `g` (per mm, pointing in),
    /// `fallback` the outward direction where it vanishes (straight up if that is zero too).
    fn wall_normal(g: [f32; 2], fallback: [f32; 2]) -> [f32; 3] {
        let len = g[0].hypot(g[1]);
        let out = if len > 1e-6 && len.is_finite() {
            [-g[0] / len, -g[1] / len]
        } else {
            fallback
        };
        if out == [0.0, 0.0] {
            return [0.0, 0.0, 1.0];
        }
        let (sin, cos) = WALL_BATTER.sin_cos();
        [out[0] * cos, out[1] * cos, sin]
    }

    /// The wall's normal a share `t` along the grid edge from `inner` to `outer`: from the
    /// outline's slope interpolated there, outward along the edge where it vanishes.
    fn edge_wall_normal(&self, inner: usize, outer: usize, t: f32) -> [f32; 3] {
        let outline = |j: usize| self.relief.outline[j];
        let (gi, go) = (
            central_difference(self.relief, inner, outline),
            central_difference(self.relief, outer, outline),
        );
        let (pi, po) = (node_xy(self.relief, inner), node_xy(self.relief, outer));
        Self::wall_normal(
            [gi[0] + t * (go[0] - gi[0]), gi[1] + t * (go[1] - gi[1])],
            normalised([po[0] - pi[0], po[1] - pi[1]]),
        )
    }

    /// The portrait's node nearest to node `i` (the highest coverage among the top's nodes
    /// around it): the wall's material and hair layer are the portrait's.
    fn portrait_near(&self, i: usize) -> Option<usize> {
        let (cols, rows) = (self.relief.cols, self.relief.rows);
        let (x, y) = (i % cols, i / cols);
        let mut best: Option<usize> = None;
        for r in 1..=4 {
            for ny in y.saturating_sub(r)..=(y + r).min(rows - 1) {
                for nx in x.saturating_sub(r)..=(x + r).min(cols - 1) {
                    let j = ny * cols + nx;
                    if self.on_top(j)
                        && best.is_none_or(|b| self.relief.outline[j] > self.relief.outline[b])
                    {
                        best = Some(j);
                    }
                }
            }
            if best.is_some() {
                break;
            }
        }
        best
    }

    /// A wall vertex at `xy` and height `z` whose material is the portrait's near `near`
    /// and whose light is the ground's at `ground` (read from the relief and the plan: a
    /// node near the cut need not be a mesh vertex, inside a merged square).
    fn wall_vertex(
        &self,
        xy: [f32; 2],
        z: f32,
        normal: [f32; 3],
        near: usize,
        ground: usize,
    ) -> Vertex {
        let r = self.relief;
        let (region, hair) = match self.portrait_near(near) {
            Some(j) => (self.plan.region[j] as u32, r.hair[j].clamp(0.0, 1.0)),
            None => (Region::Relief as u32, 0.0),
        };
        Vertex {
            position: [xy[0], xy[1], z],
            normal,
            relief: z,
            region,
            hair,
            occlusion: r.occlusion[ground],
            key_light: r.key_light[ground],
            transmit: r.transmit[ground],
        }
    }

    /// The rim on the edge between a node on the top and one off it.
    fn rim(&mut self, mesh: &mut Mesh, inner: usize, outer: usize) -> Rim {
        if let Some(r) = self.rims.get(&(inner, outer)) {
            return *r;
        }
        let r = self.relief;
        let t = rim_t(self.relief, inner, outer);
        let xy = self.position(inner, outer, t);
        let z = (r.top[inner] + t * (r.top[outer] - r.top[inner])).max(GROUND_EPS);
        let normal = self.edge_wall_normal(inner, outer, t);
        let on = mesh.vertices[self.index[inner] as usize];
        let top = Vertex {
            position: [xy[0], xy[1], z],
            relief: z,
            ..on
        };
        let wall = Vertex { normal, ..top };
        let [top, wall] = push_pair(mesh, [top, wall]);
        let rim = Rim { top, wall };
        self.rims.insert((inner, outer), rim);
        rim
    }

    /// The foot on the grid edge between `inner` (inside the foot) and `outer` (on the
    /// ground): between the edge's rim and `outer` where the edge has one, else between the
    /// nodes.
    fn foot(&mut self, mesh: &mut Mesh, inner: usize, outer: usize) -> Foot {
        if let Some(f) = self.feet.get(&(inner, outer)) {
            return *f;
        }
        let (from, start) = if self.on_top(inner) {
            (Corner::Rim(inner, outer), rim_t(self.relief, inner, outer))
        } else {
            (Corner::Node(inner), 0.0)
        };
        let (fa, fb) = (self.foot_at(from), self.plan.foot[outer]);
        let s = (fa / (fa - fb).max(1e-6)).clamp(0.01, 0.99);
        let t = start + s * (1.0 - start);
        let xy = self.position(inner, outer, t);
        let normal = self.edge_wall_normal(inner, outer, t);
        let off = mesh.vertices[self.index[outer] as usize];
        let ground = Vertex {
            position: [xy[0], xy[1], 0.0],
            relief: 0.0,
            ..off
        };
        let wall = self.wall_vertex(xy, 0.0, normal, inner, outer);
        let [wall, ground] = push_pair(mesh, [wall, ground]);
        let foot = Foot { wall, ground };
        self.feet.insert((inner, outer), foot);
        foot
    }

    /// Node `i` under the wall: on the wall's plane, `foot` / tan(batter) above the ground
    /// (the top's height where the node is at the contour, 0 at the foot).
    fn wall_node(&mut self, mesh: &mut Mesh, i: usize) -> u32 {
        if let Some(&v) = self.walls.get(&i) {
            return v;
        }
        let r = self.relief;
        let z = (self.plan.foot[i] / WALL_BATTER.tan()).clamp(0.0, r.top[i].max(GROUND_EPS));
        let g = central_difference(r, i, |j| r.outline[j]);
        let normal = Self::wall_normal(g, [0.0, 0.0]);
        let v = self.wall_vertex(node_xy(r, i), z, normal, i, i);
        let id = mesh.vertices.len() as u32;
        mesh.vertices.push(v);
        self.walls.insert(i, id);
        id
    }

    /// One grid triangle (counter-clockwise nodes), cut along the outline's contour and the
    /// wall's foot into up to three convex pieces (each keeps the triangle's winding).
    fn triangle(&mut self, mesh: &mut Mesh, nodes: [usize; 3]) {
        let mut top: Vec<Corner> = Vec::with_capacity(4);
        let mut rest: Vec<Corner> = Vec::with_capacity(4);
        for k in 0..3 {
            let (p, q) = (nodes[k], nodes[(k + 1) % 3]);
            if self.on_top(p) {
                top.push(Corner::Node(p));
            } else {
                rest.push(Corner::Node(p));
            }
            match (self.on_top(p), self.on_top(q)) {
                (true, false) => {
                    top.push(Corner::Rim(p, q));
                    rest.push(Corner::Rim(p, q));
                }
                (false, true) => {
                    top.push(Corner::Rim(q, p));
                    rest.push(Corner::Rim(q, p));
                }
                _ => {}
            }
        }
        let mut wall: Vec<Corner> = Vec::with_capacity(5);
        let mut ground: Vec<Corner> = Vec::with_capacity(4);
        for k in 0..rest.len() {
            let (a, b) = (rest[k], rest[(k + 1) % rest.len()]);
            let (fa, fb) = (self.foot_at(a), self.foot_at(b));
            if fa >= 0.0 {
                wall.push(a);
            } else {
                ground.push(a);
            }
            if (fa >= 0.0) != (fb >= 0.0)
                && let Some((inner, outer)) = self.foot_edge(a, b)
            {
                let c = Corner::Foot(inner, outer);
                wall.push(c);
                ground.push(c);
            }
        }
        let mut ids = Vec::with_capacity(5);
        for (piece, part) in [(&top, 0), (&wall, 1), (&ground, 2)] {
            if piece.len() < 3 {
                continue;
            }
            ids.clear();
            for &c in piece.iter() {
                let id = match (c, part) {
                    (Corner::Node(i), 1) => self.wall_node(mesh, i),
                    (Corner::Node(i), _) => self.index[i],
                    (Corner::Rim(i, o), 0) => self.rim(mesh, i, o).top,
                    (Corner::Rim(i, o), _) => self.rim(mesh, i, o).wall,
                    (Corner::Foot(i, o), 1) => self.foot(mesh, i, o).wall,
                    (Corner::Foot(i, o), _) => self.foot(mesh, i, o).ground,
                };
                ids.push(id);
            }
            for k in 1..ids.len() - 1 {
                mesh.indices
                    .extend_from_slice(&[ids[0], ids[k], ids[k + 1]]);
            }
        }
    }
}

/// `v` scaled to unit length (unchanged if it is zero).
/// Appends two vertices to `mesh`; their indices.
fn push_pair(mesh: &mut Mesh, pair: [Vertex; 2]) -> [u32; 2] {
    let first = mesh.vertices.len() as u32;
    mesh.vertices.extend_from_slice(&pair);
    [first, first + 1]
}

fn normalised(v: [f32; 2]) -> [f32; 2] {
    let len = v[0].hypot(v[1]);
    if len > 1e-9 {
        [v[0] / len, v[1] / len]
    } else {
        v
    }
}
