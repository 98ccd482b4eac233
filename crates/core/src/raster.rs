//! A small CPU rasteriser for grey renders of a face mesh: the likeness's measure and search
//! look at the fitted face the way a recognition network looks at a photo, without a GPU and
//! in well under a millisecond at the networks' input sizes.
//!
//! Units and frames: the mesh in model millimetres (y up, face along +z); a [`View`] is a
//! scaled-orthographic camera (the fit's own camera model): image x = `scale` (R p).x + `tx`,
//! image y = `ty` - `scale` (R p).y (pixels, y down, a pixel's centre at `i + 0.5`), depth
//! (R p).z, larger nearer the viewer. Normals are turned by R; the light's direction is in the
//! camera's frame (+z towards the viewer). Shading is Lambertian on normals interpolated per
//! pixel. Pure computation.

use crate::vec3::{triangle_normal, unit};

/// A scaled-orthographic camera: model mm -> image pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// Model-to-camera rotation, row-major.
    pub rotation: [[f32; 3]; 3],
    /// Pixels per millimetre.
    pub scale: f32,
    /// Image position of the model origin, pixels (x right, y down).
    pub tx: f32,
    pub ty: f32,
}

impl View {
    /// Looking at the face from the front, turned by `yaw` (about the vertical axis) and
    /// `pitch` (about the horizontal axis), radians; `scale` pixels per mm, the model origin at
    /// (`tx`, `ty`).
    pub fn turned(yaw: f32, pitch: f32, scale: f32, tx: f32, ty: f32) -> Self {
        let (sy, cy) = yaw.sin_cos();
        let (sp, cp) = pitch.sin_cos();
        // R = Rx(pitch) Ry(yaw)
        let rotation = [
            [cy, 0.0, sy],
            [sp * sy, cp, -sp * cy],
            [-cp * sy, sp, cp * cy],
        ];
        View {
            rotation,
            scale,
            tx,
            ty,
        }
    }

    /// A model direction in the camera's frame (y up).
    pub fn turn(&self, p: [f32; 3]) -> [f32; 3] {
        let r = &self.rotation;
        std::array::from_fn(|k| r[k][0] * p[0] + r[k][1] * p[1] + r[k][2] * p[2])
    }

    /// Image position (pixels) and depth of a model point.
    pub fn project(&self, p: [f32; 3]) -> [f32; 3] {
        let q = self.turn(p);
        [
            self.scale * q[0] + self.tx,
            self.ty - self.scale * q[1],
            q[2],
        ]
    }
}

/// Lighting for [`shade`]: one directional light (camera frame, towards the light) and an
/// ambient share.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    pub direction: [f32; 3],
    pub ambient: f32,
}

impl Default for Light {
    /// From the upper left and in front, as portrait photographs are lit.
    fn default() -> Self {
        Light {
            direction: [-0.35, 0.45, 0.82],
            ambient: 0.25,
        }
    }
}

/// A light fitted to brightness samples: weighted least squares of brightness on (1, n), so
/// that brightness ~ `light[0] + light[1..4] . n` ([`lambert`]); `n` in the camera's frame.
/// Samples are (normal, brightness, weight); those of weight 0 or less are skipped. A ridge
/// of a thousandth of the total weight keeps a flat-lit face solvable. `None` with no weight,
/// a singular system or a non-finite answer.
pub fn fit_light(samples: impl IntoIterator<Item = ([f32; 3], f64, f64)>) -> Option<[f32; 4]> {
    use nalgebra::{Matrix4, Vector4};
    let mut ata = Matrix4::<f64>::zeros();
    let mut atb = Vector4::<f64>::zeros();
    let mut total = 0.0;
    for (n, brightness, w) in samples {
        if w <= 0.0 {
            continue;
        }
        let row = Vector4::new(1.0, f64::from(n[0]), f64::from(n[1]), f64::from(n[2]));
        ata += row * row.transpose() * w;
        atb += row * (w * brightness);
        total += w;
    }
    if total <= 0.0 {
        return None;
    }
    ata += Matrix4::identity() * 1e-3 * total;
    let x = ata.cholesky()?.solve(&atb);
    let l = [x[0] as f32, x[1] as f32, x[2] as f32, x[3] as f32];
    l.iter().all(|v| v.is_finite()).then_some(l)
}

/// The brightness a [`fit_light`] light gives a unit normal `n` (camera frame).
pub fn lambert(light: &[f32; 4], n: [f32; 3]) -> f32 {
    light[0] + light[1] * n[0] + light[2] * n[1] + light[3] * n[2]
}

/// Unit vertex normals, the area-weighted mean of the normals of the triangles around each
/// vertex (counter-clockwise seen from outside: outward). Zero where none is defined; triangles
/// past the vertex list or with a non-finite corner are skipped.
pub fn vertex_normals(positions: &[f32], triangles: &[[u32; 3]]) -> Vec<[f32; 3]> {
    let n = positions.len() / 3;
    let mut normals = vec![[0f32; 3]; n];
    let at = |i: u32| -> Option<[f32; 3]> {
        let v = positions.get(3 * i as usize..3 * i as usize + 3)?;
        Some([v[0], v[1], v[2]])
    };
    for t in triangles {
        let (Some(a), Some(b), Some(c)) = (at(t[0]), at(t[1]), at(t[2])) else {
            continue;
        };
        let f = triangle_normal(a, b, c);
        if f.iter().any(|x| !x.is_finite()) {
            continue;
        }
        for &i in t {
            for k in 0..3 {
                normals[i as usize][k] += f[k];
            }
        }
    }
    normals.iter().map(|&n| unit(n)).collect()
}

/// A grey render: `width` x `height` intensities (row-major, 0..1), NaN where no triangle
/// covers a pixel's centre. Triangles with a non-finite corner or one past the vertex list are
/// skipped; the nearest surface wins.
pub fn shade(
    positions: &[f32],
    triangles: &[[u32; 3]],
    normals: &[[f32; 3]],
    view: &View,
    light: &Light,
    width: usize,
    height: usize,
) -> Vec<f32> {
    let l = unit(light.direction);
    let points: Vec<Option<[f32; 3]>> = positions
        .chunks_exact(3)
        .map(|v| {
            let p = view.project([v[0], v[1], v[2]]);
            p.iter().all(|c| c.is_finite()).then_some(p)
        })
        .collect();
    let turned: Vec<[f32; 3]> = (0..points.len())
        .map(|i| normals.get(i).map_or([0.0; 3], |&n| view.turn(n)))
        .collect();
    let mut out = vec![f32::NAN; width * height];
    shade_points(
        &points,
        &turned,
        triangles,
        &|n| {
            light.ambient
                + (1.0 - light.ambient) * (n[0] * l[0] + n[1] * l[1] + n[2] * l[2]).max(0.0)
        },
        width,
        height,
        &mut out,
    );
    out
}

/// The rasteriser under [`shade`], for vertices already projected: `points` are image x, y
/// (pixels) and depth (larger nearer), `normals` in the camera's frame, `shading` turns an
/// interpolated unit normal into an intensity. Writes covered pixels of `out` (`width` x
/// `height`, row-major) and leaves the others.
pub fn shade_points(
    points: &[Option<[f32; 3]>],
    normals: &[[f32; 3]],
    triangles: &[[u32; 3]],
    shading: &dyn Fn([f32; 3]) -> f32,
    width: usize,
    height: usize,
    out: &mut [f32],
) {
    let mut depth = vec![f32::NEG_INFINITY; width * height];
    let nv = points.len().min(normals.len());
    for t in triangles {
        let idx = t.map(|i| i as usize);
        if idx.iter().any(|&i| i >= nv) {
            continue;
        }
        let (Some(a), Some(b), Some(c)) = (points[idx[0]], points[idx[1]], points[idx[2]]) else {
            continue;
        };
        let area = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
        if area.abs() < 1e-9 {
            continue;
        }
        let x0 = (a[0].min(b[0]).min(c[0]) - 0.5).ceil().max(0.0) as usize;
        let y0 = (a[1].min(b[1]).min(c[1]) - 0.5).ceil().max(0.0) as usize;
        let x1 = ((a[0].max(b[0]).max(c[0]) - 0.5).floor()).min(width as f32 - 1.0);
        let y1 = ((a[1].max(b[1]).max(c[1]) - 0.5).floor()).min(height as f32 - 1.0);
        if x1 < 0.0 || y1 < 0.0 {
            continue;
        }
        let (x1, y1) = (x1 as usize, y1 as usize);
        let (na, nb, nc) = (normals[idx[0]], normals[idx[1]], normals[idx[2]]);
        for y in y0..=y1 {
            let py = y as f32 + 0.5;
            for x in x0..=x1 {
                let px = x as f32 + 0.5;
                let wa = ((b[0] - px) * (c[1] - py) - (c[0] - px) * (b[1] - py)) / area;
                let wb = ((c[0] - px) * (a[1] - py) - (a[0] - px) * (c[1] - py)) / area;
                let wc = 1.0 - wa - wb;
                if wa < -1e-6 || wb < -1e-6 || wc < -1e-6 {
                    continue;
                }
                let z = wa * a[2] + wb * b[2] + wc * c[2];
                let i = y * width + x;
                if z <= depth[i] {
                    continue;
                }
                depth[i] = z;
                let n = unit(std::array::from_fn(|k| {
                    wa * na[k] + wb * nb[k] + wc * nc[k]
                }));
                out[i] = shading(n);
            }
        }
    }
}

/// Surrey Face Model vertices (3448-vertex topology, 0-based, `ibug_to_sfm.txt`) of the five
/// points a recognition network aligns a face by, in image order for a face looking out: the
/// subject's right eye's six points (iBUG 37-42), the left eye's (43-48), the nose tip (31),
/// the right and left mouth corners (49, 55).
pub const SFM_RIGHT_EYE: [usize; 6] = [177, 172, 191, 181, 173, 174];
pub const SFM_LEFT_EYE: [usize; 6] = [614, 624, 605, 610, 607, 606];
pub const SFM_NOSE_TIP: usize = 114;
pub const SFM_MOUTH_CORNERS: [usize; 2] = [398, 812];

/// The five alignment points (eye centres, nose tip, mouth corners; image pixels) of a Surrey
/// mesh seen through `view`; `None` for another topology or a non-finite point.
pub fn sfm_five_points(positions: &[f32], view: &View) -> Option<[[f32; 2]; 5]> {
    if positions.len() != 3 * 3448 {
        return None;
    }
    let at = |i: usize| {
        let p = view.project([positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]]);
        [p[0], p[1]]
    };
    let centre = |ids: &[usize; 6]| {
        let (x, y) = ids
            .iter()
            .map(|&i| at(i))
            .fold((0.0, 0.0), |(x, y), p| (x + p[0], y + p[1]));
        [x / 6.0, y / 6.0]
    };
    let five = [
        centre(&SFM_RIGHT_EYE),
        centre(&SFM_LEFT_EYE),
        at(SFM_NOSE_TIP),
        at(SFM_MOUTH_CORNERS[0]),
        at(SFM_MOUTH_CORNERS[1]),
    ];
    five.iter().flatten().all(|v| v.is_finite()).then_some(five)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit sphere's octahedron subdivided: enough to shade.
    fn sphere(r: f32, levels: usize) -> (Vec<f32>, Vec<[u32; 3]>) {
        let mut v: Vec<[f32; 3]> = vec![
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ];
        let mut t: Vec<[u32; 3]> = vec![
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ];
        for _ in 0..levels {
            let mut next = Vec::new();
            for tri in &t {
                let mids: Vec<u32> = (0..3)
                    .map(|k| {
                        let (p, q) = (v[tri[k] as usize], v[tri[(k + 1) % 3] as usize]);
                        v.push(unit([p[0] + q[0], p[1] + q[1], p[2] + q[2]]));
                        (v.len() - 1) as u32
                    })
                    .collect();
                next.push([tri[0], mids[0], mids[2]]);
                next.push([mids[0], tri[1], mids[1]]);
                next.push([mids[2], mids[1], tri[2]]);
                next.push([mids[0], mids[1], mids[2]]);
            }
            t = next;
        }
        (v.iter().flat_map(|p| p.map(|c| c * r)).collect(), t)
    }

    #[test]
    fn a_lit_sphere_is_brightest_towards_the_light_and_covers_its_disc() {
        let (pos, tri) = sphere(40.0, 4);
        let normals = vertex_normals(&pos, &tri);
        let view = View::turned(0.0, 0.0, 1.0, 50.0, 50.0);
        let light = Light {
            direction: [-1.0, 1.0, 1.0],
            ambient: 0.1,
        };
        let img = shade(&pos, &tri, &normals, &view, &light, 100, 100);
        let covered = img.iter().filter(|v| v.is_finite()).count() as f32;
        let disc = std::f32::consts::PI * 40.0 * 40.0;
        assert!((covered / disc - 1.0).abs() < 0.03, "{covered} of {disc}");
        // Upper left (towards the light) bright, lower right (away) at the ambient level.
        let at = |x: usize, y: usize| img[y * 100 + x];
        assert!(at(30, 30) > 0.85, "{}", at(30, 30));
        assert!((at(75, 75) - 0.1).abs() < 0.05, "{}", at(75, 75));
        assert!(
            img.iter()
                .filter(|v| v.is_finite())
                .all(|v| (0.0..=1.0).contains(v))
        );
    }

    #[test]
    fn the_nearest_surface_wins_and_bad_input_is_skipped() {
        // Two squares, the nearer one (z = 5) dark-facing, the farther bright-facing.
        let pos = vec![
            0.0,
            0.0,
            0.0,
            10.0,
            0.0,
            0.0,
            10.0,
            10.0,
            0.0,
            0.0,
            10.0,
            0.0, // far
            0.0,
            0.0,
            5.0,
            10.0,
            0.0,
            5.0,
            10.0,
            10.0,
            5.0,
            0.0,
            10.0,
            5.0, // near
            f32::NAN,
            0.0,
            0.0,
        ];
        let tri = vec![
            [0, 1, 2],
            [0, 2, 3],
            [4, 5, 6],
            [4, 6, 7],
            [0, 1, 8],
            [0, 1, 99],
        ];
        let mut normals = vec![[0.0, 0.0, 1.0]; 9];
        for n in &mut normals[4..8] {
            *n = [0.0, 0.0, -1.0];
        }
        let view = View::turned(0.0, 0.0, 1.0, 0.0, 10.0);
        let light = Light {
            direction: [0.0, 0.0, 1.0],
            ambient: 0.2,
        };
        let img = shade(&pos, &tri, &normals, &view, &light, 10, 10);
        assert!(img.iter().all(|v| (v - 0.2).abs() < 1e-5), "{img:?}");
    }

    #[test]
    fn turning_moves_the_nose_the_right_way() {
        // A point in front of the origin goes right when the head turns by a positive yaw.
        let v = View::turned(0.3, 0.0, 1.0, 0.0, 0.0);
        assert!(v.project([0.0, 0.0, 10.0])[0] > 2.0);
        // ... and down (larger image y) when it tilts forward by a positive pitch.
        let p = View::turned(0.0, 0.3, 1.0, 0.0, 0.0);
        assert!(p.project([0.0, 0.0, 10.0])[1] > 2.0);
    }
}
