//! Rasterising the face mesh into the relief grid: the highest surface over each cell.
//!
//! Vertices arrive already projected to grid coordinates (x, y in cells, from node (0, 0))
//! and a height (canonical millimetres); the caller does the projection (see
//! [`super::face::Placement`]). Pure computation.

/// A triangle's corners and its signed area in the plane, if it is drawn: all three corners
/// exist and are finite, it reaches height 0 (the far half of the head is hidden behind the
/// near half; triangles that reach the centre plane stay: they make the profile's outline)
/// and it is not degenerate.
fn near_triangle(points: &[Option<[f32; 3]>], t: &[u32; 3]) -> Option<([[f32; 3]; 3], f32)> {
    let corner = |i: u32| points.get(i as usize).copied().flatten();
    let (a, b, c) = (corner(t[0])?, corner(t[1])?, corner(t[2])?);
    if a[2].max(b[2]).max(c[2]) < 0.0 {
        return None;
    }
    let area = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
    (area.abs() >= 1e-12).then_some(([a, b, c], area))
}

/// Rasterises triangles into a max-height grid (`cols` x `rows`, row-major). Only what lies
/// above height 0 is drawn (profile: the near half of the head). `None` vertices (non-finite
/// input) and triangles pointing past the list are skipped. Returns NaN where no triangle
/// covers a node.
pub fn rasterise(
    points: &[Option<[f32; 3]>],
    triangles: &[[u32; 3]],
    cols: usize,
    rows: usize,
) -> Vec<f32> {
    rasterise_with(points, triangles, None, cols, rows).0
}

/// [`rasterise`], and a per-vertex attribute interpolated on the surface it keeps (0 where
/// no triangle covers a node, or a vertex has no value).
pub fn rasterise_attribute(
    points: &[Option<[f32; 3]>],
    triangles: &[[u32; 3]],
    attribute: &[f32],
    cols: usize,
    rows: usize,
) -> (Vec<f32>, Vec<f32>) {
    rasterise_with(points, triangles, Some(attribute), cols, rows)
}

fn rasterise_with(
    points: &[Option<[f32; 3]>],
    triangles: &[[u32; 3]],
    attribute: Option<&[f32]>,
    cols: usize,
    rows: usize,
) -> (Vec<f32>, Vec<f32>) {
    let mut h = vec![f32::NAN; cols * rows];
    let mut values = vec![0f32; if attribute.is_some() { cols * rows } else { 0 }];
    let value = |i: u32| {
        attribute
            .and_then(|a| a.get(i as usize))
            .copied()
            .filter(|v| v.is_finite())
            .unwrap_or(0.0)
    };
    for t in triangles {
        let Some(([a, b, c], area)) = near_triangle(points, t) else {
            continue;
        };
        // Samples sit on whole nodes: the box runs from the first node at or after the smallest
        // coordinate to the last at or before the largest, widened by the edge tolerance below
        // (a sample with every weight >= -1e-4 lies within 3e-4 of the triangle's extent).
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
                        if attribute.is_some() {
                            values[y * cols + x] =
                                w0 * value(t[0]) + w1 * value(t[1]) + w2 * value(t[2]);
                        }
                    }
                }
            }
        }
    }
    (h, values)
}

/// Sub-samples per node for [`coverage`] (and the template's coverage, which follows it).
pub const COVERAGE_SAMPLES: usize = 64;

/// Offset (cells, -0.5..0.5 each way) of sub-sample `k` from its node: a rank-1 lattice of
/// [`COVERAGE_SAMPLES`] points with generator 19, so no two share a row or a column. An
/// outline along either axis (the commonest stretches: the crown, the nape, the brow) is
/// found to 1/64 of a cell; the regular 4 x 4 grid before found it to a quarter, which showed
/// as stair-steps at 3840 px. Every direction's worst error is 0.07 of a cell (the 4 x 4
/// grid's 0.125), the mean 0.007 (0.019).
pub fn coverage_offset(k: usize) -> [f32; 2] {
    let n = COVERAGE_SAMPLES;
    let at = |v: usize| (v as f32 + 0.5) / n as f32 - 0.5;
    [at(k % n), at((k * 19) % n)]
}

/// The share of each node's cell (the square of one cell around it) covered by the
/// triangles' near half (as [`rasterise`] draws it), from [`COVERAGE_SAMPLES`] sub-samples:
/// an outline with sub-cell precision, so the relief's wall follows the silhouette instead of
/// the grid's stair-steps. `centres` is [`rasterise`]'s result for the same triangles: a node
/// whose 3 x 3 neighbourhood is all covered (or all empty) there is taken as whole (or empty)
/// without sampling, so only the outline's nodes cost sub-samples.
pub fn coverage(
    points: &[Option<[f32; 3]>],
    triangles: &[[u32; 3]],
    centres: &[f32],
    cols: usize,
    rows: usize,
) -> Vec<f32> {
    let mut bits = vec![0u64; cols * rows];
    // Nodes on the outline: some node of the 3 x 3 neighbourhood differs from the others
    // (looked for only around the covered nodes' box).
    let mut edge = vec![false; cols * rows];
    let (mut x0, mut y0, mut x1, mut y1) = (cols, rows, 0, 0);
    for (i, _) in centres.iter().enumerate().filter(|(_, c)| c.is_finite()) {
        let (x, y) = (i % cols, i / cols);
        (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
    }
    if x0 > x1 {
        return vec![0.0; cols * rows];
    }
    let (x0, y0) = (x0.saturating_sub(1), y0.saturating_sub(1));
    let (x1, y1) = ((x1 + 1).min(cols - 1), (y1 + 1).min(rows - 1));
    for y in y0..=y1 {
        for x in x0..=x1 {
            let i = y * cols + x;
            let here = centres[i].is_finite();
            let mut differs = false;
            for ny in y.saturating_sub(1)..=(y + 1).min(rows - 1) {
                for nx in x.saturating_sub(1)..=(x + 1).min(cols - 1) {
                    differs |= centres[ny * cols + nx].is_finite() != here;
                }
            }
            if differs {
                edge[i] = true;
            } else if here {
                bits[i] = u64::MAX;
            }
        }
    }
    let offsets: [[f32; 2]; COVERAGE_SAMPLES] = std::array::from_fn(coverage_offset);
    for t in triangles {
        let Some(([a, b, c], area)) = near_triangle(points, t) else {
            continue;
        };
        let inv_area = 1.0 / area;
        let (lo_x, hi_x) = (a[0].min(b[0]).min(c[0]), a[0].max(b[0]).max(c[0]));
        let (lo_y, hi_y) = (a[1].min(b[1]).min(c[1]), a[1].max(b[1]).max(c[1]));
        let min_x = (lo_x - 0.5).ceil().max(0.0) as usize;
        let max_x = ((hi_x + 0.5).floor() as isize).min(cols as isize - 1);
        let min_y = (lo_y - 0.5).ceil().max(0.0) as usize;
        let max_y = ((hi_y + 0.5).floor() as isize).min(rows as isize - 1);
        if max_x < min_x as isize || max_y < min_y as isize {
            continue;
        }
        for y in min_y..=max_y as usize {
            for x in min_x..=max_x as usize {
                let mut mask = bits[y * cols + x];
                if mask == u64::MAX || !edge[y * cols + x] {
                    continue;
                }
                // The barycentric weights are affine in the sample's offset: the node's, plus
                // the offset times their gradients.
                let (px, py) = (x as f32, y as f32);
                let w0 = ((b[0] - px) * (c[1] - py) - (c[0] - px) * (b[1] - py)) * inv_area;
                let w1 = ((c[0] - px) * (a[1] - py) - (a[0] - px) * (c[1] - py)) * inv_area;
                let d0 = [(b[1] - c[1]) * inv_area, (c[0] - b[0]) * inv_area];
                let d1 = [(c[1] - a[1]) * inv_area, (a[0] - c[0]) * inv_area];
                for (k, [ox, oy]) in offsets.iter().enumerate() {
                    let u = w0 + ox * d0[0] + oy * d0[1];
                    let v = w1 + ox * d1[0] + oy * d1[1];
                    if u >= -1e-4 && v >= -1e-4 && 1.0 - u - v >= -1e-4 {
                        mask |= 1u64 << k;
                    }
                }
                bits[y * cols + x] = mask;
            }
        }
    }
    bits.iter()
        .map(|b| b.count_ones() as f32 / COVERAGE_SAMPLES as f32)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rasterise_covers_nodes_on_edges_and_corners() {
        // A right triangle with corners on nodes, height 5.
        let points = [
            Some([1.0, 1.0, 5.0]),
            Some([4.0, 1.0, 5.0]),
            Some([1.0, 4.0, 5.0]),
        ];
        let h = rasterise(&points, &[[0, 1, 2]], 6, 6);
        let covered: Vec<(usize, usize)> = (0..36)
            .filter(|&i| h[i].is_finite())
            .map(|i| (i % 6, i / 6))
            .collect();
        // Nodes with x, y in 1..=4 and (x - 1) + (y - 1) <= 3: ten, corners included.
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

    #[test]
    fn coverage_is_the_covered_share_of_each_cell() {
        // A square 2.5 x 2.5 cells from (0.75, 0.75): node (2, 2)'s cell is covered whole,
        // node (3, 2)'s (x 2.5..3.5) up to x = 3.25: three quarters (exactly: the lattice has
        // a sample in each of its 64 columns); the corners' cells 0.75 x 0.75 to within the
        // lattice's error.
        let points = [
            Some([0.75, 0.75, 1.0]),
            Some([3.25, 0.75, 1.0]),
            Some([3.25, 3.25, 1.0]),
            Some([0.75, 3.25, 1.0]),
        ];
        let tris = [[0, 1, 2], [0, 2, 3]];
        let c = coverage(&points, &tris, &rasterise(&points, &tris, 5, 5), 5, 5);
        assert_eq!(c[2 * 5 + 2], 1.0);
        assert_eq!(c[2 * 5 + 3], 0.75);
        assert_eq!(c[2 * 5 + 1], 0.75);
        assert!(
            (c[3 * 5 + 3] - 0.75 * 0.75).abs() <= 2.0 / 64.0,
            "{}",
            c[3 * 5 + 3]
        );
        assert!((c[5 + 1] - 0.75 * 0.75).abs() <= 2.0 / 64.0, "{}", c[5 + 1]);
        assert_eq!(c[4 * 5 + 4], 0.0);
        assert_eq!(c[1], 0.0, "{c:?}");
    }

    /// A half-plane's share of a cell from the sub-sample lattice, against the exact area, for
    /// edges in every direction and position: within 0.075 of a cell's area (the old
    /// regular 4 x 4 grid: 0.125), and along the axes within 1/64 (the grid: 1/8).
    #[test]
    fn the_sub_samples_measure_a_straight_edge_in_any_direction() {
        let offsets: Vec<[f32; 2]> = (0..COVERAGE_SAMPLES).map(coverage_offset).collect();
        // Exact area of the unit cell (centred on 0) where n . p < d, by fine integration.
        let exact = |n: [f32; 2], d: f32| {
            let m = 256;
            let at = |k: usize| (k as f32 + 0.5) / m as f32 - 0.5;
            (0..m * m)
                .filter(|&k| n[0] * at(k % m) + n[1] * at(k / m) < d)
                .count() as f32
                / (m * m) as f32
        };
        let share = |n: [f32; 2], d: f32| {
            offsets
                .iter()
                .filter(|o| n[0] * o[0] + n[1] * o[1] < d)
                .count() as f32
                / COVERAGE_SAMPLES as f32
        };
        let (mut worst, mut worst_axis) = (0f32, 0f32);
        for a in 0..36 {
            let angle = a as f32 * 5f32.to_radians();
            let n = [angle.cos(), angle.sin()];
            for s in 0..=40 {
                let d = -0.7 + 1.4 * s as f32 / 40.0;
                let e = (share(n, d) - exact(n, d)).abs();
                worst = worst.max(e);
                if a % 18 == 0 {
                    worst_axis = worst_axis.max(e);
                }
            }
        }
        assert!(worst < 0.075, "worst {worst}");
        assert!(
            worst_axis <= 1.0 / 64.0 + 0.01,
            "along the axes {worst_axis}"
        );
    }

    #[test]
    fn rasterise_keeps_the_highest_and_skips_bad_triangles() {
        let points = [
            Some([0.0, 0.0, 1.0]),
            Some([5.0, 0.0, 1.0]),
            Some([0.0, 5.0, 1.0]),
            Some([0.0, 0.0, 3.0]),
            Some([5.0, 0.0, 3.0]),
            Some([0.0, 5.0, 3.0]),
            None,
            Some([0.0, 0.0, -2.0]),
            Some([5.0, 0.0, -2.0]),
            Some([0.0, 5.0, -2.0]),
        ];
        let tris = [[0, 1, 2], [3, 4, 5], [6, 1, 2], [0, 1, 99], [7, 8, 9]];
        let h = rasterise(&points, &tris, 6, 6);
        assert_eq!(h[6 + 1], 3.0);
        assert!(h[5 * 6 + 5].is_nan());
    }
}
