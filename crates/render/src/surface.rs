//! Surface detail for the stone, on the CPU (no GPU code here): the engraved border of the
//! ground (a height map and its tangent-space normal map, which the scene pass uses for
//! parallax occlusion mapping and normal mapping), and per-vertex tangent frames with a guard
//! against degenerate ones (the art-gallery seed's NaN tangents where two vertices of a
//! triangle share texture coordinates). Also the box over the mesh that its slowly varying
//! noise is baked into ([`NoiseVolume`]).
//!
//! Units: object-space mm. The maps are planar: they cover the mesh's XY bounding box, texture
//! coordinate u running with +X and v with -Y (image rows go down), (0, 0) at (min x, max y).
//! The relief's steep walls are exactly where planar coordinates degenerate (a wall's vertices
//! share their XY), so the guard is not a corner case here.

use glyptic_core::scene::Vertex;
use glyptic_core::vec3::{add, cross, dot, scaled, sub};

/// The planar texture frame of a mesh: the centre and half extents of its XY bounding box, mm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanarFrame {
    pub centre: [f32; 2],
    pub half: [f32; 2],
}

impl PlanarFrame {
    /// Texture coordinates of an object-space point.
    pub fn uv(&self, p: [f32; 3]) -> [f32; 2] {
        [
            (p[0] - self.centre[0]) / (2.0 * self.half[0]) + 0.5,
            0.5 - (p[1] - self.centre[1]) / (2.0 * self.half[1]),
        ]
    }

    /// How far (`x`, `y`) lies inside the frame's ellipse (the gem's outline), mm, to first
    /// order: (1 - rho) / |grad rho| for rho the ellipse's normalised radius. Negative outside.
    /// The scene shader's `inset_mm` is the same.
    pub fn inset_mm(&self, x: f32, y: f32) -> f32 {
        let [a, b] = self.half;
        let (qx, qy) = ((x - self.centre[0]) / a, (y - self.centre[1]) / b);
        let rho = (qx * qx + qy * qy).sqrt();
        let grad = ((qx / a).powi(2) + (qy / b).powi(2)).sqrt() / rho.max(1e-6);
        (1.0 - rho) / grad.max(1e-6)
    }

    /// Object-space offset (x, y), mm, from the frame's centre to texel centre (`i`, `j`) of a
    /// `size` x `size` map.
    fn texel_mm(&self, i: u32, j: u32, size: u32) -> [f32; 2] {
        let u = (i as f32 + 0.5) / size as f32;
        let v = (j as f32 + 0.5) / size as f32;
        [
            (u - 0.5) * 2.0 * self.half[0],
            (0.5 - v) * 2.0 * self.half[1],
        ]
    }
}

/// The engraved border: a Greek-key meander between two plain lines, running round the ground
/// just inside the bezel, at a constant distance from the frame's ellipse (the gem's outline).
#[derive(Clone, Debug, PartialEq)]
pub struct EngravingParams {
    /// The band's outer and inner edge, as distances inside the outline, mm.
    pub inset_mm: [f32; 2],
    /// Depth of the grooves, mm.
    pub depth_mm: f32,
    /// Groove width as a fraction of the pattern's unit (the band is [`BAND_UNITS`] units wide).
    pub groove: f32,
    /// Side of the square maps, texels (16..=2048 for the renderer; rounded up to a power of
    /// two for the mip chain).
    pub size: u32,
}

impl Default for EngravingParams {
    fn default() -> Self {
        EngravingParams {
            // The ground starts about 2.3 mm inside the outline (the bezel's inner foot).
            inset_mm: [2.6, 6.0],
            depth_mm: 0.25,
            groove: 0.5,
            size: 1024,
        }
    }
}

/// Units across the band: a line, the meander (four units tall) and a line, with gaps.
pub const BAND_UNITS: f32 = 7.0;
/// Units along the band per repeat of the meander.
const PERIOD_UNITS: f32 = 5.0;
/// The meander's segments in one period, (x along, y across from its foot), units: a rail and
/// a hook turning in on itself.
const KEY: [[f32; 4]; 6] = [
    [0.0, 0.0, 5.0, 0.0],
    [1.0, 0.0, 1.0, 4.0],
    [1.0, 4.0, 4.0, 4.0],
    [4.0, 4.0, 4.0, 1.5],
    [4.0, 1.5, 2.5, 1.5],
    [2.5, 1.5, 2.5, 2.7],
];

fn segment_distance(p: [f32; 2], s: [f32; 4]) -> f32 {
    let (dx, dy) = (s[2] - s[0], s[3] - s[1]);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 {
        (((p[0] - s[0]) * dx + (p[1] - s[1]) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let (ex, ey) = (p[0] - s[0] - t * dx, p[1] - s[1] - t * dy);
    (ex * ex + ey * ey).sqrt()
}

/// The engraving's maps, full resolution first, then each mip level down to 1 x 1.
#[derive(Clone, Debug)]
pub struct Engraving {
    /// Height of the surface, 0..=255 (255 the polished ground, 0 a groove's bottom), per level.
    pub height: Vec<Vec<u8>>,
    /// Tangent-space normals encoded as n * 0.5 + 0.5 (RGBA, a = 255), per level.
    pub normal: Vec<Vec<[u8; 4]>>,
    /// Side of level 0, texels.
    pub size: u32,
}

/// Heights (1 the ground, 0 a groove's bottom) of the engraved border over `frame`.
pub fn engraving_heights(frame: &PlanarFrame, p: &EngravingParams) -> Vec<f32> {
    let n = p.size.max(1);
    let [a, b] = frame.half;
    let [i0, i1] = p.inset_mm;
    let unit_mm = (i1 - i0) / BAND_UNITS;
    // Whole periods round the outline (Ramanujan's perimeter of the band's middle).
    let (am, bm) = (a - 0.5 * (i0 + i1), b - 0.5 * (i0 + i1));
    let h = ((am - bm) / (am + bm)).powi(2);
    let perimeter =
        std::f32::consts::PI * (am + bm) * (1.0 + 3.0 * h / (10.0 + (4.0 - 3.0 * h).sqrt()));
    let periods = (perimeter / (PERIOD_UNITS * unit_mm)).round().max(1.0);
    let half_groove = 0.5 * p.groove;
    let mut out = vec![1.0f32; (n * n) as usize];
    for j in 0..n {
        for i in 0..n {
            let [x, y] = frame.texel_mm(i, j, n);
            let inside = frame.inset_mm(x + frame.centre[0], y + frame.centre[1]);
            let across = (inside - i0) / unit_mm;
            if !(-1.0..=BAND_UNITS + 1.0).contains(&across) {
                continue;
            }
            let along = ((y / b).atan2(x / a) / std::f32::consts::TAU).rem_euclid(1.0)
                * periods
                * PERIOD_UNITS;
            let local = [along.rem_euclid(PERIOD_UNITS), across - 1.5];
            // The framing lines at 0.5 and 6.5 units, the meander between 1.5 and 5.5.
            let mut d = (across - 0.5).abs().min((across - 6.5).abs());
            for s in KEY {
                d = d.min(segment_distance(local, s));
                // The rail and the top run on into the neighbouring periods.
                d = d.min(segment_distance([local[0] + PERIOD_UNITS, local[1]], s));
                d = d.min(segment_distance([local[0] - PERIOD_UNITS, local[1]], s));
            }
            if d < half_groove {
                // A rounded groove: a half-ellipse profile.
                let r = d / half_groove;
                out[(j * n + i) as usize] = 1.0 - (1.0 - r * r).sqrt();
            }
        }
    }
    out
}

/// Tangent-space normals of a height field (1 = `depth_mm` above 0), texels `texel_mm` wide
/// along u and v: n = normalize(-dh/du, -dh/dv, 1) in mm, v pointing down the image.
pub fn normal_map(heights: &[f32], size: u32, texel_mm: [f32; 2], depth_mm: f32) -> Vec<[u8; 4]> {
    let n = size as usize;
    let at = |i: usize, j: usize| heights[j * n + i];
    let mut out = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let (il, ir) = (i.saturating_sub(1), (i + 1).min(n - 1));
            let (ju, jd) = (j.saturating_sub(1), (j + 1).min(n - 1));
            let du = (at(ir, j) - at(il, j)) * depth_mm / (texel_mm[0] * (ir - il).max(1) as f32);
            let dv = (at(i, jd) - at(i, ju)) * depth_mm / (texel_mm[1] * (jd - ju).max(1) as f32);
            let len = (du * du + dv * dv + 1.0).sqrt();
            let enc = |c: f32| ((c / len * 0.5 + 0.5) * 255.0).round().clamp(0.0, 255.0) as u8;
            out.push([enc(-du), enc(-dv), enc(1.0), 255]);
        }
    }
    out
}

/// Halves a square map (box filter), `f` combining four texels.
fn halve<T: Copy>(level: &[T], size: u32, f: impl Fn([T; 4]) -> T) -> Vec<T> {
    let (n, m) = (size as usize, (size / 2).max(1) as usize);
    let mut out = Vec::with_capacity(m * m);
    for j in 0..m {
        for i in 0..m {
            let (i0, j0) = ((2 * i).min(n - 1), (2 * j).min(n - 1));
            let (i1, j1) = ((2 * i + 1).min(n - 1), (2 * j + 1).min(n - 1));
            out.push(f([
                level[j0 * n + i0],
                level[j0 * n + i1],
                level[j1 * n + i0],
                level[j1 * n + i1],
            ]));
        }
    }
    out
}

/// The engraving over `frame`, with its mip chains (averaged heights; averaged and
/// renormalised normals, so a distant border shades as its mean slope).
pub fn engraving(frame: &PlanarFrame, p: &EngravingParams) -> Engraving {
    let size = p.size.max(1).next_power_of_two();
    let p = EngravingParams { size, ..p.clone() };
    let heights = engraving_heights(frame, &p);
    let texel = [
        2.0 * frame.half[0] / size as f32,
        2.0 * frame.half[1] / size as f32,
    ];
    let mut normal = vec![normal_map(&heights, size, texel, p.depth_mm)];
    let mut height = vec![
        heights
            .iter()
            .map(|h| (h * 255.0).round().clamp(0.0, 255.0) as u8)
            .collect::<Vec<u8>>(),
    ];
    let mut s = size;
    while s > 1 {
        let next_h = halve(height.last().map_or(&[][..], |v| v), s, |q| {
            ((q.iter().map(|&v| u32::from(v)).sum::<u32>() + 2) / 4) as u8
        });
        let next_n = halve(normal.last().map_or(&[][..], |v| v), s, |q| {
            let mut c = [0f32; 3];
            for t in q {
                for k in 0..3 {
                    c[k] += f32::from(t[k]) / 127.5 - 1.0;
                }
            }
            let len = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt().max(1e-6);
            let e = |v: f32| ((v / len * 0.5 + 0.5) * 255.0).round().clamp(0.0, 255.0) as u8;
            [e(c[0]), e(c[1]), e(c[2]), 255]
        });
        height.push(next_h);
        normal.push(next_n);
        s /= 2;
    }
    Engraving {
        height,
        normal,
        size,
    }
}

/// Relief below which a vertex is ground for the engraving (mm; the shader fades it out
/// between 0.02 and 0.08).
const ENGRAVED_RELIEF_MM: f32 = 0.08;

/// `indices` reordered so that the triangles the engraved band can touch come last, and where
/// they start: a triangle is in the band when a vertex of it is stone ground and its vertices'
/// insets (mm, [`PlanarFrame::inset_mm`]) reach into `band_mm`. The scene pass draws the first
/// part with a pipeline that has no engraving code, which a CPU rasteriser would otherwise run
/// for every fragment.
pub fn band_last(
    vertices: &[Vertex],
    indices: &[u32],
    frame: &PlanarFrame,
    band_mm: [f32; 2],
) -> (Vec<u32>, usize) {
    let gold = glyptic_core::scene::Region::Gold as u32;
    // Each vertex's inset and whether it is stone ground, once (a vertex serves about six
    // triangles).
    let per_vertex: Vec<(f32, bool)> = vertices
        .iter()
        .map(|v| {
            (
                frame.inset_mm(v.position[0], v.position[1]),
                v.region != gold && v.relief < ENGRAVED_RELIEF_MM,
            )
        })
        .collect();
    let (mut rest, mut band) = (Vec::with_capacity(indices.len()), Vec::new());
    for tri in indices.chunks_exact(3) {
        let mut lo = f32::INFINITY;
        let mut hi = f32::NEG_INFINITY;
        let mut ground = false;
        for &(inset, is_ground) in tri.iter().filter_map(|&i| per_vertex.get(i as usize)) {
            lo = lo.min(inset);
            hi = hi.max(inset);
            ground |= is_ground;
        }
        if ground && hi >= band_mm[0] && lo <= band_mm[1] {
            band.extend_from_slice(tri);
        } else {
            rest.extend_from_slice(tri);
        }
    }
    let split = rest.len();
    rest.extend_from_slice(&band);
    (rest, split)
}

/// Per-vertex tangent frames for normal mapping with texture coordinates `uv` of a position:
/// xyz a unit tangent along +u, perpendicular to the vertex normal, and w the handedness (+1
/// or -1: the bitangent, along +v, is w * normal x tangent). Triangles whose texture
/// coordinates are degenerate (two vertices sharing them, or all three on a line: a vertical
/// wall under planar coordinates) give no tangent; a vertex with no usable frame at all (only
/// such triangles, or a zero normal) gets w = 0, which tells the shader to shade it without
/// the normal map. Never NaN.
pub fn tangents(
    vertices: &[Vertex],
    indices: &[u32],
    uv: impl Fn([f32; 3]) -> [f32; 2],
) -> Vec<[f32; 4]> {
    let uvs: Vec<[f32; 2]> = vertices.iter().map(|v| uv(v.position)).collect();
    let mut t_sum = vec![[0f32; 3]; vertices.len()];
    let mut b_sum = vec![[0f32; 3]; vertices.len()];
    for tri in indices.chunks_exact(3) {
        let [a, b, c] = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
        if a.max(b).max(c) >= vertices.len() {
            continue;
        }
        let (p0, p1, p2) = (
            vertices[a].position,
            vertices[b].position,
            vertices[c].position,
        );
        let (e1, e2) = (sub(p1, p0), sub(p2, p0));
        let (du1, dv1) = (uvs[b][0] - uvs[a][0], uvs[b][1] - uvs[a][1]);
        let (du2, dv2) = (uvs[c][0] - uvs[a][0], uvs[c][1] - uvs[a][1]);
        let det = du1 * dv2 - du2 * dv1;
        // Degenerate in texture space: the two uv edges (nearly) parallel, relative to their
        // lengths, so the scale of the coordinates does not matter.
        let scale = (du1 * du1 + dv1 * dv1) * (du2 * du2 + dv2 * dv2);
        if !(det.is_finite() && det * det > 1e-6 * scale && scale > 0.0) {
            continue;
        }
        // Weighted by the triangle's area (its normal's length), direction from the uv map.
        let area = dot(cross(e1, e2), cross(e1, e2)).sqrt();
        let t = sub(scaled(e1, dv2), scaled(e2, dv1));
        let bt = sub(scaled(e2, du1), scaled(e1, du2));
        let (tl, bl) = (dot(t, t).sqrt(), dot(bt, bt).sqrt());
        if !(tl > 0.0 && bl > 0.0 && area.is_finite()) {
            continue;
        }
        // The sign of det orients them (a mirrored uv map flips the tangent).
        let weight = area * det.signum();
        let (t, bt) = (scaled(t, weight / tl), scaled(bt, weight / bl));
        for v in [a, b, c] {
            t_sum[v] = add(t_sum[v], t);
            b_sum[v] = add(b_sum[v], bt);
        }
    }
    vertices
        .iter()
        .zip(t_sum.iter().zip(&b_sum))
        .map(|(v, (&t, &bt))| {
            let nl = dot(v.normal, v.normal).sqrt();
            if !(nl > 1e-12 && nl.is_finite()) {
                return [1.0, 0.0, 0.0, 0.0];
            }
            let n = scaled(v.normal, 1.0 / nl);
            // Gram-Schmidt against the normal.
            let t = sub(t, scaled(n, dot(n, t)));
            let tl = dot(t, t).sqrt();
            if !(tl > 1e-12 && tl.is_finite()) {
                // No frame: any unit vector across the normal, flagged unusable.
                let axis = if n[0].abs() < 0.9 {
                    [1.0, 0.0, 0.0]
                } else {
                    [0.0, 1.0, 0.0]
                };
                let t = sub(axis, scaled(n, dot(n, axis)));
                let l = dot(t, t).sqrt();
                return [t[0] / l, t[1] / l, t[2] / l, 0.0];
            }
            let t = scaled(t, 1.0 / tl);
            let w = if dot(cross(n, t), bt) < 0.0 {
                -1.0
            } else {
                1.0
            };
            [t[0], t[1], t[2], w]
        })
        .collect()
}

/// Voxel size of the baked noise, mm. Its shortest waves (the marble's fine cloudiness, the
/// gold's ripple) are 4.3 and 6.7 mm long; trilinear reads between voxels this far apart keep
/// the goldens within their tolerance (measured in BENCHMARKS.md).
pub const NOISE_VOXEL_MM: f32 = 0.35;
/// Margin round the mesh's vertices, mm: the engraving's parallax moves the point the stone
/// is shaded at along the ground and into its grooves.
const NOISE_MARGIN_MM: f32 = 1.0;
/// The box's corners lie on this grid (mm), so that gems of one size share a volume and the
/// voxels sit at the same places in every volume.
const NOISE_GRID_MM: f32 = 4.0;
/// The most voxels along one side: a larger stone gets larger voxels.
const NOISE_MAX_SIDE: u32 = 256;

/// Where the mesh's baked noise lies: voxel centres at `origin + i * voxel_mm` for
/// `i < dims` along each axis (mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseVolume {
    pub origin: [f32; 3],
    pub voxel_mm: f32,
    pub dims: [u32; 3],
}

impl NoiseVolume {
    /// The volume over a mesh whose vertices span `min`..`max` (mm), with a margin, its
    /// corners on a fixed grid; `None` for a non-finite or inverted box.
    pub fn covering(min: [f32; 3], max: [f32; 3]) -> Option<Self> {
        if !(0..3).all(|k| min[k].is_finite() && max[k].is_finite() && min[k] <= max[k]) {
            return None;
        }
        let lo = min.map(|v| ((v - NOISE_MARGIN_MM) / NOISE_GRID_MM).floor() * NOISE_GRID_MM);
        let hi = max.map(|v| ((v + NOISE_MARGIN_MM) / NOISE_GRID_MM).ceil() * NOISE_GRID_MM);
        let longest = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f32::max);
        let voxel_mm = NOISE_VOXEL_MM.max(longest / (NOISE_MAX_SIDE - 1) as f32);
        let dims = [0, 1, 2].map(|k| ((hi[k] - lo[k]) / voxel_mm).ceil() as u32 + 1);
        Some(NoiseVolume {
            origin: lo,
            voxel_mm,
            dims,
        })
    }

    /// Whether the volume holds a mesh spanning `min`..`max` with its margin (so it can be
    /// kept for that mesh instead of baking again).
    pub fn holds(&self, min: [f32; 3], max: [f32; 3]) -> bool {
        (0..3).all(|k| {
            let end = self.origin[k] + (self.dims[k] - 1) as f32 * self.voxel_mm;
            min[k] - NOISE_MARGIN_MM >= self.origin[k] && max[k] + NOISE_MARGIN_MM <= end
        })
    }

    pub fn voxels(&self) -> u64 {
        self.dims.iter().map(|&d| u64::from(d)).product()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glyptic_core::scene::Region;

    fn vertex(p: [f32; 3], n: [f32; 3]) -> Vertex {
        Vertex::open(p, n, 0.0, Region::Ground)
    }

    const FRAME: PlanarFrame = PlanarFrame {
        centre: [0.0, 0.0],
        half: [23.6, 29.6],
    };

    #[test]
    fn a_flat_ground_has_the_planar_frame() {
        // Two triangles of the plane z = 0, facing +z.
        let v: Vec<Vertex> = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
            .iter()
            .map(|&[x, y]| vertex([x, y, 0.0], [0.0, 0.0, 1.0]))
            .collect();
        let t = tangents(&v, &[0, 1, 2, 0, 2, 3], |p| FRAME.uv(p));
        for f in t {
            // +u is +x; +v is -y, which is -(n x t) = -(+y): handedness -1.
            assert!(
                (f[0] - 1.0).abs() < 1e-5 && f[1].abs() < 1e-5 && f[2].abs() < 1e-5,
                "{f:?}"
            );
            assert_eq!(f[3], -1.0);
        }
    }

    #[test]
    fn degenerate_texture_coordinates_give_no_nan_and_no_frame() {
        // A vertical wall under planar coordinates: vertices 0 and 3 share x and y (and so
        // their uv), as do 1 and 2; a wall vertex shared with a good ground triangle keeps a
        // good frame.
        let wall = [1.0, 0.0, 0.0];
        let v = vec![
            vertex([0.0, 0.0, 0.0], wall),
            vertex([0.0, 1.0, 0.0], wall),
            vertex([0.0, 1.0, 2.0], wall),
            vertex([0.0, 0.0, 2.0], wall),
            vertex([-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
            vertex([-1.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
            // A zero normal and a NaN position.
            vertex([5.0, 5.0, 0.0], [0.0, 0.0, 0.0]),
            vertex([f32::NAN, 5.0, 0.0], [0.0, 0.0, 1.0]),
            vertex([6.0, 5.0, 0.0], [0.0, 0.0, 1.0]),
        ];
        let idx = [0, 1, 2, 0, 2, 3, 4, 0, 1, 4, 1, 5, 6, 7, 8];
        let t = tangents(&v, &idx, |p| FRAME.uv(p));
        assert!(t.iter().flatten().all(|c| c.is_finite()), "{t:?}");
        // Wall-only vertices: flagged, still unit and across their normal.
        for k in [2, 3] {
            assert_eq!(t[k][3], 0.0, "vertex {k}: {:?}", t[k]);
            let l = (t[k][0].powi(2) + t[k][1].powi(2) + t[k][2].powi(2)).sqrt();
            assert!((l - 1.0).abs() < 1e-5 && t[k][0].abs() < 1e-5);
        }
        // Ground vertices keep the planar frame.
        for k in [4, 5] {
            assert!(
                (t[k][0] - 1.0).abs() < 1e-5 && t[k][3] == -1.0,
                "vertex {k}: {:?}",
                t[k]
            );
        }
        // Vertex 0 is on the wall and the ground: the ground's tangent, made perpendicular to
        // its (wall) normal, is degenerate too (+x is the wall's normal): no frame, no NaN.
        assert_eq!(t[0][3], 0.0);
        for k in [6, 7, 8] {
            assert_eq!(t[k][3], 0.0, "vertex {k}: {:?}", t[k]);
        }
    }

    #[test]
    fn the_border_is_engraved_inside_the_bezel_and_nowhere_else() {
        let p = EngravingParams {
            size: 512,
            ..EngravingParams::default()
        };
        let h = engraving_heights(&FRAME, &p);
        let n = p.size as usize;
        let texel_at = |x: f32, y: f32| {
            let uv = FRAME.uv([x, y, 0.0]);
            let (i, j) = ((uv[0] * n as f32) as usize, (uv[1] * n as f32) as usize);
            h[j.min(n - 1) * n + i.min(n - 1)]
        };
        // The centre, the bezel and outside are untouched.
        assert_eq!(texel_at(0.0, 0.0), 1.0);
        assert_eq!(texel_at(22.0, 0.0), 1.0);
        assert_eq!(texel_at(0.0, 29.0), 1.0);
        // Along a ray across the band (x from the outline inwards): the two framing lines, each
        // a groove reaching near its full depth, and grooves in between.
        let profile: Vec<f32> = (0..400)
            .map(|k| texel_at(23.6 - 2.0 - 5.0 * k as f32 / 400.0, 0.3))
            .collect();
        let grooves = profile
            .windows(2)
            .filter(|w| w[0] == 1.0 && w[1] < 1.0)
            .count();
        assert!(grooves >= 3, "{grooves} grooves across the band");
        assert!(profile.iter().cloned().fold(1.0, f32::min) < 0.2);
        // The engraved share of the band is a pattern, not a fill.
        let engraved = h.iter().filter(|&&v| v < 1.0).count() as f32 / h.len() as f32;
        assert!((0.01..0.15).contains(&engraved), "{engraved}");
    }

    #[test]
    fn band_triangles_go_last_and_none_is_lost() {
        // A grid over the frame: ground, with a raised block in the middle and gold at x > 20.
        let mut v = Vec::new();
        let n = 48u32;
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (
                    -23.6 + 47.2 * i as f32 / n as f32,
                    -29.6 + 59.2 * j as f32 / n as f32,
                );
                let mut vx = vertex([x, y, 0.0], [0.0, 0.0, 1.0]);
                if x.abs() < 8.0 && y.abs() < 8.0 {
                    vx.relief = 3.0;
                    vx.region = Region::Relief as u32;
                }
                if x > 20.0 {
                    vx.region = Region::Gold as u32;
                }
                v.push(vx);
            }
        }
        let mut idx = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let a = j * (n + 1) + i;
                idx.extend_from_slice(&[a, a + 1, a + n + 2, a, a + n + 2, a + n + 1]);
            }
        }
        let band = [2.4, 6.2];
        let (ordered, start) = band_last(&v, &idx, &FRAME, band);
        let mut a: Vec<[u32; 3]> = idx.chunks(3).map(|t| [t[0], t[1], t[2]]).collect();
        let mut b: Vec<[u32; 3]> = ordered.chunks(3).map(|t| [t[0], t[1], t[2]]).collect();
        a.sort_unstable();
        b.sort_unstable();
        assert_eq!(a, b, "the same triangles, reordered");
        assert!(start % 3 == 0 && start < ordered.len() && start > ordered.len() / 2);
        for (k, t) in ordered.chunks(3).enumerate() {
            let in_band = 3 * k >= start;
            let insets: Vec<f32> = t
                .iter()
                .map(|&i| FRAME.inset_mm(v[i as usize].position[0], v[i as usize].position[1]))
                .collect();
            let ground = t.iter().any(|&i| {
                v[i as usize].region != Region::Gold as u32 && v[i as usize].relief < 0.08
            });
            let reaches = insets.iter().cloned().fold(f32::MIN, f32::max) >= band[0]
                && insets.iter().cloned().fold(f32::MAX, f32::min) <= band[1];
            assert_eq!(
                in_band,
                ground && reaches,
                "triangle {t:?}, insets {insets:?}"
            );
        }
        // The raised middle and the gold are never drawn with the engraving.
        assert!(ordered[start..].iter().all(|&i| {
            let p = v[i as usize].position;
            p[0].abs() >= 8.0 - 1.0 || p[1].abs() >= 8.0 - 1.5
        }));
    }

    #[test]
    fn normals_tilt_away_from_rising_ground() {
        // Height rising along +u: the normal leans towards -u; along +v: towards -v.
        let size = 8;
        let ramp_u: Vec<f32> = (0..64).map(|k| (k % 8) as f32 / 8.0).collect();
        let ramp_v: Vec<f32> = (0..64).map(|k| (k / 8) as f32 / 8.0).collect();
        let nu = normal_map(&ramp_u, size, [0.1, 0.1], 0.1);
        let nv = normal_map(&ramp_v, size, [0.1, 0.1], 0.1);
        let flat = normal_map(&[0.5; 64], size, [0.1, 0.1], 0.1);
        assert!(nu[27][0] < 128 && nu[27][1] == 128 && nu[27][2] > 128);
        assert!(nv[27][1] < 128 && nv[27][0] == 128);
        assert!(flat.iter().all(|t| *t == [128, 128, 255, 255]));
    }

    #[test]
    fn the_maps_have_a_full_mip_chain() {
        let e = engraving(
            &FRAME,
            &EngravingParams {
                size: 100,
                ..EngravingParams::default()
            },
        );
        assert_eq!(e.size, 128);
        assert_eq!(e.height.len(), 8);
        for (k, (h, n)) in e.height.iter().zip(&e.normal).enumerate() {
            let side = (128usize >> k).max(1);
            assert_eq!((h.len(), n.len()), (side * side, side * side), "level {k}");
        }
        // The 1 x 1 level of a mostly flat map: almost flat, almost white.
        assert!(e.height[7][0] > 240 && e.normal[7][0][2] > 250);
    }

    #[test]
    fn the_noise_volume_covers_the_mesh_on_a_fixed_grid() {
        // A 44 x 56 mm cameo, its back 3 mm below the ground, relief up to 5 mm.
        let (min, max) = ([-22.0, -28.0, -3.0], [22.0, 28.0, 5.0]);
        let v = NoiseVolume::covering(min, max).expect("a finite box");
        assert_eq!(v.voxel_mm, NOISE_VOXEL_MM);
        for k in 0..3 {
            let end = v.origin[k] + (v.dims[k] - 1) as f32 * v.voxel_mm;
            assert!(v.origin[k] <= min[k] - NOISE_MARGIN_MM, "axis {k}: {v:?}");
            assert!(end >= max[k] + NOISE_MARGIN_MM, "axis {k}: {v:?}");
            assert_eq!(v.origin[k] % NOISE_GRID_MM, 0.0, "axis {k}: {v:?}");
            // No more than a grid step of slack each side.
            assert!(end - v.origin[k] <= max[k] - min[k] + 2.0 * (NOISE_MARGIN_MM + NOISE_GRID_MM));
        }
        assert!(v.holds(min, max));
        // A slightly different face on the same stone keeps the volume; a taller relief does not.
        assert!(v.holds([-21.5, -27.5, -3.0], [21.0, 27.5, 5.5]));
        assert!(!v.holds(min, [22.0, 28.0, 9.0]));
        assert_eq!(
            NoiseVolume::covering([-21.5, -27.5, -3.0], [21.0, 27.5, 5.5]),
            Some(v)
        );
        // Bounded for a huge mesh, none for a broken box.
        let huge = NoiseVolume::covering([-5e4; 3], [5e4; 3]).expect("finite");
        assert!(
            huge.dims.iter().all(|&d| d <= NOISE_MAX_SIDE + 1),
            "{huge:?}"
        );
        assert!(huge.holds([-5e4; 3], [5e4; 3]));
        assert_eq!(NoiseVolume::covering([0.0, 0.0, f32::NAN], [1.0; 3]), None);
        assert_eq!(NoiseVolume::covering([1.0; 3], [0.0; 3]), None);
    }
}
