//! The hair's texture, read at the photo's own resolution over the scalp's hair (the person
//! canvas's 0.04 IOD cells are as wide as a curl): how much its strands agree in direction,
//! the structure tensor's **coherence**. Straight and wavy hair is strands side by side, one
//! direction over a patch; curls and coils turn within a patch; a crop shows no strands.
//! (Measured beside it on the labelled photos and left out, as they told the kinds apart no
//! better: the Hessian's blob share, the detail's contrast, the directions' agreement over
//! wider windows and after coarser smoothing.)
//!
//! The kind is decided from the coherence and the layer's thickness ([`kind`]): hair whose
//! strands turn within a patch is curly, or cropped where it is a thin layer on the skull;
//! the rest is straight (waves are not told from straight locks: both are strands side by
//! side over a patch).
//!
//! Frame and units: the head frame of `super` (IOD, `t` down the face). Lightness 0..1.

use super::Frame;

/// Fewer cells of hair than this (0.02 IOD each) are too few to read a texture from.
const MIN_CELLS: usize = 50;

/// Hair whose strands agree less than this ([`Texture::coherence`]) turns within a patch:
/// curls, coils or a crop. On the 165 photos of `bench/labels/person.tsv` with a labelled kind
/// and hair found, the quartiles were straight 0.74 / 0.82 / 0.87, curly 0.59 / 0.64 / 0.75,
/// cropped 0.57 / 0.64 / 0.70: this is the textured kinds' median, which 8 of 132 straight
/// heads reach (tousled short hair, small photos).
pub const TEXTURED: f32 = 0.64;
/// The coherence of typical straight hair (the labelled straight heads' median) and of
/// tight curls (the curliest labelled head): [`super::Hair::curl`] 0 and 1.
const CURL_STRAIGHT: f32 = 0.82;
const CURL_TIGHT: f32 = 0.55;
/// A crop is a layer at most this thick over the skull's top and beside the temples (face
/// lengths; [`super::Hair::top`], [`super::Hair::sides`]), ending above the ears.
pub const CROP_TOP: f32 = 0.1;
pub const CROP_SIDES: f32 = 0.3;

/// The hair's kind, as decided: what the report and `bench/labels/person.tsv` call it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HairKind {
    /// No hair over the crown.
    Bald,
    /// Clipped close to the skull: a thin, even layer without locks.
    Cropped,
    /// Strands side by side (straight or wavy): locks.
    Straight,
    /// Strands turning within a patch: curls or coils.
    Curly,
}

impl HairKind {
    pub fn as_str(self) -> &'static str {
        match self {
            HairKind::Bald => "bald",
            HairKind::Cropped => "cropped",
            HairKind::Straight => "straight",
            HairKind::Curly => "curly",
        }
    }
}

/// How curled the texture is: 0 straight (typical straight hair's coherence or more) .. 1
/// tight curls.
pub(super) fn curl(t: &Texture) -> f32 {
    if t.cells < MIN_CELLS {
        return 0.0;
    }
    ((CURL_STRAIGHT - t.coherence) / (CURL_STRAIGHT - CURL_TIGHT)).clamp(0.0, 1.0)
}

/// The kind of a head of hair from its texture and how thick a layer it is (`top`, `sides`,
/// face lengths) and where it ends (`length`, face lengths below the eyes). Too little hair
/// to read ([`MIN_CELLS`]) is straight: the template's locks.
pub(super) fn kind(t: &Texture, top: f32, sides: f32, length: f32) -> HairKind {
    let textured = t.cells >= MIN_CELLS && t.coherence < TEXTURED;
    if !textured {
        HairKind::Straight
    } else if top < CROP_TOP && sides < CROP_SIDES && length <= super::traits::SHORT_LENGTH {
        HairKind::Cropped
    } else {
        HairKind::Curly
    }
}

/// Canvas cell, IOD: about a millimetre and a quarter on an adult.
const RES: f32 = 0.02;
/// The canvas: over the head and beside the face to below the chin.
const S_SPAN: f32 = 2.6;
const T_TOP: f32 = -2.8;
const T_BOTTOM: f32 = 2.4;
/// How far inside the hair's outline a cell must be to be read (IOD): the outline's own edge
/// against the background is not the hair's texture.
const INSET: f32 = 0.1;

/// What was measured of the hair's texture; see the module's cues.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Texture {
    /// Cells read (the scalp's hair inside its outline); under [`MIN_CELLS`] nothing else was.
    pub cells: usize,
    /// Structure-tensor coherence over 0.14 IOD windows, 0 (no direction) .. 1 (one).
    pub coherence: f32,
    /// Photo pixels per IOD.
    pub iod: f32,
}

/// Reads the texture; `hair(s, t)` says whether a head-frame point is the scalp's hair.
pub(super) fn measure(
    frame: Frame,
    iod: f32,
    lightness: &dyn Fn(f32, f32) -> f32,
    hair: &dyn Fn([f32; 2]) -> bool,
) -> Texture {
    let w = (2.0 * S_SPAN / RES).round() as usize + 1;
    let h = ((T_BOTTOM - T_TOP) / RES).round() as usize + 1;
    let at = |c: usize, r: usize| [-S_SPAN + c as f32 * RES, T_TOP + r as f32 * RES];
    // Which cells are read: hair, and hair INSET away in the four directions and diagonals.
    let read: Vec<bool> = (0..w * h)
        .map(|i| super::colour::inside_by(hair, at(i % w, i / w), INSET))
        .collect();
    let cells = read.iter().filter(|&&r| r).count();
    if cells < MIN_CELLS {
        return Texture {
            cells,
            ..Texture::default()
        };
    }
    // Each cell averages the photo over its own area (as in `glasses`; at most 3 x 3 samples:
    // a cell more than 3 pixels wide is seen a little aliased, not worth 4 x 4).
    let k = ((RES * iod).ceil() as usize).clamp(1, 3);
    // Only the rows and columns around the read cells are sampled.
    let (mut c0, mut c1, mut r0, mut r1) = (w, 0, h, 0);
    for i in (0..w * h).filter(|&i| read[i]) {
        let (c, r) = (i % w, i / w);
        (c0, c1, r0, r1) = (c0.min(c), c1.max(c), r0.min(r), r1.max(r));
    }
    let pad = 12;
    let (c0, r0) = (c0.saturating_sub(pad), r0.saturating_sub(pad));
    let (c1, r1) = ((c1 + pad).min(w - 1), (r1 + pad).min(h - 1));
    let (cw, ch) = (c1 - c0 + 1, r1 - r0 + 1);
    let mut canvas = vec![0f32; cw * ch];
    for r in 0..ch {
        for c in 0..cw {
            canvas[r * cw + c] = frame.cell_mean(at(c0 + c, r0 + r), RES, k, lightness);
        }
    }
    let inside: Vec<usize> = (0..cw * ch)
        .filter(|&i| read[(r0 + i / cw) * w + c0 + i % cw])
        .collect();
    let blur = |f: &[f32], r: usize| super::box_blur(f, cw, ch, r);
    // Central differences of the lightness smoothed over 0.06 IOD; the tensor summed over
    // 0.14 IOD windows, its eigenvalues' difference over their sum (each cell weighted by its
    // detail's strength, so flat patches say little).
    let smooth = blur(&canvas, 1);
    let (mut gx, mut gy) = (vec![0f32; cw * ch], vec![0f32; cw * ch]);
    for y in 1..ch - 1 {
        for x in 1..cw - 1 {
            let i = y * cw + x;
            gx[i] = 0.5 * (smooth[i + 1] - smooth[i - 1]);
            gy[i] = 0.5 * (smooth[i + cw] - smooth[i - cw]);
        }
    }
    let jxx: Vec<f32> = gx.iter().map(|g| g * g).collect();
    let jyy: Vec<f32> = gy.iter().map(|g| g * g).collect();
    let jxy: Vec<f32> = gx.iter().zip(&gy).map(|(a, b)| a * b).collect();
    let (xx, yy, xy) = (blur(&jxx, 3), blur(&jyy, 3), blur(&jxy, 3));
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for &i in &inside {
        num += f64::from(((xx[i] - yy[i]).powi(2) + 4.0 * xy[i].powi(2)).sqrt());
        den += f64::from(xx[i] + yy[i]);
    }
    Texture {
        cells,
        coherence: if den > 0.0 { (num / den) as f32 } else { 0.0 },
        iod,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texture(cells: usize, coherence: f32) -> Texture {
        Texture {
            cells,
            coherence,
            iod: 60.0,
        }
    }

    /// The decision's edges: textured thin hair is a crop, textured standing or long hair
    /// curls, coherent hair straight however thin, and too little hair to read is straight
    /// and uncurled.
    #[test]
    fn the_kind_follows_the_texture_and_the_layer() {
        let curly = texture(500, TEXTURED - 0.05);
        let straight = texture(500, TEXTURED + 0.05);
        assert_eq!(kind(&curly, 0.05, 0.2, 0.3), HairKind::Cropped);
        assert_eq!(kind(&curly, CROP_TOP + 0.05, 0.2, 0.3), HairKind::Curly);
        assert_eq!(kind(&curly, 0.05, CROP_SIDES + 0.05, 0.3), HairKind::Curly);
        assert_eq!(kind(&curly, 0.05, 0.2, 1.5), HairKind::Curly);
        assert_eq!(kind(&straight, 0.05, 0.2, 0.3), HairKind::Straight);
        let unread = texture(MIN_CELLS - 1, 0.0);
        assert_eq!(kind(&unread, 0.05, 0.2, 0.3), HairKind::Straight);
        assert_eq!(curl(&unread), 0.0);
        assert_eq!(curl(&texture(500, 0.95)), 0.0);
        assert_eq!(curl(&texture(500, 0.3)), 1.0);
        assert!(curl(&curly) > curl(&straight));
    }
}
