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
use crate::detect::{PersonSegmenter, SegmentError};
use crate::gem::{self, CameoParams, GemError};
use crate::render::{Mesh, RenderError, RenderParams, Renderer};
use crate::stage::timed;

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
    /// The whole cameo, gem mm.
    pub mesh: Mesh,
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
        let face = FacePipeline::load(models)?;
        let segmenter = load_segmenter(models, hair);
        Ok(GemPipeline {
            face,
            segmenter,
            cameo,
            hair,
            carve_glasses: true,
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
        face: FaceResult,
    ) -> Result<PhotoGem, GemPipelineError> {
        let cameo = self.person_cameo(img, &face.landmarks);
        let mesh = build_gem(&face.portrait, &self.face.model.shape.triangles, &cameo)?;
        Ok(PhotoGem { face, cameo, mesh })
    }

    /// The cameo with the subject's own hair, beard and glasses (stage `person`, the
    /// segmentation's share as `segment`); [`Hair::Classical`], or a photo that cannot be
    /// read for it, keeps the classical hair.
    pub fn person_cameo(&mut self, img: &image::RgbImage, landmarks: &[[f32; 2]]) -> CameoParams {
        if self.hair == Hair::Classical {
            return self.cameo.clone();
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
            || crate::person::analyse_with(img, landmarks, mask.as_ref()),
            describe_person,
        );
        match person {
            Ok(p) => CameoParams {
                hair: gem::HairStyle {
                    glasses: p.has_glasses() && self.carve_glasses,
                    ..gem::hair_style(&p)
                },
                ..self.cameo.clone()
            },
            Err(e) => {
                tracing::warn!("cannot read the hair from the photo ({e}); classical hair");
                self.cameo.clone()
            }
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

#[cfg(feature = "face")]
fn describe_person(p: &crate::person::Person) -> String {
    let glasses = if p.has_glasses() { "yes" } else { "no" };
    let (beard, moustache) = (100.0 * p.beard, 100.0 * p.moustache);
    match p.hair {
        Some(h) => format!(
            "hair: stands {:.2}, ends {:.2} face lengths below the eyes, curl {:.2}; beard {beard:.0} %, moustache {moustache:.0} %, glasses {glasses}",
            h.top.max(0.7 * h.sides),
            h.length,
            h.curl,
        ),
        None => format!("bald; beard {beard:.0} %, moustache {moustache:.0} %, glasses {glasses}"),
    }
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
    timed(
        "gem",
        || gem::build_cameo(face, triangles, cameo),
        |m| {
            format!(
                "{} vertices, {} triangles",
                m.vertices.len(),
                m.indices.len() / 3
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
