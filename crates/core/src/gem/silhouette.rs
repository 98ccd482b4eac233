//! The frontal hair's outline from a photo: the person pass's [`HairMask`] (face lengths in
//! the head frame) as a signed distance over the template's canonical plane (model mm,
//! positive inside the hair), so that the template can round the hair's volume into relief
//! from its edge inwards and the outline stays smooth between the grid's cells.
//!
//! Where the photo does not show the head (beyond its frame) the template's own hair fills
//! in; where the photo shows a full crown the cranium's top is hair (a carved skull never
//! shows above the hair's outline). Pure computation.

use super::{EYES_V, FACE_LENGTH_MM};
use crate::person::{HairMask, MASK_COLS, MASK_ROWS, MASK_S, MASK_STEP, MASK_T};

/// The hair's signed distance (mm, positive inside) on the [`HairMask`] grid mapped onto the
/// canonical plane: u = s x [`FACE_LENGTH_MM`], v = [`EYES_V`] - t x [`FACE_LENGTH_MM`].
#[derive(Clone, Copy, PartialEq)]
pub struct Silhouette {
    sdf: [[f32; MASK_COLS]; MASK_ROWS],
    /// The hair's top over the midline (canonical v, mm) where the photo shows it.
    top: Option<f32>,
}

impl std::fmt::Debug for Silhouette {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let inside = self.sdf.iter().flatten().filter(|&&d| d > 0.0).count();
        write!(f, "Silhouette {{ cells inside: {inside} }}")
    }
}

/// A cell of the grid, canonical mm.
const STEP_MM: f32 = MASK_STEP * FACE_LENGTH_MM;

impl Silhouette {
    /// The hair's top over the head's middle, canonical v (mm); `None` where the photo's
    /// frame cut it off.
    pub fn top(&self) -> Option<f32> {
        self.top
    }

    /// The signed distance at canonical (u, v), mm: bilinear between the cells' centres,
    /// far outside beyond the grid.
    pub fn at(&self, u: f32, v: f32) -> f32 {
        let x = (u / FACE_LENGTH_MM + MASK_S) / MASK_STEP - 0.5;
        let y = ((EYES_V - v) / FACE_LENGTH_MM - MASK_T.0) / MASK_STEP - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return f32::NEG_INFINITY;
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let cell = |r: f32, c: f32| {
            if r < 0.0 || c < 0.0 || r >= MASK_ROWS as f32 || c >= MASK_COLS as f32 {
                -STEP_MM
            } else {
                self.sdf[r as usize][c as usize]
            }
        };
        let top = cell(y0, x0) * (1.0 - fx) + cell(y0, x0 + 1.0) * fx;
        let bottom = cell(y0 + 1.0, x0) * (1.0 - fx) + cell(y0 + 1.0, x0 + 1.0) * fx;
        let d = top * (1.0 - fy) + bottom * fy;
        // Beyond the grid's last cells: outside, and more so the further out.
        let out = (-x)
            .max(x - (MASK_COLS - 1) as f32)
            .max(-y)
            .max(y - (MASK_ROWS - 1) as f32);
        if out > 0.0 { d - out * STEP_MM } else { d }
    }

    /// The share of the grid's cells that one silhouette has inside and the other not.
    pub fn differs(&self, other: &Silhouette) -> f32 {
        let flips = self
            .sdf
            .iter()
            .flatten()
            .zip(other.sdf.iter().flatten())
            .filter(|(a, b)| (**a > 0.0) != (**b > 0.0))
            .count();
        flips as f32 / (MASK_COLS * MASK_ROWS) as f32
    }

    /// The cell-wise median of several silhouettes (the kiosk's consensus over frames: a
    /// median of signed distances is a shape between them); `None` when there are none.
    pub fn median<'a>(all: impl Iterator<Item = &'a Silhouette>) -> Option<Silhouette> {
        let all: Vec<&Silhouette> = all.collect();
        let first = *all.first()?;
        let mut out = *first;
        for (r, row) in out.sdf.iter_mut().enumerate() {
            for (c, d) in row.iter_mut().enumerate() {
                if let Some(m) = crate::person::median(all.iter().map(|s| s.sdf[r][c]).collect()) {
                    *d = m;
                }
            }
        }
        Some(out)
    }

    /// The silhouette of `mask`; `crown` is the share of the crown that is hair
    /// ([`crate::person::Hair::crown`]); `template_hair(u, v)` says where the template's own
    /// hair is (canonical mm), for the cells the photo does not show
    /// (`Silhouette::from_mask` in [`super::template`] asks the template).
    pub fn from_cells(
        mask: &HairMask,
        crown: f32,
        template_hair: impl Fn(f32, f32) -> bool,
    ) -> Silhouette {
        let top = hair_top(mask);
        let mut inside = [[false; MASK_COLS]; MASK_ROWS];
        for (r, row) in inside.iter_mut().enumerate() {
            for (c, x) in row.iter_mut().enumerate() {
                let [s, t] = HairMask::centre(r, c);
                let (u, v) = (s * FACE_LENGTH_MM, EYES_V - t * FACE_LENGTH_MM);
                let share = mask.share[r][c];
                *x = if share.is_nan() {
                    template_hair(u, v)
                } else {
                    share >= 0.5 || (crown >= 0.5 && on_cranium_top(top, u, v))
                };
            }
        }
        // The photo's own outline on each side, asymmetric as it is: a turned head shows more
        // hair on one side, and a frontal gem that evened it out lost a quarter of its overlap
        // with the photo (median IoU 0.68 -> 0.50 on the 161 labelled photos).
        let sdf = signed_distance(&inside);
        Silhouette { sdf, top }
    }
}

/// The highest hair over the midline (the middle third of a face's width), canonical v (mm)
/// of its cell's top; `None` when the photo does not show the cells above it.
fn hair_top(mask: &HairMask) -> Option<f32> {
    let middle: Vec<usize> = (0..MASK_COLS)
        .filter(|&c| HairMask::centre(0, c)[0].abs() < 0.2)
        .collect();
    let row_is = |r: usize, f: &dyn Fn(f32) -> bool| {
        middle.iter().filter(|&&c| f(mask.share[r][c])).count() * 2 > middle.len()
    };
    let r = (0..MASK_ROWS).find(|&r| row_is(r, &|x| x >= 0.5))?;
    // Seen with something else above it: not cut off by the photo's frame.
    let above = r.checked_sub(2)?;
    if !row_is(above, &|x| x.is_finite()) {
        return None;
    }
    let t = HairMask::centre(r, 0)[1] - 0.5 * MASK_STEP;
    Some(EYES_V - t * FACE_LENGTH_MM)
}

/// The frontal cranium's vertical semi-axis (mm; its centre at v = 40) under hair whose top
/// is at `top`: 4 mm under it, between 85 and the template's own 115.
pub fn cranium_height(top: Option<f32>) -> f32 {
    top.map_or(115.0, |top| (top - 44.0).clamp(85.0, 115.0))
}

/// The frontal cranium's top, above the brows, where a full crown's hair always covers the
/// skull (the template's frontal cranium: centre v = 40, 80 mm wide, [`cranium_height`] high).
/// The forehead (where the mean face's mesh reaches, |u| < 60, v < 115) is left as the photo
/// shows it: hair there is a fringe, skin a bare forehead.
fn on_cranium_top(top: Option<f32>, u: f32, v: f32) -> bool {
    let forehead = u.abs() < 60.0 && v < 115.0;
    !forehead && v > 75.0 && (u / 80.0).powi(2) + ((v - 40.0) / cranium_height(top)).powi(2) < 1.0
}

/// Signed distance (mm, positive inside) to the boundary between the grid's inside and
/// outside cells, the boundary half a cell from each cell centre beside it; then smoothed
/// once (a binomial 3 x 3) so that the outline bends between cells rather than stepping.
fn signed_distance(inside: &[[bool; MASK_COLS]; MASK_ROWS]) -> [[f32; MASK_COLS]; MASK_ROWS] {
    let at = |r: isize, c: isize| {
        if r < 0 || c < 0 || r >= MASK_ROWS as isize || c >= MASK_COLS as isize {
            false
        } else {
            inside[r as usize][c as usize]
        }
    };
    // Cells on the boundary, each side.
    let mut edge: [Vec<(f32, f32)>; 2] = [Vec::new(), Vec::new()];
    for r in 0..MASK_ROWS as isize {
        for c in 0..MASK_COLS as isize {
            let me = at(r, c);
            if [(r - 1, c), (r + 1, c), (r, c - 1), (r, c + 1)]
                .iter()
                .any(|&(rr, cc)| at(rr, cc) != me)
            {
                edge[usize::from(me)].push((r as f32, c as f32));
            }
        }
    }
    let mut sdf = [[0f32; MASK_COLS]; MASK_ROWS];
    for (r, row) in sdf.iter_mut().enumerate() {
        for (c, d) in row.iter_mut().enumerate() {
            let me = inside[r][c];
            // The nearest cell of the other side.
            let near = edge[usize::from(!me)]
                .iter()
                .map(|&(er, ec)| (er - r as f32).hypot(ec - c as f32))
                .fold(f32::INFINITY, f32::min);
            let near = if near.is_finite() {
                near
            } else {
                (MASK_ROWS + MASK_COLS) as f32
            };
            let dist = (near - 0.5) * STEP_MM;
            *d = if me { dist } else { -dist };
        }
    }
    let mut out = sdf;
    for (r, row) in out.iter_mut().enumerate() {
        for (c, d) in row.iter_mut().enumerate() {
            let (mut sum, mut weight) = (0.0, 0.0);
            for dr in -1isize..=1 {
                for dc in -1isize..=1 {
                    let (rr, cc) = (r as isize + dr, c as isize + dc);
                    if rr < 0 || cc < 0 || rr >= MASK_ROWS as isize || cc >= MASK_COLS as isize {
                        continue;
                    }
                    let wgt = ((2 - dr.abs()) * (2 - dc.abs())) as f32;
                    sum += wgt * sdf[rr as usize][cc as usize];
                    weight += wgt;
                }
            }
            *d = sum / weight;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn disc_mask(radius: f32) -> HairMask {
        let mut share = [[0.0; MASK_COLS]; MASK_ROWS];
        for (r, row) in share.iter_mut().enumerate() {
            for (c, x) in row.iter_mut().enumerate() {
                let [s, t] = HairMask::centre(r, c);
                *x = if s.hypot(t + 0.5) < radius { 1.0 } else { 0.0 };
            }
        }
        HairMask { share }
    }

    /// A disc's distance is about the distance to its circle: the outline lies on the circle
    /// within a third of a cell, and the distance grows inward at about 1 mm per mm.
    #[test]
    fn a_discs_signed_distance_follows_its_circle() {
        let sil = Silhouette::from_cells(&disc_mask(0.5), 0.0, |_, _| false);
        let radius = 0.5 * FACE_LENGTH_MM;
        let centre_v = EYES_V + 0.5 * FACE_LENGTH_MM;
        for k in 0..16 {
            let a = k as f32 * std::f32::consts::TAU / 16.0;
            let on = |r: f32| sil.at(r * a.cos(), centre_v + r * a.sin());
            assert!(on(radius).abs() < STEP_MM / 3.0, "{a}: {}", on(radius));
            let slope = (on(radius - 20.0) - on(radius - 10.0)) / 10.0;
            assert!((0.8..1.2).contains(&slope), "{a}: slope {slope}");
            assert!(on(radius + 15.0) < -10.0);
        }
        assert!(sil.at(0.0, 1e4) < -1e3 && sil.at(f32::NAN, 0.0) < 0.0);
    }

    /// A full crown covers the cranium's top; the cells the photo does not show ask the
    /// template.
    #[test]
    fn a_crown_covers_the_skull_and_unknown_cells_ask_the_template() {
        let mut mask = disc_mask(0.0);
        assert!(Silhouette::from_cells(&mask, 1.0, |_, _| false).at(0.0, 140.0) > 0.0);
        assert!(Silhouette::from_cells(&mask, 0.0, |_, _| false).at(0.0, 140.0) < 0.0);
        for row in mask.share.iter_mut() {
            row.fill(f32::NAN);
        }
        let sil = Silhouette::from_cells(&mask, 0.0, |_, v| v > 100.0);
        assert!(
            sil.at(0.0, 150.0) > 0.0,
            "the template's hair over the head"
        );
        assert!(sil.at(0.0, -200.0) < 0.0, "none over the chest");
    }

    #[test]
    fn medians_and_differences() {
        let [a, b, c] =
            [0.3, 0.4, 0.5].map(|r| Silhouette::from_cells(&disc_mask(r), 0.0, |_, _| false));
        let m = Silhouette::median([&a, &b, &c].into_iter()).expect("three");
        assert_eq!(m.differs(&b), 0.0);
        assert!(a.differs(&c) > 0.02);
        assert!(Silhouette::median(std::iter::empty()).is_none());
    }
}
