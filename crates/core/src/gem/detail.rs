//! The photo's own detail, carved as a cameo cutter reads a sitter: what 63 shape components
//! cannot say (the brows' line and weight, where the iris sits and how dark it is, the mouth's
//! line, the folds and lines of a face) read from the photo and carried onto the face through
//! the fitted camera.
//!
//! Dark is not deep: a carver raises brows (hair), drills the iris and pupil, cuts the line
//! between the lips, and incises folds and lines; a mole, a freckle or a shadow on the cheek is
//! left alone. So the photo is not turned into height as it is; it is read per region (from
//! the 68 landmarks):
//! * **brows**: along each brow's five points, darker than the skin around = raised;
//! * **eyes**: inside each eye's opening, darker than the eye around = incised (the iris and
//!   pupil, as real cameos drill them);
//! * **mouth**: inside the lips' outline, darker = incised (the line between the lips, the
//!   corners);
//! * **skin** (the rest of the face inside its outline): only *lines* are carved, valleys of
//!   the brightness whose one curvature is much larger than the other (a fold, a wrinkle), as
//!   an incision; round dark spots (moles, pores, nostrils' shadows) have two equal curvatures
//!   and are left out, and so is everything brighter than its surroundings.
//!
//! Besides the regions, for a frontal portrait, the **tone** ([`super::tone`]): the photo's
//! fine light and dark, everywhere on the face, modelled as slopes towards or away from the
//! stone's key light, so the stone under its own light shows the pattern a face is known by
//! (kept apart from the regions' heights: a profile does not carve it); and its darks
//! **stippled**, round pits on a lattice whose size follows the darkness, since one raking
//! light shows only the slope along it, and a dark carved as a slope needs its rise back as a
//! light streak beside it, which the photo does not have. Where the tone is carved, the
//! relief's own forms finer than the tone's band give way to it
//! ([`DetailParams::photo_modelling`]): the fitted face's fine forms shade every gem alike.
//!
//! Every response is a band-pass of the brightness (what changes over a few hundredths of the
//! eyes' distance, not the light across the face) scaled by the face's own contrast (its
//! median absolute deviation), so a dim or low-contrast photo carves as deep as a bright one.
//!
//! Units: photo pixels (x right, y down, whole numbers at pixel centres) in; the map's cells
//! are [`CELLS_PER_IOD`] to the distance between the eyes' centres; heights in canonical
//! millimetres (the frame of [`super::face::Eye::carve`], added to the face before the relief
//! is compressed). Pure computation.

use image::GrayImage;

use super::blur::blur;
use super::template::smoothstep;
pub use super::tone::ToneLight;
use crate::fit::Pose;
use crate::person::{inside, median};
use crate::photo_grid::{bilinear_grey, polyline_distance};

/// Map cells per inter-ocular distance (eye centre to eye centre).
pub const CELLS_PER_IOD: f32 = 64.0;

/// The tone's steepest slope by default (see [`DetailParams::tone`]). 2.25 until the relief's
/// fine forms gave way to it ([`PHOTO_MODELLING`]); then measured at 0.8, 1.2, 1.6, 2.25 and 3
/// on three photo sets by two recognition networks: 1.2 ranks the most gems right by both and
/// brings them nearest their people's other photos (BENCHMARKS.md, issue #37, fourteenth
/// session).
pub const TONE: f32 = 1.2;
/// The tone's band: brightness against its surroundings over this share of the eyes'
/// distance (a Gaussian's sigma).
const TONE_BAND: f32 = 0.16;
/// The tone's weight over the eyes and their lids against the rest of the face's 1.
const TONE_EYES: f32 = 0.6;
/// The ridge off the face that holds the tone's heights at 0 there (per cell squared, against
/// the slope's 1; [`super::tone::fit_slopes`]).
const TONE_HOLD: f32 = 1.0;
/// The stipple's depth by default (see [`DetailParams::stipple_mm`]): about 0.9 gem mm.
/// Measured at 4, 6, 9 and 12 on three photo sets by two recognition networks and without
/// one: deeper brings every gem nearer its person's other photos by both; 9 ranks the most
/// gems right by the held-out network, 12 by the other, and looks heavier, a young face
/// grainy (BENCHMARKS.md, issue #37, ninth session).
pub const STIPPLE: f32 = 9.0;
/// The stipple's band: its darks are the photo's brightness against its surroundings over
/// this share of the eyes' distance (a Gaussian's sigma), narrower than the tone's slopes'
/// ([`TONE_BAND`]): the dark of a lid's crease, a nostril or the lips' line more than the
/// shade around them. Measured at 0.07, 0.1, 0.16 (the tone's) and 0.3 on three photo sets
/// by two recognition networks: at 0.1 the gems come a little nearer their people's other
/// photos on all three by both (BENCHMARKS.md, issue #37, tenth session).
const STIPPLE_BAND: f32 = 0.1;
/// The stipple's lattice: pits this far apart (a share of the eyes' distance, about 0.3 gem
/// mm on the default stone), in rows turned 45 degrees from the photo's axes (the eye finds a
/// screen along the axes first, as in a printer's halftone).
const STIPPLE_SPACING: f32 = 0.0424;
/// How dark (against the strongest dark over [`STIPPLE_BAND`], 1) the photo must be before a
/// pit is cut: the skin's own small variations stay smooth.
const STIPPLE_FROM: f32 = 0.1;
/// How dark (the stipple's measure, 0..1) the photo must be before the stone is sunk into the
/// key light's shadow there ([`DetailParams::shadows`]), and how dark for the shadow's full
/// dark: the strongest darks, a lid's crease, the eye's corners and lashes, a nostril, the
/// lips' line, a frame of glasses. Measured from 0.15 to 0.4 on three photo sets by two
/// recognition networks (BENCHMARKS.md, issue #37, twelfth session).
pub const SHADOW_FROM: f32 = 0.25;
pub const SHADOW_TO: f32 = 0.55;
/// How much of the relief's fine modelling the photo's replaces by default
/// ([`DetailParams::photo_modelling`]). Measured at 0, 0.5, 0.75 and 1 on three photo sets by two
/// recognition networks (BENCHMARKS.md, issue #37, fourteenth session).
pub const PHOTO_MODELLING: f32 = 1.0;
/// How much contrast the tone's match asks of the stone's light against what the carved
/// relief shows before it ([`DetailParams::tone_match`]). Measured at 1, 1.5 and 2 on three
/// photo sets by two recognition networks (BENCHMARKS.md, issue #37, sixteenth session).
pub const TONE_MATCH: f32 = 1.5;

/// How deep the photo's dark lines are engraved by default (see
/// [`DetailParams::engraved_lines_mm`]): about 1 gem mm, as deep as the stipple's darkest
/// pits. Measured at 0, 6, 10 and 15 on three photo sets by two recognition networks: each
/// depth to 10 brings the gems nearer their people's other photos by both, 15 no nearer
/// (BENCHMARKS.md, issue #37, seventeenth session).
pub const ENGRAVED_LINES: f32 = 10.0;

/// How deep each region is carved at full strength (canonical mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DetailParams {
    /// Brows raised.
    pub brow_mm: f32,
    /// Iris and pupil incised.
    pub iris_mm: f32,
    /// The line between the lips incised.
    pub mouth_mm: f32,
    /// Folds and lines incised.
    pub line_mm: f32,
    /// The steepest slope (mm per mm) with which the photo's fine light and dark is modelled
    /// for the stone's key light ([`super::tone`]), carved into the stone after the relief's
    /// compression with its slopes kept; 0: none.
    pub tone: f32,
    /// How deep the darks of that light and dark are stippled (canonical mm): round pits on a
    /// lattice, each as wide as the photo is dark there (its shadowed share follows the
    /// darkness), as a stipple engraver renders tone and as drilled gems (the *a globolo*
    /// style) cut it; carved with the tone, so only in a frontal portrait. 0: none.
    pub stipple_mm: f32,
    /// How deep the photo's dark lines are engraved (canonical mm): the lash line, the lid's
    /// crease, the eyes' corners, the lips' line, the folds, each a narrow groove cut after
    /// the relief's compression (which would flatten it) along the photo's brightness
    /// valleys, as deep as the valley is strong, as an engraver draws a line with the burin
    /// where the stipple's dots cannot (a line narrower than the lattice); carved with the
    /// stipple, so only in a frontal portrait. 0: none.
    pub engraved_lines_mm: f32,
    /// How much of the photo's strongest darks (past [`SHADOW_FROM`]) is cut into the
    /// shadow the relief casts from the key light, 0..1: the stone sunk there under the
    /// shadow's line, as deep into its penumbra as the photo is dark, as a carver sinks an
    /// eye's socket under its brow, so the dark is a cast shadow's with no lit rise inside
    /// it; carved with the tone, so only in a frontal portrait. 0: none.
    pub shadows: f32,
    /// How much of the relief's own modelling finer than the tone's band ([`TONE_BAND`]) the
    /// photo's light and dark replaces where the tone is carved, 0..1. Under the raking key
    /// light the fitted face's fine forms (the nose's sides, the eyes' sockets, the lips'
    /// edges) shade every gem alike, whoever the photo shows (the shape from 68 landmarks is
    /// much alike between people), and cast the same shadows; the photo's own light and dark
    /// there is what tells one person from another. 1: the face's forms broader than the band
    /// stay the relief's, the finer light and dark is the photo's alone; 0: both, added.
    pub photo_modelling: f32,
    /// The carved light and dark matched to the photo's as the stone's own light shows it:
    /// after the tone, the stipple and the shadows are cut, the relief is lit as the renderer
    /// lights it and its slopes along the key light corrected where its band-passed light
    /// differs from the photo's ([`super::closure`]); the value is the contrast asked for
    /// against the one the relief shows (1: the same, the pattern only). 0: none.
    pub tone_match: f32,
}

impl Default for DetailParams {
    /// Brows and irises half as deep again as the carved eye's lids (3 mm,
    /// [`super::face::Eye::carve`]), the line between the lips 3 mm, folds and lines 1.6 mm.
    /// Chosen by two recognition networks on three photo sets, and by eye: deeper brows, eyes
    /// and mouth rank the gems nearer their own person's other photos; deeper lines did too,
    /// a little, but aged and hardened young faces, so they stay (BENCHMARKS.md, issue #37).
    fn default() -> Self {
        DetailParams {
            brow_mm: 4.8,
            iris_mm: 4.8,
            mouth_mm: 3.0,
            line_mm: 1.6,
            tone: TONE,
            stipple_mm: STIPPLE,
            engraved_lines_mm: ENGRAVED_LINES,
            shadows: 1.0,
            photo_modelling: PHOTO_MODELLING,
            tone_match: TONE_MATCH,
        }
    }
}

impl DetailParams {
    /// Every depth times `k`.
    pub fn scaled(self, k: f32) -> Self {
        DetailParams {
            brow_mm: self.brow_mm * k,
            iris_mm: self.iris_mm * k,
            mouth_mm: self.mouth_mm * k,
            line_mm: self.line_mm * k,
            tone: self.tone * k,
            stipple_mm: self.stipple_mm * k,
            engraved_lines_mm: self.engraved_lines_mm * k,
            shadows: self.shadows,
            photo_modelling: self.photo_modelling,
            tone_match: self.tone_match,
        }
    }

    /// The stipple alone `k` times as deep (0: none; `glyptic photo --stipple`, the kiosk's
    /// `stipple`).
    pub fn stipple_scaled(self, k: f32) -> Self {
        DetailParams {
            stipple_mm: self.stipple_mm * k,
            ..self
        }
    }

    /// The engraved lines alone `k` times as deep (0: none; `glyptic photo
    /// --engraved-lines`, the kiosk's `engraved_lines`).
    pub fn engraved_lines_scaled(self, k: f32) -> Self {
        DetailParams {
            engraved_lines_mm: self.engraved_lines_mm * k,
            ..self
        }
    }

    /// The darks' shadows at `share` (0..1; 0: none; `glyptic photo --shadows`).
    pub fn with_shadows(self, share: f32) -> Self {
        DetailParams {
            shadows: share.clamp(0.0, 1.0),
            ..self
        }
    }

    /// The tone matched to the photo's under the stone's light at `gain` (0: not;
    /// `glyptic photo --tone-match`; [`Self::tone_match`]).
    pub fn with_tone_match(self, gain: f32) -> Self {
        DetailParams {
            tone_match: if gain.is_finite() { gain.max(0.0) } else { 0.0 },
            ..self
        }
    }

    /// The relief's fine modelling replaced by the photo's at `share` (0..1;
    /// `glyptic photo --photo-modelling`; [`Self::photo_modelling`]).
    pub fn with_photo_modelling(self, share: f32) -> Self {
        DetailParams {
            photo_modelling: share.clamp(0.0, 1.0),
            ..self
        }
    }
}

/// The detail read from one photo: a height map over a window of the photo, and where each
/// vertex of the fitted face lies in it.
#[derive(Clone, Debug, PartialEq)]
pub struct FaceDetail {
    /// Photo position of cell (0, 0), pixels; photo pixels per cell.
    origin: [f32; 2],
    step: f32,
    cols: usize,
    rows: usize,
    /// Canonical mm per cell, row-major.
    height: Vec<f32>,
    /// The photo's light and dark modelled for the key light of a frontal portrait
    /// (canonical mm per cell, row-major; empty: none read).
    tone: Vec<f32>,
    /// The stipple's pits cut into the tone's darks (canonical mm, 0 or below, row-major;
    /// empty: none cut).
    stipple: Vec<f32>,
    /// How much of the stone is sunk into the key light's shadow there, 0..1
    /// ([`DetailParams::shadows`]; empty: none).
    shadow: Vec<f32>,
    /// The relief's fine modelling the tone replaces: share 0..1 and the band's sigma,
    /// canonical mm ([`DetailParams::photo_modelling`]; `None`: no tone read).
    replaces: Option<(f32, f32)>,
    /// The moles left aside (photo pixels): retouched out before the detail was read.
    moles: Vec<[f32; 2]>,
    /// The photo's log brightness per cell (row-major; empty where the tone is not matched)
    /// and the eyes' distance in canonical mm at the face (`None`: no light seen): what the
    /// carved tone is checked against.
    bright: Vec<f32>,
    iod_mm: Option<f32>,
    /// [`DetailParams::tone_match`] where a tone was read, else 0.
    tone_match: f32,
    /// Per vertex of the face mesh: photo x, y (pixels) and how squarely the photo sees it
    /// (0: turned away or hidden, 1: facing the camera).
    seen: Vec<[f32; 3]>,
}

/// Why no detail was read.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum DetailError {
    #[error("expected 68 finite landmarks")]
    Landmarks,
    #[error("the eyes are too close together ({0:.1} px) to read the face's detail")]
    TooSmall(f32),
    #[error("the photo is empty")]
    EmptyPhoto,
}

impl FaceDetail {
    /// Reads the detail of the face with these 68 landmarks from `photo` (brightness), with
    /// `seen` from [`seen_vertices`]; with `light` (the stone's key light as the photo sees the
    /// face) the photo's fine light and dark is modelled too ([`DetailParams::tone`]).
    pub fn read(
        photo: &GrayImage,
        landmarks: &[[f32; 2]],
        seen: Vec<[f32; 3]>,
        params: &DetailParams,
        light: Option<ToneLight>,
    ) -> Result<Self, DetailError> {
        if landmarks.len() != 68 || landmarks.iter().flatten().any(|v| !v.is_finite()) {
            return Err(DetailError::Landmarks);
        }
        if photo.width() == 0 || photo.height() == 0 {
            return Err(DetailError::EmptyPhoto);
        }
        let iod = crate::identity::eye_distance(landmarks).ok_or(DetailError::Landmarks)?;
        if iod < 8.0 {
            return Err(DetailError::TooSmall(iod));
        }
        let step = iod / CELLS_PER_IOD;
        // The window: the landmarks' box grown by half the eyes' distance (the forehead's
        // lines above the brows, the folds beside the mouth).
        let grid =
            crate::photo_grid::Grid::around(landmarks, step, 0.5 * iod, 0.7 * iod, 0.5 * iod);
        let (origin, cols, rows) = (grid.origin, grid.cols, grid.rows);

        let mut lum = vec![0f32; cols * rows];
        for r in 0..rows {
            for c in 0..cols {
                let [x, y] = grid.centre(c, r);
                lum[r * cols + c] = bilinear_grey(photo, x, y);
            }
        }
        // Regions, in cells.
        let lm: Vec<[f32; 2]> = landmarks.iter().map(|&p| grid.to_cell(p)).collect();
        let iod_c = CELLS_PER_IOD;
        let jaw: Vec<[f32; 2]> = lm[0..17].to_vec();
        // The face's outline: the jaw, then up over the brows lifted by a third of the eyes'
        // distance (the forehead's lower part).
        let mut outline = jaw.clone();
        for k in (17..27).rev() {
            outline.push([lm[k][0], lm[k][1] - 0.35 * iod_c]);
        }
        let grow = |poly: &[[f32; 2]], by: f32| -> Vec<[f32; 2]> {
            let n = poly.len() as f32;
            let c = poly
                .iter()
                .fold([0.0f32; 2], |a, p| [a[0] + p[0] / n, a[1] + p[1] / n]);
            poly.iter()
                .map(|p| {
                    let (dx, dy) = (p[0] - c[0], p[1] - c[1]);
                    let l = dx.hypot(dy).max(1e-3);
                    [p[0] + by * dx / l, p[1] + by * dy / l]
                })
                .collect()
        };
        let eyes = [
            grow(&lm[36..42], 0.03 * iod_c),
            grow(&lm[42..48], 0.03 * iod_c),
        ];
        let mouth = grow(&lm[48..60], 0.04 * iod_c);
        // The eyes with their lids, where the tone is weaker: the carved eye and iris are
        // there, and spectacles' rims and dark lenses carved as light and dark cross them.
        let eyes_wide = [
            grow(&lm[36..42], 0.12 * iod_c),
            grow(&lm[42..48], 0.12 * iod_c),
        ];
        let brows = [&lm[17..22], &lm[22..27]];
        // Moles left aside: small round darks on the skin, away from the features, retouched
        // out of the brightness before anything is read from it ([`super::moles`]).
        let (nose, lips) = (
            grow(&lm[27..36], 0.1 * iod_c),
            grow(&lm[48..60], 0.1 * iod_c),
        );
        // The face's cells (inside the outline), for the moles' skin and the contrast scales.
        let in_face: Vec<bool> = (0..cols * rows)
            .map(|i| inside(&outline, [(i % cols) as f32, (i / cols) as f32]))
            .collect();
        let moles: Vec<[f32; 2]> = super::moles::retouch(&mut lum, cols, rows, |i| {
            let p = [(i % cols) as f32, (i / cols) as f32];
            in_face[i]
                && !eyes_wide.iter().any(|e| inside(e, p))
                && !inside(&nose, p)
                && !inside(&lips, p)
                && brows.iter().all(|b| polyline_distance(b, p) > 0.1 * iod_c)
        })
        .into_iter()
        .map(|[c, r]| grid.centre(c, r))
        .collect();
        // Band-pass: what changes over about 1-8 % of the eyes' distance, never finer than the
        // photo's own pixels (a small face's cells are smaller than its pixels: finer than
        // that is interpolation and compression noise).
        let fine = blur(&lum, cols, rows, 0.8f32.max(1.0 / step));
        let coarse = blur(&lum, cols, rows, 5.0);
        let band: Vec<f32> = fine.iter().zip(&coarse).map(|(f, c)| f - c).collect();
        // The iris against the whole eye: a wider band.
        let wide = blur(&lum, cols, rows, 9.0);
        let eye_band: Vec<f32> = fine.iter().zip(&wide).map(|(f, c)| f - c).collect();
        // Lines: valleys of the brightness, blurred a little (a fold is 2-4 % of the eyes'
        // distance wide).
        let valley = valleys(&blur(&lum, cols, rows, 1.5), cols, rows);

        // Contrast scales over the face: the median absolute band-pass and valley.
        let face_cells: Vec<usize> = (0..cols * rows).filter(|&i| in_face[i]).collect();
        // Floors: a face without texture (a flat drawing, a blown-out photo) is not made to
        // carve its last grey level; 2 % of the brightness range at least.
        let mad = |v: &[f32]| {
            let a: Vec<f32> = face_cells.iter().map(|&i| v[i].abs()).collect();
            median(a).unwrap_or(0.0).max(0.02 / 1.4826 / 3.0)
        };
        let (band_s, eye_s) = (1.4826 * mad(&band), 1.4826 * mad(&eye_band));
        let valley_s = {
            let mut a: Vec<f32> = face_cells.iter().map(|&i| valley[i]).collect();
            let k = (a.len() as f32 * 0.9) as usize;
            if a.is_empty() {
                1.0
            } else {
                let k = k.min(a.len() - 1);
                // A fold 2 % darker than its sides and a few cells wide at least.
                a.select_nth_unstable_by(k, f32::total_cmp).1.max(0.004)
            }
        };

        // Lines: valleys strong against the face's own, in runs long enough to be a fold or a
        // wrinkle (a mole's rim is a short closed loop: dropped).
        let mut line = vec![0f32; cols * rows];
        for &i in &face_cells {
            line[i] = smoothstep(1.0, 2.5, valley[i] / valley_s);
        }
        drop_short_runs(&mut line, cols, rows, 0.15 * iod_c);

        let mut height = vec![0f32; cols * rows];
        for &i in &face_cells {
            let p = [(i % cols) as f32, (i / cols) as f32];
            let dark = (-band[i] / band_s / 3.0).clamp(0.0, 1.0);
            // Brows: within a band about each brow's line, fading at its ends.
            let brow_w = brows
                .iter()
                .map(|b| {
                    let d = polyline_distance(b, p);
                    smoothstep(0.13 * iod_c, 0.06 * iod_c, d)
                })
                .fold(0.0f32, f32::max);
            let eye_w = eyes.iter().any(|e| inside(e, p));
            let mouth_w = inside(&mouth, p);
            let h = if eye_w {
                -params.iris_mm * (-eye_band[i] / eye_s / 3.0).clamp(0.0, 1.0)
            } else if mouth_w {
                -params.mouth_mm * dark
            } else {
                brow_w * params.brow_mm * dark - (1.0 - brow_w) * params.line_mm * line[i]
            };
            height[i] = h;
        }
        let (tone, stipple, shadow) = match light.filter(|_| params.tone > 0.0) {
            Some(light) => {
                let eye_cells: Vec<bool> = (0..cols * rows)
                    .map(|i| {
                        let p = [(i % cols) as f32, (i / cols) as f32];
                        eyes_wide.iter().any(|e| inside(e, p))
                    })
                    .collect();
                tone_heights(
                    &lum,
                    &fine,
                    &face_cells,
                    &eye_cells,
                    cols,
                    rows,
                    step,
                    light,
                    params,
                )
            }
            None => (Vec::new(), Vec::new(), Vec::new()),
        };
        // The photo's dark lines engraved with the burin, into the stipple's map: cut after
        // the compression as its pits are, where the tone is carved.
        let stipple = if tone.is_empty() {
            stipple
        } else {
            engrave_lines(stipple, &line, params.engraved_lines_mm)
        };
        // The tone's band in canonical mm: the share of the eyes' distance, in cells, times
        // the cells' size in the photo and the photo's scale at the face.
        let replaces = light
            .filter(|_| !tone.is_empty() && params.photo_modelling > 0.0)
            .map(|l| {
                (
                    params.photo_modelling.clamp(0.0, 1.0),
                    TONE_BAND * CELLS_PER_IOD * step * l.mm_per_px,
                )
            })
            .filter(|(_, band)| band.is_finite() && *band > 0.0);
        // Soften the regions' borders by a cell.
        let height = blur(&height, cols, rows, 0.7);
        // What the tone's match compares the stone's light with: only where it will run.
        let tone_match = if tone.is_empty() {
            0.0
        } else {
            params.tone_match
        };
        let iod_mm = light
            .map(|l| CELLS_PER_IOD * step * l.mm_per_px)
            .filter(|v| v.is_finite() && *v > 0.0);
        let bright = if tone_match > 0.0 && iod_mm.is_some() {
            fine.iter().map(|f| (f + 0.02).max(1e-3).ln()).collect()
        } else {
            Vec::new()
        };
        Ok(FaceDetail {
            bright,
            iod_mm,
            tone_match,
            origin,
            step,
            cols,
            rows,
            height,
            tone,
            stipple,
            shadow,
            replaces,
            moles,
            seen,
        })
    }

    /// The photo's log brightness at photo point (x, y) (its fine band), bilinear; 0 outside
    /// (and where the tone is not matched).
    pub fn bright_at(&self, x: f32, y: f32) -> f32 {
        self.sample(&self.bright, x, y)
    }

    /// How the carved tone is matched to the photo's under the stone's light: the contrast
    /// asked for ([`DetailParams::tone_match`]) and the eyes' distance (canonical mm); `None`
    /// where it is not.
    pub fn tone_match(&self) -> Option<(f32, f32)> {
        self.iod_mm
            .filter(|_| self.tone_match > 0.0 && !self.bright.is_empty())
            .map(|iod| (self.tone_match, iod))
    }

    /// The carved height (canonical mm) at photo point (x, y): bilinear, 0 outside the map.
    pub fn at(&self, x: f32, y: f32) -> f32 {
        self.sample(&self.height, x, y)
    }

    /// The tone's height (canonical mm) at photo point (x, y), for a frontal portrait: 0
    /// outside the map or when none was read.
    pub fn tone_at(&self, x: f32, y: f32) -> f32 {
        self.sample(&self.tone, x, y)
    }

    /// The stipple's pit (canonical mm, 0 or below) at photo point (x, y): 0 outside the map,
    /// between the pits, or when none was cut.
    pub fn stipple_at(&self, x: f32, y: f32) -> f32 {
        self.sample(&self.stipple, x, y)
    }

    /// How much of the stone is sunk into the key light's shadow at photo point (x, y), 0..1
    /// ([`DetailParams::shadows`]): 0 outside the map or when none is cut.
    pub fn shadow_at(&self, x: f32, y: f32) -> f32 {
        self.sample(&self.shadow, x, y)
    }

    /// Whether the stipple was cut (a frontal portrait's tone, [`DetailParams::stipple_mm`]
    /// above 0): its pits are a few tenths of a millimetre across, and a relief carves them on
    /// a finer grid ([`super::TONE_SUBDIVISION`]).
    pub fn stippled(&self) -> bool {
        !self.stipple.is_empty()
    }

    /// The moles left aside (photo pixels): small round darks on the skin, away from the
    /// features, retouched out of the photo before its detail was read.
    pub fn moles(&self) -> &[[f32; 2]] {
        &self.moles
    }

    /// Whether any of the stone is sunk into the key light's shadow
    /// ([`DetailParams::shadows`]).
    pub fn shadowed(&self) -> bool {
        !self.shadow.is_empty()
    }

    /// How much of the relief's own modelling the tone replaces, and over what band (a
    /// Gaussian's sigma, canonical mm): [`DetailParams::photo_modelling`]; `None` where no
    /// tone was read or none is replaced.
    pub fn replaces(&self) -> Option<(f32, f32)> {
        self.replaces
    }

    fn sample(&self, map: &[f32], x: f32, y: f32) -> f32 {
        if map.len() != self.cols * self.rows {
            return 0.0;
        }
        let (u, v) = (
            (x - self.origin[0]) / self.step,
            (y - self.origin[1]) / self.step,
        );
        if !(u >= 0.0 && v >= 0.0 && u <= (self.cols - 1) as f32 && v <= (self.rows - 1) as f32) {
            return 0.0;
        }
        let (c0, r0) = (u as usize, v as usize);
        let (c1, r1) = ((c0 + 1).min(self.cols - 1), (r0 + 1).min(self.rows - 1));
        let (fx, fy) = (u - c0 as f32, v - r0 as f32);
        let h = |c: usize, r: usize| map[r * self.cols + c];
        (h(c0, r0) * (1.0 - fx) + h(c1, r0) * fx) * (1.0 - fy)
            + (h(c0, r1) * (1.0 - fx) + h(c1, r1) * fx) * fy
    }

    /// Per vertex: photo x, y and how squarely the photo sees it.
    pub fn seen(&self) -> &[[f32; 3]] {
        &self.seen
    }

    /// The map's size in cells, and its heights (for tests and pictures).
    pub fn map(&self) -> (usize, usize, &[f32]) {
        (self.cols, self.rows, &self.height)
    }

    /// The tone's heights, as [`Self::map`]'s (empty when none was read).
    pub fn tone_map(&self) -> &[f32] {
        &self.tone
    }

    /// The stipple's pits, as [`Self::map`]'s (empty when none were cut).
    pub fn stipple_map(&self) -> &[f32] {
        &self.stipple
    }

    /// How much of the stone is sunk into the key light's shadow, as [`Self::map`]'s, 0..1
    /// (empty when none is cut).
    pub fn shadow_map(&self) -> &[f32] {
        &self.shadow
    }
}

/// The photo's fine light and dark as heights (canonical mm) whose slope along the key light
/// gives it back ([`super::tone`]): the log brightness against its surroundings over
/// [`TONE_BAND`] of the eyes' distance, in units of the face's own spread (its median absolute
/// value), to at most [`DetailParams::tone`]; fitted over the face, faded at its outline.
/// With them, the stipple's pits in its darks ([`DetailParams::stipple_mm`]; empty at 0),
/// read over [`STIPPLE_BAND`], and where the stone is sunk into the key light's shadow
/// ([`DetailParams::shadows`]; empty at 0).
#[allow(clippy::too_many_arguments)]
fn tone_heights(
    lum: &[f32],
    fine: &[f32],
    face_cells: &[usize],
    eye_cells: &[bool],
    cols: usize,
    rows: usize,
    step: f32,
    light: ToneLight,
    params: &DetailParams,
) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
    let (rel, spread) = relative_brightness(fine, lum, face_cells, cols, rows, TONE_BAND);
    let mut inside_face = vec![0f32; cols * rows];
    for &i in face_cells {
        inside_face[i] = 1.0;
    }
    let inside_face = blur(&inside_face, cols, rows, 2.0);
    let weight: Vec<f32> = inside_face
        .iter()
        .zip(eye_cells)
        .map(|(w, &eye)| if eye { w * TONE_EYES } else { *w })
        .collect();
    // Off the face the heights are held at 0 (the tone starts from the outline).
    let hold: Vec<f32> = inside_face.iter().map(|w| TONE_HOLD * (1.0 - w)).collect();
    let mm_per_cell = step * light.mm_per_px;
    let slope: Vec<f32> = rel
        .iter()
        .map(|r| -params.tone * mm_per_cell * (r / (3.0 * spread)).clamp(-1.0, 1.0))
        .collect();
    let field = super::tone::SlopeField::new(&slope, &weight, &hold, cols, rows);
    let solve = super::tone::ToneSolve::default();
    let h = super::tone::fit_slopes_halved(field, light.toward, &solve);
    let tone = h.iter().zip(&inside_face).map(|(h, w)| h * w).collect();
    let shadows = params.shadows.clamp(0.0, 1.0);
    if params.stipple_mm <= 0.0 && shadows <= 0.0 {
        return (tone, Vec::new(), Vec::new());
    }
    // The darks over the stipple's band, 0..1.
    let (rel, spread) = relative_brightness(fine, lum, face_cells, cols, rows, STIPPLE_BAND);
    let dark: Vec<f32> = rel
        .iter()
        .map(|r| ((-r / (3.0 * spread) - STIPPLE_FROM) / (1.0 - STIPPLE_FROM)).clamp(0.0, 1.0))
        .collect();
    let stipple = if params.stipple_mm > 0.0 {
        (0..cols * rows)
            .map(|i| {
                -params.stipple_mm
                    * stipple_pit((i % cols) as f32, (i / cols) as f32, dark[i])
                    * inside_face[i].max(0.0)
            })
            .collect()
    } else {
        Vec::new()
    };
    let shadow = if shadows > 0.0 {
        dark.iter()
            .zip(&inside_face)
            .map(|(d, w)| shadows * smoothstep(SHADOW_FROM, SHADOW_TO, *d) * w.max(0.0))
            .collect()
    } else {
        Vec::new()
    };
    (tone, stipple, shadow)
}

/// `stipple` (canonical mm, 0 or below; empty: none cut) with the lines of `line` (0..1 per
/// cell: the photo's brightness valleys, [`valleys`], in runs long enough to be a line)
/// engraved `depth` deep at full strength: each cell at least as deep as its line asks.
/// Depth 0 or less: `stipple` as it is.
fn engrave_lines(mut stipple: Vec<f32>, line: &[f32], depth: f32) -> Vec<f32> {
    if !(depth.is_finite() && depth > 0.0) || line.iter().all(|l| *l <= 0.0) {
        return stipple;
    }
    if stipple.len() != line.len() {
        stipple = vec![0.0; line.len()];
    }
    for (s, l) in stipple.iter_mut().zip(line) {
        *s = s.min(-depth * l.clamp(0.0, 1.0));
    }
    stipple
}

/// The log brightness `fine` against its surroundings in `lum` over `band` of the eyes'
/// distance (a Gaussian's sigma), and its spread over the face's cells (1.4826 times the
/// median absolute value, at least 0.01).
fn relative_brightness(
    fine: &[f32],
    lum: &[f32],
    face_cells: &[usize],
    cols: usize,
    rows: usize,
    band: f32,
) -> (Vec<f32>, f32) {
    const EPS: f32 = 0.02;
    let around = blur(lum, cols, rows, band * CELLS_PER_IOD);
    let rel: Vec<f32> = fine
        .iter()
        .zip(&around)
        .map(|(f, a)| (f + EPS).ln() - (a + EPS).ln())
        .collect();
    let spread = 1.4826
        * median(face_cells.iter().map(|&i| rel[i].abs()).collect())
            .unwrap_or(0.0)
            .max(0.01);
    (rel, spread)
}

/// The stipple's pit at map cell (`col`, `row`) where the photo is this `dark` (0..1): 0 to 1
/// (its centre), a paraboloid whose radius follows the darkness's square root, so the share of
/// the lattice's cell it hollows (and its shadow) follows the darkness; the darkest pits
/// touch their neighbours.
fn stipple_pit(col: f32, row: f32, dark: f32) -> f32 {
    if dark <= 0.0 {
        return 0.0;
    }
    let spacing = STIPPLE_SPACING * CELLS_PER_IOD;
    let (a, b) = (
        (col + row) * std::f32::consts::FRAC_1_SQRT_2 / spacing,
        (row - col) * std::f32::consts::FRAC_1_SQRT_2 / spacing,
    );
    let d = (a - a.round()).hypot(b - b.round());
    let radius = 0.5 * dark.sqrt();
    if d < radius {
        1.0 - (d / radius).powi(2)
    } else {
        0.0
    }
}

/// Where each vertex of `mesh` (model mm, the fitted face with its expression) lies in the
/// photo under the fit's `pose`, and how squarely the photo sees it: its normal turned towards
/// the camera, 0 below 0.1 (seen edge-on or from behind) to 1 above 0.4.
pub fn seen_vertices(mesh: &[f32], triangles: &[[u32; 3]], pose: &Pose) -> Vec<[f32; 3]> {
    let normals = crate::raster::vertex_normals(mesh, triangles);
    mesh.chunks_exact(3)
        .zip(&normals)
        .map(|(v, n)| {
            let p = pose.project(&nalgebra::Vector3::new(
                f64::from(v[0]),
                f64::from(v[1]),
                f64::from(v[2]),
            ));
            let nz = (pose.rotation.row(2)[0] * f64::from(n[0])
                + pose.rotation.row(2)[1] * f64::from(n[1])
                + pose.rotation.row(2)[2] * f64::from(n[2])) as f32;
            let (x, y) = (p.x as f32, p.y as f32);
            if x.is_finite() && y.is_finite() && nz.is_finite() {
                [x, y, smoothstep(0.1, 0.4, nz)]
            } else {
                [0.0, 0.0, 0.0]
            }
        })
        .collect()
}

/// Valley strength of a brightness field: where the larger curvature is positive (darker
/// than both sides across) and much larger than the other (a line, not a spot), the
/// difference of the two, else 0.
fn valleys(f: &[f32], cols: usize, rows: usize) -> Vec<f32> {
    let mut out = vec![0f32; cols * rows];
    for r in 1..rows.saturating_sub(1) {
        for c in 1..cols.saturating_sub(1) {
            let i = r * cols + c;
            let fxx = f[i - 1] - 2.0 * f[i] + f[i + 1];
            let fyy = f[i - cols] - 2.0 * f[i] + f[i + cols];
            let fxy =
                0.25 * (f[i + cols + 1] - f[i + cols - 1] - f[i - cols + 1] + f[i - cols - 1]);
            let m = 0.5 * (fxx + fyy);
            let d = (0.25 * (fxx - fyy) * (fxx - fyy) + fxy * fxy).sqrt();
            let (l1, l2) = (m + d, m - d);
            out[i] = (l1 - l2.abs()).max(0.0);
        }
    }
    out
}

/// Zeroes the connected runs (4-neighbours, values over 0.2) of `f` whose bounding box's
/// diagonal is shorter than `min_len` cells.
fn drop_short_runs(f: &mut [f32], cols: usize, rows: usize, min_len: f32) {
    let mut seen = vec![false; cols * rows];
    let mut stack = Vec::new();
    let mut members = Vec::new();
    for start in 0..cols * rows {
        if seen[start] || f[start] <= 0.2 {
            continue;
        }
        seen[start] = true;
        stack.push(start);
        members.clear();
        let (mut lo, mut hi) = ([usize::MAX; 2], [0usize; 2]);
        while let Some(i) = stack.pop() {
            members.push(i);
            let (x, y) = (i % cols, i / cols);
            lo = [lo[0].min(x), lo[1].min(y)];
            hi = [hi[0].max(x), hi[1].max(y)];
            let mut visit = |j: usize| {
                if !seen[j] && f[j] > 0.2 {
                    seen[j] = true;
                    stack.push(j);
                }
            };
            if x > 0 {
                visit(i - 1);
            }
            if x + 1 < cols {
                visit(i + 1);
            }
            if y > 0 {
                visit(i - cols);
            }
            if y + 1 < rows {
                visit(i + cols);
            }
        }
        let diag = ((hi[0] - lo[0]) as f32).hypot((hi[1] - lo[1]) as f32);
        if diag < min_len {
            for &i in &members {
                f[i] = 0.0;
            }
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The stone's key light as the tests' photo sees it: from the upper left, 0.3 mm a pixel.
    const LIGHT: ToneLight = ToneLight {
        toward: [-0.8, -0.6],
        mm_per_px: 0.3,
    };

    /// 68 landmarks of a face 200 px between the eyes' centres, centred in a 800 x 800 photo.
    pub(crate) fn face() -> Vec<[f32; 2]> {
        let mut lm = vec![[0f32; 2]; 68];
        for (k, p) in lm.iter_mut().enumerate().take(17) {
            let t = k as f32 / 16.0 * std::f32::consts::PI;
            *p = [400.0 - 240.0 * t.cos(), 380.0 + 260.0 * t.sin()];
        }
        for k in 0..5 {
            lm[17 + k] = [
                220.0 + 35.0 * k as f32,
                300.0 - 8.0 * (k as f32 - 2.0).abs(),
            ];
            lm[22 + k] = [
                440.0 + 35.0 * k as f32,
                300.0 - 8.0 * (k as f32 - 2.0).abs(),
            ];
        }
        for (k, p) in lm.iter_mut().enumerate().take(36).skip(27) {
            *p = [400.0, 340.0 + 10.0 * (k - 27) as f32];
        }
        let eye = |cx: f32| {
            [
                [cx - 45.0, 360.0],
                [cx - 15.0, 345.0],
                [cx + 15.0, 345.0],
                [cx + 45.0, 360.0],
                [cx + 15.0, 372.0],
                [cx - 15.0, 372.0],
            ]
        };
        lm[36..42].copy_from_slice(&eye(300.0));
        lm[42..48].copy_from_slice(&eye(500.0));
        for k in 0..12 {
            let t = k as f32 / 12.0 * std::f32::consts::TAU;
            lm[48 + k] = [400.0 - 80.0 * t.cos(), 520.0 - 25.0 * t.sin()];
        }
        for k in 0..8 {
            let t = k as f32 / 8.0 * std::f32::consts::TAU;
            lm[60 + k] = [400.0 - 60.0 * t.cos(), 520.0 - 5.0 * t.sin()];
        }
        lm
    }

    fn draw(img: &mut GrayImage, f: impl Fn(f32, f32) -> Option<u8>) {
        for (x, y, p) in img.enumerate_pixels_mut() {
            if let Some(v) = f(x as f32, y as f32) {
                p.0[0] = v;
            }
        }
    }

    #[test]
    fn dark_brows_rise_irises_sink_lines_are_cut_and_moles_are_left() {
        let lm = face();
        let mut img = GrayImage::from_pixel(800, 800, image::Luma([180]));
        // Dark brows along the brow points, dark irises in the eyes, a dark fold line on the
        // cheek, a dark round mole on the other cheek.
        draw(&mut img, |x, y| {
            let brow =
                (x > 215.0 && x < 365.0 || x > 435.0 && x < 585.0) && (y - 298.0).abs() < 7.0;
            let iris = (x - 300.0).hypot(y - 360.0) < 10.0 || (x - 500.0).hypot(y - 360.0) < 10.0;
            let fold = (y - (430.0 + 0.9 * (x - 250.0))).abs() < 2.5 && x > 250.0 && x < 310.0;
            let mole = (x - 560.0).hypot(y - 450.0) < 6.0;
            (brow || iris || fold || mole).then_some(60)
        });
        let d = FaceDetail::read(&img, &lm, Vec::new(), &DetailParams::default(), None)
            .expect("detail");
        let brow = d.at(290.0, 298.0);
        let iris = d.at(300.0, 360.0);
        let fold = d.at(280.0, 457.0);
        let mole = d.at(560.0, 450.0);
        let skin = d.at(480.0, 470.0);
        assert!(brow > 0.8, "brow {brow}");
        assert!(iris < -0.8, "iris {iris}");
        assert!(fold < -0.3, "fold {fold}");
        assert!(
            mole.abs() < 0.5 * fold.abs(),
            "mole {mole} against the fold {fold}"
        );
        assert!(skin.abs() < 0.05, "plain skin {skin}");
        assert_eq!(d.at(-500.0, 10.0), 0.0);
        // The mole, and only it, was retouched out before anything was read (so the tone,
        // the stipple and the darks' shadows leave it too); the fold and the features stay.
        let moles = d.moles();
        assert!(
            moles.len() == 1 && (moles[0][0] - 560.0).hypot(moles[0][1] - 450.0) < 6.0,
            "moles {moles:?}"
        );
    }

    /// The tone's heights lit by the key light give back the photo's fine light and dark: the
    /// slope away from the light (what brightens a surface under it) follows the photo's
    /// band-passed brightness over the face; without the light or at strength 0 there is none.
    #[test]
    fn the_tone_lit_by_the_key_light_shows_the_photos_light_and_dark() {
        let lm = face();
        let mut img = GrayImage::from_pixel(800, 800, image::Luma([170]));
        // Texture over the face: blotches and lines of several sizes.
        draw(&mut img, |x, y| {
            let v = 170.0
                + 35.0 * ((x * 0.045).sin() * (y * 0.06).cos())
                + 25.0 * ((x * 0.11 + y * 0.07).sin());
            Some(v.clamp(0.0, 255.0) as u8)
        });
        let light = LIGHT;
        // The slopes alone (the stipple's pits and the engraved lines: the next tests).
        let p = DetailParams {
            stipple_mm: 0.0,
            engraved_lines_mm: 0.0,
            ..DetailParams::default()
        };
        let d = FaceDetail::read(&img, &lm, Vec::new(), &p, Some(light)).expect("detail");
        let (cols, rows, _) = d.map();
        let tone = d.tone_map();
        assert_eq!(tone.len(), cols * rows);
        let largest = tone.iter().fold(0f32, |m, v| m.max(v.abs()));
        assert!(largest > 0.05 && largest < 6.0, "largest tone {largest} mm");
        // Over the cheeks and nose (inside the face, away from its outline): the key light's
        // shading of the tone, -(slope towards the light), against the photo's brightness
        // about its own local mean.
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for y in (380..500).step_by(4) {
            for x in (260..540).step_by(4) {
                let (x, y) = (x as f32, y as f32);
                let e = 3.0;
                let slope = (d.tone_at(x + e * light.toward[0], y + e * light.toward[1])
                    - d.tone_at(x - e * light.toward[0], y - e * light.toward[1]))
                    / (2.0 * e);
                let local = {
                    let mut s = 0.0;
                    for k in -4i32..=4 {
                        for l in -4i32..=4 {
                            s += f32::from(
                                img.get_pixel((x as i32 + 6 * k) as u32, (y as i32 + 6 * l) as u32)
                                    .0[0],
                            );
                        }
                    }
                    s / 81.0
                };
                a.push(-slope);
                b.push(f32::from(img.get_pixel(x as u32, y as u32).0[0]) - local);
            }
        }
        let corr = crate::stats::correlation(&a, &b);
        assert!(corr > 0.5, "shading against the photo: correlation {corr}");
        let none = FaceDetail::read(&img, &lm, Vec::new(), &p, None).expect("detail");
        assert!(none.tone_map().is_empty());
        assert_eq!(none.tone_at(400.0, 450.0), 0.0);
        let off = DetailParams { tone: 0.0, ..p };
        let off = FaceDetail::read(&img, &lm, Vec::new(), &off, Some(light)).expect("detail");
        assert!(off.tone_map().is_empty());
        // The regions' carving is the same with or without the tone.
        assert_eq!(none.map().2, d.map().2);
    }

    /// A pit's radius follows the darkness's square root: the share of the lattice it
    /// hollows (what shows dark under the light) follows the darkness, pi / 4 of it.
    #[test]
    fn the_stipples_hollowed_share_follows_the_darkness() {
        assert_eq!(stipple_pit(3.0, 7.0, 0.0), 0.0);
        for dark in [0.1f32, 0.4, 0.9] {
            let (mut cut, mut all) = (0usize, 0usize);
            for r in 0..400 {
                for c in 0..400 {
                    let v = stipple_pit(c as f32 * 0.25, r as f32 * 0.25, dark);
                    assert!((0.0..=1.0).contains(&v));
                    cut += usize::from(v > 0.0);
                    all += 1;
                }
            }
            let share = cut as f32 / all as f32;
            let want = std::f32::consts::FRAC_PI_4 * dark;
            assert!(
                (share - want).abs() < 0.03,
                "dark {dark}: share {share}, want {want}"
            );
        }
        // A pit's centre is a lattice point: the map's origin.
        assert_eq!(stipple_pit(0.0, 0.0, 0.5), 1.0);
    }

    /// The stipple cuts pits (never raises) where the face is darker than around it, and
    /// leaves the skin elsewhere nearly smooth.
    #[test]
    fn the_stipple_cuts_the_darks_and_leaves_plain_skin() {
        let lm = face();
        let mut img = GrayImage::from_pixel(800, 800, image::Luma([170]));
        // A dark patch on one cheek (a shadow), a little texture elsewhere.
        draw(&mut img, |x, y| {
            let v = if (x - 300.0).hypot(y - 450.0) < 25.0 {
                90.0
            } else {
                170.0 + 6.0 * ((x * 0.2).sin() * (y * 0.17).cos())
            };
            Some(v as u8)
        });
        let light = LIGHT;
        let with = DetailParams {
            engraved_lines_mm: 0.0,
            ..DetailParams::default()
        };
        let without = DetailParams {
            stipple_mm: 0.0,
            ..with
        };
        let read = |p: &DetailParams| {
            FaceDetail::read(&img, &lm, Vec::new(), p, Some(light)).expect("detail")
        };
        let (a, b) = (read(&with), read(&without));
        let (cols, _, _) = a.map();
        assert_eq!(a.tone_map(), b.tone_map(), "the stipple changed the slopes");
        assert!(a.stippled() && !b.stippled() && b.stipple_map().is_empty());
        // The dark patch is sunk into the key light's shadow, and the shadow's map (the
        // pictures' `--detail-maps`) is the one `shadow_at` samples.
        let sunk = a.shadow_at(300.0, 450.0);
        assert!(sunk > 0.5, "the patch's shadow {sunk}");
        assert_eq!(a.shadow_map().len(), a.stipple_map().len());
        assert!(a.shadow_map().iter().any(|s| *s >= sunk - 1e-3));
        let diff = a.stipple_map();
        let most = diff.iter().fold(f32::MIN, |m, d| m.max(*d));
        assert!(most <= 0.0, "a pit raised the stone by {most}");
        assert!(diff.iter().all(|d| *d >= -with.stipple_mm - 1e-3));
        // The share of cells cut: in the patch, and on the skin of the other cheek.
        let share = |cx: f32, cy: f32, r: f32| {
            let (mut cut, mut all) = (0, 0);
            for (i, d) in diff.iter().enumerate() {
                let [x, y] = [
                    a.origin[0] + (i % cols) as f32 * a.step,
                    a.origin[1] + (i / cols) as f32 * a.step,
                ];
                if (x - cx).hypot(y - cy) < r {
                    all += 1;
                    cut += usize::from(*d < -0.05);
                }
            }
            cut as f32 / all.max(1) as f32
        };
        let (patch, skin) = (share(300.0, 450.0, 15.0), share(500.0, 450.0, 20.0));
        // (The skin's faint texture is measured against the face's own spread: its darkest
        // spots take a few small pits.)
        assert!(
            patch > 0.25 && skin < 0.1,
            "cut: patch {patch}, skin {skin}"
        );
    }

    /// A thin dark line (a fold) is engraved along its length, as deep as asked and never
    /// deeper, into the stipple's map; plain skin and a round mole are not; depth 0 engraves
    /// nothing, and without the tone (no key light) there is no engraving.
    #[test]
    fn the_photos_dark_lines_are_engraved_and_nothing_else() {
        let lm = face();
        let mut img = GrayImage::from_pixel(800, 800, image::Luma([170]));
        draw(&mut img, |x, y| {
            let fold = (y - (430.0 + 0.9 * (x - 250.0))).abs() < 2.0 && x > 250.0 && x < 320.0;
            let mole = (x - 560.0).hypot(y - 450.0) < 5.0;
            (fold || mole).then_some(70)
        });
        let light = LIGHT;
        let only_lines = DetailParams {
            stipple_mm: 0.0,
            ..DetailParams::default()
        };
        let read = |p: &DetailParams, light: Option<ToneLight>| {
            FaceDetail::read(&img, &lm, Vec::new(), p, light).expect("detail")
        };
        let d = read(&only_lines, Some(light));
        assert!(d.stippled(), "no lines engraved");
        let depth = only_lines.engraved_lines_mm;
        let map = d.stipple_map();
        assert!(map.iter().all(|v| *v <= 0.0 && *v >= -depth - 1e-4));
        // Along the fold (its middle half), deep; beside it and on plain skin, nothing.
        let along: Vec<f32> = (265..305)
            .step_by(5)
            .map(|x| {
                let x = x as f32;
                // The deepest cell across the line (the map's cells are coarser than pixels).
                (-4..=4)
                    .map(|k| d.stipple_at(x, 430.0 + 0.9 * (x - 250.0) + k as f32))
                    .fold(0f32, f32::min)
            })
            .collect();
        assert!(
            along.iter().all(|v| *v < -0.5 * depth),
            "along the fold {along:?}"
        );
        assert!(d.stipple_at(285.0, 470.0).abs() < 1e-3, "beside the fold");
        assert!(d.stipple_at(480.0, 470.0).abs() < 1e-3, "plain skin");
        // The mole is a short closed round: retouched out, and no line either way.
        assert!(d.stipple_at(560.0, 450.0).abs() < 1e-3, "the mole");
        // Depth 0: no map; no key light (no tone): none either.
        let none = DetailParams {
            engraved_lines_mm: 0.0,
            ..only_lines
        };
        assert!(!read(&none, Some(light)).stippled());
        assert!(!read(&only_lines, None).stippled());
        // Twice as deep, twice the groove.
        let deeper = read(&only_lines.engraved_lines_scaled(2.0), Some(light));
        let (a, b) = (d.stipple_at(285.0, 461.5), deeper.stipple_at(285.0, 461.5));
        assert!((b - 2.0 * a).abs() < 1e-3 * depth, "{a} -> {b}");
    }

    #[test]
    fn a_dim_photo_carves_as_deep_as_a_bright_one() {
        let lm = face();
        let make = |bg: u8, fg: u8| {
            let mut img = GrayImage::from_pixel(800, 800, image::Luma([bg]));
            draw(&mut img, |x, y| {
                ((x > 215.0 && x < 365.0) && (y - 298.0).abs() < 7.0).then_some(fg)
            });
            // Some texture so the face's contrast scale is not the brow alone.
            draw(&mut img, |x, y| {
                (((x * 0.37).sin() * (y * 0.29).cos()) > 0.95).then_some(bg.saturating_sub(bg / 8))
            });
            FaceDetail::read(&img, &lm, Vec::new(), &DetailParams::default(), None).expect("detail")
        };
        let (bright, dim) = (make(200, 80), make(60, 24));
        let (b, d) = (bright.at(290.0, 298.0), dim.at(290.0, 298.0));
        assert!(b > 0.5 && (b - d).abs() < 0.25 * b, "bright {b}, dim {d}");
    }

    #[test]
    fn bad_landmarks_and_tiny_faces_are_refused() {
        let img = GrayImage::from_pixel(100, 100, image::Luma([128]));
        let mut lm = face();
        lm[5][0] = f32::NAN;
        let p = DetailParams::default();
        assert_eq!(
            FaceDetail::read(&img, &lm, Vec::new(), &p, None),
            Err(DetailError::Landmarks)
        );
        let tiny: Vec<[f32; 2]> = face().iter().map(|q| [q[0] * 0.01, q[1] * 0.01]).collect();
        assert!(matches!(
            FaceDetail::read(&img, &tiny, Vec::new(), &p, None),
            Err(DetailError::TooSmall(_))
        ));
        let empty = GrayImage::new(0, 0);
        assert_eq!(
            FaceDetail::read(&empty, &face(), Vec::new(), &p, None),
            Err(DetailError::EmptyPhoto)
        );
    }
}
