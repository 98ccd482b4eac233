//! The carved stone as something to make: a closed solid for a 3D printer or a CAM program
//! (binary STL), and the relief as a 16-bit height map for a CNC router.
//!
//! Both come from the relief's height field, not from the rendered mesh: the render mesh is
//! split at material borders and its bezel is a separate gold part, so it is not watertight.
//! Units: gem millimetres, the ground at z = 0, the relief above it. The solid is the stone
//! alone (the bezel is a setting, made apart): the grid's cells whose four corners lie inside
//! the stone's oval, their top at the relief's heights, walls round their outline down to a
//! flat bottom `base_mm` below the ground. Its outline follows the grid (0.2 mm steps on the
//! cameo), which no printer or cutter resolves.

/// A height field on a square grid: `heights` row-major, `cols` x `rows`, node (0, 0) at
/// `origin`, `cell` apart (mm); heights in mm above the ground. [`super::Relief::height_field`]
/// gives the cameo's.
#[derive(Clone, Copy, Debug)]
pub struct HeightField<'a> {
    pub heights: &'a [f32],
    pub cols: usize,
    pub rows: usize,
    pub origin: [f32; 2],
    pub cell: f32,
}

impl HeightField<'_> {
    /// Height at node (`c`, `r`).
    pub fn at(&self, c: usize, r: usize) -> f32 {
        self.heights[r * self.cols + c]
    }

    /// Whether node (`c`, `r`) lies inside the oval with semi-axes `half` (mm) round the
    /// origin.
    pub fn in_oval(&self, c: usize, r: usize, half: [f32; 2]) -> bool {
        let x = self.origin[0] + c as f32 * self.cell;
        let y = self.origin[1] + r as f32 * self.cell;
        (x / half[0]).powi(2) + (y / half[1]).powi(2) <= 1.0
    }
}

/// A closed triangle mesh: every edge shared by exactly two triangles, wound
/// counter-clockwise seen from outside.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Solid {
    pub positions: Vec<[f32; 3]>,
    pub triangles: Vec<[u32; 3]>,
}

/// Why a solid or a height map could not be made.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SolidError {
    #[error("the relief's grid is empty or does not match its size")]
    BadGrid,
    #[error("no grid cell lies wholly inside the stone's oval")]
    NoStone,
    #[error("the relief has a non-finite height")]
    NonFinite,
    #[error("the base must be a positive thickness in mm, not {0}")]
    BadBase(f32),
}

/// Which cells (`cols - 1` x `rows - 1`, row-major) make the stone: all four corners inside
/// the oval with semi-axes `half` (mm, centred on the origin). Each row's cells are one run
/// holding the middle column (the oval is convex and symmetric), so no two cells meet at a
/// corner only and every edge of the solid is shared by exactly two triangles.
fn stone_cells(relief: &HeightField<'_>, half: [f32; 2]) -> Vec<bool> {
    let inside = |c: usize, r: usize| relief.in_oval(c, r, half);
    let (cw, ch) = (relief.cols - 1, relief.rows - 1);
    (0..cw * ch)
        .map(|i| {
            let (c, r) = (i % cw, i / cw);
            inside(c, r) && inside(c + 1, r) && inside(c, r + 1) && inside(c + 1, r + 1)
        })
        .collect()
}

fn check(relief: &HeightField<'_>) -> Result<(), SolidError> {
    if relief.cols < 2 || relief.rows < 2 || relief.heights.len() != relief.cols * relief.rows {
        return Err(SolidError::BadGrid);
    }
    if !(relief.cell.is_finite() && relief.cell > 0.0) {
        return Err(SolidError::BadGrid);
    }
    if relief.heights.iter().any(|h| !h.is_finite()) {
        return Err(SolidError::NonFinite);
    }
    Ok(())
}

/// The stone as a closed solid: the relief's top, walls round the oval's outline, a flat
/// bottom `base_mm` below the ground. `half`: the stone oval's semi-axes, mm.
pub fn solid(relief: &HeightField<'_>, half: [f32; 2], base_mm: f32) -> Result<Solid, SolidError> {
    check(relief)?;
    if !(base_mm.is_finite() && base_mm > 0.0) {
        return Err(SolidError::BadBase(base_mm));
    }
    let keep = stone_cells(relief, half);
    if !keep.iter().any(|&k| k) {
        return Err(SolidError::NoStone);
    }
    let (cols, rows) = (relief.cols, relief.rows);
    let cw = cols - 1;
    let kept = |c: isize, r: isize| {
        c >= 0 && r >= 0 && (c as usize) < cw && (r as usize) < rows - 1 && {
            keep[r as usize * cw + c as usize]
        }
    };
    // One top and one bottom vertex per node that a kept cell uses.
    let mut top = vec![u32::MAX; cols * rows];
    let mut bottom = vec![u32::MAX; cols * rows];
    let mut s = Solid::default();
    for r in 0..rows {
        for c in 0..cols {
            let used = (0..2).any(|dr| (0..2).any(|dc| kept(c as isize - dc, r as isize - dr)));
            if used {
                let (x, y) = (
                    relief.origin[0] + c as f32 * relief.cell,
                    relief.origin[1] + r as f32 * relief.cell,
                );
                let i = r * cols + c;
                top[i] = s.positions.len() as u32;
                s.positions.push([x, y, relief.heights[i]]);
                bottom[i] = s.positions.len() as u32;
                s.positions.push([x, y, -base_mm]);
            }
        }
    }
    let node = |c: usize, r: usize| r * cols + c;
    for r in 0..rows - 1 {
        for c in 0..cw {
            if !keep[r * cw + c] {
                continue;
            }
            // Corners counter-clockwise seen from +z (x right, y up).
            let q = [
                node(c, r),
                node(c + 1, r),
                node(c + 1, r + 1),
                node(c, r + 1),
            ];
            let t = q.map(|i| top[i]);
            let b = q.map(|i| bottom[i]);
            // Top: split along the diagonal that follows the surface better (the shorter
            // height difference), so a ridge across a cell is not cut off.
            let (h0, h1, h2, h3) = (
                relief.heights[q[0]],
                relief.heights[q[1]],
                relief.heights[q[2]],
                relief.heights[q[3]],
            );
            if (h0 - h2).abs() <= (h1 - h3).abs() {
                s.triangles.push([t[0], t[1], t[2]]);
                s.triangles.push([t[0], t[2], t[3]]);
            } else {
                s.triangles.push([t[0], t[1], t[3]]);
                s.triangles.push([t[1], t[2], t[3]]);
            }
            // Bottom: seen from below.
            s.triangles.push([b[0], b[2], b[1]]);
            s.triangles.push([b[0], b[3], b[2]]);
            // Walls where the neighbour across an edge is not stone: edge k runs from corner
            // k to corner k + 1 (counter-clockwise), the outside on its right.
            let (ci, ri) = (c as isize, r as isize);
            let across = [(ci, ri - 1), (ci + 1, ri), (ci, ri + 1), (ci - 1, ri)];
            for (k, &(ac, ar)) in across.iter().enumerate() {
                if kept(ac, ar) {
                    continue;
                }
                let (a, z) = (k, (k + 1) % 4);
                s.triangles.push([t[z], t[a], b[a]]);
                s.triangles.push([t[z], b[a], b[z]]);
            }
        }
    }
    Ok(s)
}

/// The solid as binary STL (little-endian; millimetres, as slicers assume).
pub fn stl(solid: &Solid, header: &str) -> Vec<u8> {
    let mut out = Vec::with_capacity(84 + 50 * solid.triangles.len());
    let mut head = [b' '; 80];
    // "solid" must not open a binary STL's header: some readers then take it for ASCII.
    let text = header.trim_start_matches("solid").as_bytes();
    head[..text.len().min(80)].copy_from_slice(&text[..text.len().min(80)]);
    out.extend_from_slice(&head);
    out.extend_from_slice(&(solid.triangles.len() as u32).to_le_bytes());
    for t in &solid.triangles {
        let [a, b, c] = t.map(|i| solid.positions[i as usize]);
        let n = crate::vec3::triangle_normal(a, b, c);
        let len = crate::vec3::length(n).max(1e-20);
        for value in n
            .map(|x| x / len)
            .iter()
            .chain(a.iter())
            .chain(b.iter())
            .chain(c.iter())
        {
            out.extend_from_slice(&value.to_le_bytes());
        }
        out.extend_from_slice(&0u16.to_le_bytes());
    }
    out
}

/// The solid's volume, mm^3 (positive for outward-facing triangles).
pub fn volume(solid: &Solid) -> f64 {
    solid
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| solid.positions[i as usize].map(f64::from));
            (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0]))
                / 6.0
        })
        .sum()
}

/// The relief as a 16-bit grey image for a CNC router: one pixel per grid node, the top row
/// the stone's top (+y), 0 the ground (and everything outside the oval), 65535 the highest
/// point. `mm_per_level` turns a level back into a height above the ground.
#[derive(Clone, Debug, PartialEq)]
pub struct HeightMap {
    pub width: u32,
    pub height: u32,
    pub levels: Vec<u16>,
    pub mm_per_level: f32,
    /// Pixel pitch, mm.
    pub mm_per_pixel: f32,
}

/// The relief's height map over the stone oval with semi-axes `half` (mm).
pub fn height_map(relief: &HeightField<'_>, half: [f32; 2]) -> Result<HeightMap, SolidError> {
    check(relief)?;
    let (cols, rows) = (relief.cols, relief.rows);
    let inside = |c: usize, r: usize| relief.in_oval(c, r, half);
    let max = (0..rows)
        .flat_map(|r| (0..cols).map(move |c| (c, r)))
        .filter(|&(c, r)| inside(c, r))
        .map(|(c, r)| relief.heights[r * cols + c])
        .fold(0.0f32, f32::max);
    if !(0..rows).any(|r| (0..cols).any(|c| inside(c, r))) {
        return Err(SolidError::NoStone);
    }
    // A flat stone still gets a scale (1 um a level).
    let mm_per_level = if max > 0.0 { max / 65535.0 } else { 0.001 };
    let mut levels = vec![0u16; cols * rows];
    for r in 0..rows {
        for c in 0..cols {
            if inside(c, r) {
                let h = relief.heights[r * cols + c].max(0.0);
                // Image rows go down: the grid's last row (+y) is the image's first.
                levels[(rows - 1 - r) * cols + c] = (h / mm_per_level).round().min(65535.0) as u16;
            }
        }
    }
    Ok(HeightMap {
        width: cols as u32,
        height: rows as u32,
        levels,
        mm_per_level,
        mm_per_pixel: relief.cell,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    /// A relief on a coarse grid: a dome and a sharp step.
    fn heights(cols: usize, rows: usize, cell: f32) -> (Vec<f32>, [f32; 2]) {
        let origin = [
            -0.5 * cell * (cols - 1) as f32,
            -0.5 * cell * (rows - 1) as f32,
        ];
        let h = (0..cols * rows)
            .map(|i| {
                let (x, y) = (
                    origin[0] + (i % cols) as f32 * cell,
                    origin[1] + (i / cols) as f32 * cell,
                );
                let dome = (4.0 - 0.02 * (x * x + 1.5 * y * y)).max(0.0);
                dome + if x > 3.0 && y > 0.0 { 1.0 } else { 0.0 }
            })
            .collect();
        (h, origin)
    }

    fn field(h: &[f32], origin: [f32; 2], cols: usize, rows: usize, cell: f32) -> HeightField<'_> {
        HeightField {
            heights: h,
            cols,
            rows,
            origin,
            cell,
        }
    }

    fn check_closed(s: &Solid) {
        // Every directed edge once, and its reverse once: closed and consistently wound.
        let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
        for t in &s.triangles {
            assert!(
                t[0] != t[1] && t[1] != t[2] && t[0] != t[2],
                "degenerate {t:?}"
            );
            for k in 0..3 {
                *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
            }
        }
        for (&(a, b), &n) in &directed {
            assert_eq!(n, 1, "edge {a}-{b} used {n} times in one direction");
            assert_eq!(
                directed.get(&(b, a)),
                Some(&1),
                "edge {a}-{b} has no opposite: the solid is open there"
            );
        }
    }

    #[test]
    fn the_solid_is_closed_oriented_and_has_the_reliefs_volume() {
        let (h, origin) = heights(61, 81, 0.5);
        let r = field(&h, origin, 61, 81, 0.5);
        let half = [14.0, 19.0];
        let s = solid(&r, half, 3.0).unwrap();
        check_closed(&s);
        // Volume: the kept cells' area times the base plus the heights (trapezoid rule on the
        // cells, as the top's triangles integrate them up to their diagonal choice).
        let keep = stone_cells(&r, half);
        let cw = r.cols - 1;
        let (mut area, mut above) = (0.0f64, 0.0f64);
        for (i, _) in keep.iter().enumerate().filter(|(_, k)| **k) {
            let (c, row) = (i % cw, i / cw);
            let a = f64::from(r.cell * r.cell);
            area += a;
            let h = [
                r.at(c, row),
                r.at(c + 1, row),
                r.at(c + 1, row + 1),
                r.at(c, row + 1),
            ];
            above += a * h.iter().map(|&v| f64::from(v)).sum::<f64>() / 4.0;
        }
        let v = volume(&s);
        let expected = area * 3.0 + above;
        println!("volume {v:.1} mm^3, expected {expected:.1}; area {area:.1} mm^2");
        assert!(v > 0.0, "the solid is inside out: {v}");
        assert!((v - expected).abs() < 0.01 * expected, "{v} vs {expected}");
        // The oval's area, within the staircase's loss.
        let oval = std::f64::consts::PI * 14.0 * 19.0;
        assert!(area < oval && area > 0.93 * oval, "{area} of {oval}");
        // Binary STL: header, count, 50 bytes a triangle; normals unit length.
        let bytes = stl(&s, "solid glyptic test");
        assert_eq!(bytes.len(), 84 + 50 * s.triangles.len());
        assert!(!bytes.starts_with(b"solid"));
        let count = u32::from_le_bytes(bytes[80..84].try_into().unwrap());
        assert_eq!(count as usize, s.triangles.len());
        let n: Vec<f32> = (0..3)
            .map(|k| f32::from_le_bytes(bytes[84 + 4 * k..88 + 4 * k].try_into().unwrap()))
            .collect();
        assert!(
            (n.iter().map(|x| x * x).sum::<f32>() - 1.0).abs() < 1e-4,
            "{n:?}"
        );
    }

    #[test]
    fn thin_and_off_centre_ovals_stay_closed() {
        // Rows one or two cells long, and a grid whose nodes miss the oval's centre.
        let (h, origin) = heights(41, 41, 0.5);
        for (half, shift) in [([14.0, 1.2], 0.0), ([3.0, 9.0], 0.23)] {
            let origin = [origin[0] + shift, origin[1] - shift];
            let r = field(&h, origin, 41, 41, 0.5);
            let s = solid(&r, half, 1.0).unwrap();
            check_closed(&s);
            assert!(volume(&s) > 0.0);
        }
    }

    #[test]
    fn bad_reliefs_are_refused() {
        let (mut h, origin) = heights(11, 11, 0.5);
        let r = field(&h, origin, 11, 11, 0.5);
        assert_eq!(solid(&r, [2.0, 2.0], 0.0), Err(SolidError::BadBase(0.0)));
        assert_eq!(solid(&r, [0.1, 0.1], 1.0), Err(SolidError::NoStone));
        h[5] = f32::NAN;
        let r = field(&h, origin, 11, 11, 0.5);
        assert_eq!(solid(&r, [2.0, 2.0], 1.0), Err(SolidError::NonFinite));
        assert_eq!(height_map(&r, [2.0, 2.0]), Err(SolidError::NonFinite));
        h.pop();
        let r = field(&h, origin, 11, 11, 0.5);
        assert_eq!(solid(&r, [2.0, 2.0], 1.0), Err(SolidError::BadGrid));
    }

    #[test]
    fn the_height_maps_scale_gives_the_heights_back() {
        let (h, origin) = heights(61, 81, 0.5);
        let r = field(&h, origin, 61, 81, 0.5);
        let half = [14.0, 19.0];
        let m = height_map(&r, half).unwrap();
        assert_eq!((m.width, m.height), (61, 81));
        assert_eq!(m.mm_per_pixel, 0.5);
        assert!(m.levels.contains(&65535));
        for row in 0..r.rows {
            for c in 0..r.cols {
                let level = m.levels[(r.rows - 1 - row) * r.cols + c];
                let (x, y) = (
                    r.origin[0] + c as f32 * r.cell,
                    r.origin[1] + row as f32 * r.cell,
                );
                let expected = if (x / half[0]).powi(2) + (y / half[1]).powi(2) <= 1.0 {
                    r.at(c, row).max(0.0)
                } else {
                    0.0
                };
                let back = f32::from(level) * m.mm_per_level;
                assert!(
                    (back - expected).abs() <= 0.5 * m.mm_per_level + 1e-6,
                    "{back} vs {expected}"
                );
            }
        }
    }
}
