//! The hair's silhouette as the photo shows it: a coarse grid over the head frame, in face
//! lengths (eyes to chin), of how much of each cell is scalp hair. A frontal gem's hair takes
//! this outline (`gem::hair_style` turns it into a signed distance in model millimetres).
//!
//! What the labels call hair is cleaned as a carver reading the photo would: only hair joined
//! to the head counts (a dark coat over the shoulders or a dark patch of wall apart from the
//! head is not hair), holes inside it are hair (a highlight, a gap between strands), and what
//! the person pass decided wins over the raw labels (no hair below where it was found to end;
//! none beside the face below a bare ear).

use super::{Canvas, Label};

/// The grid's cell, face lengths (about 7 mm on an adult).
pub const MASK_STEP: f32 = 0.06;
/// Its columns span `s` in +-[`MASK_S`] and its rows `t` in [`MASK_T`], face lengths.
pub const MASK_S: f32 = 1.62;
pub const MASK_T: (f32, f32) = (-1.8, 3.0);
pub const MASK_COLS: usize = 54;
pub const MASK_ROWS: usize = 80;

/// The share of a cell that must be hair for the cell to be hair.
const MASK_HAIR: f32 = 0.5;

/// How much of each cell of the head frame is scalp hair, row-major from the top left
/// (`t` = [`MASK_T`]`.0`, `s` = -[`MASK_S`]), 0..1 after cleaning (0 or 1), NaN where the
/// photo does not show the cell (beyond its frame).
#[derive(Clone, Copy, PartialEq)]
pub struct HairMask {
    pub share: [[f32; MASK_COLS]; MASK_ROWS],
}

impl std::fmt::Debug for HairMask {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let hair = self
            .share
            .iter()
            .flatten()
            .filter(|&&x| x >= MASK_HAIR)
            .count();
        let unknown = self.share.iter().flatten().filter(|x| x.is_nan()).count();
        write!(f, "HairMask {{ hair cells: {hair}, unknown: {unknown} }}")
    }
}

impl HairMask {
    /// The cell's centre in the head frame, face lengths.
    pub fn centre(row: usize, col: usize) -> [f32; 2] {
        [
            -MASK_S + (col as f32 + 0.5) * MASK_STEP,
            MASK_T.0 + (row as f32 + 0.5) * MASK_STEP,
        ]
    }

    /// The share at head-frame point `[s, t]` (face lengths): `None` beyond the grid, NaN
    /// where the photo does not show it.
    pub fn at(&self, [s, t]: [f32; 2]) -> Option<f32> {
        let c = ((s + MASK_S) / MASK_STEP).floor();
        let r = ((t - MASK_T.0) / MASK_STEP).floor();
        (c >= 0.0 && r >= 0.0 && c < MASK_COLS as f32 && r < MASK_ROWS as f32)
            .then(|| self.share[r as usize][c as usize])
    }

    /// Whether the cell is hair.
    pub fn is_hair(&self, row: usize, col: usize) -> bool {
        self.share[row][col] >= MASK_HAIR
    }
}

/// What the traits decided that the silhouette obeys.
pub(super) struct Decided {
    /// Where the hair ends below the eyes, face lengths.
    pub length: f32,
    /// Per side (image-left, image-right) whether the ear shows.
    pub ear_bare: [bool; 2],
}

/// The silhouette from the labelled canvas.
pub(super) fn hair_mask(canvas: &Canvas, decided: &Decided) -> HairMask {
    let Canvas {
        labels,
        in_face,
        skull,
        chin,
        half,
        ..
    } = *canvas;
    let mut hair = vec![0u32; MASK_COLS * MASK_ROWS];
    let mut seen = vec![0u32; MASK_COLS * MASK_ROWS];
    let mut face = vec![0u32; MASK_COLS * MASK_ROWS];
    let cell_of = |p: [f32; 2]| {
        let c = ((p[0] / chin + MASK_S) / MASK_STEP).floor();
        let r = ((p[1] / chin - MASK_T.0) / MASK_STEP).floor();
        (c >= 0.0 && r >= 0.0 && c < MASK_COLS as f32 && r < MASK_ROWS as f32)
            .then(|| r as usize * MASK_COLS + c as usize)
    };
    let mut beyond = vec![0u32; MASK_COLS * MASK_ROWS];
    for i in 0..canvas.w * canvas.h {
        let Some(k) = cell_of((canvas.pos)(i)) else {
            continue;
        };
        // Beyond the photo or under a hat: not seen.
        if matches!(labels[i], Label::Outside | Label::Hat) {
            beyond[k] += 1;
            continue;
        }
        seen[k] += 1;
        face[k] += u32::from(in_face[i]);
        hair[k] += u32::from(labels[i] == Label::Hair && !in_face[i]);
    }
    // A cell is shown when the photo covers half of it (the canvas's pixels are about a
    // third of a cell wide: count them, not an area).
    let mut share = [[f32::NAN; MASK_COLS]; MASK_ROWS];
    for (r, row) in share.iter_mut().enumerate() {
        for (c, x) in row.iter_mut().enumerate() {
            let k = r * MASK_COLS + c;
            if seen[k] > 0 && seen[k] >= beyond[k] {
                *x = hair[k] as f32 / seen[k] as f32;
            }
        }
    }
    // The decisions: nothing below the hair's end, nothing beside the face under a bare ear
    // (from the ear's top, a little below the eyes).
    for (r, row) in share.iter_mut().enumerate() {
        for (c, x) in row.iter_mut().enumerate() {
            let [s, t] = HairMask::centre(r, c);
            let side = usize::from(s > 0.0);
            if t > decided.length + MASK_STEP
                || (decided.ear_bare[side] && t > 0.05 && s.abs() * chin > 0.9 * half)
            {
                *x = x.min(0.0);
            }
        }
    }
    clean(
        &mut share,
        &|r, c| {
            let [s, t] = HairMask::centre(r, c);
            skull([s * chin, t * chin]) < 1.15
        },
        &|r, c| {
            let k = r * MASK_COLS + c;
            2 * face[k] > seen[k]
        },
    );
    HairMask { share }
}

/// Keeps the hair joined to the head (`near_head`: the cells about the skull) and fills the
/// holes inside it (but not the face, `open`); every kept cell is 1, every dropped one 0,
/// unknown cells stay NaN.
fn clean(
    share: &mut [[f32; MASK_COLS]; MASK_ROWS],
    near_head: &dyn Fn(usize, usize) -> bool,
    open: &dyn Fn(usize, usize) -> bool,
) {
    let n = MASK_COLS * MASK_ROWS;
    let hair = |k: usize| share[k / MASK_COLS][k % MASK_COLS] >= MASK_HAIR;
    let neighbours = |k: usize| {
        let (r, c) = (k / MASK_COLS, k % MASK_COLS);
        let mut out = [None; 4];
        if r > 0 {
            out[0] = Some(k - MASK_COLS);
        }
        if r + 1 < MASK_ROWS {
            out[1] = Some(k + MASK_COLS);
        }
        if c > 0 {
            out[2] = Some(k - 1);
        }
        if c + 1 < MASK_COLS {
            out[3] = Some(k + 1);
        }
        out
    };
    // Flood the hair from the cells about the head.
    let mut keep = vec![false; n];
    let mut stack: Vec<usize> = (0..n)
        .filter(|&k| hair(k) && near_head(k / MASK_COLS, k % MASK_COLS))
        .collect();
    for &k in &stack {
        keep[k] = true;
    }
    while let Some(k) = stack.pop() {
        for j in neighbours(k).into_iter().flatten() {
            if !keep[j] && hair(j) {
                keep[j] = true;
                stack.push(j);
            }
        }
    }
    // Flood what is not hair from the grid's edge and from unknown cells: what it cannot
    // reach is enclosed by hair.
    let mut outside = vec![false; n];
    let mut stack: Vec<usize> = (0..n)
        .filter(|&k| {
            let (r, c) = (k / MASK_COLS, k % MASK_COLS);
            !keep[k]
                && (r == 0
                    || c == 0
                    || r + 1 == MASK_ROWS
                    || c + 1 == MASK_COLS
                    || share[r][c].is_nan()
                    || open(r, c))
        })
        .collect();
    for &k in &stack {
        outside[k] = true;
    }
    while let Some(k) = stack.pop() {
        for j in neighbours(k).into_iter().flatten() {
            if !outside[j] && !keep[j] {
                outside[j] = true;
                stack.push(j);
            }
        }
    }
    for k in 0..n {
        let x = &mut share[k / MASK_COLS][k % MASK_COLS];
        if x.is_nan() {
            continue;
        }
        *x = if keep[k] || !outside[k] { 1.0 } else { 0.0 };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(f: impl Fn(f32, f32) -> f32) -> [[f32; MASK_COLS]; MASK_ROWS] {
        let mut g = [[0.0; MASK_COLS]; MASK_ROWS];
        for (r, row) in g.iter_mut().enumerate() {
            for (c, x) in row.iter_mut().enumerate() {
                let [s, t] = HairMask::centre(r, c);
                *x = f(s, t);
            }
        }
        g
    }

    /// A ring of hair around the head with a hole in it and a detached blob over the
    /// shoulder: the hole is filled, the blob dropped, the unknown corner kept unknown.
    #[test]
    fn cleaning_keeps_the_heads_hair_and_fills_its_holes() {
        let mut g = grid(|s, t| {
            let r = s.hypot(t + 0.3);
            if t < -1.6 && s < -1.4 {
                f32::NAN
            } else if s.hypot(t + 1.4) < 0.07 {
                0.0
            } else if (0.9..1.3).contains(&r) || (s - 1.0).hypot(t - 2.0) < 0.2 {
                0.8
            } else {
                0.1
            }
        });
        let centre = |r, c| {
            let [s, t] = HairMask::centre(r, c);
            s.hypot(t + 0.3)
        };
        clean(&mut g, &|r, c| centre(r, c) < 1.15, &|r, c| {
            centre(r, c) < 0.5
        });
        let m = HairMask { share: g };
        assert_eq!(m.at([0.6, -1.2]), Some(1.0), "the ring");
        assert_eq!(m.at([0.0, -1.4]), Some(1.0), "its hole, filled");
        assert_eq!(
            m.at([0.0, -1.0]),
            Some(0.0),
            "the forehead, open to the face"
        );
        assert_eq!(m.at([1.0, 2.0]), Some(0.0), "the blob apart from the head");
        assert_eq!(m.at([0.0, 0.0]), Some(0.0), "the face inside the ring");
        assert!(
            m.at([-1.55, -1.75]).is_some_and(f32::is_nan),
            "unknown stays unknown"
        );
        assert_eq!(m.at([5.0, 0.0]), None);
    }
}
