//! Occluding-boundary vertices of a posed mesh, and their correspondences with the outline
//! landmarks on the side of the face turned away from the camera (eos's "occluding edge"
//! fitting).
//!
//! An edge is occluding when one of its two faces points towards the camera and the other away
//! (mesh-boundary edges are skipped, as in eos). Its vertices are kept only if nothing else of
//! the mesh lies between them and the camera. eos tests that by casting one ray per vertex
//! against every triangle (about 50 ms per iteration); here the triangles are bucketed once
//! into a grid over the image plane, so each ray meets only the few triangles of its cell.
//!
//! Frames: positions in model mm; `rotation` maps them to camera space, where the camera looks
//! along -z (larger z is nearer) and projection is orthographic.

use nalgebra::Matrix3;

use crate::shapemodel::EdgeTopology;

/// Grid cells along the longer side of the projected mesh.
const GRID_CELLS: usize = 96;
/// Depth margin (mm) so that a vertex is not hidden by triangles it almost touches.
const DEPTH_EPS_MM: f32 = 0.5;

/// Vertices on occluding edges that the mesh does not hide from the camera, sorted.
///
/// `positions` are the mesh's vertices, `[x0, y0, z0, x1, ...]`, model mm. Single precision is
/// ample here (the depth margin is half a millimetre) and keeps the pass cheap: it runs on the
/// whole mesh whenever the pose has turned.
pub fn visible_occluding_vertices(
    positions: &[f32],
    triangles: &[[u32; 3]],
    edges: &EdgeTopology,
    rotation: &Matrix3<f64>,
) -> Vec<u32> {
    let r = rotation.cast::<f32>();
    let rotated: Vec<[f32; 3]> = positions
        .chunks_exact(3)
        .map(|p| {
            let v = r * nalgebra::Vector3::new(p[0], p[1], p[2]);
            [v.x, v.y, v.z]
        })
        .collect();
    let n = rotated.len();
    // Which way each face points (sign of its normal's z in camera space); 0 = invalid.
    let facing: Vec<i8> = triangles
        .iter()
        .map(|t| {
            if t.iter().any(|&v| v as usize >= n) {
                return 0;
            }
            let [a, b, c] = t.map(|v| rotated[v as usize]);
            // z of (b - a) x (c - a), without forming the whole cross product.
            let z = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
            if z > 0.0 { 1 } else { -1 }
        })
        .collect();
    let mut candidates: Vec<u32> = Vec::new();
    for (faces, verts) in edges.adjacent_faces.iter().zip(&edges.adjacent_vertices) {
        let ([Some(f0), Some(f1)], [Some(v0), Some(v1)]) = (faces, verts) else {
            continue;
        };
        let a = facing.get(*f0 as usize).copied().unwrap_or(0);
        let b = facing.get(*f1 as usize).copied().unwrap_or(0);
        if a != 0 && b != 0 && a != b {
            candidates.extend([*v0, *v1]);
        }
    }
    candidates.retain(|&v| (v as usize) < n);
    candidates.sort_unstable();
    candidates.dedup();
    if candidates.is_empty() {
        return candidates;
    }
    // Only front-facing triangles can hide a vertex from the camera: a ray from a vertex on the
    // visible side of this open face mask meets the mask's front before any back-facing part.
    let front: Vec<[u32; 3]> = triangles
        .iter()
        .zip(&facing)
        .filter(|(_, f)| **f > 0)
        .map(|(t, _)| *t)
        .collect();
    let grid = TriangleGrid::new(&rotated, &front, &candidates);
    candidates.retain(|&v| !grid.occluded(v, &rotated, &front));
    candidates
}

/// Triangles bucketed by the image-plane cells their bounding boxes touch (CSR layout).
struct TriangleGrid {
    min: [f32; 2],
    cell: f32,
    cols: usize,
    rows: usize,
    starts: Vec<u32>,
    items: Vec<u32>,
}

impl TriangleGrid {
    /// Buckets the triangles, but only into cells that hold one of `queries` (the only cells
    /// that will be asked about).
    fn new(rotated: &[[f32; 3]], triangles: &[[u32; 3]], queries: &[u32]) -> Self {
        let (mut lo, mut hi) = ([f32::MAX; 2], [f32::MIN; 2]);
        for p in rotated {
            lo = [lo[0].min(p[0]), lo[1].min(p[1])];
            hi = [hi[0].max(p[0]), hi[1].max(p[1])];
        }
        let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-6);
        let cell = extent / GRID_CELLS as f32;
        let cols = ((hi[0] - lo[0]) / cell) as usize + 1;
        let rows = ((hi[1] - lo[1]) / cell) as usize + 1;
        let to_cell =
            |v: f32, o: f32, max: usize| (((v - o) / cell).max(0.0) as usize).min(max - 1);
        let mut wanted = vec![false; cols * rows];
        for &q in queries {
            let p = rotated[q as usize];
            wanted[to_cell(p[1], lo[1], rows) * cols + to_cell(p[0], lo[0], cols)] = true;
        }
        let n = rotated.len();
        // Each valid triangle's cell range, computed once for both passes.
        let ranges: Vec<Option<[u16; 4]>> = triangles
            .iter()
            .map(|t| {
                if t.iter().any(|&v| v as usize >= n) {
                    return None;
                }
                let [a, b, c] = t.map(|v| rotated[v as usize]);
                Some([
                    to_cell(a[0].min(b[0]).min(c[0]), lo[0], cols) as u16,
                    to_cell(a[0].max(b[0]).max(c[0]), lo[0], cols) as u16,
                    to_cell(a[1].min(b[1]).min(c[1]), lo[1], rows) as u16,
                    to_cell(a[1].max(b[1]).max(c[1]), lo[1], rows) as u16,
                ])
            })
            .collect();
        let mut counts = vec![0u32; cols * rows + 1];
        for [x0, x1, y0, y1] in ranges.iter().flatten().map(|r| r.map(usize::from)) {
            for cy in y0..=y1 {
                for cx in x0..=x1 {
                    let c = cy * cols + cx;
                    counts[c + 1] += wanted[c] as u32;
                }
            }
        }
        for i in 1..counts.len() {
            counts[i] += counts[i - 1];
        }
        let mut fill = counts.clone();
        let mut items = vec![0u32; counts[cols * rows] as usize];
        for (ti, range) in ranges.iter().enumerate() {
            let Some([x0, x1, y0, y1]) = range.map(|r| r.map(usize::from)) else {
                continue;
            };
            for cy in y0..=y1 {
                for cx in x0..=x1 {
                    let c = cy * cols + cx;
                    if wanted[c] {
                        items[fill[c] as usize] = ti as u32;
                        fill[c] += 1;
                    }
                }
            }
        }
        TriangleGrid {
            min: lo,
            cell,
            cols,
            rows,
            starts: counts,
            items,
        }
    }

    /// Whether a triangle not touching vertex `v` lies in front of it along the view ray.
    fn occluded(&self, v: u32, rotated: &[[f32; 3]], triangles: &[[u32; 3]]) -> bool {
        let p = rotated[v as usize];
        let cx = (((p[0] - self.min[0]) / self.cell).max(0.0) as usize).min(self.cols - 1);
        let cy = (((p[1] - self.min[1]) / self.cell).max(0.0) as usize).min(self.rows - 1);
        let cell = cy * self.cols + cx;
        let range = self.starts[cell] as usize..self.starts[cell + 1] as usize;
        self.items[range].iter().any(|&ti| {
            let t = triangles[ti as usize];
            if t.contains(&v) {
                return false;
            }
            let [a, b, c] = t.map(|i| rotated[i as usize]);
            let area = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
            if area.abs() < 1e-9 {
                return false;
            }
            let w0 = ((b[0] - p[0]) * (c[1] - p[1]) - (c[0] - p[0]) * (b[1] - p[1])) / area;
            let w1 = ((c[0] - p[0]) * (a[1] - p[1]) - (a[0] - p[0]) * (c[1] - p[1])) / area;
            let w2 = 1.0 - w0 - w1;
            w0 >= 0.0
                && w1 >= 0.0
                && w2 >= 0.0
                && w0 * a[2] + w1 * b[2] + w2 * c[2] > p[2] + DEPTH_EPS_MM
        })
    }
}
