//! A grid refined: the relief's solve grid (`CameoParams::cell`) made `k` times finer where
//! the photo's stipple is carved (`super::builder`), its fields refined bilinearly within the
//! portrait's window. Grid nodes; pure computation.

use super::window::Window;

/// A grid `k` times finer than a `cols` x `rows` one over the same area: node (x, y) of the
/// coarse one is node (k x, k y) of the fine one; fields are refined bilinearly within the
/// coarse window `area` (0 outside it; identity at k = 1).
pub(super) struct Refine {
    pub(super) coarse: (usize, usize),
    k: usize,
    pub(super) cols: usize,
    pub(super) rows: usize,
    area: Window,
}

impl Refine {
    pub(super) fn new(cols: usize, rows: usize, k: usize, area: Window) -> Self {
        let k = k.max(1);
        Refine {
            coarse: (cols, rows),
            k,
            cols: (cols - 1) * k + 1,
            rows: (rows - 1) * k + 1,
            area,
        }
    }

    /// The coarse cell and the offsets (0..1) within it of each fine node along one axis.
    fn taps(&self, n: usize) -> Vec<(usize, f32)> {
        (0..(n - 1) * self.k + 1)
            .map(|f| {
                let (c, r) = (f / self.k, f % self.k);
                if c + 1 >= n {
                    (n.saturating_sub(2), 1.0)
                } else {
                    (c, r as f32 / self.k as f32)
                }
            })
            .map(|(c, t)| if n < 2 { (0, 0.0) } else { (c, t) })
            .collect()
    }

    pub(super) fn up(&self, field: &[f32]) -> Vec<f32> {
        if self.k == 1 {
            return field.to_vec();
        }
        let (cols, rows) = self.coarse;
        let (tx, ty) = (self.taps(cols), self.taps(rows));
        let w = self.window(self.area);
        let mut out = vec![0f32; self.cols * self.rows];
        for (fy, &(y, v)) in ty.iter().enumerate().take(w.y1 + 1).skip(w.y0) {
            let y1 = (y + 1).min(rows - 1);
            let (r0, r1) = (
                &field[y * cols..(y + 1) * cols],
                &field[y1 * cols..(y1 + 1) * cols],
            );
            let row = &mut out[fy * self.cols..(fy + 1) * self.cols];
            for (fx, &(x, u)) in tx.iter().enumerate().take(w.x1 + 1).skip(w.x0) {
                let x1 = (x + 1).min(cols - 1);
                row[fx] = (r0[x] * (1.0 - u) + r0[x1] * u) * (1.0 - v)
                    + (r1[x] * (1.0 - u) + r1[x1] * u) * v;
            }
        }
        out
    }

    /// A field known only where `known`, refined: each fine node the bilinear mean of its
    /// known coarse corners' values (an unknown corner has nothing to lend), `None` where it
    /// has none.
    pub(super) fn up_where(&self, field: &[f32], known: &[bool]) -> Vec<Option<f32>> {
        let w: Vec<f32> = known.iter().map(|&k| f32::from(u8::from(k))).collect();
        let v: Vec<f32> = field
            .iter()
            .zip(known)
            .map(|(v, &k)| if k { *v } else { 0.0 })
            .collect();
        self.up(&v)
            .iter()
            .zip(&self.up(&w))
            .map(|(v, w)| (*w > 1e-6).then(|| v / w))
            .collect()
    }

    /// Points refined where `weight` is positive ([`Self::up_where`]); (0, 0) where none is.
    pub(super) fn up_points(&self, points: &[[f32; 2]], weight: &[f32]) -> Vec<[f32; 2]> {
        let known: Vec<bool> = weight.iter().map(|w| *w > 0.0).collect();
        let axis = |k: usize| {
            let v: Vec<f32> = points.iter().map(|p| p[k]).collect();
            self.up_where(&v, &known)
        };
        axis(0)
            .iter()
            .zip(&axis(1))
            .map(|(x, y)| match (x, y) {
                (Some(x), Some(y)) => [*x, *y],
                _ => [0.0; 2],
            })
            .collect()
    }

    /// Every `k`-th node of a fine field: the coarse grid's nodes.
    pub(super) fn down(&self, field: &[f32]) -> Vec<f32> {
        if self.k == 1 {
            return field.to_vec();
        }
        let (cols, rows) = self.coarse;
        (0..cols * rows)
            .map(|i| field[(i / cols) * self.k * self.cols + (i % cols) * self.k])
            .collect()
    }

    /// The coarse window that covers fine window `w`.
    pub(super) fn coarse_window(&self, w: Window) -> Window {
        let (cols, rows) = self.coarse;
        Window {
            x0: w.x0 / self.k,
            y0: w.y0 / self.k,
            x1: w.x1.div_ceil(self.k).min(cols - 1),
            y1: w.y1.div_ceil(self.k).min(rows - 1),
        }
    }

    pub(super) fn window(&self, w: Window) -> Window {
        Window {
            x0: w.x0 * self.k,
            y0: w.y0 * self.k,
            x1: w.x1 * self.k,
            y1: w.y1 * self.k,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A refined field is its coarse one at the coarse nodes and their bilinear patch between
    /// (a plane stays a plane), and every k-th node gives the coarse field back.
    #[test]
    fn a_refined_grid_keeps_the_coarse_nodes_and_interpolates_between() {
        let (cols, rows) = (5, 4);
        let plane: Vec<f32> = (0..cols * rows)
            .map(|i| 0.5 + 2.0 * (i % cols) as f32 - 3.0 * (i / cols) as f32)
            .collect();
        for k in [1, 2, 3] {
            let all = Window {
                x0: 0,
                y0: 0,
                x1: cols - 1,
                y1: rows - 1,
            };
            let g = Refine::new(cols, rows, k, all);
            assert_eq!((g.cols, g.rows), ((cols - 1) * k + 1, (rows - 1) * k + 1));
            let up = g.up(&plane);
            assert_eq!(up.len(), g.cols * g.rows);
            for (i, v) in up.iter().enumerate() {
                let (x, y) = (
                    (i % g.cols) as f32 / k as f32,
                    (i / g.cols) as f32 / k as f32,
                );
                assert!(
                    (v - (0.5 + 2.0 * x - 3.0 * y)).abs() < 1e-4,
                    "k {k} node {i}: {v}"
                );
            }
            assert_eq!(g.down(&up), plane);
            let w = g.coarse_window(Window {
                x0: 1,
                y0: 1,
                x1: g.cols - 2,
                y1: g.rows - 1,
            });
            assert!(w.x0 * k <= 1 && w.x1 * k >= g.cols - 2 && w.y1 == rows - 1);
            // Within a window only: 0 beyond it.
            let part = Window {
                x0: 1,
                y0: 1,
                x1: 3,
                y1: 2,
            };
            let inner = Refine::new(cols, rows, k, part).up(&plane);
            for (i, v) in inner.iter().enumerate() {
                let (x, y) = (i % g.cols, i / g.cols);
                let inside = (k..=3 * k).contains(&x) && (k..=2 * k).contains(&y);
                assert_eq!(
                    *v,
                    if inside || k == 1 { up[i] } else { 0.0 },
                    "k {k} node {i}"
                );
            }
        }
        // Points refined only from the corners that have one.
        let g = Refine::new(
            2,
            2,
            2,
            Window {
                x0: 0,
                y0: 0,
                x1: 1,
                y1: 1,
            },
        );
        let points = [[10.0, 20.0], [0.0, 0.0], [30.0, 20.0], [0.0, 0.0]];
        let up = g.up_points(&points, &[1.0, 0.0, 1.0, 0.0]);
        assert_eq!(up[0], [10.0, 20.0]);
        assert_eq!(up[3], [20.0, 20.0]);
        assert_eq!(up[1], [10.0, 20.0]);
    }
}
