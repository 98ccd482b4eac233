//! The face's shape read from the photo's shading (analysis by synthesis, the photometric step
//! after the landmark fit): 63 shape components fitted to 68 points say where the features
//! are, not how the cheek turns, how deep the eyes sit under the brow, the nose's bridge, the
//! jowls. The photo shows those as shading. Here the fitted face is drawn under a light fitted
//! to the photo, and a smooth depth correction is solved so that the drawing's shading matches
//! the photo's on the skin; the correction goes onto the mesh's vertices along the camera's
//! axis, so every view of the gem (profile, frontal) carries it.
//!
//! The model: brightness = `a + b . n` (one directional light and an ambient term, the same
//! light as [`crate::identity::Scene`]; albedo constant over the skin, folded into `a` and
//! `b`). The unknown is a depth offset `d` on a grid over the face (linearised around the
//! fitted normals, one Gauss-Newton step: the offsets are small); its regularisers keep it a
//! band of the face's shape: a thin-plate term removes what is finer than a fifth of the
//! eyes' distance (pores, noise), a pull towards zero what is broader than three of them
//! (that is the shape model's, and the light's own errors live there). Only skin cells vote: the
//! eyes, brows, nostrils and lips (dark by colour, not by shape) are left out by their
//! landmarks, and cells whose brightness the light cannot explain (a mole, stubble, a highlight,
//! a cast shadow) are weighted down (Cauchy weights on the light fit's residual).
//!
//! Units: photo pixels (x right, y down); grid cells of `iod / cells_per_iod` pixels; normals
//! in the camera's frame (y up, +z towards the camera); offsets in model millimetres towards
//! the camera. Pure computation.
//!
//! Length: 729 lines of code (one method read top to bottom: the drawing over the photo's grid,
//! the light's fit, the depth correction's solve and its transfer to the vertices share the
//! grid and its masks), then its unit tests (207 lines), kept beside what they test.

use image::GrayImage;
use nalgebra::Vector3;

use crate::fit::Pose;
use crate::photo_grid::{Grid, bilinear_grey, polyline_distance};
use crate::raster::{self, lambert};

/// Gauss-Newton rounds of the depth solve: offsets of a few millimetres turn the normals a
/// few degrees, where the linearised shading is close (a second round moved the synthetic
/// faces' normals by hundredths of a degree and cost 60 % more).
const ROUNDS: usize = 1;

/// How strongly and over which band the shading moves the face.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadingParams {
    /// The recovered offsets times this (1: as recovered; 0: none, and no solve: the light
    /// and [`ShadingFit::expected`] alone).
    pub strength: f32,
    /// Grid cells per inter-ocular distance (eye centre to eye centre).
    pub cells_per_iod: f32,
    /// Shortest and longest wavelength kept, in inter-ocular distances.
    pub shortest_iod: f32,
    pub longest_iod: f32,
    /// The largest offset, model mm (either way).
    pub limit_mm: f32,
}

impl Default for ShadingParams {
    /// Features from a fifth of the eyes' distance (a fold, the eyelid's crease) to three of
    /// them (a cheekbone, the brow ridge, the jowls: a narrower band lost most of a cheek's
    /// rise in the synthetic test); offsets up to 4 mm (a deep-set eye).
    fn default() -> Self {
        ShadingParams {
            strength: 1.0,
            cells_per_iod: 20.0,
            shortest_iod: 0.2,
            longest_iod: 3.0,
            limit_mm: 4.0,
        }
    }
}

impl ShadingParams {
    /// The light on the face and what it makes of each place ([`ShadingFit::expected`]),
    /// without solving for the offsets (all 0).
    pub fn light_only() -> Self {
        ShadingParams {
            strength: 0.0,
            ..Default::default()
        }
    }
}

/// What the shading said.
#[derive(Clone, Debug, PartialEq)]
pub struct ShadingFit {
    /// Per vertex: model mm towards the camera ([`displace`] moves the mesh by them).
    pub offsets: Vec<f32>,
    /// The light fitted to the skin: brightness ~ `light[0] + light[1..4] . n` (0..1).
    pub light: [f32; 4],
    /// Skin cells that voted (weight above a half).
    pub cells: usize,
    /// Weighted RMS of the photo's brightness minus the drawing's on the skin (0..1), before
    /// and after the offsets.
    pub residual_before: f32,
    pub residual_after: f32,
    /// The brightness the fitted light gives the fitted face, over the face: what its shading
    /// alone makes of each place (a chin turned from the light is darker than the cheek
    /// without being hair).
    pub expected: ShadingMap,
}

/// The light's brightness on the fitted face per photo point ([`ShadingFit::expected`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ShadingMap {
    origin: [f32; 2],
    step: f32,
    cols: usize,
    rows: usize,
    /// 0..1 per cell, NaN where the face is not.
    values: Vec<f32>,
}

impl crate::person::Shading for ShadingMap {
    fn brightness(&self, x: f32, y: f32) -> f32 {
        self.at(x, y)
    }
}

impl ShadingMap {
    /// The expected brightness at photo point (x, y) (pixels): bilinear over the cells the
    /// face covers, NaN off it.
    pub fn at(&self, x: f32, y: f32) -> f32 {
        let (u, v) = (
            (x - self.origin[0]) / self.step,
            (y - self.origin[1]) / self.step,
        );
        if !(u >= 0.0 && v >= 0.0 && u <= (self.cols - 1) as f32 && v <= (self.rows - 1) as f32) {
            return f32::NAN;
        }
        let (c0, r0) = (u as usize, v as usize);
        let (c1, r1) = ((c0 + 1).min(self.cols - 1), (r0 + 1).min(self.rows - 1));
        let (fx, fy) = (u - c0 as f32, v - r0 as f32);
        let (mut sum, mut weight) = (0.0, 0.0);
        for (c, r, w) in [
            (c0, r0, (1.0 - fx) * (1.0 - fy)),
            (c1, r0, fx * (1.0 - fy)),
            (c0, r1, (1.0 - fx) * fy),
            (c1, r1, fx * fy),
        ] {
            let value = self.values[r * self.cols + c];
            if value.is_finite() {
                sum += w * value;
                weight += w;
            }
        }
        if weight > 1e-3 {
            sum / weight
        } else {
            f32::NAN
        }
    }
}

/// Why no shape was read from the shading.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ShadingError {
    #[error("expected 68 finite landmarks")]
    Landmarks,
    #[error("the photo is empty")]
    EmptyPhoto,
    #[error("the mesh is empty or not finite")]
    Mesh,
    #[error("the eyes are too close together ({0:.1} px) to read the face's shading")]
    TooSmall(f32),
    #[error("too little skin is seen ({0} cells) to read its shading")]
    LittleSkin(usize),
    #[error("the face is lit too flatly (its shading spreads {0:.3} of white) to read its shape")]
    FlatLight(f32),
}

/// Reads the depth offsets of `mesh` (model mm, the fitted face with its expression, seen
/// through `pose`) from the shading of `photo` (brightness) around these 68 landmarks.
pub fn fit(
    photo: &GrayImage,
    landmarks: &[[f32; 2]],
    mesh: &[f32],
    triangles: &[[u32; 3]],
    pose: &Pose,
    params: &ShadingParams,
) -> Result<ShadingFit, ShadingError> {
    if photo.width() == 0 || photo.height() == 0 {
        return Err(ShadingError::EmptyPhoto);
    }
    if mesh.len() < 9 || !mesh.len().is_multiple_of(3) || mesh.iter().any(|v| !v.is_finite()) {
        return Err(ShadingError::Mesh);
    }
    let iod = crate::identity::eye_distance(landmarks).ok_or(ShadingError::Landmarks)?;
    if iod.is_nan() || iod < 20.0 {
        return Err(ShadingError::TooSmall(iod));
    }
    let cells_per_iod = params.cells_per_iod.clamp(8.0, 64.0);
    let step = iod / cells_per_iod;
    // The landmarks' box, with the forehead above the brows.
    let grid = Grid::around(landmarks, step, 0.3 * iod, 0.9 * iod, 0.3 * iod);
    let (cols, rows) = (grid.cols, grid.rows);
    let n = cols * rows;

    // The fitted face drawn into the grid: its normals per cell (camera frame).
    let normals = raster::vertex_normals(mesh, triangles);
    let rot = &pose.rotation;
    let turn = |v: [f32; 3]| -> [f32; 3] {
        let q = rot * Vector3::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2]));
        [q.x as f32, q.y as f32, q.z as f32]
    };
    let points: Vec<Option<[f32; 3]>> = mesh
        .chunks_exact(3)
        .map(|v| {
            let p = pose.project(&Vector3::new(
                f64::from(v[0]),
                f64::from(v[1]),
                f64::from(v[2]),
            ));
            let depth = turn([v[0], v[1], v[2]])[2];
            let [gx, gy] = grid.to_cell([p.x as f32, p.y as f32]);
            // The rasteriser samples cell centres at + 0.5.
            let g = [gx + 0.5, gy + 0.5, depth];
            g.iter().all(|c| c.is_finite()).then_some(g)
        })
        .collect();
    let turned: Vec<[f32; 3]> = normals.iter().map(|&v| turn(v)).collect();
    let mut cell_normal = [vec![f32::NAN; n], vec![f32::NAN; n], vec![f32::NAN; n]];
    for (k, out) in cell_normal.iter_mut().enumerate() {
        raster::shade_points(&points, &turned, triangles, &|v| v[k], cols, rows, out);
    }

    // The photo's brightness per cell (the mean over the cell's footprint) and the skin's
    // weight.
    let grey = |x: f32, y: f32| bilinear_grey(photo, x, y);
    let k = (step.ceil() as usize).clamp(1, 4);
    let skin = Skin::new(landmarks, iod);
    let mut intensity = vec![0f32; n];
    let mut weight = vec![0f32; n];
    let mut normal = vec![[0f32; 3]; n];
    for i in 0..n {
        let nz = cell_normal[2][i];
        if !nz.is_finite() {
            continue;
        }
        let nn = [cell_normal[0][i], cell_normal[1][i], nz];
        normal[i] = nn;
        let [x, y] = grid.at(i);
        let mut s = 0.0;
        for a in 0..k {
            for b in 0..k {
                let ox = ((a as f32 + 0.5) / k as f32 - 0.5) * step;
                let oy = ((b as f32 + 0.5) / k as f32 - 0.5) * step;
                s += grey(x + ox, y + oy);
            }
        }
        intensity[i] = s / (k * k) as f32;
        weight[i] = skin.weight([x, y]) * smoothstep(0.25, 0.5, nz);
    }
    let voting = weight.iter().filter(|&&w| w > 0.5).count();
    if voting < 100 {
        return Err(ShadingError::LittleSkin(voting));
    }

    // The light, robustly: Cauchy weights on the residual (scale from its median absolute
    // deviation) leave out what the light cannot explain.
    let mut robust = vec![1f32; n];
    let mut light = [0f32; 4];
    let mut sigma = 0.0;
    for _ in 0..4 {
        light = raster::fit_light((0..n).map(|i| {
            (
                normal[i],
                f64::from(intensity[i]),
                f64::from(weight[i] * robust[i]),
            )
        }))
        .ok_or(ShadingError::FlatLight(0.0))?;
        let res: Vec<f32> = (0..n)
            .filter(|&i| weight[i] > 0.0)
            .map(|i| (intensity[i] - lambert(&light, normal[i])).abs())
            .collect();
        sigma = (crate::person::median(res).unwrap_or(0.0) * 1.4826).max(0.01);
        for i in 0..n {
            let r = (intensity[i] - lambert(&light, normal[i])) / (2.5 * sigma);
            robust[i] = 1.0 / (1.0 + r * r);
        }
    }
    let strength = (light[1] * light[1] + light[2] * light[2] + light[3] * light[3]).sqrt();
    // What the light makes of the skin's turning: its spread over the skin (a flat-lit face
    // is one grey whatever its shape).
    let (mut m1, mut m2, mut mw) = (0.0f64, 0.0f64, 0.0f64);
    for i in 0..n {
        let ww = f64::from(weight[i] * robust[i]);
        let s = f64::from(lambert(&light, normal[i]));
        m1 += ww * s;
        m2 += ww * s * s;
        mw += ww;
    }
    let spread = if mw > 0.0 {
        ((m2 / mw - (m1 / mw).powi(2)).max(0.0)).sqrt() as f32
    } else {
        0.0
    };
    if !(spread >= 0.02 && strength >= 0.05) {
        return Err(ShadingError::FlatLight(spread));
    }
    // The shape's own votes: what the light leaves unexplained is the shape's signal, so only
    // far outliers (a mole, a highlight: several times the skin's spread, and more than a
    // twelfth of white) are weighted down. Normalised by the light's strength, so the band is
    // the same for a dim and a bright photo.
    let c = (4.0 * sigma).max(0.08);
    let votes: Vec<f32> = (0..n)
        .map(|i| {
            let r = (intensity[i] - lambert(&light, normal[i])) / c;
            weight[i] / (1.0 + r * r)
        })
        .collect();
    let w: Vec<f32> = votes.iter().map(|v| v / (strength * strength)).collect();

    // The fitted face's depth slopes per cell (depth in cells per cell; x right, y down):
    // n ~ (-zx, zy, 1) with y up.
    let base: Vec<[f32; 2]> = normal
        .iter()
        .map(|v| {
            if v[2] > 0.2 {
                [-v[0] / v[2], v[1] / v[2]]
            } else {
                [0.0, 0.0]
            }
        })
        .collect();
    let residual = |d: &[f32]| -> f32 {
        let (mut num, mut den) = (0.0f64, 0.0f64);
        for i in 0..n {
            if w[i] <= 0.0 {
                continue;
            }
            let [gx, gy] = slopes(d, i, cols, rows);
            let (s, _, _) = shading(&light, base[i][0] + gx, base[i][1] + gy);
            let e = f64::from(intensity[i] - s);
            let ww = f64::from(votes[i]);
            num += ww * e * e;
            den += ww;
        }
        if den > 0.0 {
            (num / den).sqrt() as f32
        } else {
            0.0
        }
    };
    let before = residual(&vec![0.0; n]);

    // Regularisers per cell: a wave of k radians a cell passes where the data's k^2 beats
    // both lambda0 (longer waves) and lambda_s k^4 (shorter ones).
    let k_lo = std::f32::consts::TAU / (params.longest_iod.max(0.05) * cells_per_iod);
    let k_hi = std::f32::consts::TAU / (params.shortest_iod.max(0.01) * cells_per_iod);
    let lambda0 = k_lo * k_lo;
    let lambda_s = 1.0 / (k_hi * k_hi);

    let mut d = vec![0f32; n];
    // Strength 0 asks for the light alone: the offsets would all be 0.
    let rounds = if params.strength == 0.0 { 0 } else { ROUNDS };
    for _ in 0..rounds {
        // Linearise around the current depth.
        let mut sx = vec![0f32; n];
        let mut sy = vec![0f32; n];
        let mut r = vec![0f32; n];
        for i in 0..n {
            if w[i] <= 0.0 {
                continue;
            }
            let [gx, gy] = slopes(&d, i, cols, rows);
            let (s, dsx, dsy) = shading(&light, base[i][0] + gx, base[i][1] + gy);
            sx[i] = dsx;
            sy[i] = dsy;
            r[i] = intensity[i] - s;
        }
        let op = Operator {
            cols,
            rows,
            sx: &sx,
            sy: &sy,
            w: &w,
            lambda0,
            lambda_s,
        };
        // Right-hand side: A^T W r - (lambda_s L^T L + lambda0) d.
        let wr: Vec<f32> = (0..n).map(|i| w[i] * r[i]).collect();
        let mut rhs = op.a_t(&wr);
        let reg = op.regulariser(&d);
        for i in 0..n {
            rhs[i] -= reg[i];
        }
        let mut scratch = Scratch::new(rhs.len());
        let step_d = crate::cg::conjugate_gradient(
            |p, out| op.apply_into(p, out, &mut scratch),
            &rhs,
            3000,
            1e-3,
        );
        for i in 0..n {
            d[i] += step_d[i];
        }
    }
    let after = residual(&d);

    // Cells -> model mm, faded to nothing at the skin's edge (ears, hairline, neck).
    let mm_per_cell = step / pose.scale as f32;
    let limit = params.limit_mm.max(0.0);
    let fade: Vec<f32> = (0..n).map(|i| skin.extent(grid.at(i))).collect();
    let fade = crate::gem::blur::blur(&fade, cols, rows, 0.08 * cells_per_iod);
    let map: Vec<f32> = (0..n)
        .map(|i| (d[i] * mm_per_cell * params.strength * fade[i]).clamp(-limit, limit))
        .collect();
    let offsets = points
        .iter()
        .zip(&turned)
        .map(|(p, nv)| match p {
            Some(p) if nv[2] > 0.1 => {
                smoothstep(0.1, 0.35, nv[2]) * sample(&map, cols, rows, p[0] - 0.5, p[1] - 0.5)
            }
            _ => 0.0,
        })
        .collect();
    Ok(ShadingFit {
        offsets,
        light,
        cells: voting,
        residual_before: before,
        residual_after: after,
        expected: ShadingMap {
            origin: grid.origin,
            step: grid.step,
            cols,
            rows,
            values: (0..n)
                .map(|i| {
                    if cell_normal[2][i].is_finite() {
                        lambert(&light, normal[i]).clamp(0.0, 1.0)
                    } else {
                        f32::NAN
                    }
                })
                .collect(),
        },
    })
}

/// Moves each vertex of `mesh` (model mm, any pose-free mesh of the fitted face's topology) by
/// its offset along the camera's axis of `pose`; a mesh of another size is left alone.
pub fn displace(mesh: &mut [f32], offsets: &[f32], pose: &Pose) {
    add(mesh, &displacement(offsets, pose));
}

/// The offsets as model-frame vectors (x, y, z per vertex, mm): along the camera's axis of the
/// `pose` they were read under, so they can be kept and added to later meshes of the same face
/// seen from elsewhere ([`add`]). Non-finite offsets move nothing.
pub fn displacement(offsets: &[f32], pose: &Pose) -> Vec<f32> {
    let axis = pose.rotation.row(2);
    let axis = [axis[0] as f32, axis[1] as f32, axis[2] as f32];
    offsets
        .iter()
        .flat_map(|&o| {
            let o = if o.is_finite() { o } else { 0.0 };
            axis.map(|a| o * a)
        })
        .collect()
}

/// Adds a [`displacement`] to `mesh`; a mesh of another size is left alone.
pub fn add(mesh: &mut [f32], displacement: &[f32]) {
    if mesh.len() != displacement.len() {
        return;
    }
    for (v, d) in mesh.iter_mut().zip(displacement) {
        *v += d;
    }
}

/// Where the skin is, from the 68 landmarks: inside the jaw and a forehead above the brows,
/// outside the eyes, brows, nostrils and lips (each grown a little).
struct Skin {
    outline: Vec<[f32; 2]>,
    eyes: [Vec<[f32; 2]>; 2],
    brows: [Vec<[f32; 2]>; 2],
    nostrils: Vec<[f32; 2]>,
    lips: Vec<[f32; 2]>,
    iod: f32,
}

impl Skin {
    fn new(l: &[[f32; 2]], iod: f32) -> Self {
        // "Up" for the face: perpendicular to the eyes' line, towards the brows.
        let [re, le, ..] = crate::identity::five_points(l).unwrap_or([[0.0; 2]; 5]);
        let (ex, ey) = ((le[0] - re[0]) / iod, (le[1] - re[1]) / iod);
        let up = [ey, -ex];
        let mut outline: Vec<[f32; 2]> = l[0..17].to_vec();
        // The forehead: the brows' points raised by most of the eyes' distance, right to left
        // (the outline goes round).
        for p in l[17..27].iter().rev() {
            outline.push([p[0] + 0.7 * iod * up[0], p[1] + 0.7 * iod * up[1]]);
        }
        // Closed, for the distance to its edge.
        outline.push(l[0]);
        let closed = |r: std::ops::Range<usize>| {
            let mut v = l[r.clone()].to_vec();
            v.push(l[r.start]);
            v
        };
        Skin {
            outline,
            eyes: [closed(36..42), closed(42..48)],
            brows: [l[17..22].to_vec(), l[22..27].to_vec()],
            nostrils: l[31..36].to_vec(),
            lips: closed(48..60),
            iod,
        }
    }

    /// 1 on skin, 0 off it (soft over a few hundredths of the eyes' distance).
    fn weight(&self, p: [f32; 2]) -> f32 {
        let iod = self.iod;
        let mut w = self.extent(p);
        let away = |line: &[[f32; 2]], inner: bool, grow: f32| -> f32 {
            let d = polyline_distance(line, p);
            let d = if inner && crate::person::inside(line, p) {
                -d
            } else {
                d
            };
            smoothstep(grow, grow + 0.05 * iod, d)
        };
        for e in &self.eyes {
            w *= away(e, true, 0.12 * iod);
        }
        for b in &self.brows {
            w *= away(b, false, 0.12 * iod);
        }
        w *= away(&self.nostrils, false, 0.08 * iod);
        w *= away(&self.lips, true, 0.06 * iod);
        w
    }

    /// 1 well inside the face's outline, 0 outside.
    fn extent(&self, p: [f32; 2]) -> f32 {
        let d = polyline_distance(&self.outline, p);
        if crate::person::inside(&self.outline, p) {
            smoothstep(0.0, 0.1 * self.iod, d)
        } else {
            0.0
        }
    }
}

/// Brightness for depth slopes (zx, zy) (x right, y down) and its derivatives by each.
fn shading(light: &[f32; 4], zx: f32, zy: f32) -> (f32, f32, f32) {
    // m = (-zx, zy, 1), n = m / |m|; dn/dq = (dm/dq - n (n . dm/dq)) / |m|.
    let len = (1.0 + zx * zx + zy * zy).sqrt();
    let nv = [-zx / len, zy / len, 1.0 / len];
    let b = [light[1], light[2], light[3]];
    let s = light[0] + b[0] * nv[0] + b[1] * nv[1] + b[2] * nv[2];
    let bn = b[0] * nv[0] + b[1] * nv[1] + b[2] * nv[2];
    // dm/dzx = (-1, 0, 0): b . (dm - n (n . dm)) = -b[0] + bn * nv[0].
    let dsx = (-b[0] + bn * nv[0]) / len;
    // dm/dzy = (0, 1, 0): b[1] - bn * nv[1].
    let dsy = (b[1] - bn * nv[1]) / len;
    (s, dsx, dsy)
}

/// Forward differences of `d` at cell `i` (0 at the grid's last column / row).
fn slopes(d: &[f32], i: usize, cols: usize, rows: usize) -> [f32; 2] {
    let (c, r) = (i % cols, i / cols);
    let gx = if c + 1 < cols { d[i + 1] - d[i] } else { 0.0 };
    let gy = if r + 1 < rows {
        d[i + cols] - d[i]
    } else {
        0.0
    };
    [gx, gy]
}

/// The normal equations' operator: `A^T W A + lambda_s L^T L + lambda0 I`, with `A` the
/// linearised shading's response to a depth change (forward differences) and `L` the
/// 5-point Laplacian (zero outside the grid).
struct Operator<'a> {
    cols: usize,
    rows: usize,
    sx: &'a [f32],
    sy: &'a [f32],
    w: &'a [f32],
    lambda0: f32,
    lambda_s: f32,
}

impl Operator<'_> {
    fn a_t(&self, y: &[f32]) -> Vec<f32> {
        let mut out = vec![0f32; y.len()];
        self.add_a_t(y, &mut out);
        out
    }

    /// `out += A^T y`.
    fn add_a_t(&self, y: &[f32], out: &mut [f32]) {
        let (cols, rows) = (self.cols, self.rows);
        for i in 0..y.len() {
            if y[i] == 0.0 {
                continue;
            }
            let (c, r) = (i % cols, i / cols);
            if c + 1 < cols {
                out[i + 1] += self.sx[i] * y[i];
                out[i] -= self.sx[i] * y[i];
            }
            if r + 1 < rows {
                out[i + cols] += self.sy[i] * y[i];
                out[i] -= self.sy[i] * y[i];
            }
        }
    }

    fn laplacian_into(&self, d: &[f32], out: &mut [f32]) {
        let (cols, rows) = (self.cols, self.rows);
        for r in 0..rows {
            for c in 0..cols {
                let i = r * cols + c;
                let mut v = -4.0 * d[i];
                if c > 0 {
                    v += d[i - 1];
                }
                if c + 1 < cols {
                    v += d[i + 1];
                }
                if r > 0 {
                    v += d[i - cols];
                }
                if r + 1 < rows {
                    v += d[i + cols];
                }
                out[i] = v;
            }
        }
    }

    fn regulariser(&self, d: &[f32]) -> Vec<f32> {
        let mut scratch = Scratch::new(d.len());
        let mut out = vec![0f32; d.len()];
        self.regulariser_into(d, &mut out, &mut scratch);
        out
    }

    /// `out = (lambda_s L^T L + lambda0) d`.
    fn regulariser_into(&self, d: &[f32], out: &mut [f32], scratch: &mut Scratch) {
        self.laplacian_into(d, &mut scratch.lap);
        self.laplacian_into(&scratch.lap, out);
        for (o, v) in out.iter_mut().zip(d) {
            *o = self.lambda_s * *o + self.lambda0 * v;
        }
    }

    fn apply_into(&self, d: &[f32], out: &mut [f32], scratch: &mut Scratch) {
        self.regulariser_into(d, out, scratch);
        for i in 0..d.len() {
            scratch.y[i] = if self.w[i] > 0.0 {
                let [gx, gy] = slopes(d, i, self.cols, self.rows);
                self.w[i] * (self.sx[i] * gx + self.sy[i] * gy)
            } else {
                0.0
            };
        }
        let y = std::mem::take(&mut scratch.y);
        self.add_a_t(&y, out);
        scratch.y = y;
    }
}

/// Buffers the operator reuses between iterations.
struct Scratch {
    lap: Vec<f32>,
    y: Vec<f32>,
}

impl Scratch {
    fn new(n: usize) -> Self {
        Scratch {
            lap: vec![0.0; n],
            y: vec![0.0; n],
        }
    }
}

fn sample(map: &[f32], cols: usize, rows: usize, u: f32, v: f32) -> f32 {
    if !(u >= 0.0 && v >= 0.0 && u <= (cols - 1) as f32 && v <= (rows - 1) as f32) {
        return 0.0;
    }
    crate::photo_grid::bilinear_map(map, cols, rows, u, v)
}

fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    crate::gem::template::smoothstep(a, b, x)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use nalgebra::{Matrix3, Vector2};

    /// A dome (a sphere of 160 mm, model mm, y up, +z to the camera) on a 2.5 mm grid, seen
    /// frontally at 4 px/mm with the model origin at photo point (400, 400): the landmarks of
    /// `detail`'s test face lie on it.
    fn dome() -> (Vec<f32>, Vec<[u32; 3]>, Pose) {
        let n = 81;
        let mut mesh = Vec::new();
        for r in 0..n {
            for c in 0..n {
                let (x, y) = (-100.0 + 2.5 * c as f32, -100.0 + 2.5 * r as f32);
                mesh.extend([x, y, base_depth(x, y)]);
            }
        }
        let mut tris = Vec::new();
        for r in 0..n - 1 {
            for c in 0..n - 1 {
                let i = (r * n + c) as u32;
                let n = n as u32;
                tris.push([i, i + 1, i + n]);
                tris.push([i + 1, i + n + 1, i + n]);
            }
        }
        let pose = Pose {
            rotation: Matrix3::identity(),
            scale: 4.0,
            translation: Vector2::new(400.0, -400.0),
        };
        (mesh, tris, pose)
    }

    fn base_depth(x: f32, y: f32) -> f32 {
        (160.0f32 * 160.0 - x * x - y * y).max(0.0).sqrt() - 160.0
    }

    /// A 3 mm bump (sigma 10 mm) on the left cheek, photo point (540, 450).
    fn bump(x: f32, y: f32) -> f32 {
        let (dx, dy) = (x - 35.0, y + 12.5);
        3.0 * (-(dx * dx + dy * dy) / (2.0 * 100.0)).exp()
    }

    const LIGHT: [f32; 4] = [0.25, -0.35, 0.3, 0.45];

    /// The photo of depth `z` (model mm) under [`LIGHT`], with an albedo.
    fn photo(z: impl Fn(f32, f32) -> f32, albedo: impl Fn(f32, f32) -> f32) -> GrayImage {
        GrayImage::from_fn(800, 800, |px, py| {
            let (x, y) = ((px as f32 - 400.0) / 4.0, (400.0 - py as f32) / 4.0);
            let h = 0.05;
            let zx = (z(x + h, y) - z(x - h, y)) / (2.0 * h);
            let zy = (z(x, y + h) - z(x, y - h)) / (2.0 * h);
            let len = (1.0 + zx * zx + zy * zy).sqrt();
            let n = [-zx / len, -zy / len, 1.0 / len];
            let s = albedo(x, y) * lambert(&LIGHT, n);
            image::Luma([(s.clamp(0.0, 1.0) * 255.0).round() as u8])
        })
    }

    #[test]
    fn a_bump_the_landmarks_cannot_see_is_read_from_the_shading() {
        let (mesh, tris, pose) = dome();
        let lm = crate::gem::detail::tests::face();
        let img = photo(|x, y| base_depth(x, y) + bump(x, y), |_, _| 1.0);
        let fit = fit(&img, &lm, &mesh, &tris, &pose, &ShadingParams::default()).expect("fit");
        // The light is found.
        // The light is found (its ambient and frontal parts trade off over a face that
        // mostly faces the camera: their sum is what is seen).
        let l = fit.light;
        assert!((l[1] - LIGHT[1]).abs() < 0.05, "{l:?}");
        assert!((l[2] - LIGHT[2]).abs() < 0.05, "{l:?}");
        assert!((l[0] + l[3] - LIGHT[0] - LIGHT[3]).abs() < 0.05, "{l:?}");
        assert!(
            fit.residual_after < 0.5 * fit.residual_before,
            "{} -> {}",
            fit.residual_before,
            fit.residual_after
        );
        // Near the cheek, the offsets follow the bump.
        let (mut got, mut want) = (Vec::new(), Vec::new());
        for (v, o) in mesh.chunks_exact(3).zip(&fit.offsets) {
            let (dx, dy) = (v[0] - 35.0, v[1] + 12.5);
            if dx.hypot(dy) < 25.0 {
                got.push(*o);
                want.push(bump(v[0], v[1]));
            }
        }
        let r = crate::stats::correlation(&got, &want);
        let peak = got.iter().copied().fold(f32::MIN, f32::max);
        assert!(r > 0.8, "correlation {r}");
        assert!((1.0..=4.0).contains(&peak), "peak {peak} mm for 3 mm");
        // Far from it (the other cheek, the chin), little moves.
        for (v, o) in mesh.chunks_exact(3).zip(&fit.offsets) {
            if (v[0] + 35.0).hypot(v[1] + 12.5) < 15.0 {
                assert!(o.abs() < 0.5, "{o} mm at the other cheek");
            }
        }
    }

    #[test]
    fn the_fitted_shape_itself_is_left_alone_and_a_mole_raises_nothing() {
        let (mesh, tris, pose) = dome();
        let lm = crate::gem::detail::tests::face();
        // A dark mole (albedo, not shape) on the cheek.
        let img = photo(base_depth, |x, y| {
            if (x - 35.0).hypot(y + 12.5) < 2.0 {
                0.3
            } else {
                1.0
            }
        });
        let fit = fit(&img, &lm, &mesh, &tris, &pose, &ShadingParams::default()).expect("fit");
        let worst = fit.offsets.iter().fold(0f32, |m, o| m.max(o.abs()));
        assert!(worst < 0.6, "{worst} mm");
    }

    #[test]
    fn the_expected_shading_is_the_lights_on_the_face_and_unknown_off_it() {
        let (mesh, tris, pose) = dome();
        let lm = crate::gem::detail::tests::face();
        let img = photo(base_depth, |_, _| 1.0);
        let fit = fit(&img, &lm, &mesh, &tris, &pose, &ShadingParams::default()).expect("fit");
        // On the cheek it is the photo's own brightness (the photo is the light on this face).
        for (x, y) in [(540.0, 450.0), (260.0, 450.0), (400.0, 250.0)] {
            let want = f32::from(img.get_pixel(x as u32, y as u32).0[0]) / 255.0;
            let got = fit.expected.at(x, y);
            assert!((got - want).abs() < 0.03, "({x}, {y}): {got} for {want}");
        }
        // The light alone: the same map, no offsets.
        let light = super::fit(&img, &lm, &mesh, &tris, &pose, &ShadingParams::light_only())
            .expect("light");
        assert_eq!(light.expected, fit.expected);
        assert!(light.offsets.iter().all(|&o| o == 0.0));
        // Far outside the face's grid: unknown.
        assert!(fit.expected.at(5.0, 5.0).is_nan());
        assert!(fit.expected.at(f32::NAN, 400.0).is_nan());
    }

    #[test]
    fn bad_input_is_refused_by_name() {
        let (mesh, tris, pose) = dome();
        let lm = crate::gem::detail::tests::face();
        let img = photo(base_depth, |_, _| 1.0);
        let p = ShadingParams::default();
        let mut nan = lm.clone();
        nan[30] = [f32::NAN, 0.0];
        assert_eq!(
            fit(&img, &nan, &mesh, &tris, &pose, &p),
            Err(ShadingError::Landmarks)
        );
        assert_eq!(
            fit(&img, &lm[..60], &mesh, &tris, &pose, &p),
            Err(ShadingError::Landmarks)
        );
        assert_eq!(
            fit(&GrayImage::new(0, 0), &lm, &mesh, &tris, &pose, &p),
            Err(ShadingError::EmptyPhoto)
        );
        let mut bad = mesh.clone();
        bad[5] = f32::INFINITY;
        assert_eq!(
            fit(&img, &lm, &bad, &tris, &pose, &p),
            Err(ShadingError::Mesh)
        );
        // A flat grey photo has no light to read.
        let flat = GrayImage::from_pixel(800, 800, image::Luma([128]));
        let got = fit(&flat, &lm, &mesh, &tris, &pose, &p);
        assert!(
            matches!(got, Err(ShadingError::FlatLight(_))),
            "{:?}",
            got.map(|f| (f.light, f.residual_before))
        );
        // Too small a face.
        let tiny: Vec<[f32; 2]> = lm.iter().map(|p| [p[0] * 0.05, p[1] * 0.05]).collect();
        assert!(matches!(
            fit(&img, &tiny, &mesh, &tris, &pose, &p),
            Err(ShadingError::TooSmall(_))
        ));
    }

    #[test]
    fn displacing_moves_vertices_along_the_cameras_axis() {
        let (mut mesh, _, pose) = dome();
        let before = mesh.clone();
        let offsets = vec![1.5; mesh.len() / 3];
        displace(&mut mesh, &offsets, &pose);
        assert!((mesh[2] - before[2] - 1.5).abs() < 1e-5);
        assert_eq!(mesh[0], before[0]);
        // Another topology is left alone.
        displace(&mut mesh, &offsets[1..], &pose);
        assert!((mesh[2] - before[2] - 1.5).abs() < 1e-5);
    }
}
