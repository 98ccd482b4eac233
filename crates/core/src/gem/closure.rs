//! The carved tone checked against its own light: the relief's face is lit as the renderer
//! lights it (sky and fill dimmed by the cavity term, the raking key light with its cast
//! shadows), its log light band-passed like the photo's, and the slopes along the key light
//! corrected where the two differ, a few rounds.
//!
//! Why: the tone, the stipple and the shadow cut are each read from the photo alone; on the
//! stone they add up with the relief's own forms, and one raking light shows a slope, a pit
//! and a shadow differently. What a viewer sees is the sum.
//!
//! Units: heights in gem mm on a grid of `cell` mm (x right, y up, as the stone); the light a
//! unit vector towards it. Pure computation.

use super::blur::Normaliser;
use super::shading::{cavity, light_visibility, penumbra};
use super::window::Window;

/// The renderer's lights: sky, fill (from the viewer), key.
use crate::scene::{FILL_LIGHT as FILL, KEY_LIGHT_INTENSITY as KEY, SKY_LIGHT as SKY};

/// The band compared, shares of the eyes' distance (Gaussians' sigmas): finer than `FINE` is
/// the stipple's grain (its pits 0.042 apart), coarser than `BAND` the face's broad form (the
/// tone's own band). Measured: `FINE` 0.015 brings the gems a little nearer their people than
/// 0.03 by both networks, `BAND` 0.3 further (BENCHMARKS.md, issue #37, sixteenth session).
const FINE: f32 = 0.015;
const BAND: f32 = 0.16;
/// Rounds of light, compare, correct; and the share of each round's correction applied (the
/// light is not linear in the slope, and the shadows move). Measured on three photo sets by
/// two recognition networks: 3, 6, 10 and 20 rounds at 0.7 (better up to 10), and 6 at 1.0 as
/// good as 10 at 0.7 in half the time (BENCHMARKS.md, issue #37, sixteenth session).
const ROUNDS: usize = 6;
const STEP: f32 = 1.0;
/// Conjugate-gradient iterations of each round's slope fit: the rounds refine it anyway.
const SOLVE_ITERATIONS: usize = 20;
/// The most one round may ask of the log light, and of the slope (mm per mm).
const MAX_ERROR: f32 = 0.3;
const MAX_SLOPE: f32 = 0.35;

/// A relief grid: `cols` x `rows` nodes `cell` mm apart.
#[derive(Clone, Copy, Debug)]
pub(super) struct Grid {
    pub(super) cols: usize,
    pub(super) rows: usize,
    pub(super) cell: f32,
}

/// How the match runs.
#[derive(Clone, Copy, Debug)]
pub(super) struct Closure {
    /// The wanted contrast against the carved relief's own (1: the same, the pattern only).
    pub(super) gain: f32,
    /// Band-pass sigmas, cells.
    pub(super) fine: f32,
    pub(super) band: f32,
    pub(super) rounds: usize,
    /// Share of each round's correction applied.
    pub(super) step: f32,
}

impl Closure {
    /// The match for a face whose eyes are `iod_cells` grid cells apart, asking `gain`.
    pub(super) fn for_face(gain: f32, iod_cells: f32) -> Self {
        Closure {
            gain,
            fine: FINE * iod_cells,
            band: BAND * iod_cells,
            rounds: ROUNDS,
            step: STEP,
        }
    }
}

/// What the match did: the weighted correlation of the relief's band-passed log light with the
/// photo's before and after, and whether any height changed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Matched {
    pub(super) before: f32,
    pub(super) after: f32,
    pub(super) changed: bool,
}

/// The light leaving each node, as the renderer computes it (view along +z).
pub(super) fn radiance(
    height: &[f32],
    vis: &[f32],
    cav: &[f32],
    cols: usize,
    rows: usize,
    cell: f32,
    light: [f32; 3],
) -> Vec<f32> {
    let mut out = vec![0f32; cols * rows];
    for r in 0..rows {
        for c in 0..cols {
            let h = |c: usize, r: usize| height[r * cols + c];
            let hx = (h((c + 1).min(cols - 1), r) - h(c.saturating_sub(1), r)) / (2.0 * cell);
            let hy = (h(c, (r + 1).min(rows - 1)) - h(c, r.saturating_sub(1))) / (2.0 * cell);
            let len = (hx * hx + hy * hy + 1.0).sqrt();
            let nz = 1.0 / len;
            let ndl = ((-hx * light[0] - hy * light[1] + light[2]) / len).max(0.0);
            let i = r * cols + c;
            out[i] = SKY * cav[i] * (0.55 + 0.45 * nz) + FILL * cav[i] * nz + KEY * vis[i] * ndl;
        }
    }
    out
}

/// Corrects `height` (and `top` with it) inside `area` where `weight` > 0 so that the relief's
/// band-passed log light follows `target`'s (the photo's log brightness per node, NaN where
/// unknown), at `how.gain` times the contrast the relief shows of that pattern: the gain by
/// least squares of the relief's band on the photo's, so what is corrected is the pattern
/// (the relief's own forms and grain less, the photo's more), not one overall contrast.
#[allow(clippy::too_many_arguments)]
pub(super) fn close(
    height: &mut [f32],
    top: &mut [f32],
    target: &[f32],
    weight: &[f32],
    grid: Grid,
    light: [f32; 3],
    area: Window,
    how: &Closure,
) -> Matched {
    let Grid { cols, rows, cell } = grid;
    let none = Matched {
        before: 0.0,
        after: 0.0,
        changed: false,
    };
    let n = cols * rows;
    if height.len() != n || top.len() != n || target.len() != n || weight.len() != n {
        return none;
    }
    if area.x1 >= cols
        || area.y1 >= rows
        || how.gain.is_nan()
        || how.gain <= 0.0
        || cell.is_nan()
        || cell <= 0.0
    {
        return none;
    }
    // Only the face and what its blurs and shadows reach: the weighted nodes' window, grown
    // by three of the band's sigmas, within `area`.
    let inside = |i: usize| {
        let (x, y) = (i % cols, i / cols);
        (area.x0..=area.x1).contains(&x)
            && (area.y0..=area.y1).contains(&y)
            && weight[i] > 0.0
            && target[i].is_finite()
    };
    let Some(face) = Window::of(cols, rows, inside) else {
        return none;
    };
    let grown = face.grow((3.0 * how.band).ceil().max(1.0) as usize, cols, rows);
    let area = Window {
        x0: grown.x0.max(area.x0),
        y0: grown.y0.max(area.y0),
        x1: grown.x1.min(area.x1),
        y1: grown.y1.min(area.y1),
    };
    let (w, h) = (area.width(), area.height());
    let wt: Vec<f32> = area
        .crop(weight, cols, |v| v)
        .iter()
        .zip(area.crop(target, cols, |v| v))
        .map(|(w, t)| if t.is_finite() { w.max(0.0) } else { 0.0 })
        .collect();
    if w < 3 || h < 3 || wt.iter().all(|v| *v <= 0.0) {
        return none;
    }
    let tgt: Vec<f32> = area
        .crop(target, cols, |v| v)
        .iter()
        .map(|t| if t.is_finite() { *t } else { 0.0 })
        .collect();
    // The weights are the same for every blur: their blurs made once.
    let (fine, broad) = (
        Normaliser::new(&wt, w, h, how.fine),
        Normaliser::new(&wt, w, h, how.band),
    );
    let band = |x: &[f32]| -> Vec<f32> {
        let f = fine.blur(x, &wt, w, h);
        let c = broad.blur(x, &wt, w, h);
        f.iter().zip(&c).map(|(f, c)| f - c).collect()
    };
    let t_band = band(&tgt);
    let plane = light[0].hypot(light[1]).max(1e-6);
    let toward = [light[0] / plane, light[1] / plane];
    let corr = |a: &[f32], b: &[f32]| {
        let (mut ab, mut aa, mut bb, mut sw) = (0f64, 0f64, 0f64, 0f64);
        let (mut ma, mut mb) = (0f64, 0f64);
        for i in 0..a.len() {
            let ww = f64::from(wt[i]);
            sw += ww;
            ma += ww * f64::from(a[i]);
            mb += ww * f64::from(b[i]);
        }
        if sw <= 0.0 {
            return (0.0, 0.0);
        }
        let (ma, mb) = (ma / sw, mb / sw);
        for i in 0..a.len() {
            let ww = f64::from(wt[i]);
            let (x, y) = (f64::from(a[i]) - ma, f64::from(b[i]) - mb);
            ab += ww * x * y;
            aa += ww * x * x;
            bb += ww * y * y;
        }
        let r = ab / (aa * bb).sqrt().max(1e-12);
        // The gain that takes a's band to b's by least squares.
        (r as f32, (ab / aa.max(1e-12)) as f32)
    };
    // The cavity term once: it reads the relief over 0.35-1.2 mm, which the corrections'
    // fractions of a millimetre hardly change; the shadows move with them.
    let cav = cavity(&area.crop(height, cols, |v| v), w, h, cell);
    let model = |height: &[f32]| -> (Vec<f32>, Vec<f32>) {
        let part = area.crop(height, cols, |v| v);
        let vis = penumbra(&light_visibility(&part, w, h, cell, light), w, h);
        (radiance(&part, &vis, &cav, w, h, cell, light), vis)
    };
    // Off the face the corrections are held at 0.
    let hold: Vec<f32> = wt.iter().map(|w| (1.0 - w.min(1.0)).max(0.0)).collect();
    let mut first = 0.0;
    let mut last = 0.0;
    let mut changed = false;
    let solve = super::tone::ToneSolve {
        iterations: SOLVE_ITERATIONS,
        ..super::tone::ToneSolve::default()
    };
    for round in 0..=how.rounds {
        let (rad, vis) = model(height);
        let log: Vec<f32> = rad.iter().map(|r| r.max(1e-3).ln()).collect();
        let g_band = band(&log);
        let (r, gain) = corr(&t_band, &g_band);
        if round == 0 {
            first = r;
        }
        last = r;
        if round == how.rounds {
            break;
        }
        let smooth_rad = fine.blur(&rad, &wt, w, h);
        let smooth_vis = fine.blur(&vis, &wt, w, h);
        let a = how.gain * gain.max(0.0);
        let slope: Vec<f32> = (0..w * h)
            .map(|i| {
                if wt[i] <= 0.0 {
                    return 0.0;
                }
                let e = (a * t_band[i] - g_band[i]).clamp(-MAX_ERROR, MAX_ERROR);
                // d(log light)/d(slope along the light) = -KEY * vis * cos(elevation) / light.
                let ds = -e * smooth_rad[i] / (KEY * plane * smooth_vis[i].max(0.25));
                ds.clamp(-MAX_SLOPE, MAX_SLOPE) * cell
            })
            .collect();
        let fit_w: Vec<f32> = wt
            .iter()
            .zip(&smooth_vis)
            .map(|(w, v)| w * v.max(0.1))
            .collect();
        let field = super::tone::SlopeField::new(&slope, &fit_w, &hold, w, h);
        let dh = super::tone::fit_slopes_halved(field, toward, &solve);
        for (j, i) in area.indices(cols).enumerate() {
            let d = how.step * dh[j] * wt[j].min(1.0);
            if wt[j] > 0.0 && d.is_finite() && d != 0.0 {
                height[i] += d;
                top[i] += d;
                changed = true;
            }
        }
    }
    Matched {
        before: first,
        after: last,
        changed,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const N: usize = 96;
    const CELL: f32 = 0.1;

    /// A 60-degree raking light from the upper left, 20 degrees up (the stone's).
    fn light() -> [f32; 3] {
        crate::scene::key_light_dir()
    }

    fn area() -> Window {
        Window {
            x0: 0,
            y0: 0,
            x1: N - 1,
            y1: N - 1,
        }
    }

    /// The photo: a dark disc (an eye) left of centre, a light bar right of it, on a flat
    /// grey; log brightness.
    fn photo() -> Vec<f32> {
        (0..N * N)
            .map(|i| {
                let (x, y) = ((i % N) as f32, (i / N) as f32);
                let disc = if (x - 36.0).hypot(y - 48.0) < 7.0 {
                    -0.8
                } else {
                    0.0
                };
                let bar = if (56.0..62.0).contains(&x) && (36.0..60.0).contains(&y) {
                    0.3
                } else {
                    0.0
                };
                disc + bar
            })
            .collect()
    }

    /// A plateau 2 mm high carrying a faint copy of the disc (a pit) and a bump the photo
    /// does not have (the relief's own form), 1 mm wide.
    fn relief() -> Vec<f32> {
        (0..N * N)
            .map(|i| {
                let (x, y) = ((i % N) as f32, (i / N) as f32);
                let pit = -0.15 * (-((x - 36.0).powi(2) + (y - 48.0).powi(2)) / 40.0).exp();
                let bump = 0.3 * (-((x - 60.0).powi(2) + (y - 20.0).powi(2)) / 25.0).exp();
                2.0 + pit + bump
            })
            .collect()
    }

    fn weight() -> Vec<f32> {
        (0..N * N)
            .map(|i| {
                let (x, y) = (i % N, i / N);
                if (8..N - 8).contains(&x) && (8..N - 8).contains(&y) {
                    1.0
                } else {
                    0.0
                }
            })
            .collect()
    }

    fn grid() -> Grid {
        Grid {
            cols: N,
            rows: N,
            cell: CELL,
        }
    }

    #[test]
    fn the_match_brings_the_stones_light_nearer_the_photos() {
        let (mut h, target, w) = (relief(), photo(), weight());
        let mut top = h.clone();
        let how = Closure::for_face(1.5, 70.0);
        let m = close(&mut h, &mut top, &target, &w, grid(), light(), area(), &how);
        assert!(m.changed);
        assert!(m.before > 0.05 && m.before < 0.8, "{m:?}");
        assert!(m.after > m.before + 0.1, "{m:?}");
        assert_eq!(h, top, "the stone's top follows the height");
        // Heights move by a fraction of a millimetre, and not off the weighted face.
        let moved = h
            .iter()
            .zip(relief())
            .map(|(a, b)| (a - b).abs())
            .fold(0f32, f32::max);
        assert!(moved > 0.01 && moved < 1.0, "{moved}");
        for (i, (a, b)) in h.iter().zip(relief()).enumerate() {
            if w[i] == 0.0 {
                assert_eq!(*a, b, "node {i} off the face moved");
            }
        }
    }

    #[test]
    fn nothing_to_match_leaves_the_relief_alone() {
        let w = weight();
        // No photo anywhere (NaN), a mismatched target, a zero gain.
        let cases: [(Vec<f32>, f32); 3] = [
            (vec![f32::NAN; N * N], 1.5),
            (vec![0.0; 10], 1.5),
            (photo(), 0.0),
        ];
        for (target, gain) in cases {
            let mut h = relief();
            let mut top = h.clone();
            let how = Closure::for_face(gain, 70.0);
            let m = close(&mut h, &mut top, &target, &w, grid(), light(), area(), &how);
            assert!(!m.changed);
            assert_eq!(h, relief());
        }
    }

    #[test]
    fn a_flat_lit_plateau_is_lit_as_the_renderer_lights_it() {
        let l = light();
        let h = vec![1.0f32; 9];
        let (vis, cav) = (vec![1.0f32; 9], vec![1.0f32; 9]);
        let r = radiance(&h, &vis, &cav, 3, 3, CELL, l);
        let want = SKY + FILL + KEY * l[2];
        assert!(r.iter().all(|v| (v - want).abs() < 1e-5), "{r:?} {want}");
        // In full shadow and a closed hollow only the sky and fill are left, dimmed.
        let r = radiance(&h, &[0.0; 9], &[0.5; 9], 3, 3, CELL, l);
        assert!(r.iter().all(|v| (v - 0.5 * (SKY + FILL)).abs() < 1e-5));
    }
}
