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
    let n = positions.len() / 3;
    let plane = |i: u32| -> Option<[f32; 3]> {
        let i = i as usize;
        if i >= n {
            return None;
        }
        let (x, y, z) = (positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]);
        let p = match view {
            View::Profile => [(-z - origin[0]) / cell, (y - origin[1]) / cell, x],
            View::Frontal => [
                (x - origin[0]) / cell,
                (y - origin[1]) / cell,
                z + FRONTAL_BACK_MM,
            ],
        };
        p.iter().all(|v| v.is_finite()).then_some(p)
    };
    for t in triangles {
        let (Some(a), Some(b), Some(c)) = (plane(t[0]), plane(t[1]), plane(t[2])) else {
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
        let min_x = a[0].min(b[0]).min(c[0]).floor().max(0.0) as usize;
        let max_x = (a[0].max(b[0]).max(c[0]).ceil() as isize).min(cols as isize - 1);
        let min_y = a[1].min(b[1]).min(c[1]).floor().max(0.0) as usize;
        let max_y = (a[1].max(b[1]).max(c[1]).ceil() as isize).min(rows as isize - 1);
        if max_x < 0 || max_y < 0 {
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

/// For each cell, the index of the nearest cell with a finite value (two-pass chamfer
/// propagation of nearest seeds; exact enough for a soft fade). `None` if there is no seed.
pub fn nearest_seeds(values: &[f32], cols: usize, rows: usize) -> Vec<Option<usize>> {
    // Seeds kept as coordinates (no division per comparison); `i32::MIN` marks "none yet".
    const NONE: i32 = i32::MIN;
    let mut sx = vec![NONE; values.len()];
    let mut sy = vec![NONE; values.len()];
    for (i, v) in values.iter().enumerate() {
        if v.is_finite() {
            sx[i] = (i % cols) as i32;
            sy[i] = (i / cols) as i32;
        }
    }
    let relax = |sx: &mut [i32], sy: &mut [i32], x: usize, y: usize, j: usize| {
        let i = y * cols + x;
        if sx[j] == NONE {
            return;
        }
        let (xi, yi) = (x as i64, y as i64);
        let d2 = |ax: i32, ay: i32| (xi - i64::from(ax)).pow(2) + (yi - i64::from(ay)).pow(2);
        if sx[i] == NONE || d2(sx[j], sy[j]) < d2(sx[i], sy[i]) {
            sx[i] = sx[j];
            sy[i] = sy[j];
        }
    };
    for y in 0..rows {
        for x in 0..cols {
            let i = y * cols + x;
            if x > 0 {
                relax(&mut sx, &mut sy, x, y, i - 1);
            }
            if y > 0 {
                relax(&mut sx, &mut sy, x, y, i - cols);
                if x > 0 {
                    relax(&mut sx, &mut sy, x, y, i - cols - 1);
                }
                if x + 1 < cols {
                    relax(&mut sx, &mut sy, x, y, i - cols + 1);
                }
            }
        }
    }
    for y in (0..rows).rev() {
        for x in (0..cols).rev() {
            let i = y * cols + x;
            if x + 1 < cols {
                relax(&mut sx, &mut sy, x, y, i + 1);
            }
            if y + 1 < rows {
                relax(&mut sx, &mut sy, x, y, i + cols);
                if x + 1 < cols {
                    relax(&mut sx, &mut sy, x, y, i + cols + 1);
                }
                if x > 0 {
                    relax(&mut sx, &mut sy, x, y, i + cols - 1);
                }
            }
        }
    }
    sx.iter()
        .zip(&sy)
        .map(|(&x, &y)| (x != NONE).then(|| y as usize * cols + x as usize))
        .collect()
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
    let to_grid = |k: usize| (wy0 + k / w) * cols + wx0 + k % w;
    let crop: Vec<f32> = (0..w * h).map(|k| face[to_grid(k)]).collect();
    let complement: Vec<f32> = crop
        .iter()
        .map(|v| if v.is_finite() { f32::NAN } else { 0.0 })
        .collect();
    // Nearest footprint cell (outside it) and nearest non-footprint cell (inside), in window
    // indices. Seeds matter only within the fade around the footprint: search the footprint's
    // box grown by the fade (two passes over that, not the window).
    let m = (fade_mm / cell).ceil() as usize + 1;
    let (sx0, sy0) = (
        x0.saturating_sub(m).max(wx0) - wx0,
        y0.saturating_sub(m).max(wy0) - wy0,
    );
    let (sx1, sy1) = ((x1 + m).min(wx1) - wx0, (y1 + m).min(wy1) - wy0);
    let (sw, sh) = (sx1 - sx0 + 1, sy1 - sy0 + 1);
    let to_window = |j: usize| (sy0 + j / sw) * w + sx0 + j % sw;
    let mut outside_seeds = vec![None; w * h];
    let mut inside_seeds = vec![None; w * h];
    for (seeds, values) in [
        (&mut outside_seeds, &crop),
        (&mut inside_seeds, &complement),
    ] {
        let sub: Vec<f32> = (0..sw * sh).map(|j| values[to_window(j)]).collect();
        for (j, seed) in nearest_seeds(&sub, sw, sh).into_iter().enumerate() {
            seeds[to_window(j)] = seed.map(to_window);
        }
    }
    let dist = |k: usize, s: usize| {
        let (dx, dy) = (
            (k % w) as f32 - (s % w) as f32,
            (k / w) as f32 - (s / w) as f32,
        );
        (dx * dx + dy * dy).sqrt() * cell
    };
    let mut height = vec![0f32; w * h];
    let mut hair = vec![0f32; w * h];
    for k in 0..w * h {
        let (head_h, hair_w) = head.get(to_grid(k)).copied().unwrap_or((0.0, 0.0));
        let (hk, face_weight) = if crop[k].is_finite() {
            let f = crop[k].max(0.0);
            let depth = inside_seeds[k].map_or(f32::INFINITY, |s| dist(k, s));
            let wgt = smoothstep(0.0, blend_mm, depth);
            (smooth_max(f, head_h, JOIN) * (1.0 - wgt) + f * wgt, wgt)
        } else {
            let edge = outside_seeds[k].map_or(0.0, |s| {
                crop[s].max(0.0) * (1.0 - smoothstep(0.0, fade_mm, dist(k, s)))
            });
            (smooth_max(edge, head_h, JOIN), 0.0)
        };
        height[k] = hk;
        // Hair only where the head, not the face, makes the surface.
        hair[k] = hair_w * (1.0 - face_weight) * smoothstep(0.0, 6.0, hk - 0.5 * head_h.min(hk));
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
