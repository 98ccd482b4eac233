//! The sculpted head and bust that the fitted face is set into: cranium, ear, hair carved as
//! locks, neck with its sternocleidomastoid, shoulders and chest under a draped mantle held by
//! a round brooch, cut by an arched truncation. Everything is a height field over the portrait
//! plane, built from analytic shapes (no third-party mesh).
//!
//! Frame and units: the *canonical* frame is the Surrey mean face's, model millimetres.
//! * Profile ([`View::Profile`]): the plane is (u, v) = (-z, y) and heights are x, the
//!   distance from the head's mid-plane (the portrait faces left; u grows towards the back of
//!   the head). The mean face's nose tip is near (-3, -2), its chin (33, -79), the top of its
//!   forehead (24, 100) and its tragus (103, -7); the head is built around those with an
//!   average adult's proportions (head length about 195 mm from the brow, chin to crown about
//!   230 mm, neck about 110 mm across).
//! * Frontal ([`View::Frontal`]): (u, v) = (x, y); heights are z + [`FRONTAL_BACK_MM`] (the
//!   ears' plane). The face looks out of the stone; hair frames it, parted in the middle.
//!
//! A fitted face is placed into this frame by [`super::anchors`] (scale and shift fitted on
//! brow, chin, forehead, tragus and jaw), so the head follows the face and the face always
//! leads: the builder uses the template only outside the face's footprint. Pure computation.
//!
//! Why one long file: the shapes are one height field, each drawn over the last with the same
//! frame and helpers; split, every part would need them all.

use super::silhouette::{Silhouette, cranium_height};

/// Which way the portrait looks out of the stone: one type for the cameo, the kiosk's TOML
/// (`portrait = "profile"`) and the command line (`--portrait`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum View {
    /// Facing left, seen from the face's +x side: the classic cameo.
    #[default]
    Profile,
    /// Facing the viewer.
    Frontal,
}

/// Frontal view: depth of the plane the heights are measured from, behind the mean face's
/// nose tip (about the ears' depth), model mm.
pub const FRONTAL_BACK_MM: f32 = 95.0;

/// Where the portrait sits in the stone: the canonical point at the oval's centre and the
/// canonical millimetres per gem millimetre, per view. Chosen so that hair, head and bust fill
/// about 82 % of the oval's height, as real cameos do.
pub fn framing(view: View) -> ([f32; 2], f32) {
    match view {
        View::Profile => ([105.0, -62.0], 262.0 / 28.0),
        View::Frontal => ([0.0, -58.0], 270.0 / 28.0),
    }
}

/// The template at one point of the canonical plane.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sample {
    /// Height above the ground plane, canonical mm (0 where nothing is).
    pub height: f32,
    /// How much of it is hair (the agate's third layer), 0..1.
    pub hair: f32,
    /// Part of the portrait (inside its outline).
    pub covered: bool,
}

/// The portrait's hair, canonical mm (the Surrey mean face's eyes are about 115 mm above
/// its chin). [`HairStyle::default`] is the classical one the template was designed with;
/// [`super::hair_style`] makes a person's from what their photo shows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HairStyle {
    /// No hair at all: the cranium shows (a bald or shaved head).
    pub bald: bool,
    /// How far the hair stands above the skull.
    pub volume: f32,
    /// Where it ends below the eyes' level (canonical v): about -45 at the nape, -80 at the
    /// chin, -200 at the shoulders; lower still, it falls over them.
    pub end: f32,
    /// 0 straight (long parallel locks) .. 1 tight curls (short locks in narrow rows, or
    /// smaller snail curls).
    pub curl: f32,
    /// How the hair's surface is cut: locks, snail curls or a stippled crop.
    pub carving: HairCarving,
    /// How thick the beard stands over the chin, mm (0: none; carved on the face by
    /// [`super::face::facial_hair`]).
    pub beard: f32,
    /// How far the beard reaches: 0 the chin below the lip only, 1 the jaw and cheeks up to
    /// the sideburns.
    pub beard_jaw: f32,
    /// How thick the moustache stands, mm (0: none).
    pub moustache: f32,
    /// Glasses carved on the face ([`super::face::glasses`]): not hair, but read from the photo
    /// with it and carried with it.
    pub glasses: bool,
    /// Short hair cut above the ears (a photo's bare ears): facing the viewer, the hair ends
    /// above each ear, with a sideburn in front of it, and the ears show; otherwise the hair
    /// covers them.
    pub ears_shown: bool,
    /// The hair's outline facing the viewer, read from a photo: its half-width at the temples
    /// and the canonical v of its top (mm); `None` sizes it by `volume` alone. Never inside
    /// the cranium.
    pub outline: Option<[f32; 2]>,
    /// Long hair's fall facing the viewer, read from a photo: per row of
    /// [`crate::person::Hair::fall`] (v = 30 - 115 t, t the row's middle in face lengths) its
    /// nearest and furthest reach from the midline, canonical mm (`[0, 0]`: none there);
    /// `None` falls in the template's own band.
    pub fall: Option<[[f32; 2]; crate::person::FALL_ROWS]>,
    /// The hair's own outline facing the viewer, read from a photo
    /// ([`super::silhouette::Silhouette`]): where it is, the frontal hair is exactly there
    /// (its volume rounded in from the outline) and `outline`, `fall` and `ears_shown` only
    /// fill in where the photo did not show the head; `None`: the template's shapes.
    pub silhouette: Option<Silhouette>,
}

impl Default for HairStyle {
    fn default() -> Self {
        HairStyle {
            bald: false,
            volume: 11.0,
            end: -45.0,
            curl: 0.5,
            carving: HairCarving::Locks,
            beard: 0.0,
            beard_jaw: 0.0,
            moustache: 0.0,
            glasses: false,
            ears_shown: false,
            outline: None,
            fall: None,
            silhouette: None,
        }
    }
}

/// How a head of hair's surface is cut (`../shared/docs/cameo.md` section 5: cutters carve
/// locks as ridges with grooves along the hair's flow, curls as drilled spirals, short crops
/// as a fine stippled cap).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum HairCarving {
    /// Locks: ridges with grooves along the hair's flow (straight and wavy hair).
    #[default]
    Locks,
    /// Snail curls: rounded bosses in staggered rows, each with a drilled centre and a groove
    /// spiralling out from it (curly hair).
    Curls,
    /// A stippled cap hugging the skull (hair clipped close).
    Stippled,
}

impl HairStyle {
    /// One style of each kind the template carves, named: bald, short with the ears bare,
    /// standing wide, the classical hair, long hair falling as a photo's does, curly hair in
    /// snail curls (short and long), a crop stippled close to the skull, and a bearded,
    /// moustached face with glasses; as `super::hair_style` makes them of a photo's readings
    /// (canonical mm). For pictures of every kind (examples/hair_kinds) and the tests that
    /// build each.
    pub fn gallery() -> [(&'static str, HairStyle); 9] {
        // A shoulder-length fall widening below the jaw, as `Hair::fall` reads one (canonical mm).
        let mut fall = [[0.0f32; 2]; crate::person::FALL_ROWS];
        for (k, row) in fall.iter_mut().enumerate().take(9) {
            *row = [58.0 + 2.0 * k as f32, 92.0 + 7.0 * k as f32];
        }
        [
            (
                "bald",
                HairStyle {
                    bald: true,
                    ..HairStyle::default()
                },
            ),
            (
                "short, ears bare",
                HairStyle {
                    volume: 5.0,
                    ears_shown: true,
                    outline: Some([86.0, 162.0]),
                    ..HairStyle::default()
                },
            ),
            (
                "standing wide",
                HairStyle {
                    volume: 28.0,
                    ears_shown: true,
                    outline: Some([130.0, 185.0]),
                    ..HairStyle::default()
                },
            ),
            ("classical", HairStyle::default()),
            (
                "long, the photo's fall",
                HairStyle {
                    end: -200.0,
                    outline: Some([100.0, 170.0]),
                    fall: Some(fall),
                    ..HairStyle::default()
                },
            ),
            (
                "curly (snail curls)",
                HairStyle {
                    volume: 16.0,
                    curl: 0.9,
                    carving: HairCarving::Curls,
                    outline: Some([104.0, 176.0]),
                    ..HairStyle::default()
                },
            ),
            (
                "long curls",
                HairStyle {
                    end: -200.0,
                    curl: 0.7,
                    carving: HairCarving::Curls,
                    outline: Some([104.0, 172.0]),
                    fall: Some(fall),
                    ..HairStyle::default()
                },
            ),
            (
                "cropped (stippled)",
                HairStyle {
                    volume: 4.0,
                    carving: HairCarving::Stippled,
                    ears_shown: true,
                    outline: Some([84.0, 158.0]),
                    ..HairStyle::default()
                },
            ),
            (
                "beard, moustache, glasses",
                HairStyle {
                    volume: 6.0,
                    ears_shown: true,
                    outline: Some([88.0, 164.0]),
                    beard: 9.0,
                    beard_jaw: 0.8,
                    moustache: 3.8,
                    glasses: true,
                    ..HairStyle::default()
                },
            ),
        ]
    }
}

impl HairStyle {
    /// The surface cut into the hair at (u, v), mm (about -2..5, as [`lock`]): `locks` is the
    /// locks' relief there (computed only when the hair is carved in locks).
    fn carved(&self, u: f32, v: f32, locks: impl FnOnce() -> f32) -> f32 {
        match self.carving {
            HairCarving::Locks => locks(),
            HairCarving::Curls => snail_curls(u, v, 20.0 - 6.0 * self.curl.clamp(0.0, 1.0)),
            // 8 mm: four relief cells (finer points would average away).
            HairCarving::Stippled => stipple(u, v, 8.0),
        }
    }

    /// Rows of locks (mm across), lock length (radians of arc) and wave (mm) for its curl:
    /// the default's 15 mm rows of 62-degree locks at 0.5.
    fn locks(&self) -> (f32, f32, f32) {
        let c = self.curl.clamp(0.0, 1.0);
        (20.0 - 10.0 * c, 1.8 - 1.44 * c, 1.0 + 6.0 * c)
    }
}

/// Hermite smoothstep.
pub(crate) fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Polynomial smooth minimum of width `k` (equals `min` when `a`, `b` differ by more than `k`;
/// below both within it, as a rounded corner's distance is).
fn smooth_min(a: f32, b: f32, k: f32) -> f32 {
    let h = (0.5 + 0.5 * (b - a) / k).clamp(0.0, 1.0);
    b + h * (a - b) - k * h * (1.0 - h)
}

/// Polynomial smooth maximum of width `k` (equals `max` when `a`, `b` differ by more than `k`).
/// The width shrinks near the ground so that two zero heights stay zero (the plain formula
/// would lift the whole ground by `k / 4`).
pub(crate) fn smooth_max(a: f32, b: f32, k: f32) -> f32 {
    let k = k.min(2.0 * a.min(b).max(0.0));
    if k <= 1e-6 {
        return a.max(b);
    }
    let h = (k - (a - b).abs()).max(0.0) / k;
    a.max(b) + h * h * k * 0.25
}

/// Height of a half-ellipsoid (semi-axes a, b in the plane, c in height) at offset (du, dv).
fn dome(du: f32, dv: f32, a: f32, b: f32, c: f32) -> f32 {
    let q = 1.0 - (du / a).powi(2) - (dv / b).powi(2);
    if q > 0.0 { c * q.sqrt() } else { 0.0 }
}

/// Distance from p to the segment p0-p1 and the position along it (0..1).
fn segment(p: [f32; 2], p0: [f32; 2], p1: [f32; 2]) -> (f32, f32) {
    let d = [p1[0] - p0[0], p1[1] - p0[1]];
    let t = (((p[0] - p0[0]) * d[0] + (p[1] - p0[1]) * d[1]) / (d[0] * d[0] + d[1] * d[1]))
        .clamp(0.0, 1.0);
    ((p[0] - p0[0] - t * d[0]).hypot(p[1] - p0[1] - t * d[1]), t)
}

/// A small integer hash to vary locks and folds, in [0, 1).
fn hash2(a: i32, b: i32) -> f32 {
    let mut h = (a as u32).wrapping_mul(0x9E37_79B1) ^ (b as u32).wrapping_mul(0x85EB_CA77);
    h ^= h >> 15;
    h = h.wrapping_mul(0x2C1B_3C6D);
    h ^= h >> 12;
    (h & 0xFFFF) as f32 / 65536.0
}

/// Monotone cubic interpolation (Fritsch-Carlson) through `keys` sorted by x; `None` outside.
fn pchip(keys: &[(f32, f32)], x: f32) -> Option<f32> {
    let n = keys.len();
    if n < 2 || x < keys[0].0 || x > keys[n - 1].0 {
        return None;
    }
    let k = keys.windows(2).position(|w| x <= w[1].0).unwrap_or(n - 2);
    let slope = |i: usize| (keys[i + 1].1 - keys[i].1) / (keys[i + 1].0 - keys[i].0);
    let tangent = |i: usize| {
        if i == 0 {
            slope(0)
        } else if i == n - 1 {
            slope(n - 2)
        } else {
            let (a, b) = (slope(i - 1), slope(i));
            if a * b <= 0.0 {
                0.0
            } else {
                let (ha, hb) = (keys[i].0 - keys[i - 1].0, keys[i + 1].0 - keys[i].0);
                let (w1, w2) = (2.0 * hb + ha, hb + 2.0 * ha);
                (w1 + w2) / (w1 / a + w2 / b)
            }
        }
    };
    let (x0, y0) = keys[k];
    let (x1, y1) = keys[k + 1];
    let h = x1 - x0;
    let t = (x - x0) / h;
    let (t2, t3) = (t * t, t * t * t);
    Some(
        (2.0 * t3 - 3.0 * t2 + 1.0) * y0
            + (t3 - 2.0 * t2 + t) * h * tangent(k)
            + (-2.0 * t3 + 3.0 * t2) * y1
            + (t3 - t2) * h * tangent(k + 1),
    )
}

/// One lock of carved hair across a band: a ridge that rises gently from the groove a wheel
/// drill cuts beside it and drops steeply into the next (a rounded sawtooth), narrowing
/// towards its tip. `s` runs across the band (0..1), `t` along the lock (0 root, 1 tip),
/// `jitter` in [0, 1) varies its strength. Continuous in `s` (the groove's bottom is the same
/// on both sides) and where one lock ends and the next begins (every term that varies per lock
/// fades out at t = 0 and 1), so the sampled relief does not alias into stair-steps.
fn lock(s: f32, t: f32, jitter: f32) -> f32 {
    let t = t.clamp(0.0, 1.0);
    let mid = (std::f32::consts::PI * t).sin().max(0.0);
    // The crest sits later across the band towards the tip (the lock narrows).
    let crest = 0.72 - 0.18 * mid;
    let s = s.clamp(0.0, 1.0);
    let rise = if s < crest {
        (std::f32::consts::FRAC_PI_2 * s / crest).sin().powf(0.8)
    } else {
        (std::f32::consts::FRAC_PI_2 * (s - crest) / (1.0 - crest))
            .cos()
            .powf(0.6)
    };
    let strength = 4.5 + 2.5 * jitter * mid;
    strength * rise * (0.6 + 0.4 * mid.sqrt()) - 2.0
}

/// Hair swept in waves around a centre `c`: rows of locks along circles about it (each row
/// `width` mm across, waving by `wave` mm), each lock `seg` radians long, starting at angle
/// `start` and running towards decreasing angle when `sense` is 1 (increasing when -1).
fn swept_locks(
    u: f32,
    v: f32,
    c: [f32; 2],
    sense: f32,
    start: f32,
    (width, seg, wave): (f32, f32, f32),
) -> f32 {
    let (du, dv) = (u - c[0], v - c[1]);
    let r = du.hypot(dv);
    let th = dv.atan2(du);
    let rw = r + wave * (th * 6.0).sin();
    let row = (rw / width).floor();
    let s = rw / width - row;
    let a = sense * (start - th) / seg + hash2(row as i32, 7);
    let j = a.floor();
    let t = a - j;
    lock(s, t, hash2(row as i32, j as i32))
}

/// The nearest of a staggered grid's centres to (u, v): the grid `size` mm apart (rows
/// `0.87 size` apart, every other one shifted half a step), each centre moved by up to
/// `jitter` of a step; returns the offset from it and its row and column.
fn nearest_centre(u: f32, v: f32, size: f32, jitter: f32) -> ([f32; 2], i32, i32) {
    let row_h = 0.866 * size;
    let r0 = (v / row_h).floor() as i32;
    let mut best = ([f32::INFINITY; 2], 0, 0);
    for row in r0 - 1..=r0 + 1 {
        let shift = if row.rem_euclid(2) == 1 {
            0.5 * size
        } else {
            0.0
        };
        let c0 = ((u - shift) / size).floor() as i32;
        for col in c0 - 1..=c0 + 1 {
            let cu = col as f32 * size + shift + jitter * size * (hash2(row, col) - 0.5);
            let cv = row as f32 * row_h + jitter * size * (hash2(col, row ^ 0x55) - 0.5);
            let d = [u - cu, v - cv];
            if d[0].hypot(d[1]) < best.0[0].hypot(best.0[1]) {
                best = (d, row, col);
            }
        }
    }
    best
}

/// Snail curls `size` mm apart at (u, v), mm: rounded bosses in staggered rows, each with a
/// drilled centre and a groove turning once round it (at a cameo's scale a curl is a few
/// relief cells across: the drill hole and the groove's crescent are what read). The same
/// range as [`lock`]. Continuous: between two curls the ground is the same for both, and
/// what turns with the angle fades out before a curl's edge.
fn snail_curls(u: f32, v: f32, size: f32) -> f32 {
    let ([du, dv], row, col) = nearest_centre(u, v, size, 0.12);
    let radius = 0.5 * size;
    let r = du.hypot(dv) / radius;
    // Rounded, meeting the ground without a wall (a vertical edge would alias).
    let boss = smoothstep(1.0, 0.15, r);
    // Each curl turns its own way (a carver alternates them), its groove starting anywhere.
    let sense = if hash2(row, col ^ 0x33) < 0.5 {
        1.0
    } else {
        -1.0
    };
    let start = std::f32::consts::TAU * hash2(col, row ^ 0x77);
    let phase = sense * dv.atan2(du) + std::f32::consts::TAU * r + start;
    let groove =
        smoothstep(0.3, 1.0, phase.cos()) * smoothstep(0.8, 0.55, r) * smoothstep(0.1, 0.3, r);
    let drill = (-(r / 0.2).powi(2)).exp();
    -2.0 + 7.0 * boss - 2.5 * groove - 5.0 * drill
}

/// Stippled points `size` mm apart at (u, v), mm, standing a millimetre and a half (about
/// -0.5..1.5): a crop's cap (no locks, the skull's shape shows) or stubble.
fn stipple(u: f32, v: f32, size: f32) -> f32 {
    let ([du, dv], _, _) = nearest_centre(u, v, size, 0.35);
    let r = du.hypot(dv) / (0.45 * size);
    -0.5 + 2.0 * smoothstep(1.0, 0.2, r)
}

/// Locks hanging down in rows across `x` (mm; each row `width` across, waving by `wave` mm
/// every `period` mm of height), each lock `length` mm long; `salt` staggers the rows
/// differently for each place they hang (fall, fringe, beard).
fn hanging_locks(
    x: f32,
    v: f32,
    width: f32,
    length: f32,
    (wave, period): (f32, f32),
    salt: i32,
) -> f32 {
    let s = (x + wave * (v / period).sin()) / width;
    let row = s.floor();
    let t = -v / length + hash2(row as i32, salt);
    lock(s - row, t - t.floor(), hash2(row as i32, t.floor() as i32))
}

/// The frontal head's locks: swept round from the parting in the middle, down each side.
fn frontal_locks(u: f32, v: f32, locks: (f32, f32, f32)) -> f32 {
    let side = if u < 0.0 { -1.0 } else { 1.0 };
    swept_locks(
        u * side,
        v,
        [12.0, 30.0],
        1.0,
        std::f32::consts::FRAC_PI_2,
        locks,
    )
}

/// A beard's or moustache's locks at canonical (u, v), mm (about -0.8..2 around 0): rows of
/// short locks hanging down, narrower and shorter the curlier the hair (`curl` as
/// [`HairStyle::curl`]).
fn beard_locks(u: f32, v: f32, curl: f32) -> f32 {
    let c = curl.clamp(0.0, 1.0);
    let (width, length, wave) = (7.0 - 3.0 * c, 16.0 - 8.0 * c, 0.5 + 2.0 * c);
    0.4 * hanging_locks(u, v, width, length, (wave, 6.0), 23)
}

/// A beard no thicker than this (mm) is stubble-length: stippled, not in locks.
pub const STUBBLE_MM: f32 = 4.0;

/// Facial hair's surface at canonical (u, v), mm (about -0.8..2 around 0), as the person's
/// hair is cut: a short beard stippled, curly hair's beard in small drilled curls, otherwise
/// [`beard_locks`].
pub fn beard_texture(style: &HairStyle, u: f32, v: f32) -> f32 {
    if style.beard > 0.0 && style.beard <= STUBBLE_MM {
        0.5 * stipple(u, v, 6.0)
    } else if style.carving == HairCarving::Curls {
        0.3 * snail_curls(u, v, 9.0)
    } else {
        beard_locks(u, v, style.curl)
    }
}

/// The template at canonical point (u, v).
pub fn sample(view: View, hair: &HairStyle, u: f32, v: f32) -> Sample {
    match view {
        View::Profile => profile(hair, u, v),
        View::Frontal => frontal(hair, u, v),
    }
}

// ------------------------------------------------------------------------------ profile

/// Torso outline per height v: front u, back u and half-breadth (the height it reaches),
/// canonical mm: the neck leans forward (its front runs from under the chin back to the
/// sternal notch), the trapezius widens it at the back, shoulders and chest below.
const TORSO: [(f32, f32, f32, f32); 10] = [
    (-380.0, 50.0, 275.0, 165.0),
    (-320.0, 50.0, 272.0, 165.0),
    (-260.0, 58.0, 264.0, 160.0),
    (-225.0, 70.0, 255.0, 140.0),
    (-195.0, 86.0, 240.0, 100.0),
    (-165.0, 82.0, 214.0, 66.0),
    (-130.0, 72.0, 192.0, 57.0),
    (-90.0, 64.0, 182.0, 54.0),
    (-40.0, 64.0, 178.0, 50.0),
    (20.0, 95.0, 170.0, 45.0),
];

fn torso_keys(col: usize) -> [(f32, f32); 10] {
    TORSO.map(|k| {
        (
            k.0,
            match col {
                1 => k.1,
                2 => k.2,
                _ => k.3,
            },
        )
    })
}

/// Neck and bust (before the drapery): elliptic cross-sections between the outlines.
fn torso(u: f32, v: f32) -> f32 {
    let (Some(front), Some(back), Some(breadth)) = (
        pchip(&torso_keys(1), v),
        pchip(&torso_keys(2), v),
        pchip(&torso_keys(3), v),
    ) else {
        return 0.0;
    };
    let (centre, half) = (0.5 * (front + back), 0.5 * (back - front));
    let t = (u - centre) / half;
    if t.abs() >= 1.0 {
        return 0.0;
    }
    let h = breadth * (1.0 - t * t).sqrt().powf(0.8);
    if v < -215.0 {
        return h;
    }
    // The sternocleidomastoid: a band that swells from the mastoid behind the ear to its
    // belly and narrows to the sternal notch, bowed a little back; fading in at the top
    // (under the ear and the jaw) so it starts without a crease.
    let (d, s) = curve([u, v], [146.0, -38.0], [128.0, -125.0], [96.0, -197.0]);
    let width = 6.0 + 8.0 * (std::f32::consts::PI * s).sin();
    let scm = 6.0
        * smoothstep(0.0, 0.3, s)
        * (1.0 - 0.3 * smoothstep(0.85, 1.0, s))
        * (-(d / width).powi(2)).exp();
    // The clavicle, from the notch out to the shoulder (mostly under the mantle).
    let (d2, s2) = curve([u, v], [100.0, -205.0], [140.0, -202.0], [175.0, -214.0]);
    let clavicle = 5.0
        * smoothstep(0.0, 0.15, s2)
        * (1.0 - smoothstep(0.85, 1.0, s2))
        * (-(d2 / 6.0).powi(2)).exp();
    // The throat: the larynx a soft swell behind the neck's front line; hollows at the
    // sternal (jugular) notch and in the triangle behind the muscle, above the clavicle.
    let larynx = 3.5 * bump(u - 74.0, v + 120.0, 10.0, 18.0);
    let notch = 4.0 * bump(u - 86.0, v + 203.0, 12.0, 10.0);
    let behind = 3.0 * bump(u - 160.0, v + 165.0, 22.0, 30.0);
    h + scm + clavicle + larynx - notch - behind
}

/// A smooth bump of height 1 at the origin falling to 0 on the ellipse with semi-axes a, b
/// (its slope 0 at the rim too, so it joins what is round it without a crease).
fn bump(du: f32, dv: f32, a: f32, b: f32) -> f32 {
    let q = 1.0 - (du / a).powi(2) - (dv / b).powi(2);
    if q > 0.0 { q * q } else { 0.0 }
}

/// Distance from p to the quadratic Bezier curve p0-c-p2 and the position along it (0..1),
/// by its nearest of 16 chords.
fn curve(p: [f32; 2], p0: [f32; 2], c: [f32; 2], p2: [f32; 2]) -> (f32, f32) {
    const N: usize = 16;
    let at = |t: f32| {
        let (a, b, w) = ((1.0 - t) * (1.0 - t), 2.0 * t * (1.0 - t), t * t);
        [
            a * p0[0] + b * c[0] + w * p2[0],
            a * p0[1] + b * c[1] + w * p2[1],
        ]
    };
    let mut best = (f32::INFINITY, 0.0);
    for k in 0..N {
        let (t0, t1) = (k as f32 / N as f32, (k + 1) as f32 / N as f32);
        let (d, s) = segment(p, at(t0), at(t1));
        if d < best.0 {
            best = (d, t0 + s * (t1 - t0));
        }
    }
    best
}

/// The brooch on the shoulder that holds the mantle, and the mantle's hanging point in front.
const BROOCH: [f32; 2] = [192.0, -222.0];
const MANTLE_FRONT: [f32; 2] = [40.0, -262.0];

/// The mantle over the bust: swags hanging between the brooch and the front of the chest
/// (each fold a ridge, deeper folds further down), a rolled hem along its neckline, and the
/// brooch: a dome in a ring.
fn drapery(u: f32, v: f32, body: f32) -> f32 {
    if body <= 0.0 {
        return 0.0;
    }
    let neckline = -238.0 + 0.5 * (u - 60.0) + 0.0015 * (u - 60.0).powi(2);
    let mut h = body;
    if v < neckline {
        let x = ((BROOCH[0] - u) / (BROOCH[0] - MANTLE_FRONT[0])).clamp(0.0, 1.0);
        let line = BROOCH[1] + (MANTLE_FRONT[1] - BROOCH[1]) * x;
        let sag = (line - v) / (4.0 * x * (1.0 - x)).max(0.12);
        let psi = sag / 16.0;
        let f = psi - psi.floor();
        let ridge = if f < 0.75 {
            (std::f32::consts::FRAC_PI_2 * f / 0.75).sin()
        } else {
            (std::f32::consts::FRAC_PI_2 * (f - 0.75) / 0.25).cos()
        };
        let amp = 7.0 * smoothstep(0.0, 25.0, sag) * smoothstep(0.02, 0.15, x);
        h = body + 5.0 + amp * (ridge - 0.5);
    }
    h += 5.0 * (-((v - neckline) / 5.0).powi(2)).exp();
    let dr = (u - BROOCH[0]).hypot(v - BROOCH[1]);
    if dr < 20.0 {
        let ring = 5.0 * (-((dr - 17.0) / 2.5).powi(2)).exp();
        let boss = dome(u - BROOCH[0], v - BROOCH[1], 16.0, 16.0, 12.0);
        h = h.max(body + 8.0 + boss.max(ring));
    }
    h
}

/// The bust's arched truncation: nothing below it.
fn above_truncation(u: f32, v: f32) -> bool {
    v > -300.0 + 40.0 * ((u - 150.0) / 140.0).powi(2)
}

/// The ear, seen flat in profile: helix rim (open at the front where it dives into the
/// concha), antihelix, concha hollow, tragus and lobe, standing out from the skull. Returns
/// its height over the skull and whether (u, v) is on it.
fn ear(u: f32, v: f32) -> Option<f32> {
    let (ca, sa) = ((-14f32).to_radians().cos(), (-14f32).to_radians().sin());
    let (eu, ev) = (u - 121.0, v - 8.0);
    let p = eu * ca + ev * sa;
    let q = -eu * sa + ev * ca;
    let (x, y) = (p / 18.0, q / 32.0);
    let r = x.hypot(y);
    if r >= 1.0 {
        return None;
    }
    let deg = y.atan2(x).to_degrees().rem_euclid(360.0);
    let gauss = |d: f32, w: f32| (-(d / w).powi(2)).exp();
    let opening = smoothstep(150.0, 175.0, deg) * (1.0 - smoothstep(215.0, 240.0, deg));
    let helix = gauss(r - 0.83, 0.1) * (1.0 - 0.85 * opening);
    let anti = gauss(r - 0.52, 0.1)
        * (1.0 - smoothstep(120.0, 150.0, deg) * (1.0 - smoothstep(250.0, 280.0, deg)));
    let concha = gauss((x + 0.2).hypot(y + 0.05), 0.36);
    let lobe = gauss((x * 1.2).hypot(y + 0.72), 0.32);
    let tragus = gauss((x + 0.9).hypot(y + 0.1), 0.16);
    let edge = smoothstep(1.0, 0.9, r);
    let h = edge * (6.0 + 4.0 * (x + 0.3).max(0.0)) + 8.0 * helix + 4.0 * anti - 7.0 * concha
        + 6.0 * lobe
        + 5.0 * tragus;
    Some(h.max(0.0))
}

/// Whether (u, v) is inside the profile's hair: over the cranium behind the hairline, clear
/// of the ear, in front of and above the nape's line.
fn profile_hair_region(u: f32, v: f32) -> bool {
    let near_ear = ((u - 121.0) / 24.0).hypot((v - 8.0) / 38.0) < 1.0;
    let before_ear = u < 122.0 && v < 28.0;
    !(near_ear || before_ear) && v > -45.0 + 0.25 * (u - 150.0)
}

/// Hair that falls below the nape, behind the ear and the neck, down to `style.end` and over
/// the shoulders: its front edge (canonical u) at height v, or `None` above the nape or below
/// the end. Its back edge follows the head's envelope, then the back.
fn profile_fall(style: &HairStyle, v: f32) -> Option<(f32, f32)> {
    if style.bald || style.end > -46.0 || v > 10.0 || v < style.end {
        return None;
    }
    // Behind the ear and jaw, then forward over the shoulder as it falls.
    let front = 128.0 - 0.18 * (-v - 10.0).max(0.0);
    let back = 214.0 + 0.1 * style.volume - 0.12 * (-v - 10.0).max(0.0);
    Some((front, back))
}

/// The profile hair's envelope: its centre's height (canonical v) and its least half-height
/// (its crown 6 mm over the cranium's top at v = 152).
const PROFILE_HAIR_CENTRE_V: f32 = 55.0;
const PROFILE_CROWN_MIN: f32 = 103.0;

fn profile(style: &HairStyle, u: f32, v: f32) -> Sample {
    let cranium = dome(u - 112.0, v - 52.0, 98.0, 100.0, 77.0);
    let mut body = if above_truncation(u, v) {
        drapery(u, v, torso(u, v))
    } else {
        0.0
    };
    // The bust stays below the head in depth: real cameos keep it in lower relief.
    body = 120.0 * (body / 120.0).tanh();
    let mut height = if body > 0.0 {
        smooth_max(cranium, body, 15.0)
    } else {
        cranium
    };
    if let Some(e) = ear(u, v) {
        height = height.max(0.9 * cranium + e);
    }
    if style.bald {
        return with_hair(height, None);
    }
    // The envelope over the cranium: the default style's 108 x 112 x 90 mm stands about 11 mm
    // above the skull. Its crown as high as the photo's hair where it was read (the
    // silhouette's top, else the outline's: a head's height is the same seen from the front
    // and the side), at least 6 mm over the cranium.
    let extra = style.volume - 11.0;
    let photo_top = style
        .silhouette
        .as_ref()
        .and_then(|s| s.top())
        .or(style.outline.map(|o| o[1]));
    let half_height = photo_top.map_or(112.0 + extra, |top| {
        (top - PROFILE_HAIR_CENTRE_V).clamp(PROFILE_CROWN_MIN, 150.0)
    });
    let envelope = dome(
        u - 114.0 - 0.3 * extra,
        v - PROFILE_HAIR_CENTRE_V,
        108.0 + extra,
        half_height,
        90.0 + 0.8 * extra,
    );
    let locks = style.locks();
    let mut hair = (envelope > 0.0 && profile_hair_region(u, v)).then(|| {
        0.93 * envelope
            + style.carved(u, v, || {
                swept_locks(u, v, [128.0, 22.0], 1.0, std::f32::consts::PI, locks)
            })
    });
    // Long hair: a fall of locks from the nape, standing over neck and shoulders.
    if let Some((front, back)) = profile_fall(style, v)
        && u > front
        && u < back
    {
        let across = ((u - front) / (back - front)).clamp(0.0, 1.0);
        let round = (std::f32::consts::PI * across).sin().sqrt();
        let taper = smoothstep(style.end, style.end + 40.0, v);
        let under = height.max(45.0);
        let (w, seg, wave) = locks;
        // Locks run down the fall: rows across u, each lock `seg` x 60 mm long.
        let fall = under
            + (14.0 + 0.6 * style.volume) * round * taper
            + style.carved(u, v, || {
                hanging_locks(u, v, w, 60.0 * seg, (wave, 25.0), 11)
            });
        hair = Some(hair.map_or(fall, |h| h.max(fall)));
    }
    with_hair(height, hair)
}

/// The template's sample where the head is `height` high and the hair (where there is any)
/// `hair` high: the hair shows where it stands above the head.
fn with_hair(height: f32, hair: Option<f32>) -> Sample {
    let (height, hair) = match hair {
        Some(h) if h > height => (h, 1.0),
        _ => (height, 0.0),
    };
    Sample {
        height: height.max(0.0),
        hair,
        covered: height > 0.5,
    }
}

// ------------------------------------------------------------------------------ frontal

/// Frontal neck and bust: a round column under the chin (its front 44 mm above the ears'
/// plane), a rounded torso (chest and deltoids) inside the trapezius' outline, the two
/// sternocleidomastoids closing in a V on the sternal notch, the larynx, the clavicles and
/// the hollows above them, and the mantle from a brooch on the viewer's right shoulder.
fn frontal_body(u: f32, v: f32) -> f32 {
    // The truncation: a rounded lower edge (a wall there aliases into a saw-tooth).
    let cut = -330.0 + 30.0 * (u / 150.0).powi(2);
    if v > -20.0 || v < cut {
        return 0.0;
    }
    let truncation = smoothstep(cut, cut + 16.0, v).sqrt();
    let a = u.abs();
    // The neck: round in section (its sides turning away steeply, as a column's do), a
    // little narrower at its middle than under the jaw, standing a wall's height off the
    // ground at its sides.
    let half = 54.0 - 5.0 * smoothstep(-30.0, -110.0, v);
    let neck = if a < half && v < 10.0 {
        8.0 + 36.0 * (1.0 - (a / half).powi(2)).sqrt().powf(0.7)
    } else {
        0.0
    };
    // The torso as one rounded mass inside the shoulders' outline: the chest highest, the
    // shoulders' caps (the deltoids) round, all falling to the ground at the outline in a
    // quarter-round. (A plateau of one height for the shoulders and chest, rounded only at
    // its rim, read as a yoke with a trough inside it.) The outline: the trapezius drooping
    // from the neck to the shoulder, its outer top corner rounded by a 40 mm smooth minimum.
    let shoulder_line = -105.0 - 0.0042 * (a - 45.0).max(0.0).powi(2);
    let breadth = 150.0;
    let inside = smooth_min(shoulder_line - v, breadth - a, 40.0);
    // (Not across the neck: there the torso rises under the neck's own round, and a rim
    // there drew a crease across the throat at the shoulders' height.)
    let neck_core = if v < 10.0 {
        smoothstep(half, half - 20.0, a)
    } else {
        0.0
    };
    let rim = (1.0 - (1.0 - (inside / 40.0).clamp(0.0, 1.0)).powi(2)).max(neck_core);
    let chest = dome(u, v + 255.0, 190.0, 200.0, 64.0);
    let deltoid = dome(a - 122.0, v + 165.0, 48.0, 70.0, 46.0);
    let torso = smooth_max(chest, deltoid, 20.0) * rim;
    let mut body = smooth_max(neck, torso, 20.0);
    if body <= 0.5 {
        return 0.0;
    }
    // The throat: the sternocleidomastoids from behind the jaw's angle to the sternal notch
    // (a V of soft swells that fade in under the jaw and flatten at the notch), the larynx
    // between them, the notch's pit and the hollows above the clavicles beside them.
    for side in [-1.0f32, 1.0] {
        let (d, s) = segment([u, v], [side * 60.0, -35.0], [side * 13.0, -190.0]);
        let width = 8.0 + 5.0 * (std::f32::consts::PI * s).sin();
        body += 4.5
            * smoothstep(0.0, 0.3, s)
            * (1.0 - 0.4 * smoothstep(0.8, 1.0, s))
            * (-(d / width).powi(2)).exp();
        // The clavicle, a soft ridge from the notch bowed up towards the shoulder (a
        // straight bar reads as a yoke from the front).
        let (_, s2) = segment([u, v], [side * 16.0, -198.0], [side * 118.0, -170.0]);
        let bow = 6.0 * (std::f32::consts::PI * s2).sin();
        let (d2, _) = segment([u, v - bow], [side * 16.0, -198.0], [side * 118.0, -170.0]);
        body += 3.0
            * smoothstep(0.0, 0.15, s2)
            * (1.0 - smoothstep(0.85, 1.0, s2))
            * (-(d2 / 7.0).powi(2)).exp();
        body -= 1.5 * bump(u - side * 72.0, v + 172.0, 28.0, 18.0);
    }
    body += 2.0 * bump(u, v + 112.0, 16.0, 26.0);
    body -= 2.0 * bump(u, v + 196.0, 24.0, 16.0);
    // The mantle: over the viewer's right shoulder, pinned by a brooch, and across the chest
    // below a neckline.
    let neckline = -250.0 + 0.9 * (u - 40.0);
    let brooch = [118.0, -228.0];
    if v < neckline {
        let (d, _) = segment([u, v], brooch, [-150.0, -300.0]);
        let psi = d / 15.0;
        let f = psi - psi.floor();
        let ridge = if f < 0.75 {
            (std::f32::consts::FRAC_PI_2 * f / 0.75).sin()
        } else {
            (std::f32::consts::FRAC_PI_2 * (f - 0.75) / 0.25).cos()
        };
        body += 5.0 + 6.0 * smoothstep(5.0, 30.0, d) * (ridge - 0.5);
    }
    body += 5.0 * (-((v - neckline) / 5.0).powi(2)).exp() * smoothstep(-160.0, -120.0, u);
    let dr = (u - brooch[0]).hypot(v - brooch[1]);
    if dr < 20.0 {
        let ring = 5.0 * (-((dr - 17.0) / 2.5).powi(2)).exp();
        let boss = dome(u - brooch[0], v - brooch[1], 16.0, 16.0, 12.0);
        body = body.max(chest.max(30.0) + 10.0 + boss.max(ring));
    }
    (body * truncation).max(0.0)
}

/// The fall's inner and outer reach at canonical height `v` (mm), between the rows' middles;
/// `None` where no row near it has hair.
fn fall_at(fall: &[[f32; 2]; crate::person::FALL_ROWS], v: f32) -> Option<(f32, f32)> {
    use crate::person::{FALL_STEP, FALL_TOP};
    let t = (30.0 - v) / 115.0;
    let x = (t - FALL_TOP) / FALL_STEP - 0.5;
    if !x.is_finite() || x < -0.5 || x > fall.len() as f32 - 0.5 {
        return None;
    }
    let k0 = x.floor().max(0.0) as usize;
    let k1 = (k0 + 1).min(fall.len() - 1);
    let f = (x - k0 as f32).clamp(0.0, 1.0);
    let has = |k: usize| fall[k][1] > 0.0;
    match (has(k0), has(k1)) {
        (true, true) => Some((
            fall[k0][0] + f * (fall[k1][0] - fall[k0][0]),
            fall[k0][1] + f * (fall[k1][1] - fall[k0][1]),
        )),
        (true, false) if f < 0.5 => Some((fall[k0][0], fall[k0][1])),
        (false, true) if f >= 0.5 => Some((fall[k1][0], fall[k1][1])),
        _ => None,
    }
}

fn frontal(style: &HairStyle, u: f32, v: f32) -> Sample {
    // The cranium, its top at v = 155, or under a photo's hair outline.
    let b = cranium_height(style.silhouette.as_ref().and_then(|s| s.top()));
    let cranium = dome(u, v - 40.0, 80.0, b, 85.0);
    let body = frontal_body(u, v);
    let mut height = smooth_max(cranium, body, 12.0);
    // Ears at the sides, seen almost edge-on: a narrow rim with a hollow.
    for side in [-1.0f32, 1.0] {
        let (x, y) = ((u - side * 80.0) / 11.0, (v - 10.0) / 31.0);
        let r = x.hypot(y);
        if r < 1.0 {
            let rim = (-((r - 0.75) / 0.15).powi(2)).exp();
            height = height.max(10.0 + 8.0 * rim - 4.0 * (1.0 - r));
        }
    }
    if style.bald {
        return with_hair(height, None);
    }
    if let Some(sil) = &style.silhouette {
        return with_hair(height, silhouette_hair(style, sil, height, u, v));
    }
    let extra = style.volume - 11.0;
    // The hair's envelope about the cranium (80 mm half-wide, its top at v = 155): sized by
    // the volume, or to the photo's own outline (at least 3 mm over the cranium).
    let (half_width, half_height) = match style.outline {
        Some([width, top]) => (
            width.clamp(83.0, 160.0),
            // At least 3 mm over the cranium's top.
            (top - 44.0).clamp(114.0, 200.0),
        ),
        None => (94.0 + extra, 125.0 + extra),
    };
    let envelope = dome(u, v - 44.0, half_width, half_height, 96.0 + 0.8 * extra);
    let locks = style.locks();
    // Hair over the cranium above the ears' line, parted in the middle, swept down each side;
    // cut short, it ends above the ears (their tops at v = 41) but for a sideburn in front.
    let lowest = if style.ears_shown && style.end > -46.0 {
        let sideburn = smoothstep(66.0, 72.0, u.abs());
        // Beyond the ear, hair standing out wide curls up and in rather than ending in a
        // straight brim.
        let above_ear = 44.0 + 0.8 * (u.abs() - 90.0).max(0.0);
        (8.0 - 0.2 * u.abs()) + sideburn * (above_ear - (8.0 - 0.2 * u.abs()))
    } else {
        8.0 - 0.2 * u.abs()
    };
    let mut hair = (envelope > 0.0 && v > lowest).then(|| {
        let full = 0.9 * envelope + style.carved(u, v, || frontal_locks(u, v, locks));
        if style.ears_shown {
            // Cut short, the hair thins onto the skin at its edge rather than ending in a
            // ledge (over 6 mm).
            height + (full - height) * smoothstep(lowest, lowest + 6.0, v)
        } else {
            full
        }
    });
    // Long hair falls beside the face and neck, onto the shoulders.
    if style.end < -46.0 && v < 20.0 && v > style.end {
        // Where the photo's hair falls (never inside the neck), or the template's own band.
        let (inner, outer) = match style.fall.and_then(|f| fall_at(&f, v)) {
            Some((i, o)) => (i.max(50.0), o.max(i.max(50.0) + 12.0)),
            None => (
                74.0 + 0.12 * (20.0 - v),
                100.0 + extra + 0.25 * (20.0 - v).min(160.0),
            ),
        };
        let a = u.abs();
        if a > inner && a < outer {
            let across = ((a - inner) / (outer - inner)).clamp(0.0, 1.0);
            let round = (std::f32::consts::PI * across).sin().sqrt();
            let taper = smoothstep(style.end, style.end + 40.0, v);
            let (w, seg, wave) = locks;
            let fall = height.max(30.0)
                + (16.0 + 0.6 * style.volume) * round * taper
                + style.carved(u, v, || {
                    hanging_locks(a, v, w, 60.0 * seg, (wave, 25.0), 13)
                });
            hair = Some(hair.map_or(fall, |h| h.max(fall)));
        }
    }
    with_hair(height, hair)
}

/// Hair carved over the face (frontal, canonical mm above the face's surface; 0 where none):
/// a fringe, where a photo's hair outline reaches down over the forehead, thinning from
/// the outline and ending above the brows. The builder lays it on the face; the outline
/// measure counts it as hair.
pub fn fringe(style: &HairStyle, u: f32, v: f32) -> f32 {
    let Some(sil) = &style.silhouette else {
        return 0.0;
    };
    let brows = smoothstep(FRINGE_V.0, FRINGE_V.1, v);
    if brows <= 0.0 {
        return 0.0;
    }
    let d = sil.at(u, v);
    if d <= 0.0 || !d.is_finite() {
        return 0.0;
    }
    let (w, seg, wave) = style.locks();
    // Locks hanging down over the forehead, narrower and shorter than the head's.
    let texture = style.carved(u, v, || {
        hanging_locks(u, v, 0.6 * w, 30.0 * seg, (wave, 25.0), 31)
    });
    let ramp = smoothstep(0.0, 6.0, d) * brows;
    (ramp * (3.0 + 0.3 * style.volume + 0.5 * texture)).max(0.0)
}

/// A fringe ends between these heights (canonical v, mm): the mean face's brows are about
/// v = 45.
const FRINGE_V: (f32, f32) = (50.0, 60.0);

/// Frontal hair inside a photo's outline: a rounded mass rising from the outline (as high as
/// the template's envelope over the head, lower where it falls beside the neck) and never
/// less than a layer over the head and bust, carved as locks swept round the head above the
/// ears and hanging in rows below them.
fn silhouette_hair(
    style: &HairStyle,
    sil: &Silhouette,
    height: f32,
    u: f32,
    v: f32,
) -> Option<f32> {
    let d = sil.at(u, v);
    if d <= 0.0 || !d.is_finite() {
        return None;
    }
    // Rising over the outline's first 6 mm, full within a lock's width of it.
    let ramp = smoothstep(0.0, 6.0, d);
    let x = (d / 60.0).min(1.0);
    let peak = 40.0 + 46.0 * smoothstep(-60.0, 0.0, v);
    let mass = peak * (1.0 - (1.0 - x) * (1.0 - x)).sqrt();
    let layer = height + (3.0 + 0.5 * style.volume) * ramp;
    let locks = style.locks();
    let texture = style.carved(u, v, || {
        let swept = frontal_locks(u, v, locks);
        let (w, seg, wave) = locks;
        let hanging = hanging_locks(u.abs(), v, w, 60.0 * seg, (wave, 25.0), 13);
        let below = smoothstep(20.0, -20.0, v);
        swept + below * (hanging - swept)
    });
    // A crop hugs the skull: the layer alone, no mass standing out.
    let body = if style.carving == HairCarving::Stippled {
        layer
    } else {
        mass.max(layer)
    };
    Some(body + ramp * texture)
}

impl Silhouette {
    /// The silhouette of `mask` for `style` (the photo's other readings already in it: its
    /// outline and fall fill where the photo does not show the head); `crown` is the share of
    /// the crown that is hair ([`crate::person::Hair::crown`]).
    pub fn from_mask(mask: &crate::person::HairMask, style: &HairStyle, crown: f32) -> Self {
        let plain = HairStyle {
            silhouette: None,
            ..*style
        };
        Silhouette::from_cells(mask, crown, |u, v| {
            sample(View::Frontal, &plain, u, v).hair > 0.0
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Where the photo shows nothing, the silhouette is the template's own hair.
    #[test]
    fn a_silhouette_takes_the_templates_hair_where_the_photo_shows_nothing() {
        use crate::person::{HairMask, MASK_COLS, MASK_ROWS};
        let mask = HairMask {
            share: [[f32::NAN; MASK_COLS]; MASK_ROWS],
        };
        let sil = Silhouette::from_mask(&mask, &HairStyle::default(), 0.0);
        assert!(
            sil.at(0.0, 150.0) > 0.0,
            "the template's hair over the head"
        );
        assert!(sil.at(0.0, -200.0) < 0.0, "none over the chest");
    }

    #[test]
    fn pchip_interpolates_monotonically() {
        let keys = [(0.0, 0.0), (1.0, 1.0), (2.0, 1.0), (3.0, 5.0)];
        assert_eq!(pchip(&keys, -0.1), None);
        assert_eq!(pchip(&keys, 3.1), None);
        for (x, y) in keys {
            assert!((pchip(&keys, x).unwrap() - y).abs() < 1e-5);
        }
        // Flat between equal keys (no overshoot), rising elsewhere.
        let mut last = 0.0;
        for i in 0..=300 {
            let y = pchip(&keys, i as f32 / 100.0).unwrap();
            assert!(y >= last - 1e-5, "not monotone at {i}");
            last = y;
            if (100..=200).contains(&i) {
                assert!((y - 1.0).abs() < 1e-5);
            }
        }
    }

    #[test]
    fn the_head_is_around_the_mean_face() {
        // The cranium reaches the mean face's forehead top and tragus, the neck runs under
        // the chin and nothing stands in front of the nose.
        let p = sample(View::Profile, &HairStyle::default(), 24.0, 100.0);
        assert!(p.covered);
        assert!(sample(View::Profile, &HairStyle::default(), 103.0, -7.0).covered);
        assert!(
            sample(View::Profile, &HairStyle::default(), 80.0, -110.0).covered,
            "throat"
        );
        assert!(
            !sample(View::Profile, &HairStyle::default(), -10.0, 0.0).covered,
            "in front of the nose"
        );
        assert!(
            !sample(View::Profile, &HairStyle::default(), 150.0, 190.0).covered,
            "above the hair"
        );
        // Hair on the crown, not on the ear or the neck.
        assert_eq!(
            sample(View::Profile, &HairStyle::default(), 150.0, 120.0).hair,
            1.0
        );
        assert_eq!(
            sample(View::Profile, &HairStyle::default(), 121.0, 8.0).hair,
            0.0
        );
        assert_eq!(
            sample(View::Profile, &HairStyle::default(), 120.0, -120.0).hair,
            0.0
        );
        // Frontal: symmetric outline.
        for (u, v) in [(60.0, 120.0), (90.0, 10.0), (40.0, -150.0), (130.0, -250.0)] {
            assert_eq!(
                sample(View::Frontal, &HairStyle::default(), u, v).covered,
                sample(View::Frontal, &HairStyle::default(), -u, v).covered,
                "({u}, {v})"
            );
        }
    }

    /// Every point of both templates is finite (a NaN would make a crack: the relief drops to
    /// the ground along it).
    #[test]
    fn templates_are_finite_everywhere() {
        // Every kind, and the extremes of the readings.
        let extremes = [
            HairStyle {
                volume: 32.0,
                end: -290.0,
                curl: 1.0,
                ..HairStyle::default()
            },
            HairStyle {
                volume: 3.0,
                end: -120.0,
                curl: 0.0,
                ..HairStyle::default()
            },
            HairStyle {
                end: -290.0,
                outline: Some([150.0, 120.0]),
                fall: Some([[40.0, 160.0]; crate::person::FALL_ROWS]),
                ..HairStyle::default()
            },
        ];
        let styles: Vec<HairStyle> = HairStyle::gallery()
            .map(|(_, s)| s)
            .into_iter()
            .chain(extremes)
            .collect();
        for style in &styles {
            for view in [View::Profile, View::Frontal] {
                for y in (-400..=250).step_by(2) {
                    for x in (-250..=350).step_by(2) {
                        let s = sample(view, style, x as f32 * 0.97, y as f32 * 0.97);
                        assert!(
                            s.height.is_finite() && s.hair.is_finite(),
                            "{view:?} {style:?} at ({x}, {y}): {s:?}"
                        );
                    }
                }
            }
        }
    }

    /// Short hair cut above the ears leaves the ears bare (hair over neither ear, facing the
    /// viewer) and still covers the crown and the temples above them; hair not cut so covers
    /// the ears' upper half.
    #[test]
    fn hair_cut_above_the_ears_shows_them() {
        let cut = HairStyle {
            ears_shown: true,
            ..HairStyle::default()
        };
        let covered = HairStyle::default();
        let hair_over = |style: &HairStyle, us: [i32; 2], vs: [i32; 2]| {
            (vs[0]..vs[1])
                .step_by(2)
                .flat_map(|v| [-1, 1].map(|side| (v, side)))
                .flat_map(|(v, side)| (us[0]..us[1]).step_by(2).map(move |u| (side * u, v)))
                .filter(|&(u, v)| sample(View::Frontal, style, u as f32, v as f32).hair > 0.0)
                .count()
        };
        // The ears: u = +-80 (11 mm half-width), v = 10 +- 31.
        assert_eq!(hair_over(&cut, [74, 90], [-15, 40]), 0);
        assert!(hair_over(&covered, [74, 90], [-5, 40]) > 50);
        assert!(hair_over(&cut, [0, 60], [90, 140]) > 300, "the crown");
        assert!(hair_over(&cut, [80, 95], [50, 80]) > 20, "the temples");
    }

    /// A photo's hair outline sizes the frontal hair: its top where the photo's is, never
    /// inside the cranium (whose top is at v = 155).
    #[test]
    fn the_frontal_hair_follows_the_photos_outline() {
        let top_of = |outline: Option<[f32; 2]>| {
            let style = HairStyle {
                outline,
                ..HairStyle::default()
            };
            (100i32..260)
                .filter(|&v| sample(View::Frontal, &style, 0.0, v as f32).hair > 0.0)
                .max()
                .unwrap_or(0)
        };
        assert!((top_of(Some([100.0, 200.0])) - 200).abs() <= 2);
        assert!((top_of(Some([100.0, 180.0])) - 180).abs() <= 2);
        assert!(
            (top_of(Some([60.0, 120.0])) - 158).abs() <= 2,
            "not inside the cranium"
        );
        let wide = HairStyle {
            outline: Some([130.0, 180.0]),
            ..HairStyle::default()
        };
        assert!(sample(View::Frontal, &wide, 125.0, 60.0).hair > 0.0);
        assert!(sample(View::Frontal, &HairStyle::default(), 125.0, 60.0).hair == 0.0);
    }

    /// A photo's silhouette is the frontal hair's outline: hair exactly where its signed
    /// distance is positive (a disc of hair over the head's top and one temple here), higher
    /// inside than at its edge; a fringe only over the forehead inside it, never below the
    /// brows.
    #[test]
    fn the_frontal_hair_is_the_photos_silhouette() {
        use crate::person::{HairMask, MASK_COLS, MASK_ROWS};
        let mut share = [[0.0; MASK_COLS]; MASK_ROWS];
        for (r, row) in share.iter_mut().enumerate() {
            for (c, x) in row.iter_mut().enumerate() {
                let [s, t] = HairMask::centre(r, c);
                *x = if s.hypot(t + 0.75) < 0.55 { 1.0 } else { 0.0 };
            }
        }
        let style = HairStyle {
            silhouette: Some(Silhouette::from_mask(
                &HairMask { share },
                &HairStyle::default(),
                0.0,
            )),
            ..HairStyle::default()
        };
        let sil = style.silhouette.expect("set");
        let mut checked = 0;
        for k in 0..60 {
            for j in 0..60 {
                let (u, v) = (-150.0 + 5.0 * k as f32, -100.0 + 5.0 * j as f32);
                let d = sil.at(u, v);
                if d.abs() < 1.0 {
                    continue;
                }
                let hair = frontal(&style, u, v).hair > 0.0;
                assert_eq!(hair, d > 0.0, "({u}, {v}): distance {d}");
                checked += 1;
            }
        }
        assert!(checked > 3000);
        let centre_v = 30.0 + 0.75 * 115.0;
        let at = |u: f32| frontal(&style, u, centre_v).height;
        assert!(
            at(0.0) > at(60.0) - 1.0 && at(55.0) > at(62.0),
            "rounded from the edge"
        );
        assert!(fringe(&style, 0.0, 80.0) > 2.0, "over the forehead");
        assert_eq!(fringe(&style, 0.0, 40.0), 0.0, "below the brows");
        assert_eq!(fringe(&style, 0.0, 200.0), 0.0, "beyond the outline");
        assert_eq!(
            fringe(&HairStyle::default(), 0.0, 80.0),
            0.0,
            "no photo, no fringe"
        );
    }

    /// Long hair falls where a photo's fall says (between its rows' reaches), else in the
    /// template's own band.
    #[test]
    fn long_hair_falls_where_the_photos_falls() {
        let mut fall = [[0.0f32; 2]; crate::person::FALL_ROWS];
        for row in fall.iter_mut().take(12) {
            *row = [60.0, 100.0];
        }
        let own = HairStyle {
            end: -220.0,
            fall: Some(fall),
            ..HairStyle::default()
        };
        let band = HairStyle { fall: None, ..own };
        let hair =
            |style: &HairStyle, u: f32, v: f32| sample(View::Frontal, style, u, v).hair > 0.0;
        // v = -100 is 1.13 face lengths below the eyes (row 5).
        assert!(hair(&own, 65.0, -100.0) && hair(&own, 95.0, -100.0));
        assert!(!hair(&own, 110.0, -100.0) && !hair(&own, 55.0, -100.0));
        assert!(
            !hair(&band, 65.0, -100.0),
            "the template's band starts further out"
        );
        assert!(hair(&band, 110.0, -100.0));
    }

    #[test]
    fn bald_heads_have_no_hair_and_long_hair_falls_to_the_shoulders() {
        let bald = HairStyle {
            bald: true,
            ..HairStyle::default()
        };
        let long = HairStyle {
            end: -220.0,
            ..HairStyle::default()
        };
        for view in [View::Profile, View::Frontal] {
            let hair_in = |style: &HairStyle, v0: i32, v1: i32| {
                (v0..v1)
                    .step_by(4)
                    .flat_map(|v| (-250..350).step_by(4).map(move |u| (u, v)))
                    .filter(|&(u, v)| sample(view, style, u as f32, v as f32).hair > 0.0)
                    .count()
            };
            assert_eq!(hair_in(&bald, -400, 250), 0, "{view:?}");
            assert_eq!(hair_in(&HairStyle::default(), -200, -100), 0, "{view:?}");
            assert!(hair_in(&long, -200, -100) > 100, "{view:?}");
            assert!(hair_in(&long, -300, -230) == 0, "{view:?}: ends at its end");
        }
    }

    #[test]
    fn smooth_max_keeps_the_ground_and_joins_smoothly() {
        assert_eq!(smooth_max(0.0, 0.0, 12.0), 0.0);
        assert_eq!(smooth_max(0.0, 5.0, 12.0), 5.0);
        assert_eq!(smooth_max(40.0, 10.0, 12.0), 40.0);
        let joined = smooth_max(30.0, 30.0, 12.0);
        assert!(joined > 30.0 && joined <= 33.0, "{joined}");
    }

    #[test]
    fn ear_has_a_rim_and_a_hollow() {
        let rim = ear(121.0 + 15.0, 8.0 + 3.0).unwrap();
        let hollow = ear(121.0 - 4.0, 8.0 - 1.0).unwrap();
        assert!(rim > hollow + 4.0, "rim {rim} hollow {hollow}");
        assert!(ear(121.0 + 30.0, 8.0).is_none());
    }

    /// Snail curls and the stipple stay within a lock's range and are continuous (no step
    /// between neighbouring samples, which the relief would show as a seam), and each curl
    /// has its drilled centre below its rim.
    #[test]
    fn curls_and_stipple_are_continuous_and_in_range() {
        for size in [14.0f32, 17.0, 20.0] {
            let (mut lo, mut hi, mut jump) = (f32::INFINITY, f32::NEG_INFINITY, 0f32);
            for row in 0..40 {
                let v = -100.0 + 5.3 * row as f32;
                let mut last = snail_curls(-100.0, v, size);
                for k in 1..4000 {
                    let h = snail_curls(-100.0 + 0.05 * k as f32, v, size);
                    (lo, hi) = (lo.min(h), hi.max(h));
                    jump = jump.max((h - last).abs());
                    last = h;
                }
            }
            assert!(lo >= -6.0 && hi <= 5.5, "size {size}: {lo:.2}..{hi:.2}");
            assert!(jump < 0.8, "size {size}: a step of {jump:.2} mm in 0.05 mm");
            // A curl's centre (the grid's, unjittered at most 12 % of a step) is drilled.
            let ([du, dv], _, _) = nearest_centre(3.0, 4.0, size, 0.12);
            let (cu, cv) = (3.0 - du, 4.0 - dv);
            let rim = (0..12)
                .map(|k| {
                    let a = std::f32::consts::TAU * k as f32 / 12.0;
                    snail_curls(cu + 0.15 * size * a.cos(), cv + 0.15 * size * a.sin(), size)
                })
                .fold(f32::NEG_INFINITY, f32::max);
            assert!(snail_curls(cu, cv, size) < rim - 1.0, "size {size}");
        }
        let (mut lo, mut hi, mut jump) = (f32::INFINITY, f32::NEG_INFINITY, 0f32);
        let mut last = stipple(0.0, 7.0, 8.0);
        for k in 1..4000 {
            let h = stipple(0.05 * k as f32, 7.0, 8.0);
            (lo, hi) = (lo.min(h), hi.max(h));
            jump = jump.max((h - last).abs());
            last = h;
        }
        assert!(lo >= -0.6 && hi <= 1.6 && hi - lo > 1.0, "{lo:.2}..{hi:.2}");
        assert!(jump < 0.3, "{jump:.2}");
    }

    /// The carving changes the hair's surface only: the same hair outline in every view,
    /// the face and bust untouched, and a crop standing lower than curls.
    #[test]
    fn the_carving_changes_only_the_hairs_surface() {
        let locks = HairStyle::default();
        let curls = HairStyle {
            carving: HairCarving::Curls,
            ..locks
        };
        let crop = HairStyle {
            carving: HairCarving::Stippled,
            volume: 4.0,
            ..locks
        };
        for view in [View::Profile, View::Frontal] {
            let (mut differ, mut hair) = (0, 0);
            for v in (-250..250).step_by(5) {
                for u in (-200..300).step_by(5) {
                    let (u, v) = (u as f32, v as f32);
                    let (a, b) = (sample(view, &locks, u, v), sample(view, &curls, u, v));
                    if a.hair == 0.0 && b.hair == 0.0 {
                        assert_eq!(a.height, b.height, "{view:?} off the hair at {u}, {v}");
                    } else {
                        hair += 1;
                        differ += usize::from((a.height - b.height).abs() > 0.1);
                    }
                }
            }
            assert!(
                differ > hair / 2,
                "{view:?}: {differ} of {hair} hair samples differ"
            );
        }
        let top = |style: &HairStyle| sample(View::Frontal, style, 0.0, 140.0).height;
        assert!(
            top(&crop) < top(&curls),
            "crop {} curls {}",
            top(&crop),
            top(&curls)
        );
    }

    /// In profile the crown stands as high as the photo's hair (its outline's top), never
    /// lower than just over the cranium; without a photo, by the volume as before.
    #[test]
    fn the_profile_crown_follows_the_photos_hair_top() {
        let top_of = |style: &HairStyle| {
            (0..400)
                .map(|k| k as f32 * 0.5)
                .filter(|&v| {
                    (60..200).any(|u| sample(View::Profile, style, u as f32, v).hair > 0.0)
                })
                .fold(f32::NEG_INFINITY, f32::max)
        };
        let plain = HairStyle::default();
        let tall = HairStyle {
            outline: Some([100.0, 195.0]),
            ..plain
        };
        let flat = HairStyle {
            outline: Some([90.0, 120.0]),
            ..plain
        };
        assert!((top_of(&plain) - 167.0).abs() < 3.0, "{}", top_of(&plain));
        assert!((top_of(&tall) - 195.0).abs() < 3.0, "{}", top_of(&tall));
        let least = PROFILE_HAIR_CENTRE_V + PROFILE_CROWN_MIN;
        assert!((top_of(&flat) - least).abs() < 3.0, "{}", top_of(&flat));
    }

    /// Facial hair is cut as the hair is: a stubble-length beard stippled, curly hair's beard
    /// in curls, otherwise locks; each within the few millimetres a beard's surface carries.
    #[test]
    fn the_beard_is_cut_as_the_hair_is() {
        let locks = HairStyle {
            beard: 9.0,
            ..HairStyle::default()
        };
        let curls = HairStyle {
            carving: HairCarving::Curls,
            ..locks
        };
        let stubble = HairStyle {
            beard: 3.0,
            ..curls
        };
        let along = |style: &HairStyle| -> Vec<f32> {
            (0..400)
                .map(|k| beard_texture(style, -20.0 + 0.1 * k as f32, -60.0 + 0.037 * k as f32))
                .collect()
        };
        let (l, c, s) = (along(&locks), along(&curls), along(&stubble));
        for v in l.iter().chain(&c).chain(&s) {
            assert!((-1.5..=2.5).contains(v), "{v}");
        }
        let differ = |a: &[f32], b: &[f32]| {
            a.iter()
                .zip(b)
                .filter(|(x, y)| (*x - *y).abs() > 0.2)
                .count()
        };
        assert!(differ(&l, &c) > 100 && differ(&c, &s) > 100 && differ(&l, &s) > 100);
    }
}

#[cfg(test)]
mod shoulder_tests {
    use super::*;

    /// The smooth minimum is the minimum away from the corner and rounds it within `k`.
    #[test]
    fn smooth_min_rounds_only_the_corner() {
        assert_eq!(smooth_min(10.0, 80.0, 40.0), 10.0);
        assert_eq!(smooth_min(80.0, 10.0, 40.0), 10.0);
        assert!(smooth_min(20.0, 20.0, 40.0) < 20.0 - 5.0);
        assert!(smooth_min(20.0, 30.0, 40.0) < 20.0);
    }

    /// The frontal shoulder's outer top corner is rounded: 12 mm inside both its top line and
    /// its side it stands under 0.4 of its height 12 mm inside the top line alone, nearer the neck (a box's
    /// corner would stand as high).
    #[test]
    fn the_frontal_shoulder_has_a_rounded_corner() {
        let line = |u: f32| -105.0 - 0.0042 * (u.abs() - 45.0).max(0.0).powi(2);
        let corner = frontal_body(150.0 - 12.0, line(138.0) - 12.0);
        let top = frontal_body(115.0, line(115.0) - 12.0);
        println!("corner {corner:.1} mm, top {top:.1} mm");
        assert!(
            corner > 0.0 && corner < 0.4 * top,
            "corner {corner}, top {top}"
        );
    }
}
