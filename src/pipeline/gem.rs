//! A photo to a gem image: decode -> face ([`FacePipeline`]) -> the person's hair, beard and
//! glasses -> the cameo's relief -> render -> PNG. `glyptic photo`, `render --photo` and
//! `batch` all go this way; `render` of the mean face joins at the relief.
//!
//! Each step is a [`crate::stage`] (`decode`, the face pipeline's, `segment`, `person`, `gem`,
//! `render`). A person pass that fails (no segmentation model, an unreadable photo region) is
//! a warning on the log and the classical hair, never a lost gem. Units: image pixels in, gem
//! millimetres in the mesh, pixels out.

use std::path::Path;

#[cfg(feature = "face")]
use crate::assets::ModelPaths;
use crate::capture::CaptureError;
#[cfg(feature = "face")]
use crate::detect::{FaceEmbedder, PersonSegmenter, SegmentError};
use crate::gem::{self, CameoParams, GemError};
use crate::render::{Mesh, RenderError, RenderParams, Renderer};
use crate::stage::timed;

#[cfg(feature = "face")]
use super::person::describe_person;
#[cfg(feature = "face")]
pub use super::person::person_json;
#[cfg(feature = "face")]
use super::{FacePipeline, FaceResult, PipelineError};

/// Whose hair the gem wears.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Hair {
    /// The person's own, as the photo shows it (bald stays bald, long hair falls over the
    /// shoulders), with their beard and moustache.
    #[default]
    Photo,
    /// The same classical hairstyle for everyone.
    Classical,
}

/// Why a photo did not become a gem image.
#[derive(Debug, thiserror::Error)]
pub enum GemPipelineError {
    #[cfg(feature = "face")]
    #[error(transparent)]
    Face(#[from] PipelineError),
    #[error("building the cameo: {0}")]
    Gem(#[from] GemError),
    #[error("rendering the gem: {0}")]
    Render(#[from] RenderError),
    #[error("encoding the PNG: {0}")]
    Encode(#[from] image::ImageError),
}

#[cfg(feature = "face")]
impl GemPipelineError {
    /// The photo was read but holds no face (a batch counts these apart from errors).
    pub fn is_no_face(&self) -> bool {
        matches!(self, GemPipelineError::Face(PipelineError::NoFace))
    }
}

#[cfg(feature = "face")]
/// A photo's gem before it is rendered.
#[derive(Clone, Debug)]
pub struct PhotoGem {
    pub face: FaceResult,
    /// The cameo cut for this person (their hair, beard and glasses).
    pub cameo: CameoParams,
    /// The photo's own detail carved into the face (brows, irises, the mouth's line, folds);
    /// `None` when it is off or could not be read.
    pub detail: Option<gem::FaceDetail>,
    /// The whole cameo, gem mm.
    pub mesh: Mesh,
    /// What was read of the person around the face (hair, beard, moustache, glasses);
    /// `None` with the classical hair or when the photo could not be read for it.
    pub person: Option<crate::person::Person>,
}

#[cfg(feature = "face")]
/// The loaded models and choices that turn photos into cameo meshes.
pub struct GemPipeline {
    pub face: FacePipeline,
    /// The person segmentation for the hair; `None` reads the hair by colour alone.
    pub segmenter: Option<PersonSegmenter>,
    /// The stone and the way the portrait is cut; the hair is filled in per photo.
    pub cameo: CameoParams,
    pub hair: Hair,
    /// Carve glasses found on the photo (the rims and temples as ridges on the face).
    pub carve_glasses: bool,
    /// Carve the photo's own detail into the face ([`gem::FaceDetail`]); `None`: only the
    /// fitted shape.
    pub detail: Option<gem::DetailParams>,
    /// The recognition network that steers the portrait's identity towards the photo
    /// ([`crate::identity`]); [`Recogniser::Off`]: the landmark fit's identity.
    pub recogniser: Recogniser,
    /// The identity search's size and prior.
    pub identity: crate::identity::SearchOptions,
    /// Read the face's shape from the photo's shading ([`crate::photometric`]); `None`: the
    /// shape model's face alone.
    pub shading: Option<crate::photometric::ShadingParams>,
    /// Carry the landmarks the shape model could not reach onto the face
    /// ([`crate::warp`]); `None`: the model's face.
    pub warp: Option<crate::warp::WarpParams>,
}

/// What [`GemPipeline::load_with`] loads, and how.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LoadOptions {
    /// Load the recognition network (the identity search); false: not even loaded.
    pub recognise: bool,
    /// Threads inside the detector's operators (1: beside other pipelines, as a batch's
    /// workers; more where a single photo waits on its detection).
    pub detector_threads: usize,
}

impl Default for LoadOptions {
    fn default() -> Self {
        Self {
            recognise: true,
            detector_threads: 1,
        }
    }
}

#[cfg(feature = "face")]
impl GemPipeline {
    /// Loads the face pipeline and, for [`Hair::Photo`], the segmentation model (missing or
    /// broken: a warning, and the hair is read by colour alone).
    pub fn load(
        models: &ModelPaths,
        cameo: CameoParams,
        hair: Hair,
    ) -> Result<Self, PipelineError> {
        Self::load_with(models, cameo, hair, LoadOptions::default())
    }

    /// [`GemPipeline::load`] with `options`' networks and threads.
    pub fn load_with(
        models: &ModelPaths,
        cameo: CameoParams,
        hair: Hair,
        options: LoadOptions,
    ) -> Result<Self, PipelineError> {
        let recognise = options.recognise;
        let face = FacePipeline::load_threads(models, options.detector_threads)?;
        let segmenter = load_segmenter(models, hair);
        // Started last: it loads while the photo is decoded and its face found (the GPU's
        // start-up, on another thread, is over by then: started first it slowed both).
        let recogniser = if recognise {
            Recogniser::load(models, 2)
        } else {
            Recogniser::Off
        };
        Ok(GemPipeline {
            face,
            segmenter,
            cameo,
            hair,
            carve_glasses: true,
            detail: Some(gem::DetailParams::default()),
            recogniser,
            identity: crate::identity::SearchOptions::default(),
            shading: Some(crate::photometric::ShadingParams::default()),
            warp: Some(crate::warp::WarpParams::default()),
        })
    }

    /// Another pipeline sharing the landmark and face models, with sessions of its own (one
    /// per batch worker); no segmenter if this one has none.
    pub fn fork(&self, models: &ModelPaths) -> Result<Self, PipelineError> {
        Ok(GemPipeline {
            face: self.face.fork(models)?,
            segmenter: if self.segmenter.is_some() {
                load_segmenter(models, self.hair)
            } else {
                None
            },
            cameo: self.cameo.clone(),
            hair: self.hair,
            carve_glasses: self.carve_glasses,
            detail: self.detail,
            // One thread each: a batch's workers share the cores.
            recogniser: if self.recogniser.is_off() {
                Recogniser::Off
            } else {
                Recogniser::load(models, 1)
            },
            identity: self.identity,
            shading: self.shading,
            warp: self.warp,
        })
    }

    /// Decodes the photo at `path` and makes its gem.
    pub fn photo(&mut self, path: &Path) -> Result<PhotoGem, GemPipelineError> {
        let (img, face) = self.face.photo(path)?;
        self.gem_for(&img, face)
    }

    /// The subject's face, their cameo and its mesh.
    pub fn image(&mut self, img: &image::RgbImage) -> Result<PhotoGem, GemPipelineError> {
        let face = self.face.process(img)?;
        self.gem_for(img, face)
    }

    /// The cameo and its mesh for a face found in `img`.
    fn gem_for(
        &mut self,
        img: &image::RgbImage,
        mut face: FaceResult,
    ) -> Result<PhotoGem, GemPipelineError> {
        // The photo's brightness, for the identity search's light and the detail (once).
        let grey = image::imageops::grayscale(img);
        let steered = self.steered_shape(img, &grey, &face);
        if let Some(shape) = &steered {
            face.portrait = self.face.portrait(shape, &face.portrait_coefficients.1);
        }
        // The photo's light on the face: its shape from the shading (unless off), and what the
        // person pass expects of the jaw's brightness (always: a shadow is not a beard).
        let shape = steered.as_ref().unwrap_or(&face.portrait_coefficients.0);
        let params = self
            .shading
            .unwrap_or_else(crate::photometric::ShadingParams::light_only);
        let shading = read_shading(
            &self.face.model,
            &grey,
            &face.landmarks,
            &face.fit,
            shape,
            &params,
        );
        if let (Some(fit), Some(_)) = (&shading, &self.shading) {
            crate::photometric::displace(&mut face.portrait, &fit.offsets, &face.fit.pose);
        }
        // The fitted face as the photo's landmarks place it: the portrait's features, and
        // where the detail is read for each vertex.
        let mut seen_mesh = std::borrow::Cow::Borrowed(&face.mesh);
        if let Some(params) = &self.warp {
            let model = &self.face.model;
            let warp = timed(
                "warp",
                || {
                    crate::warp::landmark_warp(
                        model,
                        &face.mesh,
                        &face.landmarks,
                        &face.fit.pose,
                        params,
                    )
                    .ok_or("no warp")
                },
                |w| {
                    format!(
                        "{} landmarks, residual {:.1} px, largest motion {:.1} mm",
                        w.controls, w.residual_px, w.largest_mm
                    )
                },
            );
            if let Ok(w) = warp {
                crate::photometric::add(&mut face.portrait, &w.displacement);
                crate::photometric::add(seen_mesh.to_mut(), &w.displacement);
            }
        }
        // The detail (the fitted face and the photo's brightness) and the person (hair,
        // beard, glasses: the photo's colours) need nothing of each other: the detail is read
        // on a second thread while the person is read here.
        let detail_params = self.detail;
        let model = self.face.model.clone();
        let (detail, (cameo, person)) = crate::stage::alongside(
            || {
                let params = detail_params.as_ref()?;
                let triangles = &model.shape.triangles;
                timed(
                    "detail",
                    || {
                        let seen =
                            gem::detail::seen_vertices(&seen_mesh, triangles, &face.fit.pose);
                        // The builder carves the tone into frontal portraits only.
                        let light = gem::detail::ToneLight::of_face(&face.fit.pose, &seen_mesh);
                        gem::FaceDetail::read(&grey, &face.landmarks, seen, params, light)
                    },
                    |d| {
                        let mut said = String::from("brows, irises, mouth, lines");
                        if !d.tone_map().is_empty() {
                            said.push_str(", light and dark");
                        }
                        match d.moles().len() {
                            0 => {}
                            1 => said.push_str("; a mole left aside"),
                            n => said.push_str(&format!("; {n} moles left aside")),
                        }
                        said
                    },
                )
                .map_err(|e| tracing::warn!("cannot read the face's detail ({e}); the shape alone"))
                .ok()
            },
            || self.person_cameo(img, &face.landmarks, shading.as_ref().map(|f| &f.expected)),
        );
        let mesh = build_gem_detailed(
            &face.portrait,
            &self.face.model.shape.triangles,
            &cameo,
            detail.as_ref(),
        )?;
        Ok(PhotoGem {
            face,
            cameo,
            detail,
            mesh,
            person,
        })
    }

    /// The portrait's identity steered towards the photo by the recognition network
    /// ([`steer_identity`], from the portrait's own coefficients; standard deviations);
    /// `None` without a network, or when the search cannot start (a warning: the landmark
    /// fit's identity stays).
    pub fn steered_shape(
        &mut self,
        img: &image::RgbImage,
        grey: &image::GrayImage,
        face: &FaceResult,
    ) -> Option<Vec<f32>> {
        let net = self.recogniser.get()?;
        let shape = &face.portrait_coefficients.0;
        let model = &self.face.model;
        match steer_identity(
            net,
            model,
            img,
            grey,
            &face.landmarks,
            &face.fit,
            &face.mesh,
            shape,
            &self.identity,
        ) {
            Ok(s) => Some(s.shape),
            Err(e) => {
                tracing::warn!("cannot steer the identity by the photo ({e}); the landmark fit's");
                None
            }
        }
    }

    /// The cameo with the subject's own hair, beard and glasses (stage `person`, the
    /// segmentation's share as `segment`); [`Hair::Classical`], or a photo that cannot be
    /// read for it, keeps the classical hair.
    ///
    /// `light`: the brightness the photo's light gives the fitted face
    /// ([`crate::photometric::ShadingFit::expected`]), so a shadowed jaw is not a beard.
    pub fn person_cameo(
        &mut self,
        img: &image::RgbImage,
        landmarks: &[[f32; 2]],
        light: Option<&crate::photometric::ShadingMap>,
    ) -> (CameoParams, Option<crate::person::Person>) {
        if self.hair == Hair::Classical {
            return (self.cameo.clone(), None);
        }
        let mask = self.segmenter.as_mut().and_then(|s| {
            timed(
                "segment",
                || s.segment(img, landmarks),
                |_| "person / background".into(),
            )
            .map_err(|e: SegmentError| tracing::warn!("{e}; the hair is read by colour alone"))
            .ok()
        });
        let person = timed(
            "person",
            || {
                crate::person::analyse_shaded(
                    img,
                    landmarks,
                    mask.as_ref(),
                    light.map(|m| m as &dyn crate::person::Shading),
                )
            },
            describe_person,
        );
        match person {
            Ok(p) => (
                CameoParams {
                    hair: gem::HairStyle {
                        glasses: p.has_glasses() && self.carve_glasses,
                        ..gem::hair_style(&p)
                    },
                    ..self.cameo.clone()
                },
                Some(p),
            ),
            Err(e) => {
                tracing::warn!("cannot read the hair from the photo ({e}); classical hair");
                (self.cameo.clone(), None)
            }
        }
    }
}

#[cfg(feature = "face")]
/// The face's shape and light read from the photo's shading (stage `shading`,
/// [`crate::photometric::fit`]) around the face with identity `shape` (standard deviations)
/// and the `fit`'s expression and pose; `None` (a warning) when the photo cannot say (a flat
/// light, a tiny face). The photo path and the kiosk's person thread both use it.
pub fn read_shading(
    model: &crate::shapemodel::SurreyModel,
    grey: &image::GrayImage,
    landmarks: &[[f32; 2]],
    fit: &crate::fit::Fit,
    shape: &[f32],
    params: &crate::photometric::ShadingParams,
) -> Option<crate::photometric::ShadingFit> {
    let mesh = model.instance(shape, &fit.expression);
    timed(
        "shading",
        || {
            crate::photometric::fit(
                grey,
                landmarks,
                &mesh,
                &model.shape.triangles,
                &fit.pose,
                params,
            )
        },
        |f| {
            format!(
                "skin's shading error {:.3} -> {:.3} over {} cells",
                f.residual_before, f.residual_after, f.cells
            )
        },
    )
    .map_err(|e| tracing::warn!("cannot read the face's shape from its shading ({e})"))
    .ok()
}

#[cfg(feature = "face")]
/// The identity search on one photo or frame (stage `identity`): the photo's embedding by
/// `net`, the scene (the `fit`'s pose, the light fitted on its `mesh` to `grey`), and the
/// search from `start` with the fit's expression ([`crate::identity::search`]). The photo
/// path and the kiosk's person thread both steer with it.
#[allow(clippy::too_many_arguments)]
pub fn steer_identity(
    net: &mut FaceEmbedder,
    model: &crate::shapemodel::SurreyModel,
    img: &image::RgbImage,
    grey: &image::GrayImage,
    landmarks: &[[f32; 2]],
    fit: &crate::fit::Fit,
    mesh: &[f32],
    start: &[f32],
    opts: &crate::identity::SearchOptions,
) -> Result<crate::identity::Searched, String> {
    timed(
        "identity",
        || {
            let target = net.embed(img, landmarks).map_err(|e| e.to_string())?;
            let scene = crate::identity::Scene::of_photo(
                grey,
                landmarks,
                mesh,
                &model.shape.triangles,
                &fit.pose,
            )
            .map_err(|e| e.to_string())?;
            crate::identity::search(
                model,
                &scene,
                start,
                &fit.expression,
                &target.0,
                |crops, n| {
                    net.embed_aligned(crops, n)
                        .map(|v| v.into_iter().map(|e| e.0.to_vec()).collect())
                        .map_err(|e| tracing::warn!("{e}"))
                        .ok()
                },
                opts,
            )
            .map_err(|e| e.to_string())
        },
        |s| {
            format!(
                "recognition distance {:.3} -> {:.3} in {} faces (drawing {:.0} ms, network {:.0} ms)",
                s.before, s.after, s.evaluations, s.draw_ms, s.network_ms
            )
        },
    )
}

#[cfg(feature = "face")]
/// The recognition network of a [`GemPipeline`]: loaded on a thread of its own (about 150 ms:
/// reading and verifying 38 MB, ONNX Runtime's session) while the photo is decoded and its
/// face found, so the photo path does not wait for it.
pub enum Recogniser {
    /// No identity search.
    Off,
    /// Loading on its thread (`None` only while being taken).
    Loading(Option<std::thread::JoinHandle<Option<FaceEmbedder>>>),
    /// Loaded (`None`: it could not be, said on the log once).
    Ready(Option<FaceEmbedder>),
}

#[cfg(feature = "face")]
impl std::fmt::Debug for Recogniser {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Recogniser::Off => "Off",
            Recogniser::Loading(_) => "Loading",
            Recogniser::Ready(Some(_)) => "Ready",
            Recogniser::Ready(None) => "Ready(failed)",
        })
    }
}

#[cfg(feature = "face")]
impl Drop for Recogniser {
    /// A load under way is waited for: a command that fails before it needs the network (a
    /// missing photo) must not end under ONNX Runtime building a session (it logs errors after
    /// the command's own last word, and a warning that the model is broken when it is not).
    fn drop(&mut self) {
        if let Recogniser::Loading(handle) = self
            && let Some(h) = handle.take()
        {
            let _ = h.join();
        }
    }
}

#[cfg(feature = "face")]
impl Recogniser {
    /// Starts loading SFace ([`ModelPaths::recogniser`]) with `threads` threads per operator;
    /// a failure (no model: run scripts/setup.sh) is a warning, and the portrait keeps the
    /// landmark fit's identity.
    pub fn load(models: &ModelPaths, threads: usize) -> Self {
        let (model, ort) = (models.recogniser.clone(), models.onnxruntime.clone());
        let load = move || {
            timed(
                "load recogniser",
                || FaceEmbedder::load(&model, &ort, threads),
                |_| format!("{}", model.display()),
            )
            .map_err(|e| {
                tracing::warn!(
                    "{e}; the portrait keeps the landmark fit's identity (run scripts/setup.sh)"
                )
            })
            .ok()
        };
        match std::thread::Builder::new()
            .name("load recogniser".into())
            .spawn(load.clone())
        {
            Ok(handle) => Recogniser::Loading(Some(handle)),
            Err(_) => Recogniser::Ready(load()),
        }
    }

    /// No identity search was asked for.
    pub fn is_off(&self) -> bool {
        matches!(self, Recogniser::Off)
    }

    /// The network, once loaded (waits for the loading thread the first time); `None` when
    /// off or it could not be loaded.
    pub fn get(&mut self) -> Option<&mut FaceEmbedder> {
        if let Recogniser::Loading(handle) = self {
            let net = handle.take().and_then(|h| {
                h.join().unwrap_or_else(|_| {
                    tracing::warn!(
                        "loading the recognition network failed; the landmark fit's identity"
                    );
                    None
                })
            });
            *self = Recogniser::Ready(net);
        }
        match self {
            Recogniser::Ready(net) => net.as_mut(),
            _ => None,
        }
    }
}

#[cfg(feature = "face")]
fn load_segmenter(models: &ModelPaths, hair: Hair) -> Option<PersonSegmenter> {
    if hair == Hair::Classical {
        return None;
    }
    PersonSegmenter::load(&models.segmenter, &models.onnxruntime)
        .map_err(|e| tracing::warn!("{e}; the hair is read by colour alone (run scripts/setup.sh)"))
        .ok()
}

/// Reads and decodes a photo (stage `decode`, its size as the detail).
pub fn decode(path: &Path) -> Result<image::RgbImage, CaptureError> {
    timed(
        "decode",
        || crate::capture::load_photo(path),
        |i| format!("{}x{}", i.width(), i.height()),
    )
}

/// The cameo round a face mesh (model mm; stage `gem`).
pub fn build_gem(
    face: &[f32],
    triangles: &[[u32; 3]],
    cameo: &CameoParams,
) -> Result<Mesh, GemError> {
    build_gem_detailed(face, triangles, cameo, None)
}

/// [`build_gem`] with the photo's own detail carved into the face.
pub fn build_gem_detailed(
    face: &[f32],
    triangles: &[[u32; 3]],
    cameo: &CameoParams,
    detail: Option<&gem::FaceDetail>,
) -> Result<Mesh, GemError> {
    timed(
        "gem",
        || gem::build_cameo_detailed(face, triangles, cameo, detail),
        |m| {
            format!(
                "{} vertices, {} triangles, {}",
                m.vertices.len(),
                m.indices.len() / 3,
                cameo.mount()
            )
        },
    )
}

/// Renders the gem (stage `render`).
pub fn render(
    renderer: &mut Renderer,
    mesh: &Mesh,
    params: &RenderParams,
) -> Result<image::RgbaImage, RenderError> {
    timed(
        "render",
        || renderer.render(mesh, params),
        |_| {
            format!(
                "{}x{} {:?}, SSS {}",
                params.width,
                params.height,
                params.material,
                params
                    .sss
                    .map_or("off".to_string(), |s| format!("{} taps", s.taps))
            )
        },
    )
}

/// A rendered gem as PNG bytes.
pub fn encode_png(rgba: image::RgbaImage) -> Result<Vec<u8>, image::ImageError> {
    let mut png = Vec::new();
    image::DynamicImage::ImageRgba8(rgba)
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)?;
    Ok(png)
}

/// Renders the gem and encodes it as PNG (stages `render` and `encode`).
pub fn render_png(
    renderer: &mut Renderer,
    mesh: &Mesh,
    params: &RenderParams,
) -> Result<Vec<u8>, GemPipelineError> {
    render_encoded(renderer, mesh, params, ImageKind::Png)
}

/// The image formats a gem is written in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageKind {
    Png,
    /// Quality 92; no alpha (a transparent backdrop needs PNG).
    Jpeg,
}

impl ImageKind {
    /// The format an output path's extension names (`.png`, `.jpg`, `.jpeg`, any case).
    pub fn from_path(path: &std::path::Path) -> Option<Self> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "png" => Some(ImageKind::Png),
            "jpg" | "jpeg" => Some(ImageKind::Jpeg),
            _ => None,
        }
    }
}

/// A rendered gem as JPEG bytes (the alpha dropped).
pub fn encode_jpeg(rgba: image::RgbaImage) -> Result<Vec<u8>, image::ImageError> {
    let mut jpeg = Vec::new();
    let rgb = image::DynamicImage::ImageRgba8(rgba).into_rgb8();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, 92).encode_image(&rgb)?;
    Ok(jpeg)
}

/// Renders the gem and encodes it as `kind` (stages `render` and `encode`).
pub fn render_encoded(
    renderer: &mut Renderer,
    mesh: &Mesh,
    params: &RenderParams,
    kind: ImageKind,
) -> Result<Vec<u8>, GemPipelineError> {
    let rgba = render(renderer, mesh, params)?;
    Ok(timed(
        "encode",
        || match kind {
            ImageKind::Png => encode_png(rgba),
            ImageKind::Jpeg => encode_jpeg(rgba),
        },
        |bytes| format!("{} kB {kind:?}", bytes.len() / 1024),
    )?)
}
