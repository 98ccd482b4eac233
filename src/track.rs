//! Tracking one face through video: detect only when the face is lost, otherwise start the
//! landmarks from the box of the previous frame's landmarks; fit the model from the previous
//! fit; let identity accumulate over the first frames and then hold it; smooth pose and
//! expression with One-Euro filters.
//!
//! A track is lost when the landmarks or the fit fail, when the fit needs implausibly large
//! landmark noise (the points no longer look like a face), when the face leaves the frame, when
//! its box holds no contrast (a wall, a covered lens), or when a check every
//! [`TrackOptions::verify_every`] frames finds no face in a small crop around the box (the
//! landmark regressor returns a face-like shape on anything, so something has to look); the
//! next frame then runs the detector on the whole frame. Losing a track forgets the identity
//! too: the next face may be another visitor.
//!
//! Units: image pixels (landmarks, boxes), model millimetres (mesh), degrees (smoothed angles),
//! seconds (frame times).

use image::RgbImage;

use crate::fit::{Fit, Pose};
use crate::landmarks::{FaceBox, GreyPixels};
use crate::pipeline::{FacePipeline, PipelineError, Stage, timed};
use crate::smooth::{OneEuro, OneEuroParams};

/// Settings of a [`Tracker`].
#[derive(Clone, Copy, Debug)]
pub struct TrackOptions {
    /// Smooth pose and expression (off: each frame's own fit is passed through).
    pub smoothing: bool,
    /// Filter for yaw, pitch and roll, degrees.
    pub angle_filter: OneEuroParams,
    /// Filter for the face's position and size: translation x, y and 100 mm at the face's
    /// scale, all in pixels.
    pub position_filter: OneEuroParams,
    /// Filter for the expression weights (unitless).
    pub expression_filter: OneEuroParams,
    /// Identity is the mean of this many frames' fits, then holds (0: every frame fits its
    /// own identity).
    pub identity_frames: usize,
    /// A fit that needs more landmark noise than this (model mm) has lost the face.
    pub max_noise_mm: f64,
    /// A face whose landmark box has less than this fraction of its area inside the frame is
    /// lost.
    pub min_inside: f32,
    /// A face whose box's grey levels have a standard deviation below this is lost.
    pub min_contrast: f32,
    /// Look for the face with the detector in a crop around its box every this many tracked
    /// frames (0: never).
    pub verify_every: u32,
    /// Longer side of that crop as the detector sees it, pixels (its cost grows with the
    /// square).
    pub verify_side: u32,
}

impl Default for TrackOptions {
    fn default() -> Self {
        TrackOptions {
            smoothing: true,
            angle_filter: OneEuroParams::default(),
            position_filter: OneEuroParams {
                min_cutoff_hz: 1.0,
                beta: 0.02,
                d_cutoff_hz: 1.0,
            },
            expression_filter: OneEuroParams {
                min_cutoff_hz: 1.0,
                beta: 2.0,
                d_cutoff_hz: 1.0,
            },
            identity_frames: 30,
            max_noise_mm: 8.0,
            min_inside: 0.6,
            min_contrast: 6.0,
            verify_every: 10,
            verify_side: 160,
        }
    }
}

/// One frame's result.
#[derive(Clone, Debug)]
pub struct TrackedFace {
    /// The detector ran on this frame (first frame, or the face was lost).
    pub detected: bool,
    /// 68 landmarks, image pixels.
    pub landmarks: Vec<[f32; 2]>,
    /// This frame's own fit, before smoothing.
    pub raw: Fit,
    /// Smoothed pose.
    pub pose: Pose,
    /// Smoothed expression weights.
    pub expression: Vec<f32>,
    /// Identity in use (the running mean, then held).
    pub shape: Vec<f32>,
    /// Frames averaged into the identity so far.
    pub identity_frames: usize,
    /// Face mesh from `shape` and `expression`, model mm, pose removed.
    pub mesh: Vec<f32>,
    /// The face the gem carves: the mean of the learning frames' portrait identities
    /// ([`FacePipeline::portrait_coefficients`]), or the identity steered towards the visitor
    /// ([`Tracker::steer`]), with `expression`, caricatured (see [`FacePipeline::portrait`]).
    pub portrait: Vec<f32>,
    /// That identity before the caricature, standard deviations.
    pub portrait_shape: Vec<f32>,
    /// Which track this face belongs to (a new number each time the detector starts one), so
    /// work done on one visitor's frames is not given to the next.
    pub track: u64,
    /// The portrait's identity was steered by the recognition network ([`Tracker::steer`]).
    pub steered: bool,
    /// The visitor's detail read with the steered identity from one of the track's frames
    /// ([`Tracker::steer`]; brows, irises, the mouth, lines, and the light and dark a frontal
    /// gem models), attached to the face's vertices; `None` before.
    pub detail: Option<std::sync::Arc<crate::gem::FaceDetail>>,
}

/// A frame's outcome: a face, or why there is none.
#[derive(Clone, Debug)]
pub struct TrackStep {
    pub face: Option<TrackedFace>,
    /// Why the track was lost on this frame before the detector ran, if it was.
    pub lost: Option<String>,
    pub stages: Vec<Stage>,
}

struct TrackState {
    track: u64,
    /// The portrait's identity as the recognition network steered it.
    steered: Option<Vec<f32>>,
    /// The shape read from the visitor's shading, added to the steered portrait.
    relief: Option<Vec<f32>>,
    /// The detail read from the steered frame.
    detail: Option<std::sync::Arc<crate::gem::FaceDetail>>,
    landmarks: Vec<[f32; 2]>,
    fit: Fit,
    identity_sum: Vec<f64>,
    /// The same frames' portrait identities ([`FacePipeline::portrait_coefficients`]).
    portrait_sum: Vec<f64>,
    identity_n: usize,
    angles: OneEuro,
    position: OneEuro,
    expression: OneEuro,
    /// Tracked frames since the detector last confirmed the face.
    unverified: u32,
}

/// Follows one face (the subject: largest or most central) through a sequence of frames.
pub struct Tracker {
    pub pipeline: FacePipeline,
    pub options: TrackOptions,
    state: Option<TrackState>,
    detections: u64,
    tracks: u64,
}

impl Tracker {
    /// The face model's triangles (of every [`TrackedFace::mesh`]).
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.pipeline.model.shape.triangles
    }

    pub fn new(pipeline: FacePipeline, options: TrackOptions) -> Self {
        Tracker {
            pipeline,
            options,
            state: None,
            detections: 0,
            tracks: 0,
        }
    }

    /// Carves `shape` (identity, standard deviations) as the portrait of track `track` from
    /// now on, with `relief` (the shape read from the visitor's shading, a model-frame
    /// displacement per vertex, [`crate::photometric::displacement`]) added and `detail` (read
    /// from the same frame) carved, if that track is still the one followed; `false` (and
    /// nothing changes) when it was lost meanwhile.
    pub fn steer(
        &mut self,
        track: u64,
        shape: Vec<f32>,
        relief: Option<Vec<f32>>,
        detail: Option<std::sync::Arc<crate::gem::FaceDetail>>,
    ) -> bool {
        match &mut self.state {
            Some(s) if s.track == track && shape.len() == s.fit.shape.len() => {
                s.steered = Some(shape);
                s.relief = relief;
                s.detail = detail;
                true
            }
            _ => false,
        }
    }

    /// Frames on which the detector ran so far.
    pub fn detections(&self) -> u64 {
        self.detections
    }

    /// Forgets the face (the next frame runs the detector).
    pub fn reset(&mut self) {
        self.state = None;
    }

    /// Tracks the face into `img`, taken at `time_s` seconds; the step's stages are those
    /// this frame ran ([`crate::stage::record`]).
    pub fn process(&mut self, img: &RgbImage, time_s: f64) -> Result<TrackStep, PipelineError> {
        let (step, stages) = crate::stage::record(|| self.step(img, time_s));
        let (face, lost) = step?;
        Ok(TrackStep { face, lost, stages })
    }

    /// [`Tracker::process`]'s work: the face, and why the track was lost before it.
    fn step(
        &mut self,
        img: &RgbImage,
        time_s: f64,
    ) -> Result<(Option<TrackedFace>, Option<String>), PipelineError> {
        let mut lost = None;
        if let Some(mut state) = self.state.take() {
            match self.follow(img, &state) {
                Ok((landmarks, fit, verified)) => {
                    state.unverified = if verified { 0 } else { state.unverified + 1 };
                    let face = self.update(state, landmarks, fit, time_s, false);
                    return Ok((Some(face), None));
                }
                Err(why) => lost = Some(why),
            }
        }
        self.detections += 1;
        let Some((found, fit, _)) = self.pipeline.fit_subject(img)? else {
            return Ok((None, lost));
        };
        let o = &self.options;
        self.tracks += 1;
        let state = TrackState {
            track: self.tracks,
            steered: None,
            relief: None,
            detail: None,
            landmarks: Vec::new(),
            fit: fit.clone(),
            identity_sum: vec![0.0; fit.shape.len()],
            portrait_sum: vec![0.0; fit.shape.len()],
            identity_n: 0,
            angles: OneEuro::new(o.angle_filter),
            position: OneEuro::new(o.position_filter),
            expression: OneEuro::new(o.expression_filter),
            unverified: 0,
        };
        let face = self.update(state, found.points, fit, time_s, true);
        Ok((Some(face), lost))
    }

    /// Landmarks from the previous landmarks' box and a fit from the previous fit, and whether
    /// the detector confirmed the face on this frame; `Err` says why the face counts as lost.
    fn follow(
        &mut self,
        img: &RgbImage,
        state: &TrackState,
    ) -> Result<(Vec<[f32; 2]>, Fit, bool), String> {
        let o = self.options;
        let predictor = &self.pipeline.faces.predictor;
        let face_box = predictor
            .box_for_all_parts(&state.landmarks)
            .map_err(|e| e.to_string())?;
        let inside = inside_fraction(&face_box, img.width(), img.height());
        if inside < o.min_inside {
            return Err(format!(
                "face left the frame ({:.0} % inside)",
                inside * 100.0
            ));
        }
        let (landmarks, contrast) = timed(
            "landmarks",
            || {
                // Straight on the RGB frame: the trees read a few thousand pixels, converting
                // the frame (or the region around the face) to grey first costs more.
                let contrast = grey_deviation(img, &face_box);
                let points = predictor.predict(img, &face_box)?;
                Ok::<_, crate::landmarks::LandmarkError>((points, contrast))
            },
            |_| "68 points (tracked)".to_string(),
        )
        .map_err(|e| e.to_string())?;
        if contrast.is_nan() || contrast < o.min_contrast {
            return Err(format!(
                "no contrast where the face was (grey deviation {contrast:.1})"
            ));
        }
        let verify = o.verify_every > 0 && state.unverified + 1 >= o.verify_every;
        if verify {
            let found = timed(
                "verify",
                || self.face_near(img, &face_box, o.verify_side),
                |f| if *f { "face confirmed" } else { "no face" }.to_string(),
            )
            .map_err(|e| e.to_string())?;
            if !found {
                return Err("the detector no longer sees a face there".into());
            }
        }
        let (model, opts) = (&self.pipeline.model, &self.pipeline.fit_options);
        let hold =
            self.options.identity_frames > 0 && state.identity_n >= self.options.identity_frames;
        let mut previous = state.fit.clone();
        if hold {
            previous.shape = mean_identity(state, &state.identity_sum);
        }
        let fit = timed(
            "fit",
            || crate::fit::fit_from(model, &landmarks, opts, &previous, hold),
            |f| {
                format!(
                    "reprojection {:.2} px{}",
                    f.reprojection_px,
                    if hold { ", identity held" } else { "" }
                )
            },
        )
        .map_err(|e| e.to_string())?;
        if fit.noise_mm.is_nan() || fit.noise_mm > o.max_noise_mm {
            return Err(format!(
                "landmarks no longer fit a face (noise {:.1} mm)",
                fit.noise_mm
            ));
        }
        Ok((landmarks, fit, verify))
    }

    /// Whether the detector finds a face overlapping `face_box` in a crop twice its size.
    fn face_near(
        &mut self,
        img: &RgbImage,
        face_box: &FaceBox,
        side: u32,
    ) -> Result<bool, PipelineError> {
        let [cx, cy] = face_box.center();
        let half = face_box.width.max(face_box.height);
        let clamp = |v: f32, max: u32| v.clamp(0.0, max as f32) as u32;
        let (x0, y0) = (
            clamp(cx - half, img.width()),
            clamp(cy - half, img.height()),
        );
        let (x1, y1) = (
            clamp(cx + half, img.width()),
            clamp(cy + half, img.height()),
        );
        if x1 <= x0 + 1 || y1 <= y0 + 1 {
            return Ok(false);
        }
        let crop = image::imageops::crop_imm(img, x0, y0, x1 - x0, y1 - y0).to_image();
        let opts = crate::detect::DetectOptions {
            max_side: side,
            min_side: side.min(self.pipeline.faces.detect_options.min_side),
            ..self.pipeline.faces.detect_options.clone()
        };
        let faces = self.pipeline.faces.detector.detect(&crop, &opts)?;
        let tracked = [
            face_box.left - x0 as f32,
            face_box.top - y0 as f32,
            face_box.width,
            face_box.height,
        ];
        Ok(faces
            .iter()
            .any(|f| crate::detect::iou(&f.bbox, &tracked) > 0.1))
    }

    /// Accumulates identity, smooths, and builds the frame's face.
    fn update(
        &mut self,
        mut state: TrackState,
        landmarks: Vec<[f32; 2]>,
        fit: Fit,
        time_s: f64,
        detected: bool,
    ) -> TrackedFace {
        let o = &self.options;
        let accumulate = o.identity_frames == 0 || state.identity_n < o.identity_frames;
        if accumulate {
            // The portrait's identity is fitted only while the identity is still being
            // learnt (a second fit on those frames, none once it holds).
            let (firm, _) = self.pipeline.portrait_coefficients(&landmarks, &fit);
            if o.identity_frames == 0 {
                state.identity_sum = fit.shape.iter().map(|&c| f64::from(c)).collect();
                state.portrait_sum = firm.iter().map(|&c| f64::from(c)).collect();
                state.identity_n = 1;
            } else {
                for (s, &c) in state.identity_sum.iter_mut().zip(&fit.shape) {
                    *s += f64::from(c);
                }
                for (s, &c) in state.portrait_sum.iter_mut().zip(&firm) {
                    *s += f64::from(c);
                }
                state.identity_n += 1;
            }
        }
        let shape = mean_identity(&state, &state.identity_sum);
        let portrait_shape = state
            .steered
            .clone()
            .unwrap_or_else(|| mean_identity(&state, &state.portrait_sum));
        let (pose, expression) = if o.smoothing {
            let angles = state.angles.filter(time_s, &fit.pose.yaw_pitch_roll_deg());
            let t = fit.pose.translation;
            let p = state
                .position
                .filter(time_s, &[t.x, t.y, 100.0 * fit.pose.scale]);
            let e: Vec<f64> = fit.expression.iter().map(|&w| f64::from(w)).collect();
            let e = state.expression.filter(time_s, &e);
            let pose = Pose {
                rotation: Pose::rotation_from_yaw_pitch_roll_deg([angles[0], angles[1], angles[2]]),
                scale: p[2] / 100.0,
                translation: nalgebra::Vector2::new(p[0], p[1]),
            };
            // The filter's mix of non-negative weights stays non-negative.
            (pose, e.iter().map(|&w| w as f32).collect())
        } else {
            (fit.pose, fit.expression.clone())
        };
        let mesh = self.pipeline.model.instance(&shape, &expression);
        let mut portrait = self.pipeline.portrait(&portrait_shape, &expression);
        // Set only with the steered identity (Tracker::steer).
        if let Some(relief) = &state.relief {
            crate::photometric::add(&mut portrait, relief);
        }
        let identity_frames = state.identity_n;
        let (track, steered, detail) = (state.track, state.steered.is_some(), state.detail.clone());
        state.landmarks = landmarks.clone();
        state.fit = fit.clone();
        self.state = Some(state);
        TrackedFace {
            detected,
            landmarks,
            raw: fit,
            pose,
            expression,
            shape,
            identity_frames,
            mesh,
            portrait,
            portrait_shape,
            track,
            steered,
            detail,
        }
    }
}

/// The mean of `sum` over the frames learnt so far (the last fit's identity before any).
fn mean_identity(state: &TrackState, sum: &[f64]) -> Vec<f32> {
    if state.identity_n == 0 {
        return state.fit.shape.clone();
    }
    let n = state.identity_n as f64;
    sum.iter().map(|s| (s / n) as f32).collect()
}

/// Standard deviation of the grey levels inside the box (sampled on a grid of at most 32 x 32).
fn grey_deviation(img: &impl GreyPixels, b: &FaceBox) -> f32 {
    let (mut sum, mut sq, mut n) = (0.0f64, 0.0f64, 0u32);
    for j in 0..32 {
        for i in 0..32 {
            let x = b.left + b.width * (i as f32 + 0.5) / 32.0;
            let y = b.top + b.height * (j as f32 + 0.5) / 32.0;
            if x < 0.0 || y < 0.0 {
                continue;
            }
            if let Some(v) = img.grey(x as u32, y as u32) {
                let v = f64::from(v);
                sum += v;
                sq += v * v;
                n += 1;
            }
        }
    }
    if n < 2 {
        return 0.0;
    }
    let mean = sum / f64::from(n);
    ((sq / f64::from(n) - mean * mean).max(0.0).sqrt()) as f32
}

/// Fraction of the box's area inside a `width` x `height` image.
fn inside_fraction(b: &FaceBox, width: u32, height: u32) -> f32 {
    let overlap = |lo: f32, len: f32, max: f32| ((lo + len).min(max) - lo.max(0.0)).max(0.0);
    let area = b.width * b.height;
    if area.is_nan() || area <= 0.0 {
        return 0.0;
    }
    overlap(b.left, b.width, width as f32) * overlap(b.top, b.height, height as f32) / area
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inside_fraction_of_boxes() {
        let b = |left, top| FaceBox {
            left,
            top,
            width: 100.0,
            height: 100.0,
        };
        assert_eq!(inside_fraction(&b(10.0, 10.0), 640, 480), 1.0);
        assert_eq!(inside_fraction(&b(-50.0, 10.0), 640, 480), 0.5);
        assert_eq!(inside_fraction(&b(590.0, 430.0), 640, 480), 0.25);
        assert_eq!(inside_fraction(&b(700.0, 10.0), 640, 480), 0.0);
        let degenerate = FaceBox {
            width: f32::NAN,
            ..b(0.0, 0.0)
        };
        assert_eq!(inside_fraction(&degenerate, 640, 480), 0.0);
    }
}
