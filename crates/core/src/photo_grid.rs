//! A grid of cells over a face in a photo, and how the photo is read on it: what the detail map
//! ([`crate::gem::detail`]) and the shape from shading ([`crate::photometric`]) share.
//! Units: photo pixels (x right, y down, whole numbers at pixel centres). Pure computation.

use image::GrayImage;

/// A grid over the face: cell (c, r)'s centre is photo point `origin + (c, r) step`.
pub(crate) struct Grid {
    pub(crate) origin: [f32; 2],
    pub(crate) step: f32,
    pub(crate) cols: usize,
    pub(crate) rows: usize,
}

impl Grid {
    /// The landmarks' box grown by `side` to the left and right, `above` and `below`
    /// (pixels), in cells of `step` pixels.
    pub(crate) fn around(
        landmarks: &[[f32; 2]],
        step: f32,
        side: f32,
        above: f32,
        below: f32,
    ) -> Self {
        let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
        for p in landmarks {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let origin = [lo[0] - side, lo[1] - above];
        let cols = ((hi[0] + side - origin[0]) / step).ceil() as usize + 1;
        let rows = ((hi[1] + below - origin[1]) / step).ceil() as usize + 1;
        Grid {
            origin,
            step,
            cols,
            rows,
        }
    }

    /// The photo point of cell (c, r)'s centre.
    pub(crate) fn centre(&self, c: usize, r: usize) -> [f32; 2] {
        [
            self.origin[0] + c as f32 * self.step,
            self.origin[1] + r as f32 * self.step,
        ]
    }

    /// The photo point of the `i`th cell, row-major.
    pub(crate) fn at(&self, i: usize) -> [f32; 2] {
        self.centre(i % self.cols, i / self.cols)
    }

    /// A photo point in cells (fractional; cell centres at whole numbers).
    pub(crate) fn to_cell(&self, p: [f32; 2]) -> [f32; 2] {
        [
            (p[0] - self.origin[0]) / self.step,
            (p[1] - self.origin[1]) / self.step,
        ]
    }
}

/// The photo's brightness at (x, y) (pixels, whole numbers at pixel centres), 0..1, bilinear,
/// clamped to the photo's edge.
pub(crate) fn bilinear_grey(img: &GrayImage, x: f32, y: f32) -> f32 {
    let (w, h) = img.dimensions();
    let (x, y) = (x.clamp(0.0, (w - 1) as f32), y.clamp(0.0, (h - 1) as f32));
    let (x0, y0) = (x as u32, y as u32);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    let px = |x: u32, y: u32| f32::from(img.get_pixel(x, y).0[0]) / 255.0;
    (px(x0, y0) * (1.0 - fx) + px(x1, y0) * fx) * (1.0 - fy)
        + (px(x0, y1) * (1.0 - fx) + px(x1, y1) * fx) * fy
}

/// A row-major map of `cols` x `rows` values read at (u, v) (cells, whole numbers at the
/// nodes), bilinear, clamped to its edge: the photo's maps, the tone's coarse heights and the
/// relief read between their nodes.
pub(crate) fn bilinear_map(map: &[f32], cols: usize, rows: usize, u: f32, v: f32) -> f32 {
    let (u, v) = (
        u.clamp(0.0, (cols - 1) as f32),
        v.clamp(0.0, (rows - 1) as f32),
    );
    let (c0, r0) = (u as usize, v as usize);
    let (c1, r1) = ((c0 + 1).min(cols - 1), (r0 + 1).min(rows - 1));
    let (fx, fy) = (u - c0 as f32, v - r0 as f32);
    let h = |c: usize, r: usize| map[r * cols + c];
    (h(c0, r0) * (1.0 - fx) + h(c1, r0) * fx) * (1.0 - fy)
        + (h(c0, r1) * (1.0 - fx) + h(c1, r1) * fx) * fy
}

/// The distance from `p` to the nearest segment of `line` (infinite for fewer than two points).
pub(crate) fn polyline_distance(line: &[[f32; 2]], p: [f32; 2]) -> f32 {
    line.windows(2)
        .map(|w| {
            let (a, b) = (w[0], w[1]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let l2 = (dx * dx + dy * dy).max(1e-9);
            let t = (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2).clamp(0.0, 1.0);
            (p[0] - a[0] - t * dx).hypot(p[1] - a[1] - t * dy)
        })
        .fold(f32::INFINITY, f32::min)
}
