//! The person around the face, read from the photo: where the hair is, how far it stands out
//! from the skull, how long it falls, whether it is straight or curled, and whether there is a
//! beard or a moustache. 68 landmarks say nothing of these, and at a cameo's size they are
//! most of what makes a person recognisable.
//!
//! Method: the photo is resampled into the *head frame*, then every pixel is labelled
//! background, skin or hair by colour models (Gaussian mixtures, refitted a few times as in
//! GrabCut) weighted by where each is likely to be around a head and, when there is one, by a
//! person segmentation ([`PersonMask`], MediaPipe's selfie network run by
//! `detect::PersonSegmenter`: it knows a wall from hair of the same colour, though not a hat or
//! a hand from the person), with the posteriors smoothed before each decision. Skin is
//! learnt from the cheeks and nose, background from the frame's far corners and the photo's
//! edges, hair from the crown and temples where they are neither. Facial hair is what is
//! hair-labelled, darker or greyer than the skin inside the chin's, jaw's and upper lip's
//! regions; glasses are their bridge's thin line across the nose, dark lenses or a thick
//! frame's dark bar (`glasses`, read at the photo's own resolution).
//!
//! Frame and units: origin midway between the eyes' centres, `s` along the eye line towards
//! the image-right eye, `t` perpendicular to it down the face, both in inter-ocular distances
//! (IOD, the eyes' centres apart, about 63 mm on an adult). Pure computation.
//!
//! Length: about 900 lines, most of it [`analyse_shaded`], one pass read top to bottom: every
//! decision (skin, hair, beard, moustache, glasses, hat, ears, the crown) reads the same head-frame
//! canvas and its labels, and each is measured against the others (a beard is dark below the
//! mouth only where it is not hair); the readers with their own state are the submodules.

mod canvas;
mod colour;
mod glasses;
mod hat;
mod kind;
mod silhouette;
mod stubble;
mod traits;

use image::RgbImage;

use canvas::Canvas;
pub(crate) use colour::inside;
use colour::*;
pub use glasses::{DARK_LENSES, GLASSES_BRIDGE, GLASSES_DIP, Glasses};
pub use hat::HAT;
pub use kind::{CROP_SIDES, CROP_TOP, HairKind, TEXTURED, Texture};
pub use silhouette::{HairMask, MASK_COLS, MASK_ROWS, MASK_S, MASK_STEP, MASK_T};
pub use stubble::{STUBBLE, Stubble};
pub(crate) use traits::median;
use traits::*;
pub use traits::{CURTAIN, FALL_ROWS, FALL_STEP, FALL_TOP};

/// Head-frame extent of the analysis canvas, IOD.
const S_RANGE: (f32, f32) = (-3.6, 3.6);
const T_RANGE: (f32, f32) = (-3.4, 6.0);
/// How far (squared Mahalanobis) from the hair's colours a chest colour must be to be learnt
/// as clothes.
const CLOTHES_NOT_HAIR: f32 = 9.0;
/// Canvas pixel, IOD.
const RES: f32 = 0.04;
/// Canvas pixels a thread takes at least when per-pixel work is spread over the cores.
const PAR_PIXELS: usize = 2048;
/// How unlike the face's skin (squared Mahalanobis distance) a colour of the crown must be to
/// seed the hair's model; in a black-and-white photo, where only brightness tells them apart,
/// less (a grey or fair head otherwise read bald: on black-and-white copies of the labelled
/// photos, 48 of 175 heads with hair were; BENCHMARKS.md, issue #38).
const HAIR_SEED_D2: f32 = 14.0;
const GREY_HAIR_SEED_D2: f32 = 6.0;
/// In a black-and-white photo, how far (IOD) skin beside the face may lie inside the head's
/// hair to be taken for its inner part, and from where beside the face (times the face's
/// half-width).
const GREY_FILL_REACH: f32 = 0.8;
const GREY_FILL_BESIDE: f32 = 0.9;

/// Whether the photo's pixels on the canvas (`valid`) carry no colour: its chroma axes under
/// half a grey level in 99 % of them.
fn black_and_white(col: &[Colour], valid: &[bool]) -> bool {
    let (mut seen, mut grey) = (0usize, 0usize);
    for (c, _) in col.iter().zip(valid).filter(|(_, v)| **v) {
        seen += 1;
        grey += usize::from(c[1].abs() < 0.002 && c[2].abs() < 0.002);
    }
    seen > 0 && grey * 100 >= seen * 99
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum PersonError {
    #[error("expected 68 landmarks, got {0}")]
    Landmarks(usize),
    #[error("landmark {0} is not a finite point")]
    NonFinite(usize),
    #[error("the eyes are {0:.1} pixels apart: too close to read a head from")]
    TooSmall(f32),
}

/// The hair as it is read from the photo (absent: a bald or shaved head).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hair {
    /// Share of the crown (where a full head of hair grows, above the forehead) that is hair.
    pub crown: f32,
    /// How far the hair stands above the skull's top, in face lengths (eyes to chin, the mouth
    /// closed).
    pub top: f32,
    /// How far it stands out beside the temples beyond the skull, in face lengths.
    pub sides: f32,
    /// Its outline: how high its top is above the eyes, in face lengths.
    pub height: f32,
    /// Its outline: its half-width at the temples (the widest row between the brows and the
    /// eyes, the wider side), in face lengths.
    pub width: f32,
    /// Where it ends below the eyes, in face lengths: about 0.5 cropped at the ears, 1 at
    /// the chin, 1.8 at the shoulders, more when it falls over them.
    pub length: f32,
    /// How it falls beside the face and below: per row ([`FALL_TOP`], [`FALL_STEP`]) its
    /// nearest and furthest reach from the face's midline, face lengths; `[0, 0]` where it
    /// has ended.
    pub fall: [[f32; 2]; FALL_ROWS],
    /// Its silhouette over the head frame (what the frontal gem's hair outline follows).
    pub mask: HairMask,
    /// How much hair hangs beside the cheeks between the mouth and the chin, in face
    /// half-widths (the wider side's median row): hair that falls past the jaw hangs there
    /// as a curtain; short hair leaves at most a shadowed strip along the cheek.
    pub curtain: f32,
    /// 0 straight .. 1 tight curls (from how little its strands agree in direction at the
    /// photo's resolution, [`Texture::coherence`]).
    pub curl: f32,
    /// Mean brightness 0..1 (grey and blond hair are light).
    pub brightness: f32,
    /// Its texture at the photo's resolution (what its kind is read from).
    pub texture: Texture,
}

/// Hair that ends more than this far below the eyes (face lengths) falls past the chin: long.
pub const LONG_HAIR: f32 = 1.0;

/// How long the hair is, as decided: what a script reading the report, and the labels of
/// `bench/labels/person.tsv`, call it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HairLength {
    /// No hair over the crown (bald or shaved).
    Bald,
    /// Ends above the chin (cropped, short, tied back or up seen from the front).
    Short,
    /// Falls to the chin or beyond ([`LONG_HAIR`]).
    Long,
}

impl HairLength {
    pub fn as_str(self) -> &'static str {
        match self {
            HairLength::Bald => "bald",
            HairLength::Short => "short",
            HairLength::Long => "long",
        }
    }
}

/// The share of the chin that makes a beard. On deepface's 61 photos (12 with beards, from
/// stubble-length to full) bearded chins measure 0.61-1.00, shaven ones 0.03-0.46 (the highest
/// a day's stubble).
pub const BEARD_SHARE: f32 = 0.55;

/// The share of the upper lip that makes a moustache.
pub const MOUSTACHE_SHARE: f32 = 0.5;

/// The person around the face.
#[derive(Clone, Debug, PartialEq)]
pub struct Person {
    pub hair: Option<Hair>,
    /// Share of the chin (below the lower lip) that is beard, 0..1.
    pub beard: f32,
    /// Share of the jaw (round the chin, up to below the cheekbones) that is beard, 0..1: a
    /// full beard's is high, a goatee's or a chin beard's lower.
    pub beard_jaw: f32,
    /// Share of the upper lip's region that is moustache, 0..1.
    pub moustache: f32,
    /// What was measured for glasses (the bridge's thin line, dark lenses, a thick frame's
    /// dark bar); [`Glasses::found`] decides.
    pub glasses: Glasses,
    /// How unlike the hair beside the temples what covers the crown is (`hat`; over
    /// [`HAT`]: a hat, labelled [`Label::Hat`] and left out of the hair).
    pub hat: f32,
    /// The chin's fine detail against the cheeks' (`stubble`).
    pub stubble: Stubble,
    /// The labelled canvas, for pictures and measurement.
    pub labels: Labels,
}

impl Person {
    /// Whether a beard is carved: more than [`BEARD_SHARE`] of the chin is hair-coloured,
    /// or the chin is stubbled ([`Stubble::on_chin`]).
    pub fn has_beard(&self) -> bool {
        self.beard > BEARD_SHARE || self.stubble.on_chin()
    }
    /// Whether the beard is stubble only: found by its texture, not its colour.
    pub fn stubble_only(&self) -> bool {
        self.beard <= BEARD_SHARE && self.stubble.on_chin()
    }
    /// Whether a moustache is carved: more than [`MOUSTACHE_SHARE`] of the upper lip, or a
    /// stubbled one.
    pub fn has_moustache(&self) -> bool {
        self.moustache > MOUSTACHE_SHARE || self.stubble.on_lip()
    }
    /// The hair's length as decided.
    pub fn hair_length(&self) -> HairLength {
        match self.hair {
            None => HairLength::Bald,
            Some(h) if h.length > LONG_HAIR => HairLength::Long,
            Some(_) => HairLength::Short,
        }
    }
    /// The hair's kind as decided (`kind`: its texture and how thick a layer it is).
    pub fn hair_kind(&self) -> HairKind {
        match self.hair {
            None => HairKind::Bald,
            Some(h) => kind::kind(&h.texture, h.top, h.sides, h.length),
        }
    }
    /// Whether a hat covers the crown (its pixels are [`Label::Hat`], not hair).
    pub fn has_hat(&self) -> bool {
        self.hat > HAT
    }
    /// Whether the person wears glasses ([`Glasses::found`]).
    pub fn has_glasses(&self) -> bool {
        self.glasses.found()
    }
}

/// What each canvas pixel was found to be.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Label {
    Outside,
    Background,
    Skin,
    Hair,
    /// Something worn over the hair (`hat`): the hair under it is not seen.
    Hat,
}

/// The head frame's canvas with a label per pixel, and the way back to the photo.
#[derive(Clone, Debug, PartialEq)]
pub struct Labels {
    pub width: usize,
    pub height: usize,
    pub labels: Vec<Label>,
    frame: Frame,
    /// The face's length (eyes to chin, the mouth closed), IOD: the head frame's unit for
    /// comparing a head with a carved one.
    pub face_length: f32,
    /// The face's outline (jaw and brows, iBUG 1-17 and 27-18), head frame, IOD.
    pub face: Vec<[f32; 2]>,
}

impl Labels {
    /// The label at photo pixel (x, y) (`Outside` beyond the canvas).
    pub fn at_pixel(&self, x: f32, y: f32) -> Label {
        self.at_head(self.frame.to_head([x, y]))
    }

    /// The label at head-frame point `[s, t]` (IOD; `Outside` beyond the canvas).
    pub fn at_head(&self, p: [f32; 2]) -> Label {
        canvas_index(self.width, self.height, p).map_or(Label::Outside, |i| self.labels[i])
    }

    /// Whether head-frame point `p` (IOD) is inside the face's outline.
    pub fn in_face(&self, p: [f32; 2]) -> bool {
        inside(&self.face, p)
    }
}

/// The index of the analysis canvas's pixel (`w` x `h`, row-major) at head-frame point
/// `[s, t]` (IOD); `None` beyond it.
fn canvas_index(w: usize, h: usize, [s, t]: [f32; 2]) -> Option<usize> {
    let c = ((s - S_RANGE.0) / RES).floor();
    let r = ((t - T_RANGE.0) / RES).floor();
    (c >= 0.0 && r >= 0.0 && c < w as f32 && r < h as f32).then(|| r as usize * w + c as usize)
}

/// Where the person (head, hair, body, hat, hands) is in the photo as opposed to the background,
/// from a segmentation network: a square grid of probabilities laid axis-aligned over the
/// photo (see [`mask_window`]). It tells hair from a wall of the same colour, which colour
/// alone cannot.
#[derive(Clone, Debug, PartialEq)]
pub struct PersonMask {
    /// Cells per side.
    pub size: usize,
    /// Photo position (pixels) of the grid's top-left corner.
    pub origin: [f32; 2],
    /// A cell's side, photo pixels.
    pub step: f32,
    /// Probability of the person, row-major, `size * size` values in 0..1.
    pub prob: Vec<f32>,
}

impl PersonMask {
    /// A `size` x `size` grid of `step`-pixel cells from `origin` whose probability at each
    /// cell's centre (photo pixels) is `prob(x, y)`: a mask drawn rather than found (tests,
    /// synthetic photos).
    pub fn from_fn(
        size: usize,
        origin: [f32; 2],
        step: f32,
        prob: impl Fn(f32, f32) -> f32,
    ) -> Self {
        let prob = (0..size * size)
            .map(|i| {
                prob(
                    origin[0] + ((i % size) as f32 + 0.5) * step,
                    origin[1] + ((i / size) as f32 + 0.5) * step,
                )
            })
            .collect();
        PersonMask {
            size,
            origin,
            step,
            prob,
        }
    }

    /// The probability at photo pixel `p` (bilinear between cell centres); `None` off the grid
    /// or when the grid is malformed.
    pub fn at(&self, p: [f32; 2]) -> Option<f32> {
        if self.prob.len() != self.size * self.size || self.size == 0 || self.step <= 0.0 {
            return None;
        }
        let gx = (p[0] - self.origin[0]) / self.step - 0.5;
        let gy = (p[1] - self.origin[1]) / self.step - 0.5;
        let last = (self.size - 1) as f32;
        if !(gx >= -0.5 && gy >= -0.5 && gx <= last + 0.5 && gy <= last + 0.5) {
            return None;
        }
        let (gx, gy) = (gx.clamp(0.0, last), gy.clamp(0.0, last));
        let (x0, y0) = (gx as usize, gy as usize);
        let (x1, y1) = ((x0 + 1).min(self.size - 1), (y0 + 1).min(self.size - 1));
        let (fx, fy) = (gx - x0 as f32, gy - y0 as f32);
        let v = |x: usize, y: usize| self.prob[y * self.size + x];
        let top = v(x0, y0) * (1.0 - fx) + v(x1, y0) * fx;
        let bottom = v(x0, y1) * (1.0 - fx) + v(x1, y1) * fx;
        let q = top * (1.0 - fy) + bottom * fy;
        q.is_finite().then(|| q.clamp(0.0, 1.0))
    }
}

/// The photo square a person segmentation should see for this face: centre and side, photo
/// pixels. It covers the analysis canvas (head, hair standing out, shoulders) and is upright,
/// as portrait segmentation networks are trained.
pub fn mask_window(landmarks: &[[f32; 2]]) -> Result<([f32; 2], f32), PersonError> {
    let frame = head_frame(landmarks)?;
    let centre = frame.to_pixel([0.0, 0.5 * (T_RANGE.0 + T_RANGE.1)]);
    let iod = frame.axis[0].hypot(frame.axis[1]);
    Ok((centre, (T_RANGE.1 - T_RANGE.0) * iod))
}

/// The head frame from 68 landmarks, checked.
fn head_frame(landmarks: &[[f32; 2]]) -> Result<Frame, PersonError> {
    if landmarks.len() != 68 {
        return Err(PersonError::Landmarks(landmarks.len()));
    }
    if let Some(i) = landmarks
        .iter()
        .position(|p| !p.iter().all(|v| v.is_finite()))
    {
        return Err(PersonError::NonFinite(i));
    }
    let centre = |r: std::ops::Range<usize>| {
        let n = r.len() as f32;
        let (x, y) = landmarks[r]
            .iter()
            .fold((0.0, 0.0), |(x, y), p| (x + p[0], y + p[1]));
        [x / n, y / n]
    };
    let (le, re) = (centre(36..42), centre(42..48));
    let axis = [re[0] - le[0], re[1] - le[1]];
    let iod = axis[0].hypot(axis[1]);
    if iod < 8.0 {
        return Err(PersonError::TooSmall(iod));
    }
    Ok(Frame {
        origin: [(le[0] + re[0]) / 2.0, (le[1] + re[1]) / 2.0],
        axis,
    })
}

/// The photo's colour at (x, y), pixel centres at whole numbers, bilinear, RGB in 0..1; a
/// point beyond the photo takes its nearest edge. The image must not be empty.
pub fn bilinear_rgb(img: &RgbImage, x: f32, y: f32) -> [f32; 3] {
    let (w, h) = img.dimensions();
    let (x, y) = (x.clamp(0.0, (w - 1) as f32), y.clamp(0.0, (h - 1) as f32));
    let (x0, y0) = (x as u32, y as u32);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    let px = |x: u32, y: u32| img.get_pixel(x, y).0.map(|v| f32::from(v) / 255.0);
    let (a, b, c, d) = (px(x0, y0), px(x1, y0), px(x0, y1), px(x1, y1));
    std::array::from_fn(|k| {
        (a[k] * (1.0 - fx) + b[k] * fx) * (1.0 - fy) + (c[k] * (1.0 - fx) + d[k] * fx) * fy
    })
}

/// Photo pixels <-> head frame.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Frame {
    origin: [f32; 2],
    /// Unit eye-line direction times the IOD, in pixels.
    axis: [f32; 2],
}

impl Frame {
    fn to_pixel(self, [s, t]: [f32; 2]) -> [f32; 2] {
        let [ax, ay] = self.axis;
        [
            self.origin[0] + s * ax - t * ay,
            self.origin[1] + s * ay + t * ax,
        ]
    }
    /// The photo's mean `lightness` over the square head-frame cell of side `res` (IOD)
    /// centred at `p`, from `k` x `k` sub-samples: a large photo seen at a canvas's resolution
    /// without aliasing, a small one interpolated.
    fn cell_mean(
        self,
        [s, t]: [f32; 2],
        res: f32,
        k: usize,
        lightness: &dyn Fn(f32, f32) -> f32,
    ) -> f32 {
        let k = k.max(1);
        let mut sum = 0.0;
        for i in 0..k {
            for j in 0..k {
                let ds = ((i as f32 + 0.5) / k as f32 - 0.5) * res;
                let dt = ((j as f32 + 0.5) / k as f32 - 0.5) * res;
                let [x, y] = self.to_pixel([s + ds, t + dt]);
                sum += lightness(x, y);
            }
        }
        sum / (k * k) as f32
    }
    fn to_head(self, [x, y]: [f32; 2]) -> [f32; 2] {
        let [ax, ay] = self.axis;
        let n = ax * ax + ay * ay;
        let (dx, dy) = (x - self.origin[0], y - self.origin[1]);
        [(dx * ax + dy * ay) / n, (-dx * ay + dy * ax) / n]
    }
}

/// Reads the person around the face from an RGB photo and the face's 68 iBUG landmarks
/// (photo pixels), by colour alone.
pub fn analyse(img: &RgbImage, landmarks: &[[f32; 2]]) -> Result<Person, PersonError> {
    analyse_with(img, landmarks, None)
}

/// [`analyse`], with a person segmentation where there is one: what it calls background is
/// not hair nor skin, whatever its colour (a light wall beside white hair, a dark doorway
/// beside dark hair), and the background's colours are learnt from it.
pub fn analyse_with(
    img: &RgbImage,
    landmarks: &[[f32; 2]],
    mask: Option<&PersonMask>,
) -> Result<Person, PersonError> {
    analyse_shaded(img, landmarks, mask, None)
}

/// How the light falls on a face: the brightness its own shape would have at a photo point
/// (pixels) under the photo's light, NaN where it is not known. Closures are one; so is
/// [`crate::photometric::ShadingMap`].
pub trait Shading {
    fn brightness(&self, x: f32, y: f32) -> f32;
}

impl<F: Fn(f32, f32) -> f32> Shading for F {
    fn brightness(&self, x: f32, y: f32) -> f32 {
        self(x, y)
    }
}

/// [`analyse_with`], knowing how the light falls on the face: `shading` gives the brightness
/// the face's own shape would have at a photo point under the photo's light (NaN where it
/// does not know; e.g. a [`crate::photometric::ShadingMap`]). A chin or jaw turned from the
/// light is then expected darker than the cheeks, and only what is darker than that is
/// facial hair: a shadow under the jaw is not a beard.
pub fn analyse_shaded(
    img: &RgbImage,
    landmarks: &[[f32; 2]],
    mask: Option<&PersonMask>,
    shading: Option<&dyn Shading>,
) -> Result<Person, PersonError> {
    let frame = head_frame(landmarks)?;
    let head: Vec<[f32; 2]> = landmarks.iter().map(|p| frame.to_head(*p)).collect();
    // Where the chin is, and the face's length (eyes to chin) with the mouth closed, which
    // sizes the skull: an open mouth drops the chin, not the crown (IOD).
    let chin_y = head[8][1].max(1.0);
    let gap = [(61, 67), (62, 66), (63, 65)]
        .iter()
        .map(|&(u, l)| head[l][1] - head[u][1])
        .sum::<f32>()
        / 3.0;
    let chin = (chin_y - gap.max(0.0)).max(0.5 * chin_y);
    let half = (0.5 * (head[16][0] - head[0][0]).abs()).max(0.7);

    // The canvas.
    let w = ((S_RANGE.1 - S_RANGE.0) / RES) as usize;
    let h = ((T_RANGE.1 - T_RANGE.0) / RES) as usize;
    let pos = |i: usize| {
        [
            S_RANGE.0 + ((i % w) as f32 + 0.5) * RES,
            T_RANGE.0 + ((i / w) as f32 + 0.5) * RES,
        ]
    };
    let (iw, ih) = (img.width() as f32, img.height() as f32);
    let mut rgb = vec![[0f32; 3]; w * h];
    let mut valid = vec![false; w * h];
    let mut border = vec![false; w * h];
    for i in 0..w * h {
        let [x, y] = frame.to_pixel(pos(i));
        if !(x >= 0.0 && y >= 0.0 && x <= iw - 1.0 && y <= ih - 1.0) {
            continue;
        }
        rgb[i] = bilinear_rgb(img, x, y);
        valid[i] = true;
        // Within 2 % of the photo's edge: photographers frame the head with background.
        let m = 0.02 * iw.min(ih);
        border[i] = x < m || y < m || x > iw - 1.0 - m || y > ih - 1.0 - m;
    }
    let col: Vec<Colour> = rgb.iter().map(|p| colour(*p)).collect();
    // A black-and-white photo (no chroma wherever the canvas sees it): only brightness tells
    // grey, fair or white hair from lit skin, so hair is learnt from what is less unlike the
    // skin there.
    let grey_photo = black_and_white(&col, &valid);
    let seed_d2 = if grey_photo {
        GREY_HAIR_SEED_D2
    } else {
        HAIR_SEED_D2
    };
    // The segmentation's probability of the person per canvas pixel (NaN: not known).
    let person: Vec<f32> = (0..w * h)
        .map(|i| {
            mask.and_then(|m| m.at(frame.to_pixel(pos(i))))
                .unwrap_or(f32::NAN)
        })
        .collect();
    // Unknown (NaN) counts as maybe.
    let maybe_person = |i: usize| person[i].is_nan() || person[i] >= 0.5;

    // Regions from the landmarks.
    let face_poly: Vec<[f32; 2]> = (0..=16).chain((17..=26).rev()).map(|k| head[k]).collect();
    let lip_top = head[51][1];
    let in_face: Vec<bool> = (0..w * h).map(|i| inside(&face_poly, pos(i))).collect();
    // The skull: an ellipse from the temples' breadth and the face's length (the eyes sit
    // about halfway down the head).
    let skull = |p: [f32; 2]| {
        let (a, b) = (1.08 * half, 0.98 * chin);
        let ct = 0.02 * chin;
        ((p[0] / a).powi(2) + ((p[1] - ct) / b).powi(2)).sqrt()
    };

    // Seeds.
    // Skin: the nose and the cheeks beside it, above the nose's base (a beard may grow up the
    // cheeks to there) and clear of the face's sides (long hair may hang over them); the
    // darkest (nostrils, a beard's upper edge, shadow beside the nose) left out.
    let nose_base = head[33][1].min(lip_top - 0.08);
    let cheeks = |i: usize| {
        let p = pos(i);
        valid[i] && in_face[i] && p[1] > 0.3 && p[1] < nose_base && p[0].abs() < 0.6 * half
    };
    let mut skin_seed: Vec<Colour> = (0..w * h).filter(|&i| cheeks(i)).map(|i| col[i]).collect();
    let mut ls: Vec<f32> = skin_seed.iter().map(|c| c[0]).collect();
    ls.sort_by(f32::total_cmp);
    if let Some(&median) = ls.get(ls.len() / 2) {
        skin_seed.retain(|c| c[0] > 0.7 * median);
    }
    let skin0 = Gmm::fit(&skin_seed, 2);
    let bg_seed: Vec<Colour> = (0..w * h)
        .filter(|&i| {
            let p = pos(i);
            // The photo's edges away from the head (a tight crop cuts through the hair).
            // (Seeding the background from what a segmentation calls background as well
            // thins the model's dark colours, and dark clothes below the chin become hair.)
            valid[i]
                && (border[i] && p[1] < chin_y && skull(p) > 1.5
                    || skull(p) > 2.1 && p[1] < 0.5 * chin)
        })
        .map(|i| col[i])
        .collect();
    let bg0 = Gmm::fit(&bg_seed, 3);
    let crown_band = |p: [f32; 2]| {
        let r = skull(p);
        (0.7..1.05).contains(&r) && p[1] < -0.45 * chin
            || (p[0].abs() > half * 0.98 && p[0].abs() < half * 1.2 && (-0.9..-0.1).contains(&p[1]))
    };
    let crown_pixels = (0..w * h)
        .filter(|&i| valid[i] && crown_band(pos(i)))
        .count();
    let enough = (crown_pixels / 12).max(30);
    // A person's pixel whose colour is not the face's skin.
    let person_not_skin = |i: usize| {
        valid[i] && maybe_person(i) && skin0.as_ref().is_none_or(|g| g.d2(col[i]) > seed_d2)
    };
    let unlike_skin = |i: usize| person_not_skin(i) && crown_band(pos(i));
    // Hair is what is neither skin nor background there; when that leaves too little, hair
    // and background share a colour and only skin is ruled out (where it lies then decides).
    let mut hair_seed: Vec<Colour> = (0..w * h)
        .filter(|&i| unlike_skin(i) && bg0.as_ref().is_none_or(|g| g.d2(col[i]) > 6.0))
        .map(|i| col[i])
        .collect();
    if hair_seed.len() < enough {
        hair_seed = (0..w * h)
            .filter(|&i| unlike_skin(i))
            .map(|i| col[i])
            .collect();
    }

    let below_chin = |p: [f32; 2]| p[1] > chin_y * 1.05;
    // Where each class is likely to be, before colour: [background, skin, hair]; a
    // segmentation's verdict weighs on it outside the face (softly: its own edge is blurred).
    let prior: Vec<[f32; 3]> = (0..w * h)
        .map(|i| {
            let p = pos(i);
            let r = skull(p);
            let [b, s, h] = if in_face[i] {
                return [0.04, 0.86, 0.10];
            } else if below_chin(p) {
                // Below the chin: neck near the middle, clothes and background, long hair.
                let neck = (p[0].abs() < 0.75 * half) as u8 as f32;
                [0.55 - 0.2 * neck, 0.1 + 0.3 * neck, 0.35 - 0.1 * neck]
            } else if r < 1.0 {
                [0.1, 0.35, 0.55]
            } else {
                let hair = (0.5 - 0.5 * (r - 1.0)).clamp(0.12, 0.5);
                [0.92 - hair, 0.08, hair]
            };
            let q = person[i];
            if !q.is_finite() {
                return [b, s, h];
            }
            // Below the chin the person is mostly clothes, which count as background here (the
            // clothes model below tells only clothes unlike the hair): there only what the
            // segmentation is sure is background rules hair and skin out.
            let (b, s, h) = if below_chin(p) {
                let f = (10.0 * q).clamp(0.05, 1.0);
                (b, s * f, h * f)
            } else {
                (b * (1.02 - q), s * (q + 0.02), h * (q + 0.02))
            };
            let z = b + s + h;
            [b / z, s / z, h / z]
        })
        .collect();

    let mut skin = skin0.clone();
    let mut bg = bg0;
    // Hair is learnt from what is not skin where a full head grows (it may be the
    // background's colour: then where it is decides); with almost nothing there, the head
    // is bald or shaved.
    let bald = hair_seed.len() < enough;
    let mut hair = if bald { None } else { Gmm::fit(&hair_seed, 2) };
    // Clothes: the middle of the chest below the neck, where the person is (or nothing says
    // otherwise), neither the skin of the neck or a neckline nor the hair's colour (long hair
    // falls beside the chest, and a colour shared with the hair is left to where it lies).
    // Below the chin they count as background: a dark suit is not long hair. They weigh only
    // on the last labelling, after the models are learnt (learning with them lets the
    // background's model drift: a hoodie became hair).
    let clothes_seed: Vec<Colour> = (0..w * h)
        .filter(|&i| {
            let p = pos(i);
            person_not_skin(i)
                && p[1] > chin_y + 0.8 * chin
                && p[0].abs() < 0.8 * half
                && hair
                    .as_ref()
                    .is_none_or(|g| g.d2(col[i]) > CLOTHES_NOT_HAIR)
        })
        .map(|i| col[i])
        .collect();
    let clothes = if clothes_seed.len() >= 30 {
        Gmm::fit(&clothes_seed, 2)
    } else {
        None
    };
    let mut labels = vec![Label::Outside; w * h];
    const ROUNDS: usize = 4;
    for round in 0..ROUNDS {
        let last = round + 1 == ROUNDS;
        // Each pixel's posterior alone: spread over the cores (the photo waits on it).
        let each = crate::par::map(w * h, PAR_PIXELS, |i| {
            if !valid[i] {
                return [0f32; 3];
            }
            let mut ll = [&bg, &skin, &hair].map(|g| {
                g.as_ref()
                    .map_or(f32::NEG_INFINITY, |g| g.log_pdf(col[i]).max(-60.0))
            });
            if let Some(c) = clothes.as_ref().filter(|_| last && below_chin(pos(i))) {
                ll[0] = ll[0].max(c.log_pdf(col[i]).max(-60.0));
            }
            let lp: [f32; 3] = std::array::from_fn(|c| prior[i][c].ln() + ll[c]);
            let m = lp.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            let e: [f32; 3] = std::array::from_fn(|c| (lp[c] - m).exp());
            let z: f32 = e.iter().sum();
            e.map(|e| e / z)
        });
        let post: [Vec<f32>; 3] = std::array::from_fn(|c| {
            box_blur(&each.iter().map(|p| p[c]).collect::<Vec<_>>(), w, h, 2)
        });
        for i in 0..w * h {
            labels[i] = if !valid[i] {
                Label::Outside
            } else if post[2][i] > post[0][i] && post[2][i] > post[1][i] {
                Label::Hair
            } else if post[1][i] >= post[0][i] {
                Label::Skin
            } else {
                Label::Background
            };
        }
        if last {
            break;
        }
        let of = |l: Label, keep: &dyn Fn(usize) -> bool| -> Vec<Colour> {
            (0..w * h)
                .filter(|&i| labels[i] == l && keep(i))
                .map(|i| col[i])
                .collect()
        };
        // Skin learnt around the face only (a beige wall far away is not the person).
        if let Some(g) = Gmm::fit(&of(Label::Skin, &|i| skull(pos(i)) < 1.3), 2) {
            skin = Some(g);
        }
        if let Some(g) = Gmm::fit(&of(Label::Background, &|_| true), 4) {
            bg = Some(g);
        }
        if !bald {
            hair = Gmm::fit(&of(Label::Hair, &|i| skull(pos(i)) < 2.0 && !in_face[i]), 3);
        }
    }

    // Hair is what is connected to the crown or the temples; the rest (dark clothes, a dark
    // doorway) is background.
    let mut keep = vec![false; w * h];
    let mut stack: Vec<usize> = (0..w * h)
        .filter(|&i| labels[i] == Label::Hair && crown_band(pos(i)))
        .collect();
    for &i in &stack {
        keep[i] = true;
    }
    while let Some(i) = stack.pop() {
        let (x, y) = (i % w, i / w);
        let around = [
            (x > 0).then(|| i - 1),
            (x + 1 < w).then(|| i + 1),
            (y > 0).then(|| i - w),
            (y + 1 < h).then(|| i + w),
        ];
        for j in around.into_iter().flatten() {
            // Hair stands at most about 0.8 skull radii out (a big afro); beyond is a wall.
            let far = skull(pos(j)) > 1.8 && pos(j)[1] < chin_y;
            if !keep[j] && labels[j] == Label::Hair && !in_face[j] && !far {
                keep[j] = true;
                stack.push(j);
            }
        }
    }
    // Facial hair: inside the face, hair-labelled pixels count; elsewhere only connected hair.
    for i in 0..w * h {
        if labels[i] == Label::Hair && !keep[i] && !in_face[i] {
            labels[i] = Label::Background;
        }
    }
    // In black and white, grey hair as bright as the lit skin is labelled skin, and the head's
    // hair floats off it (the bundled Einstein). Beside the face and above the ears (the band
    // where an ear's bare skin is read, below, is left alone), skin with the head's hair further
    // out along the ray from the head's centre, within GREY_FILL_REACH, is that hair's inner
    // part; a bald temple has nothing beyond it.
    if grey_photo {
        let centre = [0.0, 0.02 * chin];
        let mut fill = Vec::new();
        for i in 0..w * h {
            let p = pos(i);
            if labels[i] != Label::Skin
                || in_face[i]
                || p[1] > 0.05 * chin
                || p[0].abs() < GREY_FILL_BESIDE * half
            {
                continue;
            }
            let d = [p[0] - centre[0], p[1] - centre[1]];
            let len = d[0].hypot(d[1]).max(1e-6);
            let step = [d[0] / len * RES, d[1] / len * RES];
            for k in 1..=(GREY_FILL_REACH / RES) as usize {
                let q = [p[0] + step[0] * k as f32, p[1] + step[1] * k as f32];
                let Some(j) = canvas_index(w, h, q) else {
                    break;
                };
                if keep[j] {
                    fill.push(i);
                    break;
                }
                if matches!(labels[j], Label::Background | Label::Outside) {
                    break;
                }
            }
        }
        for i in fill {
            labels[i] = Label::Hair;
            keep[i] = true;
        }
    }

    // Facial hair: a region's share of pixels that are hair-labelled, darker than the skin
    // (0.72 of its median lightness) or greyer (under half its median chroma per lightness):
    // stubble, dark beards and grey or white ones alike. Regions clear of the lips' edges and
    // the nostrils, whose shadows are dark on every face.
    let chroma = |c: Colour| c[1].hypot(c[2]) / c[0].max(0.02);
    let skin_l = median(skin_seed.iter().map(|c| c[0]).collect()).unwrap_or(0.5);
    let skin_chroma = median(skin_seed.iter().map(|c| chroma(*c)).collect()).unwrap_or(0.1);
    // The light's share per canvas pixel, relative to the skin's seed region (NaN where not
    // known): a place the light is expected to leave at 0.6 of the cheeks' brightness is
    // facial hair only below 0.6 of the darkness threshold.
    let light: Vec<f32> = match shading {
        Some(f) => {
            let expected: Vec<f32> = (0..w * h)
                .map(|i| {
                    let [x, y] = frame.to_pixel(pos(i));
                    f.brightness(x, y)
                })
                .collect();
            let reference = median(
                (0..w * h)
                    .filter(|&i| cheeks(i) && expected[i].is_finite())
                    .map(|i| expected[i])
                    .collect(),
            );
            match reference {
                Some(r) if r > 0.05 => expected
                    .iter()
                    .map(|e| {
                        if e.is_finite() {
                            (e / r).clamp(0.4, 1.2)
                        } else {
                            f32::NAN
                        }
                    })
                    .collect(),
                _ => vec![f32::NAN; w * h],
            }
        }
        None => vec![f32::NAN; w * h],
    };
    let facial_hair = |i: usize| {
        let known = light[i].is_finite();
        let k = if known { light[i] } else { 1.0 };
        // The colour models label by colour alone, so skin in shadow can look like dark
        // hair: where the light is known, hair-coloured is facial hair only if it is also
        // darker than the skin would be there.
        (labels[i] == Label::Hair && (!known || col[i][0] < skin_l * k))
            || col[i][0] < 0.72 * skin_l * k
            || chroma(col[i]) < 0.5 * skin_chroma
    };
    let share = |poly: &[[f32; 2]]| {
        let (mut n, mut hair) = (0usize, 0usize);
        for i in (0..w * h).filter(|&i| valid[i] && inside(poly, pos(i))) {
            n += 1;
            hair += usize::from(facial_hair(i));
        }
        if n == 0 { 0.0 } else { hair as f32 / n as f32 }
    };
    let toward =
        |a: [f32; 2], b: [f32; 2], t: f32| [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
    // The chin below the lower lip (its top a third of the way down to the chin, below the
    // shadow under the lip), between the jaw's points beside the chin.
    let below_lip = |k: usize| [head[k][0], toward(head[k], head[8], 0.3)[1]];
    let chin_poly: Vec<[f32; 2]> = [59, 58, 57, 56, 55]
        .into_iter()
        .map(below_lip)
        .chain([10, 9, 8, 7, 6].map(|k| head[k]))
        .collect();
    // The jaw: from below the cheekbones round the chin, under the mouth.
    let jaw_poly: Vec<[f32; 2]> = (4..=12)
        .chain([54, 55, 56, 57, 58, 59, 48])
        .map(|k| head[k])
        .collect();
    // The upper lip between the nose's base and the lip, its top clear of the nostrils.
    let lip_poly: Vec<[f32; 2]> = [48, 49, 50, 51, 52, 53, 54]
        .map(|k| toward(head[k], head[33], 0.15))
        .into_iter()
        .chain([35, 34, 33, 32, 31].map(|k| toward(head[k], head[51], 0.35)))
        .collect();
    let beard = share(&chin_poly);
    let beard_jaw = share(&jaw_poly);
    let moustache = share(&lip_poly);

    // Glasses (a thick frame's cue; the thin ones are read in `glasses`): their bridge
    // crosses the nose between the eyes, a dark bar where the nose's bridge is otherwise lit
    // skin. Each canvas row's mean lightness between the eyes' inner
    // corners, from a little above the eyes (t = -0.3) to the bridge's lower end (t = 0.15);
    // how far the darkest dips below the median row (a shadow over the whole band does not).
    let bridge_x = 0.45 * 0.5 * (head[42][0] - head[39][0]).abs();
    let first = ((-0.3 - T_RANGE.0) / RES - 0.5).round() as usize;
    let mut means = Vec::new();
    for row in first..(first + (0.45 / RES) as usize).min(h) {
        let (mut sum, mut n) = (0.0, 0);
        for i in (row * w..(row + 1) * w).filter(|&i| valid[i] && pos(i)[0].abs() < bridge_x) {
            sum += col[i][0];
            n += 1;
        }
        if n > 0 {
            means.push(sum / n as f32);
        }
    }
    let darkest = means.iter().copied().fold(f32::INFINITY, f32::min);
    let typical = median(means.clone()).unwrap_or(0.0);
    let dip = if darkest.is_finite() && typical > 0.0 {
        (1.0 - darkest / typical).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let iod = frame.axis[0].hypot(frame.axis[1]);
    let lightness = |x: f32, y: f32| {
        let [r, g, b] = bilinear_rgb(img, x, y);
        0.299 * r + 0.587 * g + 0.114 * b
    };
    let glasses = Glasses {
        dip,
        ..glasses::measure(frame, iod, &lightness)
    };
    // Stubble: the chin's fine detail against the upper cheeks' (beside the nose, below the
    // eyes' shadow, above where a beard grows).
    let chin_region = |p: [f32; 2]| inside(&chin_poly, p);
    let cheek_region = |p: [f32; 2]| {
        inside(&face_poly, p)
            && (0.3..0.6 * half).contains(&p[0].abs())
            && p[1] > 0.35
            && p[1] < nose_base
    };
    let lip_region = |p: [f32; 2]| inside(&lip_poly, p);
    let stubble = stubble::measure(
        frame,
        iod,
        &lightness,
        &chin_region,
        &lip_region,
        &cheek_region,
    );

    // The scalp's hair is measured without the face, nor a beard's (below the nose's base,
    // within the jaw's breadth, where it joins the sideburns and hangs under the chin; long
    // hair falls beside the face and behind).
    let cheeks = head[33][1];
    let not_scalp: Vec<bool> = (0..w * h)
        .map(|i| {
            let p = pos(i);
            in_face[i] || (beard > BEARD_SHARE && p[1] > cheeks && p[0].abs() < 1.15 * half)
        })
        .collect();
    // A hat over the hair: its pixels leave the hair (the hair under it is not seen).
    // The canvas the hat and the hair's traits read, with the labels of the moment.
    let unlabelled = Canvas {
        labels: &[],
        w,
        h,
        pos: &pos,
        in_face: &not_scalp,
        skull: &skull,
        chin,
        half,
    };
    let canvas = Canvas {
        labels: &labels,
        ..unlabelled
    };
    let (hat, worn) = hat::read(&canvas, &col);
    for i in worn {
        labels[i] = Label::Hat;
    }
    // Hair over less than a third of the crown: a bald head (perhaps with a fringe of hair
    // at the sides, which a carver leaves out at this size).
    let hair_traits = (!bald)
        .then(|| {
            let canvas = Canvas {
                labels: &labels,
                ..unlabelled
            };
            traits(&canvas, &col)
        })
        .flatten()
        .filter(|h| h.crown >= 0.33)
        .map(|found| {
            let scalp_hair = |p: [f32; 2]| {
                canvas_index(w, h, p).is_some_and(|i| labels[i] == Label::Hair && !not_scalp[i])
            };
            let texture = kind::measure(frame, iod, &lightness, &scalp_hair);
            Hair {
                texture,
                curl: kind::curl(&texture),
                ..found
            }
        });
    Ok(Person {
        hair: hair_traits,
        beard,
        beard_jaw,
        moustache,
        glasses,
        hat,
        stubble,
        labels: Labels {
            width: w,
            height: h,
            labels,
            frame,
            face_length: chin,
            face: face_poly,
        },
    })
}

#[cfg(test)]
mod test_head;
#[cfg(test)]
mod tests;
