//! The face pipeline on one frame: detect -> 68 landmarks -> morphable-model fit.
//!
//! Units: image pixels (0-based, y down) for detections and landmarks; model millimetres for
//! the fitted mesh. Each stage's time is recorded so callers can report speed per stage.

use std::path::Path;
use std::time::Instant;

use crate::detect::{DetectError, DetectOptions, Detection, FaceDetector};
use crate::fit::{Fit, FitError, FitOptions};
use crate::landmarks::{LandmarkError, ShapePredictor};
use crate::shapemodel::{ModelError, SurreyModel};

/// Rounds of box re-estimation after the first landmark pass (see the landmarks tests).
const LANDMARK_REFINE_ROUNDS: usize = 1;

#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    #[error(transparent)]
    Detect(#[from] DetectError),
    #[error(transparent)]
    Landmarks(#[from] LandmarkError),
    #[error("fitting the face model: {0}")]
    Fit(#[from] FitError),
    #[error(transparent)]
    Model(#[from] ModelError),
    #[error("no face found")]
    NoFace,
}

/// One timed stage.
#[derive(Clone, Debug)]
pub struct Stage {
    pub name: &'static str,
    pub ms: f64,
    pub detail: String,
}

/// Runs `f`, appending its time and a description of its result to `stages`.
pub fn timed<T, E>(
    stages: &mut Vec<Stage>,
    name: &'static str,
    f: impl FnOnce() -> Result<T, E>,
    describe: impl FnOnce(&T) -> String,
) -> Result<T, E> {
    let t = Instant::now();
    let out = f()?;
    stages.push(Stage {
        name,
        ms: t.elapsed().as_secs_f64() * 1e3,
        detail: describe(&out),
    });
    Ok(out)
}

/// What the pipeline found in a frame.
#[derive(Clone, Debug)]
pub struct FaceResult {
    /// The face that was fitted (the largest).
    pub detection: Detection,
    /// How many faces the detector found.
    pub faces_found: usize,
    /// 68 iBUG points, image pixels.
    pub landmarks: Vec<[f32; 2]>,
    pub fit: Fit,
    /// Fitted mesh in model mm, `[x0, y0, z0, ...]` (pose removed).
    pub mesh: Vec<f32>,
}

/// The loaded models.
pub struct FacePipeline {
    pub detector: FaceDetector,
    pub predictor: ShapePredictor,
    pub model: SurreyModel,
    pub detect_options: DetectOptions,
    pub fit_options: FitOptions,
}

impl FacePipeline {
    /// Loads the three models, timing each.
    pub fn load(
        detector_model: &Path,
        ort_library: &Path,
        landmark_model: &Path,
        sfm_dir: &Path,
        stages: &mut Vec<Stage>,
    ) -> Result<Self, PipelineError> {
        let detector = timed(
            stages,
            "load detector",
            || FaceDetector::load(detector_model, ort_library),
            |_| format!("{}", detector_model.display()),
        )?;
        let predictor = timed(
            stages,
            "load landmarks",
            || ShapePredictor::load(landmark_model),
            |p| format!("{} parts", p.num_parts()),
        )?;
        let model = timed(
            stages,
            "load face model",
            || SurreyModel::load_dir(sfm_dir),
            |m| {
                format!(
                    "{} vertices, {} shape + {} expression components",
                    m.shape.num_vertices(),
                    m.shape.num_components(),
                    m.blendshapes.offsets.ncols()
                )
            },
        )?;
        Ok(FacePipeline {
            detector,
            predictor,
            model,
            detect_options: DetectOptions::default(),
            fit_options: FitOptions::default(),
        })
    }

    /// Detects the largest face, finds its landmarks and fits the model.
    pub fn process(
        &mut self,
        img: &image::RgbImage,
        stages: &mut Vec<Stage>,
    ) -> Result<FaceResult, PipelineError> {
        let opts = self.detect_options.clone();
        let faces = timed(
            stages,
            "detect",
            || self.detector.detect(img, &opts),
            |d| match d.len() {
                0 => "no face".to_string(),
                n => format!(
                    "{n} face{} (largest scored {:.2})",
                    if n == 1 { "" } else { "s" },
                    crate::detect::largest(d).map_or(0.0, |f| f.score)
                ),
            },
        )?;
        let detection = crate::detect::largest(&faces)
            .cloned()
            .ok_or(PipelineError::NoFace)?;
        let gray = crate::landmarks::to_gray(img);
        let predictor = &self.predictor;
        let landmarks = timed(
            stages,
            "landmarks",
            || {
                let face_box = predictor.box_for_five_points(&detection.points)?;
                predictor.predict_refined(&gray, &face_box, LANDMARK_REFINE_ROUNDS)
            },
            |p: &Vec<[f32; 2]>| format!("{} points", p.len()),
        )?;
        let model = &self.model;
        let fit_opts = &self.fit_options;
        let fit = timed(
            stages,
            "fit",
            || crate::fit::fit(model, &landmarks, fit_opts),
            |f| {
                let [yaw, pitch, roll] = f.pose.yaw_pitch_roll_deg();
                format!(
                    "yaw {yaw:.0} pitch {pitch:.0} roll {roll:.0} deg, reprojection {:.2} px, {} iterations",
                    f.reprojection_px, f.iterations
                )
            },
        )?;
        let mesh = model.instance(&fit.shape, &fit.expression);
        Ok(FaceResult {
            detection,
            faces_found: faces.len(),
            landmarks,
            fit,
            mesh,
        })
    }
}
