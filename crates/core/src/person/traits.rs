//! The hair's traits (how far it stands out, how long it falls, its silhouette), measured on
//! the labelled head frame. Its texture and curl are read at the photo's resolution
//! (`super::kind`).

use super::{Canvas, Colour, Hair, Label, RES, T_RANGE};

/// The middle value (the upper of the two for an even count); `None` when empty.
pub(crate) fn median(mut v: Vec<f32>) -> Option<f32> {
    if v.is_empty() {
        return None;
    }
    let k = v.len() / 2;
    Some(*v.select_nth_unstable_by(k, f32::total_cmp).1)
}

/// The least curtain ([`Hair::curtain`], face half-widths) of hair that falls past the jaw:
/// about 3 cm of hair beside the cheek. On the 149 photos of `bench/labels/person.tsv`
/// labelled short or long, long hair measured 0.56-0.82 where it was found at all, while 38
/// short-haired photos read as long (a suit or a shadowed neck joined to the hair) spread
/// over 0.00-0.82, 23 of them under this.
pub const CURTAIN: f32 = 0.4;

/// The rows of [`super::Hair::fall`]: the first's top, face lengths below the eyes, and each
/// row's height.
pub const FALL_TOP: f32 = 0.1;
pub const FALL_STEP: f32 = 0.2;
pub const FALL_ROWS: usize = 15;

/// The share of skin beside the face at the ear's height that makes a bare ear.
const EAR_BARE: f32 = 0.3;

/// Where hair without a curtain is taken to end (face lengths below the eyes: about the ears).
pub(super) const SHORT_LENGTH: f32 = 0.6;

/// The hair's traits from its labelled pixels (`col`: each pixel's colour).
pub(super) fn traits(canvas: &Canvas, col: &[Colour]) -> Option<Hair> {
    let Canvas {
        labels,
        w,
        h,
        pos,
        in_face,
        skull,
        chin,
        half,
    } = *canvas;
    // Scalp hair only (the face's own hair-coloured pixels are brows and beard).
    let hair: Vec<usize> = (0..w * h)
        .filter(|&i| labels[i] == Label::Hair && !in_face[i])
        .collect();
    if hair.len() < 30 {
        return None;
    }
    // The crown: over the head's top, above the forehead's hairline (which recedes on many
    // men) to beyond the skull's top (where hair stands), the share of the head there that
    // is hair rather than skin; the background around the head does not count. A bald scalp
    // is skin; a receding hairline leaves the top hair.
    let (mut crown_hair, mut crown_skin) = (0usize, 0usize);
    let mut crown_px = 0usize;
    for i in 0..w * h {
        let p = pos(i);
        if matches!(labels[i], Label::Outside | Label::Hat)
            || in_face[i]
            || p[1] > -0.75 * chin
            || p[0].abs() > 0.8 * half
            || skull(p) > 1.4
        {
            continue;
        }
        crown_px += 1;
        match labels[i] {
            Label::Hair => crown_hair += 1,
            Label::Skin => crown_skin += 1,
            _ => {}
        }
    }
    let crown = if crown_hair + crown_skin < 20 {
        // Nothing of the head there (cut off by the photo's edge): say nothing against hair.
        if crown_px == 0 { 1.0 } else { 0.0 }
    } else {
        crown_hair as f32 / (crown_hair + crown_skin) as f32
    };
    // Top: the highest hair over the head's middle, beyond the skull's top.
    let top_t = hair
        .iter()
        .map(|&i| pos(i))
        .filter(|p| p[0].abs() < 0.7 * half)
        .map(|p| p[1])
        .fold(f32::INFINITY, f32::min);
    let top = if top_t.is_finite() {
        ((-top_t - 0.96 * chin) / chin).max(0.0)
    } else {
        0.0
    };
    // Sides: the hair's reach beside the temples (the widest row between brow and eyes).
    let side_reach = hair
        .iter()
        .map(|&i| pos(i))
        .filter(|p| (-0.6 * chin..0.2 * chin).contains(&p[1]))
        .map(|p| p[0].abs())
        .fold(0.0f32, f32::max);
    let sides = ((side_reach - 1.08 * half) / chin).max(0.0);
    // Length: walk down beside the face while each row still has hair (gaps under 0.15 face
    // lengths are bridged: a strand of background, an ear).
    let row_has_hair = |t0: f32, t1: f32| {
        hair.iter().any(|&i| {
            let p = pos(i);
            p[1] >= t0 && p[1] < t1 && p[0].abs() > 0.55 * half
        })
    };
    let step = 0.05 * chin;
    let mut t = -0.2 * chin;
    let mut last = t;
    while t < T_RANGE.1 {
        if row_has_hair(t, t + step) {
            last = t + step;
        } else if t - last > 0.15 * chin {
            break;
        }
        t += step;
    }
    let length = (last / chin).max(0.0);
    // The curtain: in each canvas row from the mouth to the chin, the scalp hair beside the
    // face on each side (beyond a tenth of the face's half-width from its outline, where a
    // shadowed cheek's edge may pass for hair, and within most of a half-width of it).
    // The canvas rows between two heights (t, IOD) that cross the face, with the face's
    // widest reach from the midline in each.
    let face_rows = |t0: f32, t1: f32| {
        (0..h).filter_map(move |y| {
            let row = y * w..(y + 1) * w;
            if !(t0..t1).contains(&pos(y * w)[1]) {
                return None;
            }
            row.clone()
                .filter(|&i| in_face[i])
                .map(|i| pos(i)[0].abs())
                .reduce(f32::max)
                .map(|face_x| (row, face_x))
        })
    };
    let (mut left, mut right) = (Vec::new(), Vec::new());
    for (row, face_x) in face_rows(0.45 * chin, 0.9 * chin) {
        let (lo, hi) = (face_x + 0.1 * half, face_x + 0.9 * half);
        let (mut l, mut r) = (0usize, 0usize);
        for i in row.filter(|&i| labels[i] == Label::Hair && !in_face[i]) {
            let x = pos(i)[0];
            if (lo..hi).contains(&x.abs()) {
                if x < 0.0 {
                    l += 1;
                } else {
                    r += 1;
                }
            }
        }
        left.push(l as f32 * RES / half);
        right.push(r as f32 * RES / half);
    }
    // An ear left bare (skin beside the face between the eyes' and the nose's heights) is a
    // side whose hair is short: what hangs below it there is a collar, a suit or a dark
    // ground, not a curtain of hair.
    let (mut bare, mut seen) = ([0usize; 2], [0usize; 2]);
    for (row, face_x) in face_rows(0.05 * chin, 0.4 * chin) {
        for i in row.filter(|&i| labels[i] != Label::Outside && !in_face[i]) {
            let x = pos(i)[0];
            if (face_x..face_x + 0.25 * half).contains(&x.abs()) {
                let side = usize::from(x > 0.0);
                seen[side] += 1;
                bare[side] += usize::from(labels[i] == Label::Skin);
            }
        }
    }
    let ear_bare = |side: usize| seen[side] > 0 && bare[side] as f32 > EAR_BARE * seen[side] as f32;
    let side_curtain = |v: Vec<f32>, side: usize| {
        if ear_bare(side) {
            0.0
        } else {
            median(v).unwrap_or(0.0)
        }
    };
    let curtain = side_curtain(left, 0).max(side_curtain(right, 1));
    // Without a curtain the hair does not fall past the jaw, whatever joined it below (a dark
    // suit, a shadowed neck): it ends about the ears.
    let length = if curtain < CURTAIN {
        length.min(SHORT_LENGTH)
    } else {
        length
    };
    // The fall: per row of FALL_STEP face lengths from FALL_TOP down to where the hair ends,
    // how near the face's midline and how far out the hair reaches (its tenth and ninetieth
    // percentiles per side, then the mean of the sides with hair), face lengths.
    let mut rows: Vec<[Vec<f32>; 2]> = (0..FALL_ROWS).map(|_| [Vec::new(), Vec::new()]).collect();
    for &i in &hair {
        let p = pos(i);
        let t = p[1] / chin;
        let k = ((t - FALL_TOP) / FALL_STEP).floor();
        if t > length || !(k >= 0.0 && (k as usize) < FALL_ROWS) {
            continue;
        }
        rows[k as usize][usize::from(p[0] > 0.0)].push(p[0].abs() / chin);
    }
    let mut fall = [[0f32; 2]; FALL_ROWS];
    for (row, out) in rows.iter_mut().zip(fall.iter_mut()) {
        let mut sides = Vec::new();
        for v in row.iter_mut().filter(|v| v.len() >= 3) {
            v.sort_by(f32::total_cmp);
            let at = |q: f32| v[((v.len() - 1) as f32 * q).round() as usize];
            sides.push([at(0.1), at(0.9)]);
        }
        if !sides.is_empty() {
            let n = sides.len() as f32;
            *out = [
                sides.iter().map(|r| r[0]).sum::<f32>() / n,
                sides.iter().map(|r| r[1]).sum::<f32>() / n,
            ];
        }
    }
    let brightness = hair.iter().map(|&i| col[i][0]).sum::<f32>() / hair.len() as f32;
    // The hair's outline: its top above the eyes and its half-width at the temples.
    let height = if top_t.is_finite() {
        (-top_t / chin).max(0.0)
    } else {
        0.96
    };
    let width = side_reach.max(1.08 * half) / chin;
    let mask = super::silhouette::hair_mask(
        canvas,
        &super::silhouette::Decided {
            length,
            ear_bare: [ear_bare(0), ear_bare(1)],
        },
    );
    Some(Hair {
        crown,
        top,
        sides,
        height,
        width,
        length,
        fall,
        mask,
        curtain,
        brightness,
        // Read at the photo's resolution by the caller (`super::kind`).
        curl: 0.0,
        texture: super::Texture::default(),
    })
}
