//! Measures of a relief against the face it was carved from, for tests and benchmarks:
//!
//! * [`profile_line`]: how far the relief's outline lies from the fitted face's own profile
//!   (the mesh's silhouette seen from the side) over brow, nose, lips and chin, gem mm;
//! * [`detail_kept`]: how much of the face's slopes and fine detail the relief keeps, against a
//!   uniform scale-down of the same portrait to the same depth;
//! * [`difference`]: the share of two reliefs' area where they differ visibly;
//! * [`frontal_hair_iou`]: how well a frontal gem's hair outline matches the photo's hair.
//!
//! Units: gem millimetres on the stone; canonical millimetres for the portrait before
//! compression (see [`super::Relief`]). Pure computation.

use super::{Relief, View, basrelief};

/// Relief above this height (gem mm) is part of the portrait for the outline.
const OUTLINE_LEVEL_MM: f32 = 0.4;
/// Two reliefs differ where their heights differ by more than this, gem mm (about what a
/// raking light shows on a polished stone).
pub const DIFFERENCE_MM: f32 = 0.1;
/// Fine detail: what a Gaussian of this width (gem mm) removes, i.e. features under about
/// 1 mm on the stone.
const FINE_SIGMA_MM: f32 = 0.25;
/// Cells along the face's border left out of the detail measures (the wall, the join).
const BORDER_CELLS: usize = 3;

/// Vertices of the Surrey face (3448 topology): the brows' inner ends (iBUG 22, 23) and the
/// chin (iBUG 9), which bound the profile line measured.
const BROWS: [usize; 2] = [157, 590];
const CHIN: usize = 33;

/// Distance of the relief's outline from the face's profile line.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ProfileLine {
    /// Profile points measured (every quarter cell between brow and chin).
    pub samples: usize,
    pub mean_mm: f32,
    pub max_mm: f32,
}

/// Silhouette samples per grid row.
const PROFILE_SAMPLES_PER_CELL: usize = 4;

/// Measures the distance from the face's profile line to the relief's outline between the
/// brows and the chin: the profile line is the front-most point of the face mesh's silhouette
/// (its near half's triangles crossing a horizontal line, exactly) at every quarter cell; the
/// outline is the relief's contour at [`OUTLINE_LEVEL_MM`] (marching squares over the grid);
/// each profile point's distance is to the nearest contour segment. Profile portraits of
/// Surrey faces only (`None` otherwise).
pub fn profile_line(
    relief: &Relief,
    positions: &[f32],
    triangles: &[[u32; 3]],
) -> Option<ProfileLine> {
    if relief.view != View::Profile || positions.len() != 3 * super::face::SFM_VERTICES {
        return None;
    }
    let gem = |i: usize| {
        let v = positions.get(3 * i..3 * i + 3)?;
        Some(relief.model_to_gem([v[0], v[1], v[2]]))
    };
    let brow = 0.5 * (gem(BROWS[0])?[1] + gem(BROWS[1])?[1]);
    let chin = gem(CHIN)?[1];
    let points: Vec<Option<[f32; 3]>> = (0..positions.len() / 3).map(gem).collect();
    let near: Vec<[[f32; 3]; 3]> = triangles
        .iter()
        .filter_map(|t| {
            let p = [0, 1, 2].map(|k| points.get(t[k] as usize).copied().flatten());
            let p = [p[0]?, p[1]?, p[2]?];
            (p.iter().any(|q| q[2] >= 0.0)).then_some(p)
        })
        .collect();
    let contour = contour_segments(relief, OUTLINE_LEVEL_MM, chin - 2.0, brow + 2.0);
    let (mut sum, mut max, mut samples) = (0f32, 0f32, 0usize);
    let step = relief.cell / PROFILE_SAMPLES_PER_CELL as f32;
    let mut y = chin;
    while y <= brow {
        // The silhouette: the smallest x where a triangle of the near half crosses this line.
        let mut front = f32::INFINITY;
        for p in &near {
            for k in 0..3 {
                let (a, b) = (p[k], p[(k + 1) % 3]);
                if (a[1] - y) * (b[1] - y) <= 0.0 && a[1] != b[1] {
                    let s = (y - a[1]) / (b[1] - a[1]);
                    front = front.min(a[0] + s * (b[0] - a[0]));
                }
            }
        }
        if front.is_finite() {
            let d = contour
                .iter()
                .map(|&(a, b)| point_segment([front, y], a, b))
                .fold(f32::INFINITY, f32::min);
            if d.is_finite() {
                sum += d;
                max = max.max(d);
                samples += 1;
            }
        }
        y += step;
    }
    (samples > 0).then(|| ProfileLine {
        samples,
        mean_mm: sum / samples as f32,
        max_mm: max,
    })
}

/// Distance from p to the segment a-b.
fn point_segment(p: [f32; 2], a: [f32; 2], b: [f32; 2]) -> f32 {
    let d = [b[0] - a[0], b[1] - a[1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    let t = if len2 > 0.0 {
        (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - a[0] - t * d[0]).hypot(p[1] - a[1] - t * d[1])
}

/// The relief's contour at `level` (gem mm) between heights `y0` and `y1` (gem mm), as
/// segments from marching squares over the grid's cells.
fn contour_segments(relief: &Relief, level: f32, y0: f32, y1: f32) -> Vec<([f32; 2], [f32; 2])> {
    let (cols, cell) = (relief.cols, relief.cell);
    let pos = |x: f32, y: f32| [relief.origin[0] + x * cell, relief.origin[1] + y * cell];
    let row0 = (((y0 - relief.origin[1]) / cell).floor().max(0.0)) as usize;
    let row1 = (((y1 - relief.origin[1]) / cell).ceil() as usize).min(relief.rows - 1);
    let mut out = Vec::new();
    for y in row0..row1 {
        for x in 0..cols - 1 {
            let h = |dx: usize, dy: usize| relief.height[(y + dy) * cols + x + dx] - level;
            // Corners counter-clockwise and the crossings on the four edges.
            let c = [(0, 0), (1, 0), (1, 1), (0, 1)];
            let mut crossings = Vec::with_capacity(4);
            for k in 0..4 {
                let (a, b) = (c[k], c[(k + 1) % 4]);
                let (ha, hb) = (h(a.0, a.1), h(b.0, b.1));
                if (ha < 0.0) != (hb < 0.0) {
                    let t = ha / (ha - hb);
                    let px = x as f32 + a.0 as f32 + t * (b.0 as f32 - a.0 as f32);
                    let py = y as f32 + a.1 as f32 + t * (b.1 as f32 - a.1 as f32);
                    crossings.push(pos(px, py));
                }
            }
            for pair in crossings.chunks_exact(2) {
                out.push((pair[0], pair[1]));
            }
        }
    }
    out
}

/// How much detail a relief keeps of its face.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DetailKept {
    /// Mean slope magnitude of the relief over that of the uniform scale-down, over the face.
    pub slopes: f32,
    /// RMS of the fine detail (the relief minus its blur at [`FINE_SIGMA_MM`]) over that of the
    /// uniform scale-down.
    pub fine: f32,
    /// The uniform scale-down's gem mm per canonical mm.
    pub uniform_scale: f32,
    /// Face cells measured.
    pub cells: usize,
}

/// Compares the relief with a uniform scale-down of its own portrait to the same depth (gem
/// height = `uniform_scale` x portrait height, `uniform_scale` = the relief's depth above its
/// wall over the highest point of `reference`, a mask of the nodes whose heights set it:
/// the whole portrait, or the face alone for a stricter measure), over the face's footprint
/// minus its border and its depth jumps.
pub fn detail_kept(relief: &Relief, wall: f32, depth: f32, reference: &[bool]) -> DetailKept {
    let (cols, rows, cell) = (relief.cols, relief.rows, relief.cell);
    let n = cols * rows;
    let top = (0..n)
        .filter(|&i| reference[i])
        .map(|i| relief.portrait[i])
        .fold(0f32, f32::max);
    let k = (depth - wall) / top.max(1e-6);
    let uniform: Vec<f32> = relief.portrait.iter().map(|p| p * k).collect();
    // Interior face cells: the footprint eroded by the border.
    let mut interior = relief.face.clone();
    for _ in 0..BORDER_CELLS {
        let prev = interior.clone();
        for y in 0..rows {
            for x in 0..cols {
                let i = y * cols + x;
                if prev[i]
                    && (x == 0
                        || y == 0
                        || x + 1 == cols
                        || y + 1 == rows
                        || !prev[i - 1]
                        || !prev[i + 1]
                        || !prev[i - cols]
                        || !prev[i + cols])
                {
                    interior[i] = false;
                }
            }
        }
    }
    let grad = |f: &[f32], i: usize| {
        let gx = (f[i + 1] - f[i - 1]) / (2.0 * cell);
        let gy = (f[i + cols] - f[i - cols]) / (2.0 * cell);
        gx.hypot(gy)
    };
    let sigma = FINE_SIGMA_MM / cell;
    let fine_r: Vec<f32> = {
        let b = basrelief::blur(&relief.height, cols, rows, sigma);
        relief.height.iter().zip(&b).map(|(h, b)| h - b).collect()
    };
    let fine_u: Vec<f32> = {
        let b = basrelief::blur(&uniform, cols, rows, sigma);
        uniform.iter().zip(&b).map(|(h, b)| h - b).collect()
    };
    let (mut sr, mut su, mut fr, mut fu, mut count) = (0f64, 0f64, 0f64, 0f64, 0usize);
    for y in 1..rows.saturating_sub(1) {
        for x in 1..cols.saturating_sub(1) {
            let i = y * cols + x;
            if !interior[i] {
                continue;
            }
            sr += f64::from(grad(&relief.height, i));
            su += f64::from(grad(&uniform, i));
            fr += f64::from(fine_r[i]).powi(2);
            fu += f64::from(fine_u[i]).powi(2);
            count += 1;
        }
    }
    DetailKept {
        slopes: (sr / su.max(1e-12)) as f32,
        fine: (fr / fu.max(1e-12)).sqrt() as f32,
        uniform_scale: k,
        cells: count,
    }
}

/// Share of the two reliefs' combined area (nodes above the ground in either) where their
/// heights differ by more than [`DIFFERENCE_MM`]. The reliefs must share a grid.
pub fn difference(a: &Relief, b: &Relief) -> f32 {
    let (mut union, mut differ) = (0usize, 0usize);
    for (ha, hb) in a.height.iter().zip(&b.height) {
        if *ha > 0.0 || *hb > 0.0 {
            union += 1;
            if (ha - hb).abs() > DIFFERENCE_MM {
                differ += 1;
            }
        }
    }
    differ as f32 / union.max(1) as f32
}

/// Share of the two reliefs' combined face footprints where their heights differ by more than
/// [`DIFFERENCE_MM`].
pub fn face_difference(a: &Relief, b: &Relief) -> f32 {
    let (mut union, mut differ) = (0usize, 0usize);
    for i in 0..a.height.len().min(b.height.len()) {
        if a.face[i] || b.face[i] {
            union += 1;
            if (a.height[i] - b.height[i]).abs() > DIFFERENCE_MM {
                differ += 1;
            }
        }
    }
    differ as f32 / union.max(1) as f32
}

/// The share of the face's footprint (nodes the mesh covers whole) where the portrait before
/// compression is the face's own height: 1 when nothing of the sculpted head stands over it.
pub fn face_leads(relief: &Relief) -> f32 {
    let (mut face, mut led) = (0usize, 0usize);
    for i in 0..relief.height.len() {
        if relief.face[i] {
            face += 1;
            if relief.face_height[i].is_finite()
                && (relief.portrait[i] - relief.face_height[i]).abs() < 1e-3
            {
                led += 1;
            }
        }
    }
    led as f32 / face.max(1) as f32
}

/// Grid step of [`frontal_hair_iou`], face lengths.
const HAIR_IOU_STEP: f32 = 0.02;
/// The grid's extent: 2 face lengths each side, from 2 above the eyes to 3 below them (the
/// shoulders).
const HAIR_IOU_S: f32 = 2.0;
const HAIR_IOU_T: (f32, f32) = (-2.0, 3.0);

/// What a cell of [`frontal_hair_cells`]'s grid holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HairCell {
    /// Beyond the photo, or inside the face's outline: not compared.
    Ignored,
    Neither,
    PhotoOnly,
    GemOnly,
    Both,
}

/// The frontal portrait's face outline in the template's canonical frame (mm): the convex
/// hull of the face mesh's vertices (model mm, the Surrey topology) placed as the gem places
/// them ([`super::face::place`]). The gem shows no hair inside it: the face covers the
/// template's hair there (the forehead up to the mesh's edge included).
pub fn frontal_face_outline(positions: &[f32]) -> Option<Vec<[f32; 2]>> {
    if positions.len() < 9 || !positions.len().is_multiple_of(3) {
        return None;
    }
    let placement = super::face::place(positions, View::Frontal);
    let mut points: Vec<[f32; 2]> = positions
        .chunks_exact(3)
        .map(|v| {
            let c = placement.to_canonical(View::Frontal, [v[0], v[1], v[2]]);
            [c[0], c[1]]
        })
        .filter(|p| p[0].is_finite() && p[1].is_finite())
        .collect();
    if points.len() < 3 {
        return None;
    }
    // Andrew's monotone chain: the lower hull left to right, then the upper right to left.
    points.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    let cross = |o: [f32; 2], a: [f32; 2], b: [f32; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let half = |points: &mut dyn Iterator<Item = [f32; 2]>| {
        let mut chain: Vec<[f32; 2]> = Vec::new();
        for p in points {
            while chain.len() >= 2
                && cross(chain[chain.len() - 2], chain[chain.len() - 1], p) <= 0.0
            {
                chain.pop();
            }
            chain.push(p);
        }
        chain.pop();
        chain
    };
    let mut hull = half(&mut points.iter().copied());
    hull.extend(half(&mut points.iter().rev().copied()));
    (hull.len() >= 3).then_some(hull)
}

/// The grid of [`frontal_hair_iou`], row-major from the top left, and its width.
pub fn frontal_hair_cells(
    labels: &crate::person::Labels,
    style: &super::HairStyle,
    gem_face: Option<&[[f32; 2]]>,
) -> (Vec<HairCell>, usize) {
    use crate::person::Label;
    let chin = labels.face_length;
    let w = (2.0 * HAIR_IOU_S / HAIR_IOU_STEP) as usize;
    let h = ((HAIR_IOU_T.1 - HAIR_IOU_T.0) / HAIR_IOU_STEP) as usize;
    let mut cells = vec![HairCell::Ignored; w * h];
    if chin.is_nan() || chin <= 0.0 {
        return (cells, w);
    }
    for j in 0..h {
        let t = HAIR_IOU_T.0 + (j as f32 + 0.5) * HAIR_IOU_STEP;
        for i in 0..w {
            let s = -HAIR_IOU_S + (i as f32 + 0.5) * HAIR_IOU_STEP;
            let p = [s * chin, t * chin];
            let label = labels.at_head(p);
            if matches!(label, Label::Outside | Label::Hat) || labels.in_face(p) {
                continue;
            }
            let photo = label == Label::Hair;
            let (u, v) = (
                s * super::FACE_LENGTH_MM,
                super::EYES_V - t * super::FACE_LENGTH_MM,
            );
            let gem = if gem_face.is_some_and(|f| crate::person::inside(f, [u, v])) {
                // Under the gem's face only a fringe is hair.
                super::template::fringe(style, u, v) > 0.0
            } else {
                super::template::sample(View::Frontal, style, u, v).hair > 0.0
            };
            cells[j * w + i] = match (photo, gem) {
                (true, true) => HairCell::Both,
                (true, false) => HairCell::PhotoOnly,
                (false, true) => HairCell::GemOnly,
                (false, false) => HairCell::Neither,
            };
        }
    }
    (cells, w)
}

/// Intersection over union of the hair a frontal gem carves for `style` and the hair the
/// photo shows (`labels`, the person pass's), both in the head frame scaled by the face's
/// length (eyes to chin): the template's eyes' level and face length
/// ([`super::EYES_V`], [`super::FACE_LENGTH_MM`]) against the photo's. Inside the face's
/// outline neither counts (the face covers the template's hair), nor does the photo beyond
/// its frame; with `gem_face` ([`frontal_face_outline`]) the gem shows no hair where its face
/// covers the template. `None` when neither shows any hair (a bald head carved bald).
pub fn frontal_hair_iou(
    labels: &crate::person::Labels,
    style: &super::HairStyle,
    gem_face: Option<&[[f32; 2]]>,
) -> Option<f32> {
    let (cells, _) = frontal_hair_cells(labels, style, gem_face);
    let both = cells.iter().filter(|c| **c == HairCell::Both).count();
    let either = cells
        .iter()
        .filter(|c| matches!(c, HairCell::Both | HairCell::PhotoOnly | HairCell::GemOnly))
        .count();
    (either > 0).then(|| both as f32 / either as f32)
}
