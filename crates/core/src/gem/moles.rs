//! Moles left aside, as a cameo cutter leaves them: small, round, isolated darks on the skin
//! (a mole, an age spot, a blemish) are retouched out of the photo's brightness before its
//! detail is read, so neither the modelled light and dark, nor the stipple, nor the darks'
//! shadows carve them. A fold or a line is long, not round, and stays; so does everything near
//! the eyes, brows, nose and mouth, whose small darks (a nostril, an eye's corner, the lips'
//! ends) are the face's own.
//!
//! Units: the detail map's cells ([`super::detail::CELLS_PER_IOD`] to the eyes' distance);
//! brightness 0..1. Pure computation.

use super::blur::blur;

/// A mole's scale: the blurs that find a dark spot against its ring of skin (sigmas, cells;
/// 1.2 and 4 cells are about 0.02 and 0.06 of the eyes' distance: a spot 1-4 mm across on an
/// adult).
const SPOT_SIGMA: f32 = 1.2;
const RING_SIGMA: f32 = 4.0;
/// How much darker than its ring a spot must be, against the face's own spread of that
/// difference (1.4826 median absolute values): only a mark that stands out of the skin.
const MIN_CONTRAST: f32 = 5.0;
/// And at least this much of the brightness range (a clean, smooth photo's spread is tiny).
const MIN_DARK: f32 = 0.04;
/// How round (the smaller curvature against the larger, at the spot's centre) a spot must be:
/// a line's ratio is near 0, a round spot's near 1.
const MIN_ROUNDNESS: f32 = 0.35;
/// How far from a spot's centre (cells) nothing may be half as dark, in any of eight
/// directions: a spot, not a line's end.
const ISOLATION: f32 = 4.0;
/// The retouched disc's radius (cells), and its edge's blend.
const RADIUS: f32 = 4.0;
const EDGE: f32 = 1.5;

/// The moles found and retouched out of `lum` (row-major, `cols` x `rows`, 0..1) where
/// `skin(i)` holds (the face, away from its features): each replaced by its ring of skin's
/// brightness, blended over its edge. Returns their centres (cells).
pub(super) fn retouch(
    lum: &mut [f32],
    cols: usize,
    rows: usize,
    skin: impl Fn(usize) -> bool,
) -> Vec<[usize; 2]> {
    let n = cols * rows;
    if lum.len() != n || cols < 8 || rows < 8 {
        return Vec::new();
    }
    let spot = blur(lum, cols, rows, SPOT_SIGMA);
    let ring = blur(lum, cols, rows, RING_SIGMA);
    let dark: Vec<f32> = ring.iter().zip(&spot).map(|(r, s)| r - s).collect();
    let skin_cells: Vec<usize> = (0..n).filter(|&i| skin(i)).collect();
    if skin_cells.is_empty() {
        return Vec::new();
    }
    let spread = 1.4826
        * crate::person::median(skin_cells.iter().map(|&i| dark[i].abs()).collect()).unwrap_or(0.0);
    let threshold = (MIN_CONTRAST * spread).max(MIN_DARK);
    let mut found = Vec::new();
    for &i in &skin_cells {
        let (c, r) = (i % cols, i / cols);
        if c < 2 || r < 2 || c + 2 >= cols || r + 2 >= rows || dark[i] < threshold {
            continue;
        }
        // The darkest point of its 5 x 5 neighbourhood.
        let peak = (-2isize..=2).all(|dy| {
            (-2isize..=2).all(|dx| {
                let j = ((r as isize + dy) as usize) * cols + (c as isize + dx) as usize;
                j == i || dark[j] < dark[i] || (dark[j] == dark[i] && j > i)
            })
        });
        if !peak {
            continue;
        }
        // Round, not a line: the brightness's curvatures at the centre (a dark spot is a
        // minimum, both positive), over two cells.
        let at = |dx: isize, dy: isize| {
            spot[((r as isize + dy) as usize) * cols + (c as isize + dx) as usize]
        };
        let (xx, yy) = (
            at(2, 0) + at(-2, 0) - 2.0 * at(0, 0),
            at(0, 2) + at(0, -2) - 2.0 * at(0, 0),
        );
        let xy = 0.25 * (at(2, 2) + at(-2, -2) - at(2, -2) - at(-2, 2));
        let (mean, diff) = (0.5 * (xx + yy), (0.25 * (xx - yy).powi(2) + xy * xy).sqrt());
        let (small, large) = (mean - diff, mean + diff);
        if small <= 0.0 || small < MIN_ROUNDNESS * large {
            continue;
        }
        // Alone: no dark runs on from it in any direction (a line's end is round too).
        let alone = (0..8).all(|k| {
            let a = k as f32 * std::f32::consts::FRAC_PI_4;
            let (x, y) = (
                (c as f32 + ISOLATION * a.cos()).round(),
                (r as f32 + ISOLATION * a.sin()).round(),
            );
            x < 0.0
                || y < 0.0
                || x >= cols as f32
                || y >= rows as f32
                || dark[y as usize * cols + x as usize] < 0.5 * dark[i]
        });
        if alone {
            found.push([c, r]);
        }
    }
    let reach = (RADIUS + EDGE).ceil() as isize;
    for &[c, r] in &found {
        // Only darker than the skin around it: a light mark beside it stays.
        let fill = ring[c + r * cols];
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                let (x, y) = (c as isize + dx, r as isize + dy);
                if x < 0 || y < 0 || x >= cols as isize || y >= rows as isize {
                    continue;
                }
                let d = ((dx * dx + dy * dy) as f32).sqrt();
                let w = 1.0 - super::template::smoothstep(RADIUS, RADIUS + EDGE, d);
                let j = y as usize * cols + x as usize;
                if lum[j] < fill {
                    lum[j] += w * (fill - lum[j]);
                }
            }
        }
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Skin with a little texture, a round dark spot and a dark line of the same darkness:
    /// the spot is found and filled, the line stays, and a spot where `skin` does not hold
    /// (a feature) stays too.
    #[test]
    fn a_round_spot_is_retouched_and_a_line_is_not() {
        let (cols, rows) = (96, 80);
        let mut lum: Vec<f32> = (0..cols * rows)
            .map(|i| {
                let (x, y) = ((i % cols) as f32, (i / cols) as f32);
                0.6 + 0.01 * (0.7 * x).sin() * (0.9 * y).cos()
            })
            .collect();
        let paint = |lum: &mut [f32], x: f32, y: f32, r: f32| {
            for (i, v) in lum.iter_mut().enumerate() {
                let (cx, cy) = ((i % cols) as f32, (i / cols) as f32);
                let d = (cx - x).hypot(cy - y);
                *v -= 0.25 * (1.0 - super::super::template::smoothstep(r, r + 1.0, d));
            }
        };
        paint(&mut lum, 30.0, 30.0, 1.5);
        paint(&mut lum, 70.0, 30.0, 1.5);
        // A line from (20, 60) to (76, 60), 1.5 cells wide: its ends are round too.
        for (i, v) in lum.iter_mut().enumerate() {
            let (x, y) = ((i % cols) as f32, (i / cols) as f32);
            if (20.0..76.0).contains(&x) && (y - 60.0).abs() < 1.5 {
                *v -= 0.25;
            }
        }
        let before = lum.clone();
        // The second spot lies in a feature.
        let found = retouch(&mut lum, cols, rows, |i| {
            let (x, y) = (i % cols, i / cols);
            !(60..80).contains(&x) || !(20..40).contains(&y)
        });
        assert_eq!(found, vec![[30, 30]], "found {found:?}");
        let at = |v: &[f32], x: usize, y: usize| v[y * cols + x];
        assert!(at(&before, 30, 30) < 0.4 && at(&lum, 30, 30) > 0.55);
        assert_eq!(at(&lum, 70, 30), at(&before, 70, 30));
        assert_eq!(at(&lum, 48, 60), at(&before, 48, 60));
        // Nothing is made darker, and far from the spot nothing changes.
        assert!(lum.iter().zip(&before).all(|(a, b)| a >= b));
        assert_eq!(at(&lum, 10, 10), at(&before, 10, 10));
    }
}
