//! A window of relief grid nodes: the builder's passes (and the shading's) work only on the
//! part of the grid the portrait can reach. Indices are row-major node indices; bounds are
//! inclusive.

/// A rectangle of grid nodes (inclusive bounds): the relief's work is done only where the
/// portrait can reach.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Window {
    pub(super) x0: usize,
    pub(super) y0: usize,
    pub(super) x1: usize,
    pub(super) y1: usize,
}

impl Window {
    /// The nodes where `pred` holds, or `None`.
    pub(super) fn of(cols: usize, rows: usize, pred: impl Fn(usize) -> bool) -> Option<Self> {
        let (mut x0, mut y0, mut x1, mut y1) = (cols, rows, 0, 0);
        for i in (0..cols * rows).filter(|&i| pred(i)) {
            let (x, y) = (i % cols, i / cols);
            (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
        }
        (x0 <= x1).then_some(Window { x0, y0, x1, y1 })
    }

    pub(super) fn grow(self, m: usize, cols: usize, rows: usize) -> Self {
        self.grow_towards((m, m), (m, m), cols, rows)
    }

    /// Grown by (before, after) nodes along x and along y, within the grid.
    pub(super) fn grow_towards(
        self,
        x: (usize, usize),
        y: (usize, usize),
        cols: usize,
        rows: usize,
    ) -> Self {
        Window {
            x0: self.x0.saturating_sub(x.0),
            y0: self.y0.saturating_sub(y.0),
            x1: (self.x1 + x.1).min(cols - 1),
            y1: (self.y1 + y.1).min(rows - 1),
        }
    }

    pub(super) fn union(self, o: Self) -> Self {
        Window {
            x0: self.x0.min(o.x0),
            y0: self.y0.min(o.y0),
            x1: self.x1.max(o.x1),
            y1: self.y1.max(o.y1),
        }
    }

    pub(super) fn width(&self) -> usize {
        self.x1 - self.x0 + 1
    }

    pub(super) fn height(&self) -> usize {
        self.y1 - self.y0 + 1
    }

    /// Row-major node indices of the grid (`cols` wide) inside the window.
    pub(super) fn indices(self, cols: usize) -> impl Iterator<Item = usize> {
        (self.y0..=self.y1).flat_map(move |y| (self.x0..=self.x1).map(move |x| y * cols + x))
    }

    /// The window's part of a grid field, each value mapped.
    pub(super) fn crop(&self, field: &[f32], cols: usize, f: impl Fn(f32) -> f32) -> Vec<f32> {
        self.indices(cols).map(|i| f(field[i])).collect()
    }

    /// Writes a window-sized field into the grid field.
    pub(super) fn paste(&self, part: &[f32], field: &mut [f32], cols: usize) {
        for (k, i) in self.indices(cols).enumerate() {
            field[i] = part[k];
        }
    }
}
