//! Glasses, read from the photo at its own resolution (the person canvas's 0.04 IOD cells are
//! wider than a metal frame).
//!
//! Three cues, any of which makes glasses:
//! * **the bridge as a thin line** across the nose at the eyes' height: the strongest
//!   left-to-right path of thin-line response (dark or bright, up to 0.08 IOD wide: a step
//!   edge or a shadow's gradient gives none) over the nose between the eyes, divided by the
//!   median response over the eyes' band (a face's own texture). Metal and rimless frames
//!   show here even at 40 pixels between the eyes, where their rims are a pixel wide; a
//!   frown's creases lie higher, between the brows, and are left out of the search;
//! * **dark lenses**: the brightest tenth of the eyes' region (the whites of the eyes, a
//!   lid's highlight) darker than 0.4 of the cheeks: sunglasses;
//! * **a dark bar** between the eyes (the darkest row's dip below the median row, from the
//!   person canvas): a thick frame's bridge, wider than a thin line.
//!
//! Frame and units: the head frame of `super` (IOD, `t` down the face). Lightness 0..1.

use super::Frame;

/// Canvas cell, IOD: a pixel or less on a 40-pixel face.
const RES: f32 = 0.02;
/// The canvas: across both eyes and down to the cheeks.
const S_SPAN: f32 = 1.0;
const T_TOP: f32 = -0.5;
const T_BOTTOM: f32 = 0.9;
/// The rows whose median line response normalises the bridge's: brows, eyes, nose (not the
/// cheeks, which the lenses' test reads).
const T_TEXTURE: f32 = 0.7;
/// A thin line's half-width reach: the neighbours compared are this many cells away.
const REACH: usize = 2;
/// Where a bridge is looked for: across the nose, from a little above the eyes' centres
/// (frowns' creases lie higher) to a little below.
const BRIDGE_S: f32 = 0.18;
const BRIDGE_T: (f32, f32) = (-0.12, 0.15);

/// The bridge's line strength (times the face's median line response) that makes glasses.
/// On 159 labelled photos (LFW's ten men and deepface's set, 25 with glasses) frames measure
/// 4-66 (median 19), faces without 2-16 (median 4.6): a frown or a crease at the nose's root
/// can reach past it, a rimless frame on a 40-pixel face can stay under.
pub const GLASSES_BRIDGE: f32 = 11.0;
/// Dark lenses: the eyes' brightest tenth below this share of the cheeks' median. Measured
/// 0.15 for sunglasses, 0.73 and more on 158 faces without.
pub const DARK_LENSES: f32 = 0.4;
/// A thick frame's dark bar: the darkest row between the eyes dips this far below the
/// median row (thick frames 0.72-0.91; faces without reach 0.57 under a strong brow).
pub const GLASSES_DIP: f32 = 0.65;

/// What was measured for glasses; see the module's cues.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Glasses {
    /// The bridge's thin-line strength over the face's median ([`GLASSES_BRIDGE`]).
    pub bridge: f32,
    /// The eyes' brightest tenth over the cheeks' median ([`DARK_LENSES`]); 1 when unknown.
    pub lenses: f32,
    /// The darkest row's dip between the eyes, 0..1 ([`GLASSES_DIP`]).
    pub dip: f32,
}

impl Glasses {
    /// Whether any cue is past its threshold.
    pub fn found(&self) -> bool {
        self.bridge > GLASSES_BRIDGE || self.lenses < DARK_LENSES || self.dip > GLASSES_DIP
    }
}

/// Measures the bridge's line and the lenses' darkness; `lightness(x, y)` is the photo's at a
/// pixel (0..1), `iod` the eyes' distance in pixels. The dip is left at 0 for the caller.
pub(super) fn measure(frame: Frame, iod: f32, lightness: &dyn Fn(f32, f32) -> f32) -> Glasses {
    let w = (2.0 * S_SPAN / RES).round() as usize + 1;
    let h = ((T_BOTTOM - T_TOP) / RES).round() as usize + 1;
    // Each cell averages the photo over its own area (a box of sub-samples), so a large photo
    // is seen at the canvas's resolution without aliasing, and a small one is interpolated.
    let cell = RES * iod;
    let k = (cell.ceil() as usize).clamp(1, 8);
    let mut canvas = vec![0f32; w * h];
    for r in 0..h {
        for c in 0..w {
            let p = [-S_SPAN + c as f32 * RES, T_TOP + r as f32 * RES];
            canvas[r * w + c] = frame.cell_mean(p, RES, k, lightness);
        }
    }
    let row = |t: f32| ((t - T_TOP) / RES).round() as usize;
    let col = |s: f32| ((s + S_SPAN) / RES).round() as usize;

    // Thin-line response along t: a cell darker (or lighter) than both its neighbours REACH
    // cells above and below, by the smaller difference.
    let mut line = vec![0f32; w * h];
    for r in REACH..h - REACH {
        for c in 0..w {
            let v = canvas[r * w + c];
            let (a, b) = (canvas[(r - REACH) * w + c], canvas[(r + REACH) * w + c]);
            line[r * w + c] = (v - a).min(v - b).max(0.0) + (a - v).min(b - v).max(0.0);
        }
    }
    let texture = super::median(line[..row(T_TEXTURE) * w].to_vec()).unwrap_or(0.0) + 0.003;
    let bridge = best_path(
        &line,
        w,
        row(BRIDGE_T.0)..row(BRIDGE_T.1),
        col(-BRIDGE_S)..col(BRIDGE_S),
    ) / texture;

    // Lenses: the eyes' boxes against the cheeks below them.
    let region = |t: (f32, f32), s: (f32, f32)| -> Vec<f32> {
        let mut v = Vec::new();
        for r in row(t.0)..row(t.1) {
            for side in [-1.0, 1.0] {
                let (c0, c1) = if side < 0.0 {
                    (col(-s.1), col(-s.0))
                } else {
                    (col(s.0), col(s.1))
                };
                v.extend((c0..c1).map(|c| canvas[r * w + c]));
            }
        }
        v
    };
    let mut eyes = region((-0.15, 0.2), (0.2, 0.8));
    eyes.sort_by(f32::total_cmp);
    let bright = eyes.get(eyes.len() * 9 / 10).copied();
    let cheeks = super::median(region((0.55, 0.85), (0.3, 0.8)));
    let lenses = match (bright, cheeks) {
        (Some(b), Some(c)) if c > 0.05 => b / (c + 0.01),
        _ => 1.0,
    };
    Glasses {
        bridge: if bridge.is_finite() { bridge } else { 0.0 },
        lenses: if lenses.is_finite() { lenses } else { 1.0 },
        dip: 0.0,
    }
}

/// The mean response along the best path from the first column to the last, moving at most
/// one row per column, within `rows` x `cols` of a row-major map `w` wide.
fn best_path(
    map: &[f32],
    w: usize,
    rows: std::ops::Range<usize>,
    cols: std::ops::Range<usize>,
) -> f32 {
    if rows.is_empty() || cols.is_empty() {
        return 0.0;
    }
    let n = rows.len();
    let mut acc: Vec<f32> = rows.clone().map(|r| map[r * w + cols.start]).collect();
    let mut next = vec![0f32; n];
    for c in cols.start + 1..cols.end {
        for (i, r) in rows.clone().enumerate() {
            let up = if i > 0 { acc[i - 1] } else { f32::NEG_INFINITY };
            let down = if i + 1 < n {
                acc[i + 1]
            } else {
                f32::NEG_INFINITY
            };
            next[i] = acc[i].max(up).max(down) + map[r * w + c];
        }
        std::mem::swap(&mut acc, &mut next);
    }
    acc.iter().copied().fold(f32::NEG_INFINITY, f32::max) / cols.len() as f32
}
