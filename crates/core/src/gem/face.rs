//! The fitted face in the portrait's frame: where it goes (a scale and shift fitted on the
//! face's own brow, chin, forehead, tragus and jaw, so the sculpted head follows the person's
//! proportions), its height field (the face leads: inside its footprint it *is* the surface),
//! and its eyes carved as a cameo cutter would.
//!
//! Units: the face mesh comes in model millimetres (`[x0, y0, z0, ...]`, y up, face along +z);
//! the canonical frame of [`super::template`] is the Surrey mean face's, also millimetres.
//! Faces with the Surrey Face Model's 3448-vertex topology are placed by their landmark
//! vertices; any other mesh by its bounding box. Pure computation.

use super::template::{FRONTAL_BACK_MM, View};

/// Vertices of the Surrey Face Model (3448-vertex topology) used as anchors, 0-based: the
/// model's `ibug_to_sfm.txt` mapping (nasion = iBUG 28: 2842, chin = iBUG 9: 33, nose tip =
/// iBUG 31: 114) and outline vertices of the mean mesh (forehead top on the mid-line: 441;
/// tragus level, left and right: 780, 363; jaw angle, left and right: 802/805, 391).
pub const SFM_VERTICES: usize = 3448;
const PROFILE_ANCHORS: [usize; 6] = [2842, 33, 441, 780, 802, 114];
const FRONTAL_ANCHORS: [usize; 8] = [2842, 33, 441, 780, 363, 805, 391, 114];
/// The mean face's anchor positions, (x, y, z) model mm, in the order of the lists above.
const MEAN_ANCHORS: [(usize, [f32; 3]); 9] = [
    (2842, [0.1, 40.7, -17.4]),
    (33, [0.4, -79.4, -33.2]),
    (441, [-0.6, 99.5, -24.2]),
    (780, [70.9, -6.8, -103.0]),
    (802, [64.2, -29.3, -98.0]),
    (114, [-0.3, -2.0, 3.3]),
    (363, [-71.1, -7.1, -103.2]),
    (805, [60.3, -39.6, -93.6]),
    (391, [-60.7, -40.2, -93.6]),
];
/// The mean face's bounding box (model mm), for meshes of another topology.
const MEAN_BOX: ([f32; 3], [f32; 3]) = ([-74.5, -82.6, -103.6], [74.1, 105.3, 3.4]);
/// Eye landmarks (iBUG 37-42 and 43-48: corners first, then upper lid, then lower lid).
const RIGHT_EYE: [usize; 6] = [177, 181, 172, 191, 173, 174];
const LEFT_EYE: [usize; 6] = [614, 610, 624, 605, 607, 606];
/// Largest stretch of the head along one axis against the mean head (keeps real proportions
/// when the fit is poor).
const AXIS_SCALE_SPREAD: f32 = 0.12;

/// Where a face goes in the canonical frame: model point m = shift + scale * canonical point
/// (per plane axis), and model height = `depth_scale` x canonical height + `depth_shift`.
/// The face keeps its own proportions (one scale for both axes); the head follows them
/// instead: the template is stretched by `head_stretch` about `head_pivot` (canonical), so a
/// face deeper or longer than the mean's gets a longer or taller head.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    pub scale: [f32; 2],
    pub shift: [f32; 2],
    pub head_stretch: [f32; 2],
    pub head_pivot: [f32; 2],
    pub depth_scale: f32,
    pub depth_shift: f32,
    /// The face's breadth (profile: its half-width; frontal: its depth) over the mean face's,
    /// beyond what `depth_scale` explains: the sculpted head's heights follow it (a broad
    /// face has a broad skull), within [`BREADTH_RANGE`].
    pub breadth: f32,
}

/// How far the head's breadth may follow the face's.
pub const BREADTH_RANGE: (f32, f32) = (0.85, 1.15);
/// The mean face's half-width (largest x) and depth (nose tip to the back of its outline),
/// model mm.
const MEAN_HALF_WIDTH: f32 = 74.07;
const MEAN_DEPTH: f32 = 106.95;

/// The face's breadth for [`Placement::breadth`], before dividing by the scale.
fn extent(positions: &[f32], view: View) -> Option<f32> {
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for v in positions.chunks_exact(3) {
        if v.iter().all(|c| c.is_finite()) {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
    }
    let e = match view {
        View::Profile => hi[0] / MEAN_HALF_WIDTH,
        View::Frontal => (hi[2] - lo[2]) / MEAN_DEPTH,
    };
    (e.is_finite() && e > 0.0).then_some(e)
}

fn with_breadth(mut p: Placement, positions: &[f32], view: View) -> Placement {
    p.breadth = extent(positions, view).map_or(1.0, |e| {
        (e / p.depth_scale).clamp(BREADTH_RANGE.0, BREADTH_RANGE.1)
    });
    p
}

impl Placement {
    /// The identity: the mean face's own frame.
    pub const IDENTITY: Placement = Placement {
        scale: [1.0, 1.0],
        shift: [0.0, 0.0],
        head_stretch: [1.0, 1.0],
        head_pivot: [0.0, 0.0],
        depth_scale: 1.0,
        depth_shift: 0.0,
        breadth: 1.0,
    };

    /// Canonical plane point and height of model point `p` seen in `view`.
    pub fn to_canonical(&self, view: View, p: [f32; 3]) -> [f32; 3] {
        let (u, v, h) = plane(view, p);
        [
            (u - self.shift[0]) / self.scale[0],
            (v - self.shift[1]) / self.scale[1],
            (h - self.depth_shift) / self.depth_scale,
        ]
    }
}

/// Model point -> (u, v, height) in `view`'s plane, before placement.
fn plane(view: View, p: [f32; 3]) -> (f32, f32, f32) {
    match view {
        View::Profile => (-p[2], p[1], p[0]),
        View::Frontal => (p[0], p[1], p[2] + FRONTAL_BACK_MM),
    }
}

fn vertex(positions: &[f32], i: usize) -> Option<[f32; 3]> {
    let v = positions.get(3 * i..3 * i + 3)?;
    let p = [v[0], v[1], v[2]];
    p.iter().all(|c| c.is_finite()).then_some(p)
}

/// Fits the placement of a face: by its anchor vertices for a Surrey mesh (least squares of a
/// scale per axis and a shift, the axes' scales kept within [`AXIS_SCALE_SPREAD`] of each
/// other), else by its bounding box. Heights scale with the mean of the two plane scales; the
/// frontal view also shifts them so the nose tip keeps its height.
pub fn place(positions: &[f32], view: View) -> Placement {
    let anchors: &[usize] = match view {
        View::Profile => &PROFILE_ANCHORS,
        View::Frontal => &FRONTAL_ANCHORS,
    };
    let pairs: Option<Vec<([f32; 3], [f32; 3])>> = (positions.len() == 3 * SFM_VERTICES)
        .then(|| {
            anchors
                .iter()
                .map(|&id| {
                    let mean = MEAN_ANCHORS.iter().find(|(i, _)| *i == id)?.1;
                    Some((vertex(positions, id)?, mean))
                })
                .collect()
        })
        .flatten();
    let Some(pairs) = pairs else {
        return with_breadth(place_by_box(positions, view), positions, view);
    };
    let pts: Vec<([f32; 3], [f32; 3])> = pairs
        .iter()
        .map(|(m, c)| {
            let (mu, mv, mh) = plane(view, *m);
            let (cu, cv, ch) = plane(view, *c);
            ([mu, mv, mh], [cu, cv, ch])
        })
        .collect();
    let n = pts.len() as f32;
    // Means of the model (side 0) and canonical (side 1) coordinate `axis`.
    let mean = |side: usize, axis: usize| {
        pts.iter()
            .map(|p| if side == 0 { p.0[axis] } else { p.1[axis] })
            .sum::<f32>()
            / n
    };
    let (mu, mv) = (mean(0, 0), mean(0, 1));
    let (cu, cv) = (mean(1, 0), mean(1, 1));
    let fit = |m0: f32, c0: f32, axis: usize| {
        let num: f32 = pts
            .iter()
            .map(|p| (p.0[axis] - m0) * (p.1[axis] - c0))
            .sum();
        let den: f32 = pts.iter().map(|p| (p.1[axis] - c0).powi(2)).sum();
        num / den.max(1e-6)
    };
    let (su, sv) = (fit(mu, cu, 0), fit(mv, cv, 1));
    let s = 0.5 * (su + sv);
    if !(s.is_finite() && s > 0.05) {
        return with_breadth(place_by_box(positions, view), positions, view);
    }
    let clamp = |a: f32| (a / s).clamp(1.0 - AXIS_SCALE_SPREAD, 1.0 + AXIS_SCALE_SPREAD);
    let scale = [s, s];
    let shift = [mu - s * cu, mv - s * cv];
    let depth_shift = match view {
        View::Profile => 0.0,
        // The nose tip (last anchor) keeps the mean's height.
        View::Frontal => {
            let (m, c) = pts[pts.len() - 1];
            m[2] - s * c[2]
        }
    };
    with_breadth(
        Placement {
            scale,
            shift,
            head_stretch: [clamp(su), clamp(sv)],
            head_pivot: [cu, cv],
            depth_scale: s,
            depth_shift,
            breadth: 1.0,
        },
        positions,
        view,
    )
}

fn place_by_box(positions: &[f32], view: View) -> Placement {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for v in positions.chunks_exact(3) {
        if v.iter().all(|c| c.is_finite()) {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
    }
    if !(lo[1].is_finite() && hi[1] > lo[1]) {
        return Placement::IDENTITY;
    }
    let s = (hi[1] - lo[1]) / (MEAN_BOX.1[1] - MEAN_BOX.0[1]);
    let centre = |b: ([f32; 3], [f32; 3])| {
        plane(
            view,
            [0.5 * (b.0[0] + b.1[0]), 0.5 * (b.0[1] + b.1[1]), b.1[2]],
        )
    };
    let (mu, mv, mh) = centre((lo, hi));
    let (cu, cv, ch) = centre(MEAN_BOX);
    let (su, sv) = (s, s);
    let (u_shift, depth_shift) = match view {
        // The nose (front of the box) lines up in profile.
        View::Profile => (mu - su * cu, 0.0),
        View::Frontal => (mu - su * cu, mh - s * ch),
    };
    Placement {
        scale: [su, sv],
        shift: [u_shift, mv - sv * cv],
        head_stretch: [1.0, 1.0],
        head_pivot: [cu, cv],
        depth_scale: s,
        depth_shift,
        breadth: 1.0,
    }
}

/// Surrey vertices (0-based) that bound facial hair, from `ibug_to_sfm.txt`: mouth corners
/// (iBUG 49 right, 55 left), the nose's base (34), the upper lip's top (52), the lower lip's
/// bottom (58), the chin (9); and the tragus (outline vertices 363 right, 780 left).
const MOUTH_CORNERS: [usize; 2] = [398, 812];
const SUBNASALE: usize = 270;
const UPPER_LIP_TOP: usize = 329;
const LOWER_LIP_BOTTOM: usize = 411;
const TRAGI: [usize; 2] = [363, 780];

/// A face with its facial hair: each vertex moved out along its normal by the hair's
/// thickness there, and that thickness per vertex (model mm), for the carving of its locks.
#[derive(Clone, Debug, PartialEq)]
pub struct FacialHair {
    pub positions: Vec<f32>,
    pub thickness: Vec<f32>,
}

/// Where a beard and a moustache grow on a Surrey face and how thick they stand, from the
/// face's own mouth, lips, nose and ears (model mm; the face as fitted, pose removed, so its
/// axes are the model's: x to the face's left, y up, z forward). The beard covers the chin
/// below the lower lip and, by `style.beard_jaw`, the jaw and cheeks up to a line from above
/// the mouth's corners to the sideburns; the moustache the upper lip between the nose and the
/// lip. Edges fade over about 5 mm, as a carver rounds them. `None` for other meshes or when
/// there is no facial hair.
pub fn facial_hair(
    positions: &[f32],
    triangles: &[[u32; 3]],
    style: &super::HairStyle,
) -> Option<FacialHair> {
    let beard = style.beard.max(0.0);
    let moustache = style.moustache.max(0.0);
    if positions.len() != 3 * SFM_VERTICES || beard + moustache <= 0.0 {
        return None;
    }
    let [right, left] = MOUTH_CORNERS.map(|i| vertex(positions, i));
    let [tragus_r, tragus_l] = TRAGI.map(|i| vertex(positions, i));
    let (right, left, tragus_r, tragus_l) = (right?, left?, tragus_r?, tragus_l?);
    let nose = vertex(positions, SUBNASALE)?;
    let lip_top = vertex(positions, UPPER_LIP_TOP)?[1];
    let lip_bottom = vertex(positions, LOWER_LIP_BOTTOM)?[1];
    let jaw = style.beard_jaw.clamp(0.0, 1.0);
    let smooth = super::template::smoothstep;
    let weights = |p: [f32; 3]| -> (f32, f32) {
        let (corner, tragus) = if p[0] < 0.0 {
            (right, tragus_r)
        } else {
            (left, tragus_l)
        };
        let (ax, cx, tx) = (p[0].abs(), corner[0].abs(), tragus[0].abs());
        // Below the lower lip, across the chin (a goatee reaches a little past the corners).
        let chin = (1.0 - smooth(lip_bottom - 7.0, lip_bottom - 2.0, p[1]))
            * (1.0 - smooth(cx + 2.0, cx + 12.0, ax));
        // A full beard: below the line from above the mouth's corner to the sideburn, in
        // front of the ear.
        let t = ((ax - cx) / (tx - cx).max(1.0)).clamp(0.0, 1.0);
        let top = corner[1] + 8.0 + t * (tragus[1] + 2.0 - corner[1] - 8.0);
        let cheeks = (1.0 - smooth(top - 6.0, top, p[1]))
            * smooth(cx - 4.0, cx + 4.0, ax)
            * (1.0 - smooth(tragus[2] + 4.0, tragus[2] - 4.0, p[2]).min(smooth(tx - 6.0, tx, ax)));
        let b = chin.max(jaw * cheeks);
        // The upper lip: between the lip and the nose's base, out to the corners.
        let m = smooth(lip_top - 2.0, lip_top + 1.0, p[1])
            * (1.0 - smooth(nose[1] - 5.0, nose[1] - 1.0, p[1]))
            * (1.0 - smooth(cx, cx + 5.0, ax));
        (b, m)
    };
    let normals = vertex_normals(positions, triangles);
    let mut out = positions.to_vec();
    let mut thickness = vec![0f32; SFM_VERTICES];
    for v in 0..SFM_VERTICES {
        let Some(p) = vertex(positions, v) else {
            continue;
        };
        let (b, m) = weights(p);
        let t = (beard * b).max(moustache * m);
        if t > 0.0 {
            thickness[v] = t;
            for k in 0..3 {
                out[3 * v + k] += t * normals[v][k];
            }
        }
    }
    Some(FacialHair {
        positions: out,
        thickness,
    })
}

pub use crate::raster::vertex_normals;

/// An eye as the cutter shapes it, in the canonical plane: an almond from `front` to `back`
/// (u), centred at height `centre` (v), opening `upper` above and `lower` below, with `mirror`
/// set when it runs towards decreasing u.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Eye {
    pub front: f32,
    pub back: f32,
    pub centre: f32,
    pub upper: f32,
    pub lower: f32,
}

/// The eyes of a Surrey face in `view` (canonical frame): in profile the near eye (iBUG 43-48)
/// seen from the side, drawn longer than its true foreshortening as carvers do; frontal both.
pub fn eyes(positions: &[f32], view: View, placement: &Placement) -> Vec<Eye> {
    if positions.len() != 3 * SFM_VERTICES {
        return Vec::new();
    }
    let lists: &[[usize; 6]] = match view {
        View::Profile => &[LEFT_EYE],
        View::Frontal => &[RIGHT_EYE, LEFT_EYE],
    };
    let mut out = Vec::new();
    for ids in lists {
        let pts: Option<Vec<[f32; 3]>> = ids
            .iter()
            .map(|&i| vertex(positions, i).map(|p| placement.to_canonical(view, p)))
            .collect();
        let Some(pts) = pts else { continue };
        let (lo_u, hi_u) = pts
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), p| {
                (a.min(p[0]), b.max(p[0]))
            });
        let centre = pts.iter().map(|p| p[1]).sum::<f32>() / pts.len() as f32;
        let eye = match view {
            View::Profile => Eye {
                front: lo_u - 5.0,
                back: hi_u + 5.0,
                centre: centre + 0.5,
                upper: 6.0,
                lower: 4.5,
            },
            View::Frontal => {
                let upper = (0.5 * (pts[2][1] + pts[3][1]) - centre).max(2.0);
                let lower = (centre - 0.5 * (pts[4][1] + pts[5][1])).max(1.5);
                // The almond runs from the inner corner (nearest the mid-line) outwards.
                let (inner, outer) = if pts[0][0].abs() < pts[1][0].abs() {
                    (pts[0][0], pts[1][0])
                } else {
                    (pts[1][0], pts[0][0])
                };
                Eye {
                    front: inner,
                    back: outer,
                    centre,
                    upper: upper * 1.3,
                    lower: lower * 1.3,
                }
            }
        };
        out.push(eye);
    }
    out
}

/// Glasses as a carver cuts them, canonical mm added to the face at (u, v): in profile the
/// frame's front seen edge-on before the eye and the temple running back towards the ear;
/// frontal, a rim round each eye, the bridge between them and the temples out to the face's
/// sides. Rounded ridges about 2 mm high and 3 mm wide.
pub fn glasses(eyes: &[Eye], view: View, u: f32, v: f32) -> f32 {
    let ridge = |d: f32, half: f32, height: f32| {
        let t = d / half;
        if t.abs() < 1.0 {
            height * (1.0 - t * t)
        } else {
            0.0
        }
    };
    let mut h = 0f32;
    match view {
        View::Profile => {
            for e in eyes {
                let front = e.front.min(e.back) - 4.0;
                let back = e.front.max(e.back);
                if (e.centre - 13.0..e.centre + 11.0).contains(&v) {
                    h = h.max(ridge(u - front, 1.6, 2.2));
                }
                if u > front && u < back + 45.0 {
                    h = h.max(ridge(v - (e.centre + 5.0), 1.5, 1.8));
                }
            }
        }
        View::Frontal => {
            let rims: Vec<(f32, f32, f32, f32, f32)> = eyes
                .iter()
                .map(|e| {
                    let a = 0.5 * (e.back - e.front).abs() + 7.0;
                    (
                        0.5 * (e.front + e.back),
                        e.centre,
                        a,
                        0.75 * a + 2.0,
                        e.front,
                    )
                })
                .collect();
            for &(uc, vc, a, b, inner) in &rims {
                let r = ((u - uc) / a).hypot((v - vc) / b);
                h = h.max(ridge((r - 1.0) * a.min(b), 1.5, 2.0));
                // The temple, from the rim's outer side outwards.
                let out = (uc - inner).signum();
                let x = (u - (uc + out * a)) * out;
                if (0.0..25.0).contains(&x) {
                    h = h.max(ridge(v - (vc + 3.0), 1.3, 1.8));
                }
            }
            if let [l, r] = rims[..] {
                // The bridge between the rims' inner sides.
                let (lo, hi) = if l.0 < r.0 {
                    (l.0 + l.2, r.0 - r.2)
                } else {
                    (r.0 + r.2, l.0 - l.2)
                };
                if u > lo - 1.0 && u < hi + 1.0 {
                    h = h.max(ridge(v - (0.5 * (l.1 + r.1) + 2.0), 1.2, 1.8));
                }
            }
        }
    }
    h
}

impl Eye {
    /// Height added to the face at canonical point (u, v), canonical mm: the eyeball set back
    /// under thick lids, a rolled upper lid with the crease above it, a thinner lower lid.
    pub fn carve(&self, u: f32, v: f32) -> f32 {
        use super::template::smoothstep;
        let len = self.back - self.front;
        if len.abs() < 1e-3 {
            return 0.0;
        }
        let x = (u - self.front) / len; // 0 at the front corner, 1 at the back
        if !(-0.2..=1.2).contains(&x) || (v - self.centre).abs() > 3.0 * self.upper.max(self.lower)
        {
            return 0.0;
        }
        let xc = x.clamp(0.0, 1.0);
        let envelope = (std::f32::consts::PI * xc.powf(0.8)).sin();
        let up = self.centre + self.upper * envelope;
        let lo = self.centre - self.lower * envelope;
        let along = smoothstep(-0.05, 0.1, x) * smoothstep(1.1, 0.9, x);
        let mut h = 0.0;
        if x > 0.0 && x < 1.0 && v < up && v > lo {
            let span = self.upper + self.lower;
            let bu = (u - (self.front + 0.35 * len)) / (0.55 * len);
            let bv = (v - self.centre) / (0.7 * span);
            let ball = 2.5 * (1.0 - bu * bu - bv * bv).max(0.0).sqrt();
            h += ball - 2.0;
        }
        h += 3.0 * (-((v - up) / 2.2).powi(2)).exp() * along;
        h += 1.8 * (-((v - lo) / 1.6).powi(2)).exp() * along;
        h -= 1.2
            * (-((v - up - 5.0) / 1.5).powi(2)).exp()
            * smoothstep(0.1, 0.3, x)
            * smoothstep(1.0, 0.8, x);
        h
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mean_like() -> Vec<f32> {
        let mut p = vec![0f32; 3 * SFM_VERTICES];
        for (id, xyz) in MEAN_ANCHORS {
            p[3 * id..3 * id + 3].copy_from_slice(&xyz);
        }
        p
    }

    #[test]
    fn the_mean_face_is_placed_where_it_is() {
        for view in [View::Profile, View::Frontal] {
            let pl = place(&mean_like(), view);
            assert!(
                (pl.scale[0] - 1.0).abs() < 1e-3 && (pl.scale[1] - 1.0).abs() < 1e-3,
                "{pl:?}"
            );
            assert!(pl.shift[0].abs() < 0.1 && pl.shift[1].abs() < 0.1, "{pl:?}");
            assert!(pl.depth_shift.abs() < 0.1);
        }
    }

    #[test]
    fn a_larger_shifted_face_is_found() {
        let p: Vec<f32> = mean_like()
            .chunks_exact(3)
            .flat_map(|v| [1.1 * v[0], 1.1 * v[1] + 5.0, 1.1 * v[2] - 3.0])
            .collect();
        let pl = place(&p, View::Profile);
        assert!(
            (pl.scale[0] - 1.1).abs() < 1e-3 && (pl.scale[1] - 1.1).abs() < 1e-3,
            "{pl:?}"
        );
        assert!((pl.head_stretch[0] - 1.0).abs() < 1e-3 && (pl.head_stretch[1] - 1.0).abs() < 1e-3);
        // u = -z: a z shift of -3 is a u shift of +3.
        assert!(
            (pl.shift[0] - 3.0).abs() < 0.05 && (pl.shift[1] - 5.0).abs() < 0.05,
            "{pl:?}"
        );
        assert!((pl.depth_scale - 1.1).abs() < 1e-3);
        let c = pl.to_canonical(
            View::Profile,
            [1.1 * 70.9, 1.1 * -6.8 + 5.0, 1.1 * -103.0 - 3.0],
        );
        assert!(
            (c[0] - 103.0).abs() < 0.05 && (c[1] + 6.8).abs() < 0.05 && (c[2] - 70.9).abs() < 0.05
        );
    }

    /// A face 8 % deeper (front to back) than the mean keeps its proportions and gets a head
    /// 8 % longer; beyond the spread the head stops following.
    #[test]
    fn the_head_follows_the_face_proportions() {
        let p: Vec<f32> = mean_like()
            .chunks_exact(3)
            .flat_map(|v| [v[0], v[1], v[2] * 1.08])
            .collect();
        let pl = place(&p, View::Profile);
        let ratio = pl.head_stretch[0] / pl.head_stretch[1];
        assert!((ratio - 1.08).abs() < 0.03, "{pl:?}");
        assert_eq!(pl.scale[0], pl.scale[1]);
        let p: Vec<f32> = mean_like()
            .chunks_exact(3)
            .flat_map(|v| [v[0], v[1], v[2] * 1.6])
            .collect();
        let pl = place(&p, View::Profile);
        let spread = [1.0 + AXIS_SCALE_SPREAD, 1.0 - AXIS_SCALE_SPREAD];
        assert!(
            (0..2).all(|k| (pl.head_stretch[k] - spread[k]).abs() < 1e-4),
            "{pl:?}"
        );
    }

    #[test]
    fn other_meshes_and_broken_anchors_fall_back_to_the_box() {
        // A NaN anchor: the box of the finite vertices decides.
        let mut p = mean_like();
        p[3 * 33] = f32::NAN;
        let pl = place(&p, View::Profile);
        assert!(pl.scale[0].is_finite() && pl.scale[0] > 0.0);
        let tiny = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
        let pl = place(&tiny, View::Frontal);
        assert!(pl.scale.iter().all(|s| s.is_finite() && *s > 0.0), "{pl:?}");
        assert_eq!(place(&[], View::Profile), Placement::IDENTITY);
    }

    #[test]
    fn eyes_have_lids_above_a_recessed_ball() {
        let eye = Eye {
            front: 0.0,
            back: 14.0,
            centre: 0.0,
            upper: 6.0,
            lower: 4.5,
        };
        let lid = eye.carve(
            6.0,
            6.0 * (std::f32::consts::PI * (6.0f32 / 14.0).powf(0.8)).sin(),
        );
        let ball = eye.carve(6.0, 0.0);
        assert!(lid > ball + 1.0, "lid {lid} ball {ball}");
        assert_eq!(eye.carve(40.0, 0.0), 0.0);
    }
}
