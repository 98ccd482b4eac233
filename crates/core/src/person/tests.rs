//! The person pass on synthetic heads (painted skin, hair, background) and its failure modes.
//!
//! Length: about 730 lines of tests sharing one painter of synthetic heads (skin, hair kinds,
//! beard, glasses, hat, background) and its helpers.

use super::test_head::landmarks;
use super::*;

const BG: [u8; 3] = [90, 110, 140];
const SKIN: [u8; 3] = [222, 172, 142];
const BROWN: [u8; 3] = [62, 42, 28];

/// A head on a plain ground: skin over the skull's ellipse and a neck; `hair(x, y)` says
/// where hair is drawn; `beard` darkens the chin. Mild deterministic noise everywhere.
fn photo(hair: impl Fn(f32, f32) -> bool, hair_colour: [u8; 3], beard: bool) -> RgbImage {
    RgbImage::from_fn(400, 520, |x, y| {
        let (fx, fy) = (x as f32, y as f32);
        let head = ((fx - 200.0) / 72.0).powi(2) + ((fy - 205.0) / 125.0).powi(2) < 1.0;
        let neck = (fx - 200.0).abs() < 45.0 && fy > 300.0 && fy < 420.0;
        let chin = beard && head && fy > 288.0 && (fx - 200.0).abs() < 60.0;
        let mut c = if hair(fx, fy) {
            hair_colour
        } else if chin {
            BROWN
        } else if head || neck {
            SKIN
        } else {
            BG
        };
        let n = ((x.wrapping_mul(73_856_093) ^ y.wrapping_mul(19_349_663)) % 17) as i32 - 8;
        for v in &mut c {
            *v = (i32::from(*v) + n).clamp(0, 255) as u8;
        }
        image::Rgb(c)
    })
}

/// [`photo`] with `hair` of `hair_colour`, dressed in clothes of `colour` where `clothes(x, y)`
/// (not over the head nor the hair).
fn dressed(
    hair: &dyn Fn(f32, f32) -> bool,
    hair_colour: [u8; 3],
    clothes: &dyn Fn(f32, f32) -> bool,
    colour: [u8; 3],
) -> RgbImage {
    let base = photo(hair, hair_colour, false);
    RgbImage::from_fn(base.width(), base.height(), |x, y| {
        let (fx, fy) = (x as f32, y as f32);
        let head = ((fx - 200.0) / 72.0).powi(2) + ((fy - 205.0) / 125.0).powi(2) < 1.0;
        if clothes(fx, fy) && !head && !hair(fx, fy) {
            image::Rgb(colour)
        } else {
            *base.get_pixel(x, y)
        }
    })
}

/// Hair over the crown above the forehead's hairline, standing `stand` px out, and down
/// both sides to `end` (image y).
fn hair_to(stand: f32, end: f32) -> impl Fn(f32, f32) -> bool {
    move |x, y| {
        let outer =
            ((x - 200.0) / (72.0 + stand)).powi(2) + ((y - 205.0) / (125.0 + stand)).powi(2) < 1.0;
        let head = ((x - 200.0) / 72.0).powi(2) + ((y - 205.0) / 125.0).powi(2) < 1.0;
        let crown = outer && y < 150.0;
        let sides = outer && !head && y < 215.0;
        let fall = (x - 200.0).abs() > 62.0 && (x - 200.0).abs() < 100.0 && y > 140.0 && y < end;
        crown || sides || fall
    }
}

#[test]
fn bald_short_and_long_hair_are_told_apart() {
    let lm = landmarks();
    let bald = analyse(&photo(|_, _| false, BROWN, false), &lm).unwrap();
    assert!(bald.hair.is_none(), "{:?}", bald.hair);
    let short = analyse(&photo(hair_to(12.0, 0.0), BROWN, false), &lm).unwrap();
    let h = short.hair.expect("short hair found");
    assert!(h.crown > 0.6, "{h:?}");
    assert!(h.length < 0.6, "short hair ends near the ears: {h:?}");
    let long = analyse(&photo(hair_to(12.0, 470.0), BROWN, false), &lm).unwrap();
    let l = long.hair.expect("long hair found");
    assert!(l.length > 1.6, "long hair reaches the shoulders: {l:?}");
    let big = analyse(&photo(hair_to(45.0, 0.0), BROWN, false), &lm).unwrap();
    let b = big.hair.expect("big hair found");
    assert!(b.top > h.top + 0.15, "volume: {:.2} vs {:.2}", b.top, h.top);
    // In the cameo: bald stays bald, long hair ends lower, big hair stands higher.
    let (sb, ss, sl, sg) = (
        crate::gem::hair_style(&bald),
        crate::gem::hair_style(&short),
        crate::gem::hair_style(&long),
        crate::gem::hair_style(&big),
    );
    assert!(sb.bald && !ss.bald && !sl.bald);
    assert!(sl.end < ss.end - 100.0, "{sl:?} {ss:?}");
    assert!(sg.volume > ss.volume + 5.0, "{sg:?} {ss:?}");
}

/// An open mouth drops the chin and the jaw, not the crown: the hair's reading holds.
#[test]
fn an_open_mouth_does_not_move_the_crown() {
    let closed = landmarks();
    let mut open = closed.clone();
    // The jaw's lower points, the lower lip and the chin 30 px down (the mouth open by a
    // quarter of the face's length); the photo is the same.
    for (k, q) in open.iter_mut().enumerate() {
        let lower_lip = (55..=59).contains(&k) || (65..=67).contains(&k);
        if (4..=12).contains(&k) || lower_lip {
            q[1] += 30.0 * if (4..=12).contains(&k) { 1.0 } else { 0.9 };
        }
    }
    let img = photo(hair_to(12.0, 0.0), BROWN, false);
    let a = analyse(&img, &closed)
        .unwrap()
        .hair
        .expect("hair, mouth closed");
    let b = analyse(&img, &open)
        .unwrap()
        .hair
        .expect("hair, mouth open");
    assert!(b.crown > 0.6, "{b:?}");
    assert!((a.top - b.top).abs() < 0.05, "{a:?} vs {b:?}");
}

/// A segmentation of the synthetic photo: the head with `stand` px of hair, the neck, and
/// the body below y = 420 are the person.
fn person_mask(stand: f32) -> PersonMask {
    PersonMask::from_fn(130, [0.0, 0.0], 4.0, |x, y| {
        let head =
            ((x - 200.0) / (72.0 + stand)).powi(2) + ((y - 205.0) / (125.0 + stand)).powi(2) < 1.0;
        let neck = (x - 200.0).abs() < 45.0 && y > 300.0;
        f32::from(u8::from(head || neck || y > 420.0))
    })
}

#[test]
fn a_person_mask_is_read_bilinearly_and_not_beyond_its_grid() {
    let m = PersonMask {
        size: 2,
        origin: [10.0, 20.0],
        step: 5.0,
        prob: vec![0.0, 1.0, 0.0, 1.0],
    };
    // Cell centres at x = 12.5 and 17.5: halfway between them is 0.5.
    assert_eq!(m.at([15.0, 22.5]), Some(0.5));
    assert_eq!(m.at([12.5, 25.0]), Some(0.0));
    assert_eq!(m.at([19.9, 29.9]), Some(1.0));
    assert_eq!(m.at([9.0, 25.0]), None);
    assert_eq!(m.at([15.0, 31.0]), None);
    assert_eq!(m.at([f32::NAN, 25.0]), None);
    let broken = PersonMask {
        prob: vec![0.5; 3],
        ..m
    };
    assert_eq!(broken.at([15.0, 22.5]), None);
}

#[test]
fn the_mask_window_covers_the_analysis_canvas() {
    let lm = landmarks();
    let (centre, side) = mask_window(&lm).unwrap();
    // Eyes 60 px apart at y = 200: the canvas runs from 3.4 IOD above the eyes to 6 below.
    assert!((side - 9.4 * 60.0).abs() < 1.0, "{side}");
    assert!((centre[0] - 200.0).abs() < 0.5, "{centre:?}");
    assert!((centre[1] - (200.0 + 1.3 * 60.0)).abs() < 1.0, "{centre:?}");
    assert!(mask_window(&lm[..60]).is_err());
}

/// A wall the colour of the hair beside the head: colour alone cannot tell them apart, the
/// segmentation can.
#[test]
fn a_segmentation_keeps_a_wall_the_colour_of_the_hair_out_of_it() {
    let lm = landmarks();
    let hair = hair_to(12.0, 0.0);
    let wall = |x: f32, y: f32| x > 282.0 && y > 60.0 && y < 240.0;
    let img = photo(|x, y| hair(x, y) || wall(x, y), BROWN, false);
    let plain = analyse(&photo(&hair, BROWN, false), &lm).unwrap();
    let p = plain.hair.expect("hair on the plain ground");
    let colour = analyse(&img, &lm).unwrap();
    let c = colour.hair.expect("hair beside the wall");
    let mask = person_mask(12.0);
    let seg = analyse_with(&img, &lm, Some(&mask)).unwrap();
    let s = seg.hair.expect("hair with the segmentation");
    assert!(
        c.sides > p.sides + 0.1,
        "the wall joins the hair by colour: {c:?} vs {p:?}"
    );
    assert!((s.sides - p.sides).abs() < 0.05, "{s:?} vs {p:?}");
    let wall_hair = |q: &Person| {
        (290..400)
            .step_by(4)
            .flat_map(|x| (80..220).step_by(4).map(move |y| (x, y)))
            .filter(|&(x, y)| q.labels.at_pixel(x as f32, y as f32) == Label::Hair)
            .count()
    };
    assert_eq!(wall_hair(&seg), 0);
    assert!(wall_hair(&colour) > 100, "{}", wall_hair(&colour));
    // Without a wall the segmentation changes nothing that matters.
    let same = analyse_with(&photo(&hair, BROWN, false), &lm, Some(&mask)).unwrap();
    let q = same.hair.expect("hair");
    assert!(
        (q.sides - p.sides).abs() < 0.05 && (q.top - p.top).abs() < 0.05,
        "{q:?} {p:?}"
    );
    assert!(same.beard < BEARD_SHARE && !same.has_glasses());
}

/// Short grey hair over a charcoal suit whose collar rises beside the neck to the hair
/// (as the suit of a grey-haired man in deepface's img39 joined his hair through the
/// background): below the chin the suit is clothes, not hair falling to the shoulders;
/// long hair falling over the same suit is still long.
#[test]
fn a_suit_below_the_chin_is_not_long_hair() {
    const GREY: [u8; 3] = [165, 162, 160];
    const SUIT: [u8; 3] = [100, 98, 96];
    let suit = |x: f32, y: f32| {
        let dx = (x - 200.0).abs();
        y > 400.0 || (y > 215.0 && dx > 45.0 && dx < 110.0)
    };
    let dressed = |hair: &dyn Fn(f32, f32) -> bool| dressed(hair, GREY, &suit, SUIT);
    let lm = landmarks();
    let short = analyse(&dressed(&hair_to(12.0, 0.0)), &lm).unwrap();
    // The suit's share labelled hair on the shoulders (well below the chin at y = 320).
    let (mut n, mut hair) = (0, 0);
    for y in (400..500).step_by(4) {
        for x in (20..380).step_by(4) {
            let label = short.labels.at_pixel(x as f32, y as f32);
            if label != Label::Outside {
                n += 1;
                hair += usize::from(label == Label::Hair);
            }
        }
    }
    assert!(n > 500, "the shoulders are on the canvas: {n}");
    assert!(hair * 20 < n, "{hair} of {n} suit samples are hair");
    let h = short.hair.expect("short hair found");
    assert!(h.length < 1.4, "the hair ends above the shoulders: {h:?}");
    let long = analyse(&dressed(&hair_to(12.0, 470.0)), &lm).unwrap();
    let l = long.hair.expect("long hair found");
    assert!(l.length > 1.6, "long grey hair over the suit: {l:?}");
}

/// Long hair's fall is read row by row: beside the face and below the chin it reaches from
/// about the face's side to the painted hair's outer edge (62-100 px from the midline, the
/// face 120 px long: 0.52-0.83 face lengths), and short hair has none below the ears.
#[test]
fn the_hairs_fall_is_read_row_by_row() {
    let lm = landmarks();
    let long = analyse(&photo(hair_to(12.0, 470.0), BROWN, false), &lm).unwrap();
    let h = long.hair.expect("long hair");
    // Rows from 0.7 to 1.9 face lengths below the eyes (y 284-428 px).
    for (k, row) in h.fall.iter().enumerate().skip(3).take(6) {
        assert!(
            (0.45..0.65).contains(&row[0]) && (0.72..0.9).contains(&row[1]),
            "row {k}: {row:?}"
        );
    }
    let short = analyse(&photo(hair_to(12.0, 0.0), BROWN, false), &lm).unwrap();
    let s = short.hair.expect("short hair");
    assert!(s.fall.iter().skip(4).all(|r| r[1] == 0.0), "{:?}", s.fall);
}

#[test]
fn grey_hair_is_hair_and_a_beard_is_found_only_when_there() {
    let lm = landmarks();
    let grey = analyse(&photo(hair_to(12.0, 0.0), [168, 168, 170], false), &lm).unwrap();
    assert!(
        grey.hair.is_some_and(|h| h.brightness > 0.5),
        "{:?}",
        grey.hair
    );
    let shaven = analyse(&photo(hair_to(12.0, 0.0), BROWN, false), &lm).unwrap();
    assert!(!shaven.has_beard(), "beard {:.2}", shaven.beard);
    let bearded = analyse(&photo(hair_to(12.0, 0.0), BROWN, true), &lm).unwrap();
    assert!(bearded.has_beard(), "beard {:.2}", bearded.beard);
    // A full beard joined to the hair by sideburns, hanging below the chin, is not the
    // scalp's hair: short hair stays short (sideburns to the nose's base; hair that ends
    // two-thirds of a face length below the eyes starts to fall behind the neck).
    let scalp = hair_to(12.0, 0.0);
    let full_beard = move |x: f32, y: f32| {
        let dx = (x - 200.0).abs();
        let below = ((x - 200.0) / 86.0).powi(2) + ((y - 205.0) / 139.0).powi(2) < 1.0;
        scalp(x, y) || (dx > 62.0 && dx < 78.0 && y > 150.0 && y < 300.0) || (below && y > 285.0)
    };
    let full = analyse(&photo(full_beard, BROWN, false), &lm).unwrap();
    assert!(full.has_beard(), "beard {:.2}", full.beard);
    let length = |p: &Person| p.hair.map_or(f32::NAN, |h| h.length);
    assert!(
        length(&full) < 0.5,
        "hair length {:.2} with the beard, {:.2} without",
        length(&full),
        length(&shaven)
    );
}

/// `img` in black and white (the mean of its channels).
fn black_and_white(img: &RgbImage) -> RgbImage {
    RgbImage::from_fn(img.width(), img.height(), |x, y| {
        let [r, g, b] = img.get_pixel(x, y).0;
        let l = ((u16::from(r) + u16::from(g) + u16::from(b)) / 3) as u8;
        image::Rgb([l, l, l])
    })
}

/// In a black-and-white photo only brightness tells hair from skin: grey hair a little darker
/// than the face (about four times the noise) is still read as a head of hair all round the
/// skull, not a bald head, and a bald head stays bald.
#[test]
fn grey_hair_in_a_black_and_white_photo_is_hair() {
    let lm = landmarks();
    let skin_grey = (u16::from(SKIN[0]) + u16::from(SKIN[1]) + u16::from(SKIN[2])) / 3;
    let grey = (skin_grey - 14) as u8;
    let photo_bw = black_and_white(&photo(hair_to(14.0, 0.0), [grey; 3], false));
    let read = analyse(&photo_bw, &lm).unwrap();
    let h = read
        .hair
        .expect("grey hair in black and white read as bald");
    assert!(h.crown > 0.6 && h.length < 0.6, "{h:?}");
    let bald = analyse(&black_and_white(&photo(|_, _| false, BROWN, false)), &lm).unwrap();
    assert!(
        bald.hair.is_none(),
        "a bald head in black and white: {:?}",
        bald.hair
    );
    // The same photo in colour is read as before: colour keeps its full weight.
    let colour = analyse(&photo(hair_to(14.0, 0.0), BROWN, false), &lm).unwrap();
    assert!(colour.hair.is_some_and(|h| h.crown > 0.6));
}

/// Einstein's case: in a black-and-white photo the hair beside the head is white outside and,
/// next to the temples, as grey as the lit skin. That inner part is read as the hair's (beside
/// the face, above the ears), so the hair does not float off the head; an ear's bare skin is
/// left alone.
#[test]
fn grey_hair_beside_the_temples_joins_the_white_hair_in_black_and_white() {
    let lm = landmarks();
    let skin_grey = ((u16::from(SKIN[0]) + u16::from(SKIN[1]) + u16::from(SKIN[2])) / 3) as u8;
    let white = photo(hair_to(18.0, 0.0), [240; 3], false);
    // The inner 9 px of the hair beside the head, above the eyes, as grey as the skin.
    let inner = |x: f32, y: f32| {
        let head = ((x - 200.0) / 72.0).powi(2) + ((y - 205.0) / 125.0).powi(2);
        let band = ((x - 200.0) / 81.0).powi(2) + ((y - 205.0) / 134.0).powi(2);
        head >= 1.0 && band < 1.0 && (x - 200.0).abs() > 60.0 && y > 120.0 && y < 195.0
    };
    let two_tone = black_and_white(&paint(&white, [skin_grey; 3], inner));
    let read = analyse(&two_tone, &lm).unwrap();
    for x in [125.0, 275.0] {
        assert_eq!(
            read.labels.at_pixel(x, 175.0),
            Label::Hair,
            "the grey hair beside the temple at x = {x} is not the hair's"
        );
    }
    // An ear's height beside the face keeps its skin.
    assert_ne!(read.labels.at_pixel(126.0, 240.0), Label::Hair);
}

/// Glasses: a dark frame's bridge across the nose between the eyes is found; the same
/// face without it is not taken for glasses, nor is a face in shadow all over.
#[test]
fn glasses_are_found_by_their_bridge() {
    let lm = landmarks();
    let bare = photo(hair_to(12.0, 0.0), BROWN, false);
    let mut glasses = bare.clone();
    let eye = |r: std::ops::Range<usize>| {
        let n = r.len() as f32;
        lm[r]
            .iter()
            .fold([0.0, 0.0], |a, p| [a[0] + p[0] / n, a[1] + p[1] / n])
    };
    let (l, r) = (eye(36..42), eye(42..48));
    // A 4-pixel bar from eye to eye, 2 pixels above their centres.
    for x in l[0] as u32..=r[0] as u32 {
        for dy in 0..4u32 {
            let y = (0.5 * (l[1] + r[1])) as u32 - 3 + dy;
            glasses.put_pixel(x, y, image::Rgb([25, 22, 20]));
        }
    }
    let bare_p = analyse(&bare, &lm).unwrap();
    let glasses_p = analyse(&glasses, &lm).unwrap();
    assert!(!bare_p.has_glasses(), "bare {:?}", bare_p.glasses);
    assert!(glasses_p.has_glasses(), "glasses {:?}", glasses_p.glasses);
    let mut dim = bare.clone();
    for p in dim.pixels_mut() {
        p.0 = p.0.map(|v| v / 3);
    }
    let dim_p = analyse(&dim, &lm).unwrap();
    assert!(!dim_p.has_glasses(), "dim {:?}", dim_p.glasses);
}

/// Paints `colour` where `on(x, y)` over a copy of `img`.
fn paint(img: &RgbImage, colour: [u8; 3], on: impl Fn(f32, f32) -> bool) -> RgbImage {
    let mut out = img.clone();
    for (x, y, p) in out.enumerate_pixels_mut() {
        if on(x as f32, y as f32) {
            p.0 = colour;
        }
    }
    out
}

/// Thin metal frames (a one-pixel line: rims round the eyes and a bridge over the nose at
/// the eyes' height, a grey barely darker than the skin) are glasses; two frown creases
/// between the brows, above the eyes, are not.
#[test]
fn thin_frames_are_glasses_and_a_frown_is_not() {
    let lm = landmarks();
    let bare = photo(hair_to(12.0, 0.0), BROWN, false);
    // Eyes at (170, 200) and (230, 200), 60 px apart; lenses 25 x 16 px half-axes.
    let rim = |x: f32, y: f32| {
        [170.0, 230.0].iter().any(|&cx| {
            let r = ((x - cx) / 25.0).powi(2) + ((y - 202.0) / 16.0).powi(2);
            (r.sqrt() - 1.0).abs() < 0.5 / 16.0
        })
    };
    let bridge = |x: f32, y: f32| (195.0..=205.0).contains(&x) && (y - 196.0).abs() < 0.5;
    let framed = paint(&bare, [150, 118, 100], |x, y| rim(x, y) || bridge(x, y));
    let frown = paint(&bare, [170, 130, 105], |x, y| {
        (190.0..=210.0).contains(&x) && ((y - 183.0).abs() < 0.5 || (y - 187.0).abs() < 0.5)
    });
    let read = |img: &RgbImage| analyse(img, &lm).unwrap().glasses;
    let (b, f, w) = (read(&bare), read(&framed), read(&frown));
    assert!(!b.found(), "bare {b:?}");
    assert!(
        f.found() && f.bridge > 1.3 * GLASSES_BRIDGE,
        "thin frames {f:?}"
    );
    assert!(!w.found(), "frown {w:?}");
}

/// Sunglasses: dark lenses over the eyes are glasses, whatever their bridge.
#[test]
fn sunglasses_are_found_by_their_dark_lenses() {
    let lm = landmarks();
    let bare = photo(hair_to(12.0, 0.0), BROWN, false);
    let shades = paint(&bare, [20, 20, 24], |x, y| {
        [170.0, 230.0]
            .iter()
            .any(|&cx| ((x - cx) / 25.0).powi(2) + ((y - 202.0) / 16.0).powi(2) < 1.0)
    });
    let g = analyse(&shades, &lm).unwrap().glasses;
    assert!(g.found() && g.lenses < DARK_LENSES, "{g:?}");
}

#[test]
fn bad_landmarks_are_named() {
    let img = photo(|_, _| false, BROWN, false);
    let mut lm = landmarks();
    assert_eq!(analyse(&img, &lm[..5]), Err(PersonError::Landmarks(5)));
    lm[30][1] = f32::NAN;
    assert_eq!(analyse(&img, &lm), Err(PersonError::NonFinite(30)));
    let tiny: Vec<[f32; 2]> = landmarks()
        .iter()
        .map(|p| [200.0 + 0.05 * (p[0] - 200.0), 200.0 + 0.05 * (p[1] - 200.0)])
        .collect();
    assert!(matches!(
        analyse(&img, &tiny),
        Err(PersonError::TooSmall(_))
    ));
    // A face at the photo's edge, mostly outside it: an answer, not a panic.
    let edge: Vec<[f32; 2]> = landmarks().iter().map(|p| [p[0] - 230.0, p[1]]).collect();
    assert!(analyse(&img, &edge).is_ok());
}

/// A shadow under the jaw (the chin lit at 55 % of the cheeks, as a light from above leaves
/// it) passes the darkness test for a beard; told how the light falls on the face
/// ([`analyse_shaded`]) it is skin, while a real beard in the same shadow is still a beard.
#[test]
fn a_shadowed_chin_is_not_a_beard_when_the_light_is_known() {
    let lm = landmarks();
    let shade = |y: f32| if y > 288.0 { 0.55 } else { 1.0 };
    let in_shadow = |img: RgbImage| {
        RgbImage::from_fn(img.width(), img.height(), |x, y| {
            let k = shade(y as f32);
            let p = img.get_pixel(x, y).0;
            image::Rgb(p.map(|v| (f32::from(v) * k).round() as u8))
        })
    };
    let light = |_x: f32, y: f32| 0.8 * shade(y);
    let shadowed = in_shadow(photo(hair_to(12.0, 0.0), BROWN, false));
    let plain = analyse(&shadowed, &lm).unwrap();
    let lit = analyse_shaded(&shadowed, &lm, None, Some(&light)).unwrap();
    assert!(
        plain.beard > lit.beard + 0.3,
        "the shadow reads as beard {:.2} without the light, {:.2} with it",
        plain.beard,
        lit.beard
    );
    assert!(!lit.has_beard(), "beard {:.2}", lit.beard);
    let bearded = in_shadow(photo(hair_to(12.0, 0.0), BROWN, true));
    let still = analyse_shaded(&bearded, &lm, None, Some(&light)).unwrap();
    assert!(still.has_beard(), "beard {:.2}", still.beard);
    // A light that knows nothing (NaN everywhere) changes nothing.
    let unknown = |_x: f32, _y: f32| f32::NAN;
    let same = analyse_shaded(&shadowed, &lm, None, Some(&unknown)).unwrap();
    assert_eq!(same.beard, plain.beard);
}

/// A suit the colour of the hair, joined to short hair by a dark collar round the neck (as on
/// a tight crop: a suit, a shadowed neck): the colours alone label it hair down to the frame's
/// edge; without hair hanging beside the cheeks (no curtain) the hair still ends about the
/// ears. The same suit under a curtain of long hair stays long.
#[test]
fn hair_without_a_curtain_beside_the_cheeks_does_not_fall_past_the_jaw() {
    let suit = |x: f32, y: f32| {
        let dx = (x - 200.0).abs();
        // The jacket, and the collar joining it to the hair behind the neck.
        y > 400.0 || (y > 330.0 && dx < 110.0) || (y > 215.0 && dx > 72.0 && dx < 80.0)
    };
    let dressed = |hair: &dyn Fn(f32, f32) -> bool| dressed(hair, BROWN, &suit, BROWN);
    let lm = landmarks();
    let short = analyse(&dressed(&hair_to(12.0, 0.0)), &lm).unwrap();
    let h = short.hair.expect("short hair found");
    assert!(h.curtain < CURTAIN, "{h:?}");
    assert!(
        h.length <= 0.6 + 1e-6,
        "the short hair ends about the ears: {h:?}"
    );
    let long = analyse(&dressed(&hair_to(12.0, 470.0)), &lm).unwrap();
    let l = long.hair.expect("long hair found");
    assert!(l.curtain >= CURTAIN, "{l:?}");
    assert!(l.length > 1.6, "long hair over the suit: {l:?}");
}

/// A dark ground the colour of the hair beside the jaw (a tight crop against a dark curtain
/// or a suit's shoulders) hangs where a curtain of hair would; a bare ear beside the face
/// says the hair on that side is short. Hair falling over the ears stays long.
#[test]
fn a_bare_ear_is_short_hair_whatever_hangs_below_it() {
    let ear =
        |x: f32, y: f32| ((x.abs() - 75.0) / 7.0).powi(2) + ((y - 225.0) / 20.0).powi(2) < 1.0;
    // Joined to the hair's sides above the ear, as a dark ground is.
    let ground = |x: f32, y: f32| (x - 200.0).abs() > 72.0 && y > 190.0;
    let lm = landmarks();
    let with_ears = |hair: &dyn Fn(f32, f32) -> bool| {
        let base = dressed(hair, BROWN, &ground, BROWN);
        paint(&base, SKIN, |x, y| !hair(x, y) && ear(x - 200.0, y))
    };
    let short = analyse(&with_ears(&hair_to(12.0, 0.0)), &lm).unwrap();
    let h = short.hair.expect("short hair found");
    assert!(
        h.length <= 0.6 + 1e-6,
        "ears bare, the hair is short: {h:?}"
    );
    let long = analyse(&with_ears(&hair_to(12.0, 470.0)), &lm).unwrap();
    let l = long.hair.expect("long hair found");
    assert!(
        l.length > 1.6,
        "hair over the ears falls past the jaw: {l:?}"
    );
}

/// A receding hairline (the forehead's skin reaching high, hair over the top of the head
/// only) is a head of hair, not a bald one; a bald scalp is bald.
#[test]
fn a_receding_hairline_is_not_bald() {
    let lm = landmarks();
    let full = hair_to(14.0, 0.0);
    // Skin up to 40 px above the usual hairline over the forehead's middle.
    let receding = move |x: f32, y: f32| full(x, y) && !((x - 200.0).abs() < 45.0 && y > 100.0);
    let p = analyse(&photo(receding, BROWN, false), &lm).unwrap();
    let h = p.hair.expect("a receding hairline is hair");
    assert!(h.crown > 0.5, "{h:?}");
    let bald = analyse(&photo(|_, _| false, BROWN, false), &lm).unwrap();
    assert!(bald.hair.is_none(), "{:?}", bald.hair);
}

/// The frontal gem's hair outline is measured against the photo's (issue #38): a short-haired
/// head's own reading matches its photo better than long hair or a big volume would, the
/// photo's own silhouette better than the template's outline sized to it, and hair carved on a
/// bald head overlaps next to nothing.
#[test]
fn the_frontal_hair_outline_is_measured_against_the_photo() {
    use crate::gem::{HairStyle, hair_style, measure::frontal_hair_iou};
    let lm = landmarks();
    let short = analyse(&photo(hair_to(12.0, 0.0), BROWN, false), &lm).unwrap();
    let style = hair_style(&short);
    let own = frontal_hair_iou(&short.labels, &style, None).expect("hair on both");
    let sized = HairStyle {
        silhouette: None,
        ..style
    };
    let long = HairStyle {
        end: -220.0,
        ..sized
    };
    let big = HairStyle {
        outline: None,
        volume: 32.0,
        ..sized
    };
    let worse = |style: &HairStyle| frontal_hair_iou(&short.labels, style, None).unwrap_or(0.0);
    assert!(own > 0.6, "own {own:.2}");
    for (what, other) in [("sized", &sized), ("long", &long), ("big", &big)] {
        assert!(
            own > worse(other) + 0.05,
            "own {own:.2}, {what} {:.2}",
            worse(other)
        );
    }
    let bald = analyse(&photo(|_, _| false, BROWN, false), &lm).unwrap();
    let carved = frontal_hair_iou(&bald.labels, &HairStyle::default(), None).unwrap_or(0.0);
    assert!(carved < 0.1, "hair carved on a bald head: {carved:.2}");
}

/// [`photo`] with its hair's brightness varied by `texture(x, y)` (a factor about 1).
fn textured(hair: impl Fn(f32, f32) -> bool, texture: impl Fn(f32, f32) -> f32) -> RgbImage {
    let mut img = photo(&hair, BROWN, false);
    for (x, y, px) in img.enumerate_pixels_mut() {
        if hair(x as f32, y as f32) {
            let k = texture(x as f32, y as f32);
            px.0 = px.0.map(|v| (f32::from(v) * k).clamp(0.0, 255.0) as u8);
        }
    }
    img
}

/// Strands running down the head: light and dark lines 5 px apart (eyes 60 px apart).
fn strands(x: f32, _y: f32) -> f32 {
    1.0 + 0.45 * (std::f32::consts::TAU * x / 5.0).sin()
}

/// Curls: in each 9 px cell of a staggered grid, rings round its centre.
fn curls(x: f32, y: f32) -> f32 {
    let row = (y / 9.0).floor();
    let shift = if row as i32 % 2 == 0 { 0.0 } else { 4.5 };
    let (cx, cy) = (
        ((x - shift) / 9.0).floor() * 9.0 + 4.5 + shift,
        row * 9.0 + 4.5,
    );
    let r = (x - cx).hypot(y - cy);
    1.0 + 0.45 * (std::f32::consts::TAU * r / 4.5).cos()
}

/// The hair's kind (issue #38): strands side by side are straight and carved in locks, curls
/// standing out are curly and carved as snail curls, curls clipped to a thin layer are a crop
/// carved stippled and close; a bald head is bald.
#[test]
fn the_hairs_kind_is_read_from_its_texture() {
    use crate::gem::{HairCarving, hair_style};
    let lm = landmarks();
    let read = |img: &RgbImage| analyse(img, &lm).unwrap();
    let straight = read(&textured(hair_to(14.0, 0.0), strands));
    let curly = read(&textured(hair_to(16.0, 0.0), curls));
    let cropped = read(&textured(hair_to(0.0, 0.0), curls));
    let bald = read(&photo(|_, _| false, BROWN, false));
    let coherence = |p: &Person| p.hair.map_or(f32::NAN, |h| h.texture.coherence);
    assert!(
        coherence(&straight) > 0.8 && coherence(&curly) < TEXTURED,
        "straight {:.2}, curly {:.2}",
        coherence(&straight),
        coherence(&curly)
    );
    assert!(curly.hair.unwrap().curl > straight.hair.unwrap().curl + 0.5);
    let kinds = [&straight, &curly, &cropped, &bald].map(|p| p.hair_kind());
    assert_eq!(
        kinds,
        [
            HairKind::Straight,
            HairKind::Curly,
            HairKind::Cropped,
            HairKind::Bald
        ],
        "{:?}",
        [&straight, &curly, &cropped].map(|p| p.hair.map(|h| (h.top, h.sides, h.texture)))
    );
    let carving = [&straight, &curly, &cropped].map(|p| hair_style(p).carving);
    assert_eq!(
        carving,
        [
            HairCarving::Locks,
            HairCarving::Curls,
            HairCarving::Stippled
        ]
    );
    assert!(hair_style(&cropped).volume <= 4.0);
}

/// A hat is not hair (issue #38): a red hat with a brim over short brown hair is found, its
/// pixels labelled `Hat`, and the hair is still the person's own (short, not bald); grey
/// temples under dark hair (a difference of lightness, not of colour) are no hat.
#[test]
fn a_hat_is_left_out_of_the_hair() {
    let lm = landmarks();
    let hat = |x: f32, y: f32| {
        let crown = ((x - 200.0) / 80.0).powi(2) + ((y - 120.0) / 75.0).powi(2) < 1.0 && y < 128.0;
        crown || (x - 200.0).abs() < 118.0 && (118.0..134.0).contains(&y)
    };
    let hatted = paint(&photo(hair_to(8.0, 0.0), BROWN, false), [150, 40, 45], hat);
    let p = analyse(&hatted, &lm).unwrap();
    assert!(p.has_hat(), "hat measure {:.1}", p.hat);
    assert!(p.labels.labels.contains(&Label::Hat));
    assert_eq!(p.labels.at_pixel(200.0, 100.0), Label::Hat);
    assert_eq!(p.hair_length(), HairLength::Short, "{:?}", p.hair);
    // Grey temples, dark hair above.
    let grey = paint(
        &photo(hair_to(10.0, 0.0), BROWN, false),
        [150, 150, 148],
        |x, y| hair_to(10.0, 0.0)(x, y) && y > 135.0,
    );
    let p = analyse(&grey, &lm).unwrap();
    // Compared (both sides read), and apart in lightness only.
    assert!(p.hat > 0.0 && !p.has_hat(), "hat measure {:.1}", p.hat);
    assert!(!p.labels.labels.contains(&Label::Hat));
}

/// Stubble (dark points a pixel wide, three pixels apart, on the chin and the upper lip) is
/// too sparse for the colour's share but found by its texture; and carved stippled. A
/// shaven face with the same noise everywhere is not.
#[test]
fn stubble_is_found_by_its_texture() {
    let lm = landmarks();
    let shaven_photo = photo(hair_to(12.0, 0.0), BROWN, false);
    let shaven = analyse(&shaven_photo, &lm).unwrap();
    assert!(
        !shaven.has_beard() && !shaven.has_moustache(),
        "{:?} beard {:.2} moustache {:.2}",
        shaven.stubble,
        shaven.beard,
        shaven.moustache
    );
    let dots = |x: f32, y: f32| x as i32 % 3 == 0 && y as i32 % 3 == 0;
    let chin = |x: f32, y: f32| {
        ((x - 200.0) / 72.0).powi(2) + ((y - 205.0) / 125.0).powi(2) < 1.0
            && y > 284.0
            && (x - 200.0).abs() < 55.0
    };
    let lip = |x: f32, y: f32| (252.0..266.0).contains(&y) && (x - 200.0).abs() < 26.0;
    let stubbled_photo = paint(&shaven_photo, [120, 92, 78], |x, y| {
        dots(x, y) && (chin(x, y) || lip(x, y))
    });
    let stubbled = analyse(&stubbled_photo, &lm).unwrap();
    assert!(
        stubbled.beard <= BEARD_SHARE && stubbled.stubble_only(),
        "{:?} beard {:.2}",
        stubbled.stubble,
        stubbled.beard
    );
    assert!(stubbled.has_beard() && stubbled.has_moustache());
    let style = crate::gem::hair_style(&stubbled);
    assert!(
        style.beard > 0.0 && style.beard <= crate::gem::template::STUBBLE_MM,
        "{style:?}"
    );
}
