//! The portrait as a height field: face (rasterised in profile or from the front) joined to a
//! generated head.
//!
//! Frames and units: the face mesh comes in model millimetres (y up, face along +z). The
//! profile view (the default, see [`View`]) looks at the face's +x side, so a model point
//! (x, y, z) lands on the portrait plane at (u, v) = (-z, y) with height x above the face's
//! centre plane; the nose points towards -u (the portrait faces left). The frontal view maps
//! (x, y, z) to (u, v) = (x, y), height z + [`FRONTAL_BACK_MM`]. The grid samples the plane in
//! model millimetres.
//!
//! Because the portrait is one height field, face and head form one continuous surface with no
//! gaps or intersections by construction: outside the face's footprint the face's edge height
//! is carried outwards (nearest footprint cell, fading with distance), and the head's shape is
//! joined to it with a smooth maximum.

/// A regular grid of heights over the portrait plane, model millimetres.
#[derive(Clone, Debug)]
pub struct HeightField {
    /// Plane position of cell (0, 0)'s centre.
    pub origin: [f32; 2],
    /// Cell size, model mm.
    pub cell: f32,
    pub cols: usize,
    pub rows: usize,
    /// Height above the centre plane, row-major, mm (0 = ground).
    pub height: Vec<f32>,
    /// 1 where the generated hair dominates, 0 elsewhere (soft edge in between).
    pub hair: Vec<f32>,
    /// Cells covered by the face mesh itself (the rest is head, extension or ground).
    pub face_mask: Vec<bool>,
}

impl HeightField {
    /// Bilinear sample at a plane position; 0 outside the grid.
    pub fn sample(&self, values: &[f32], u: f32, v: f32) -> f32 {
        let fx = (u - self.origin[0]) / self.cell;
        let fy = (v - self.origin[1]) / self.cell;
        if !(fx >= 0.0 && fy >= 0.0) {
            return 0.0;
        }
        let (x0, y0) = (fx.floor() as usize, fy.floor() as usize);
        if x0 + 1 >= self.cols || y0 + 1 >= self.rows {
            return 0.0;
        }
        let (tx, ty) = (fx - x0 as f32, fy - y0 as f32);
        let at = |x: usize, y: usize| values[y * self.cols + x];
        let top = at(x0, y0) * (1.0 - tx) + at(x0 + 1, y0) * tx;
        let bottom = at(x0, y0 + 1) * (1.0 - tx) + at(x0 + 1, y0 + 1) * tx;
        top * (1.0 - ty) + bottom * ty
    }
}

/// Which way the portrait looks out of the stone.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum View {
    /// Facing left, seen from the face's +x side: the classic cameo. The plane is (u, v) =
    /// (-z, y); height is x above the face's centre plane.
    #[default]
    Profile,
    /// Facing the viewer: (u, v) = (x, y); height is z above a plane [`FRONTAL_BACK_MM`] behind
    /// the face's front (about the ears' depth).
    Frontal,
}

/// Frontal view: depth of the plane the heights are measured from, behind the face's front
/// (the Surrey face's nose tip is near z = 0 and its ears near z = -95), model mm.
pub const FRONTAL_BACK_MM: f32 = 95.0;

/// Head proportions around the Surrey face, model mm (an average adult head: length about
/// 195 mm, breadth about 150 mm, chin to crown about 230 mm).
#[derive(Clone, Copy, Debug)]
pub struct HeadShape {
    /// The view these proportions are for (the plane's axes differ).
    pub view: View,
    /// Cranium ellipsoid centre (u, v) and semi-axes (u, v, height).
    pub cranium_centre: [f32; 2],
    pub cranium_axes: [f32; 3],
    /// Neck: centre line u, half-width in u, top v, height.
    pub neck_u: f32,
    pub neck_half_width: f32,
    pub neck_top: f32,
    pub neck_height: f32,
    /// Ear: centre (u, v), semi-axes (u, v), how far it stands out from the cranium.
    pub ear_centre: [f32; 2],
    pub ear_axes: [f32; 2],
    pub ear_height: f32,
    /// Hair lies on the cranium behind this direction from the ear (degrees, 0 = straight
    /// back, 90 = straight up); the face's own forehead is never hair.
    pub hairline_angle: f32,
}

impl HeadShape {
    /// A head seen from the front: the cranium frames the face (hair above the ears' line and
    /// beside the face), the neck below; the face mesh brings its own ears.
    pub fn frontal() -> Self {
        HeadShape {
            view: View::Frontal,
            cranium_centre: [0.0, 28.0],
            cranium_axes: [82.0, 118.0, 98.0],
            neck_u: 0.0,
            neck_half_width: 50.0,
            neck_top: -70.0,
            neck_height: 72.0,
            ear_centre: [0.0, -5.0],
            ear_axes: [1.0, 1.0],
            ear_height: 0.0,
            hairline_angle: 0.0,
        }
    }
}

impl Default for HeadShape {
    /// The profile head.
    fn default() -> Self {
        HeadShape {
            view: View::Profile,
            cranium_centre: [100.0, 38.0],
            cranium_axes: [102.0, 108.0, 76.0],
            neck_u: 95.0,
            neck_half_width: 52.0,
            neck_top: -20.0,
            neck_height: 58.0,
            ear_centre: [98.0, 2.0],
            ear_axes: [17.0, 30.0],
            ear_height: 10.0,
            hairline_angle: 135.0,
        }
    }
}

/// Polynomial smooth maximum (width `k`) of two heights: equals `max(a, b)` when they differ by
/// more than `k`. The width shrinks near the ground so that two zero heights stay zero (the
/// plain formula would lift the whole ground by `k / 4`).
pub fn smooth_max(a: f32, b: f32, k: f32) -> f32 {
    let k = k.min(2.0 * a.min(b).max(0.0));
    if k <= 1e-6 {
        return a.max(b);
    }
    let h = (k - (a - b).abs()).max(0.0) / k;
    a.max(b) + h * h * k * 0.25
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Height of a half-ellipsoid (semi-axes a, b in the plane, c in height) at offset (du, dv).
fn dome(du: f32, dv: f32, a: f32, b: f32, c: f32) -> f32 {
    let q = 1.0 - (du / a).powi(2) - (dv / b).powi(2);
    if q > 0.0 { c * q.sqrt() } else { 0.0 }
}

impl HeadShape {
    /// Height of the generated head (cranium, ear, neck) and how much of it is hair (0..1).
    pub fn height(&self, u: f32, v: f32) -> (f32, f32) {
        let [cu, cv] = self.cranium_centre;
        let [a, b, c] = self.cranium_axes;
        let cranium = dome(u - cu, v - cv, a, b, c);
        // The neck: a vertical rounded column below the jaw, widening slightly downwards.
        let du = (u - self.neck_u)
            / (self.neck_half_width * (1.0 + 0.004 * (self.neck_top - v).max(0.0)));
        let neck = if du.abs() < 1.0 && v < self.neck_top + 40.0 {
            let fade_top = smoothstep(self.neck_top + 40.0, self.neck_top, v);
            self.neck_height * (1.0 - du * du).sqrt() * fade_top
        } else {
            0.0
        };
        let [eu, ev] = self.ear_centre;
        let [ea, eb] = self.ear_axes;
        let ear_q = 1.0 - ((u - eu) / ea).powi(2) - ((v - ev) / eb).powi(2);
        let ear = if ear_q > 0.0 {
            self.ear_height * ear_q.sqrt()
        } else {
            0.0
        };
        let head = smooth_max(cranium, neck, 12.0);
        let with_ear = if cranium > 0.0 {
            head.max(cranium + ear)
        } else {
            head
        };
        if self.view == View::Frontal {
            // Hair: the cranium above the ears' line (the face covers the rest of it).
            let hair = smoothstep(ev - 10.0, ev + 10.0, v) * smoothstep(0.0, 8.0, cranium);
            return (head, hair);
        }
        // Hair: the part of the cranium behind a hairline that sweeps from the top of the
        // forehead over the ear and down to the nape, measured as an angle around the ear.
        let (du, dv) = (u - eu, v - ev);
        let angle = dv.atan2(du).to_degrees();
        let behind = smoothstep(-45.0, -30.0, angle)
            * (1.0 - smoothstep(self.hairline_angle - 12.0, self.hairline_angle, angle));
        let clear_of_ear = smoothstep(0.0, 0.5, -ear_q + 0.15);
        let hair = behind * clear_of_ear * smoothstep(0.0, 8.0, cranium);
        (with_ear, hair)
    }
}

/// Rasterises triangles (model mm) into a max-height grid over the portrait plane of `view`.
/// Only what lies above the height 0 plane is drawn (profile: the near half, x >= 0). Returns
/// heights (NaN where no triangle covers a cell).
pub fn rasterise(
    positions: &[f32],
    triangles: &[[u32; 3]],
    view: View,
    origin: [f32; 2],
    cell: f32,
    cols: usize,
    rows: usize,
) -> Vec<f32> {
    let mut h = vec![f32::NAN; cols * rows];
    // Every vertex in grid coordinates (x, y in cells) and height, once: each is shared by
    // about six triangles. `None` for a non-finite vertex.
    let plane: Vec<Option<[f32; 3]>> = positions
        .chunks_exact(3)
        .map(|v| {
            let (x, y, z) = (v[0], v[1], v[2]);
            let p = match view {
                View::Profile => [(-z - origin[0]) / cell, (y - origin[1]) / cell, x],
                View::Frontal => [
                    (x - origin[0]) / cell,
                    (y - origin[1]) / cell,
                    z + FRONTAL_BACK_MM,
                ],
            };
            p.iter().all(|v| v.is_finite()).then_some(p)
        })
        .collect();
    let corner = |i: u32| plane.get(i as usize).copied().flatten();
    for t in triangles {
        let (Some(a), Some(b), Some(c)) = (corner(t[0]), corner(t[1]), corner(t[2])) else {
            continue;
        };
        // Profile: the far half of the head (x < 0) is hidden behind the near half; where its
        // outline pokes past the near half's edge it would leave slivers of zero height inside
        // the footprint (seen at the top of the forehead). Triangles that reach the centre plane
        // stay: they make the profile's outline. Frontal: nothing lies behind the back plane.
        if a[2].max(b[2]).max(c[2]) < 0.0 {
            continue;
        }
        let area = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
        if area.abs() < 1e-12 {
            continue;
        }
        // Samples sit on whole cells: the box runs from the first whole cell at or after the
        // smallest coordinate to the last at or before the largest, widened by the edge
        // tolerance below (a sample with every weight >= -1e-4 lies within 3e-4 of the
        // triangle's extent outside it).
        let (lo_x, hi_x) = (a[0].min(b[0]).min(c[0]), a[0].max(b[0]).max(c[0]));
        let (lo_y, hi_y) = (a[1].min(b[1]).min(c[1]), a[1].max(b[1]).max(c[1]));
        let slack = 3e-4 * (hi_x - lo_x).max(hi_y - lo_y) + 1e-5;
        let min_x = (lo_x - slack).ceil().max(0.0) as usize;
        let max_x = ((hi_x + slack).floor() as isize).min(cols as isize - 1);
        let min_y = (lo_y - slack).ceil().max(0.0) as usize;
        let max_y = ((hi_y + slack).floor() as isize).min(rows as isize - 1);
        if max_x < min_x as isize || max_y < min_y as isize {
            continue;
        }
        let inv_area = 1.0 / area;
        for y in min_y..=max_y as usize {
            for x in min_x..=max_x as usize {
                let (px, py) = (x as f32, y as f32);
                let w0 = ((b[0] - px) * (c[1] - py) - (c[0] - px) * (b[1] - py)) * inv_area;
                let w1 = ((c[0] - px) * (a[1] - py) - (a[0] - px) * (c[1] - py)) * inv_area;
                let w2 = 1.0 - w0 - w1;
                // A small tolerance closes hairline cracks between neighbouring triangles.
                if w0 >= -1e-4 && w1 >= -1e-4 && w2 >= -1e-4 {
                    let z = w0 * a[2] + w1 * b[2] + w2 * c[2];
                    let cell = &mut h[y * cols + x];
                    if !(cell.is_finite() && *cell >= z) {
                        *cell = z;
                    }
                }
            }
        }
    }
    h
}

/// No cell of the other class (see [`nearest_other`]).
pub const NO_CELL: [i32; 2] = [i32::MIN, i32::MIN];

/// For each cell of a grid split in two classes (`mask`, row-major), the coordinates `[x, y]`
/// of the nearest cell of the other class, or [`NO_CELL`]: two-pass chamfer propagation
/// (8 neighbours; exact enough for a soft fade). Both distance transforms, footprint to
/// outside and outside to footprint, in one pass: a neighbour of the other class offers itself,
/// one of the same class its own nearest.
pub fn nearest_other(mask: &[bool], cols: usize, rows: usize) -> Vec<[i32; 2]> {
    let mut seed = vec![NO_CELL; mask.len()];
    let dist2 = |x: usize, y: usize, s: [i32; 2]| {
        (x as i64 - i64::from(s[0])).pow(2) + (y as i64 - i64::from(s[1])).pow(2)
    };
    // Offers cell (x, y) the nearest of neighbour (jx, jy), keeping the nearer (ties keep what
    // it has: the earlier neighbour).
    let offer = |seed: &[[i32; 2]],
                 best: &mut ([i32; 2], i64),
                 x: usize,
                 y: usize,
                 jx: usize,
                 jy: usize| {
        let j = jy * cols + jx;
        let s = if mask[j] != mask[y * cols + x] {
            [jx as i32, jy as i32]
        } else {
            seed[j]
        };
        if s != NO_CELL {
            let d = dist2(x, y, s);
            if d < best.1 {
                *best = (s, d);
            }
        }
    };
    let start = |seed: &[[i32; 2]], x: usize, y: usize| {
        let s = seed[y * cols + x];
        let d = if s == NO_CELL {
            i64::MAX
        } else {
            dist2(x, y, s)
        };
        (s, d)
    };
    // Forward: left, up, up-left, up-right; backward: right, down, down-right, down-left.
    for y in 0..rows {
        for x in 0..cols {
            let mut best = start(&seed, x, y);
            if x > 0 {
                offer(&seed, &mut best, x, y, x - 1, y);
            }
            if y > 0 {
                offer(&seed, &mut best, x, y, x, y - 1);
                if x > 0 {
                    offer(&seed, &mut best, x, y, x - 1, y - 1);
                }
                if x + 1 < cols {
                    offer(&seed, &mut best, x, y, x + 1, y - 1);
                }
            }
            seed[y * cols + x] = best.0;
        }
    }
    for y in (0..rows).rev() {
        for x in (0..cols).rev() {
            let mut best = start(&seed, x, y);
            if x + 1 < cols {
                offer(&seed, &mut best, x, y, x + 1, y);
            }
            if y + 1 < rows {
                offer(&seed, &mut best, x, y, x, y + 1);
                if x + 1 < cols {
                    offer(&seed, &mut best, x, y, x + 1, y + 1);
                }
                if x > 0 {
                    offer(&seed, &mut best, x, y, x - 1, y + 1);
                }
            }
            seed[y * cols + x] = best.0;
        }
    }
    seed
}

/// Builds the portrait height field from a face mesh (model mm) and a head shape.
///
/// Inside the face's footprint the face makes the surface, blending into the head within
/// `blend_mm` of the footprint's edge; outside, the face's edge height fades to the ground
/// within `fade_mm` and the head joins it by a smooth maximum. Both sides agree on the edge,
/// so the surface is continuous there by construction.
///
/// `head` is [`head_layer`] over the same grid. A caller rebuilding after every fit keeps the
/// head layer and [`head_only`] and calls [`portrait_over`], which computes only the face's
/// neighbourhood.
#[allow(clippy::too_many_arguments)]
pub fn portrait(
    positions: &[f32],
    triangles: &[[u32; 3]],
    view: View,
    head: &[(f32, f32)],
    origin: [f32; 2],
    cell: f32,
    cols: usize,
    rows: usize,
    fade_mm: f32,
    blend_mm: f32,
) -> HeightField {
    let base = head_only(head, origin, cell, cols, rows);
    portrait_over(positions, triangles, view, head, &base, fade_mm, blend_mm).0
}

/// The cells (inclusive bounds) where a portrait differs from the head alone.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Window {
    pub x0: usize,
    pub y0: usize,
    pub x1: usize,
    pub y1: usize,
}

/// Smoothing passes of the portrait's heights (each reaches one cell further).
const SMOOTH_PASSES: usize = 2;
/// Height-field smooth maximum width where face and head join, model mm.
const JOIN: f32 = 10.0;

/// The portrait field of the head alone (no face), over a grid with head layer `head`.
pub fn head_only(
    head: &[(f32, f32)],
    origin: [f32; 2],
    cell: f32,
    cols: usize,
    rows: usize,
) -> HeightField {
    let mut height: Vec<f32> = head.iter().map(|&(h, _)| h).collect();
    height.resize(cols * rows, 0.0);
    let mut hair: Vec<f32> = head
        .iter()
        .map(|&(h, w)| w * smoothstep(0.0, 6.0, 0.5 * h))
        .collect();
    hair.resize(cols * rows, 0.0);
    smooth(&mut height, cols, rows, SMOOTH_PASSES);
    HeightField {
        origin,
        cell,
        cols,
        rows,
        height,
        hair,
        face_mask: vec![false; cols * rows],
    }
}

/// [`portrait`] from `base` = [`head_only`] of the same grid: the face changes only its
/// footprint grown by the fade and the smoothing, so only that window is computed (the rest is
/// copied, bit-identical to computing it). Also returns the window (`None`: no footprint).
pub fn portrait_over(
    positions: &[f32],
    triangles: &[[u32; 3]],
    view: View,
    head: &[(f32, f32)],
    base: &HeightField,
    fade_mm: f32,
    blend_mm: f32,
) -> (HeightField, Option<Window>) {
    let (origin, cell, cols, rows) = (base.origin, base.cell, base.cols, base.rows);
    let face = rasterise(positions, triangles, view, origin, cell, cols, rows);
    let (mut x0, mut y0, mut x1, mut y1) = (cols, rows, 0, 0);
    for (i, v) in face.iter().enumerate() {
        if v.is_finite() {
            let (x, y) = (i % cols, i / cols);
            (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
        }
    }
    let mut field = base.clone();
    if x0 > x1 {
        return (field, None);
    }
    // The face reaches `fade` beyond its footprint, smoothing 2 cells further; the window keeps
    // 2 more cells as an apron whose smoothed values (edges clamped) are not used.
    let reach = (fade_mm / cell).ceil() as usize + 1 + SMOOTH_PASSES;
    let apron = SMOOTH_PASSES;
    let (wx0, wy0) = (
        x0.saturating_sub(reach + apron),
        y0.saturating_sub(reach + apron),
    );
    let (wx1, wy1) = (
        (x1 + reach + apron).min(cols - 1),
        (y1 + reach + apron).min(rows - 1),
    );
    let (w, h) = (wx1 - wx0 + 1, wy1 - wy0 + 1);
    let mut crop = Vec::with_capacity(w * h);
    for y in wy0..=wy1 {
        crop.extend_from_slice(&face[y * cols + wx0..=y * cols + wx1]);
    }
    // For each cell near the footprint, the nearest cell across its edge: outside, the nearest
    // footprint cell (whose height fades out); inside, the nearest outside cell (how deep it
    // lies). Seeds matter only within the fade around the footprint: search the footprint's
    // box grown by the fade, not the window.
    let m = (fade_mm / cell).ceil() as usize + 1;
    let (sx0, sy0) = (
        x0.saturating_sub(m).max(wx0) - wx0,
        y0.saturating_sub(m).max(wy0) - wy0,
    );
    let (sx1, sy1) = ((x1 + m).min(wx1) - wx0, (y1 + m).min(wy1) - wy0);
    let sw = sx1 - sx0 + 1;
    let mut footprint = Vec::with_capacity(sw * (sy1 - sy0 + 1));
    for y in sy0..=sy1 {
        footprint.extend(
            crop[y * w + sx0..=y * w + sx1]
                .iter()
                .map(|v| v.is_finite()),
        );
    }
    let across = nearest_other(&footprint, sw, sy1 - sy0 + 1);
    let mut height = vec![0f32; w * h];
    let mut hair = vec![0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let k = y * w + x;
            let (head_h, hair_w) = head
                .get((wy0 + y) * cols + wx0 + x)
                .copied()
                .unwrap_or((0.0, 0.0));
            // The nearest cell across the footprint's edge, as (distance mm, window index).
            let inside_search = (sx0..=sx1).contains(&x) && (sy0..=sy1).contains(&y);
            let other = if inside_search {
                let s = across[(y - sy0) * sw + x - sx0];
                (s != NO_CELL).then(|| {
                    let (dx, dy) = (
                        (x - sx0) as f32 - s[0] as f32,
                        (y - sy0) as f32 - s[1] as f32,
                    );
                    (
                        (dx * dx + dy * dy).sqrt() * cell,
                        (sy0 + s[1] as usize) * w + sx0 + s[0] as usize,
                    )
                })
            } else {
                None
            };
            let (hk, face_weight) = if crop[k].is_finite() {
                let f = crop[k].max(0.0);
                let depth = other.map_or(f32::INFINITY, |(d, _)| d);
                let wgt = smoothstep(0.0, blend_mm, depth);
                (smooth_max(f, head_h, JOIN) * (1.0 - wgt) + f * wgt, wgt)
            } else {
                let edge = other.map_or(0.0, |(d, s)| {
                    crop[s].max(0.0) * (1.0 - smoothstep(0.0, fade_mm, d))
                });
                (smooth_max(edge, head_h, JOIN), 0.0)
            };
            height[k] = hk;
            // Hair only where the head, not the face, makes the surface.
            hair[k] =
                hair_w * (1.0 - face_weight) * smoothstep(0.0, 6.0, hk - 0.5 * head_h.min(hk));
        }
    }
    smooth(&mut height, w, h, SMOOTH_PASSES);
    // Copy all but the apron (except where the window meets the grid's edge, where the
    // clamped smoothing is the grid's own).
    let cx0 = if wx0 > 0 { apron } else { 0 };
    let cy0 = if wy0 > 0 { apron } else { 0 };
    let cx1 = if wx1 < cols - 1 { w - 1 - apron } else { w - 1 };
    let cy1 = if wy1 < rows - 1 { h - 1 - apron } else { h - 1 };
    for ly in cy0..=cy1 {
        for lx in cx0..=cx1 {
            let (k, i) = (ly * w + lx, (wy0 + ly) * cols + wx0 + lx);
            field.height[i] = height[k];
            field.hair[i] = hair[k];
            field.face_mask[i] = crop[k].is_finite();
        }
    }
    let window = Window {
        x0: wx0 + cx0,
        y0: wy0 + cy0,
        x1: wx0 + cx1,
        y1: wy0 + cy1,
    };
    (field, Some(window))
}

/// [`HeadShape::height`] at every node of a grid (`origin`, `cell` in model mm, row-major).
pub fn head_layer(
    head: &HeadShape,
    origin: [f32; 2],
    cell: f32,
    cols: usize,
    rows: usize,
) -> Vec<(f32, f32)> {
    (0..cols * rows)
        .map(|i| {
            let (x, y) = (i % cols, i / cols);
            head.height(origin[0] + x as f32 * cell, origin[1] + y as f32 * cell)
        })
        .collect()
}

/// Binomial (1-2-1) smoothing, `passes` times, to remove rasterisation noise.
fn smooth(values: &mut [f32], cols: usize, rows: usize, passes: usize) {
    let mut tmp = vec![0f32; values.len()];
    for _ in 0..passes {
        for y in 0..rows {
            for x in 0..cols {
                let at = |xx: usize| values[y * cols + xx];
                tmp[y * cols + x] =
                    0.25 * at(x.saturating_sub(1)) + 0.5 * at(x) + 0.25 * at((x + 1).min(cols - 1));
            }
        }
        for y in 0..rows {
            for x in 0..cols {
                let at = |yy: usize| tmp[yy * cols + x];
                values[y * cols + x] =
                    0.25 * at(y.saturating_sub(1)) + 0.5 * at(y) + 0.25 * at((y + 1).min(rows - 1));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pseudo-random masks: blobs and speckle, from a small LCG (no dependency).
    fn masks() -> Vec<(Vec<bool>, usize, usize)> {
        let mut state = 12345u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 33) as f32 / (1u64 << 31) as f32
        };
        let mut out = Vec::new();
        for (cols, rows) in [(1, 1), (1, 7), (9, 1), (23, 17), (40, 31)] {
            for density in [0.02, 0.3, 0.9] {
                let (cx, cy, r) = (next() * cols as f32, next() * rows as f32, next() * 12.0);
                let mask = (0..cols * rows)
                    .map(|i| {
                        let (x, y) = ((i % cols) as f32, (i / cols) as f32);
                        (x - cx).hypot(y - cy) < r || next() < density * 0.2
                    })
                    .collect();
                out.push((mask, cols, rows));
            }
        }
        out
    }

    #[test]
    fn nearest_other_finds_a_near_cell_of_the_other_class() {
        let mut worst = 0f32;
        for (mask, cols, rows) in masks() {
            let found = nearest_other(&mask, cols, rows);
            for i in 0..cols * rows {
                let (x, y) = ((i % cols) as f32, (i / cols) as f32);
                let truth = (0..cols * rows)
                    .filter(|&j| mask[j] != mask[i])
                    .map(|j| (x - (j % cols) as f32).hypot(y - (j / cols) as f32))
                    .min_by(f32::total_cmp);
                match (truth, found[i]) {
                    (None, s) => assert_eq!(s, NO_CELL, "cell {i}: nothing to find"),
                    (Some(_), NO_CELL) => panic!("cell {i}: a cell of the other class was missed"),
                    (Some(d), s) => {
                        let j = s[1] as usize * cols + s[0] as usize;
                        assert_ne!(mask[j], mask[i], "cell {i}: {s:?} is of its own class");
                        let got = (x - s[0] as f32).hypot(y - s[1] as f32);
                        worst = worst.max(got - d);
                    }
                }
            }
        }
        // Two-pass 8-neighbour propagation misses the nearest by a fraction of a cell at most.
        assert!(worst < 0.5, "chamfer error {worst} cells");
    }

    #[test]
    fn rasterise_covers_cells_on_edges_and_corners() {
        // A right triangle with corners on cell centres (profile view: u = -z, v = y, height x).
        let positions = [5.0, 1.0, -1.0, 5.0, 1.0, -4.0, 5.0, 4.0, -1.0];
        let h = rasterise(
            &positions,
            &[[0, 1, 2]],
            View::Profile,
            [0.0, 0.0],
            1.0,
            6,
            6,
        );
        let covered: Vec<(usize, usize)> = (0..36)
            .filter(|&i| h[i].is_finite())
            .map(|i| (i % 6, i / 6))
            .collect();
        // Cells with u in 1..=4, v in 1..=4 and (u - 1) + (v - 1) <= 3: ten, corners included.
        let expected: Vec<(usize, usize)> = (0..36)
            .map(|i| (i % 6, i / 6))
            .filter(|&(u, v)| u >= 1 && v >= 1 && (u - 1) + (v - 1) <= 3)
            .collect();
        assert_eq!(covered, expected);
        assert!(
            h.iter()
                .filter(|v| v.is_finite())
                .all(|&v| (v - 5.0).abs() < 1e-5)
        );
    }
}
