//! `glyptic photo` and `glyptic render`: a photo (or a face mesh, or the mean face) to a gem
//! image through [`glyptic::pipeline::gem`], the GPU coming up on a thread meanwhile.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, anyhow, bail};

#[cfg(feature = "face")]
use glyptic::gem;
use glyptic::render::{RenderParams, Renderer};
use glyptic::stage::{Stage, timed};

use super::ViewArgs;
use super::make::{MakeArgs, make_files, source_label, stage_gem_obj, stage_made};
#[cfg(feature = "face")]
use super::{ChoiceArgs, GlassesArg};
use crate::outputs::{check_outputs, commit, stage};
#[cfg(feature = "face")]
use crate::report::Pose;
use crate::report::{Outputs, Run, note_stages};
use glyptic::files::Staged;

#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:
  glyptic render -o mean.png                        the cameo with the model's mean face
  glyptic render -o gem.png --photo portrait.jpg    as `glyptic photo`
  glyptic render -o gem.png --face face.obj --gem-obj gem.obj --stl gem.stl
  glyptic render -o gem.png --material agate --gltf gem.glb   the cameo for a 3D viewer
  glyptic render -o clear.png --background transparent --material agate")]
pub struct RenderArgs {
    /// Output image: .png or .jpg (the format follows the extension).
    #[arg(short, long, value_parser = crate::values::file_named(&["png", "jpg", "jpeg"], "PNG or JPEG"))]
    pub output: PathBuf,
    #[command(flatten)]
    pub view: ViewArgs,
    /// Use this face mesh instead of the mean face: Wavefront OBJ in model millimetres
    /// (y up, face towards +z), e.g. one written by `glyptic photo --obj`.
    #[arg(long, value_name = "FILE.obj", conflicts_with = "photo")]
    pub face: Option<PathBuf>,
    /// Fit the face in this photo instead (as `glyptic photo`).
    #[arg(long, value_name = "IMAGE")]
    pub photo: Option<PathBuf>,
    #[command(flatten)]
    pub make: MakeArgs,
    /// Report as one JSON object on stdout (stages and times, the files written) instead of
    /// the stage table.
    #[arg(long)]
    pub json: bool,
}

/// The photo on standard input (`glyptic photo - ...`), read up to the photo size limit and
/// decoded as a file would be (stage `decode`).
#[cfg(feature = "face")]
fn decode_stdin() -> Result<image::RgbImage> {
    let name = Path::new("standard input");
    glyptic::stage::timed(
        "decode",
        || -> Result<_> {
            let bytes = glyptic::files::read_all_limited(
                std::io::stdin().lock(),
                glyptic::files::MAX_PHOTO_BYTES,
                0,
            )
            .context("standard input: cannot read the photo")?;
            if bytes.is_empty() {
                bail!("standard input: empty (pipe a photo in, or name a file)");
            }
            Ok(glyptic::capture::decode_photo(&bytes, name)?)
        },
        |i| format!("{}x{} from standard input", i.width(), i.height()),
    )
}

#[cfg(feature = "face")]
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:
  glyptic photo portrait.jpg -o gem.png
  glyptic photo portrait.jpg -o gem.jpg --material agate --size 1280x1600
  glyptic photo portrait.jpg -o gem.png --stl gem.stl --heightmap gem-height.png
  glyptic photo portrait.jpg -o gem.png --gltf gem.glb      (binary glTF 2.0)
  glyptic photo portrait.jpg -o gem.png --antialias off     (faster without a GPU)
  glyptic photo portrait.jpg -o gem.png --portrait profile  (the classic profile cameo)
  glyptic photo portrait.jpg -o gem.png --likeness-search 22  (a longer likeness search)

Exit codes: 0 the gem was written; 1 an error (named on stderr, nothing written); 2 a bad
option.")]
pub struct PhotoArgs {
    /// Portrait photo (JPEG, PNG, PPM, BMP, TIFF, WebP).
    /// `-` reads the photo from standard input.
    pub image: PathBuf,
    /// Output image: .png or .jpg (the format follows the extension); `-` writes the PNG to
    /// standard output.
    #[arg(short, long, value_parser = crate::values::file_named_or_stdout(&["png", "jpg", "jpeg"], "PNG or JPEG"))]
    pub output: PathBuf,
    #[command(flatten)]
    pub view: ViewArgs,
    #[command(flatten)]
    pub choice: ChoiceArgs,
    /// Also write the 68 landmarks as an iBUG .pts file (1-based, like menpo's).
    #[arg(long, value_name = "FILE.pts",
          value_parser = crate::values::file_named(&["pts"], "iBUG points"))]
    pub landmarks_out: Option<PathBuf>,
    /// Also write the fitted face mesh (model millimetres) as Wavefront OBJ.
    #[arg(long, value_name = "FILE.obj",
          value_parser = crate::values::file_named(&["obj"], "Wavefront OBJ"))]
    pub obj: Option<PathBuf>,
    #[command(flatten)]
    pub make: MakeArgs,
    /// Report as one JSON object on stdout (stages and times, the files written, the face:
    /// its box, 68 landmarks, pose and fit error) instead of the stage table.
    #[arg(long)]
    pub json: bool,
}

/// The renderer coming up on its own thread ([`spawn_renderer`]). Dropped before it is joined
/// (an error ended the command first), it still waits for the start to finish: a process
/// that exits while the GPU driver initialises can make wgpu's EGL start-up panic.
pub(super) struct RendererStart(
    Option<std::thread::JoinHandle<Result<(Renderer, f64), glyptic::render::RenderError>>>,
);

impl RendererStart {
    /// Waits for the start: the renderer and how long it took, ms.
    pub(super) fn join(mut self) -> Result<(Renderer, f64)> {
        let handle = self
            .0
            .take()
            .ok_or_else(|| anyhow!("the renderer was already taken"))?;
        handle
            .join()
            .map_err(|_| anyhow!("the renderer thread panicked"))?
            .context("starting the renderer")
    }
}

impl Drop for RendererStart {
    fn drop(&mut self) {
        if let Some(handle) = self.0.take() {
            let _ = handle.join();
        }
    }
}

/// Starts the GPU device and pipelines on another thread: they do not depend on the face, so
/// they come up while the photo is decoded and fitted; a warm-up frame with `params`' stone
/// and passes follows there ([`Renderer::warm_up`]: lavapipe compiles its shaders at their
/// first draw), its failure left for the real frame to report.
pub(super) fn spawn_renderer(params: RenderParams) -> RendererStart {
    RendererStart(Some(std::thread::spawn(move || {
        let t = Instant::now();
        Renderer::new_headless().map(|mut r| {
            // Images for files: each one what its input gives alone (batch's order and
            // repeats change nothing).
            r.set_noise_baking(false);
            let _ = r.warm_up(&params);
            (r, t.elapsed().as_secs_f64() * 1e3)
        })
    })))
}

/// Waits for [`spawn_renderer`] and prints its stage line.
pub(super) fn join_renderer(start: RendererStart) -> Result<Renderer> {
    let (renderer, init_ms) = start.join()?;
    note_stages(&[Stage {
        name: "gpu init",
        ms: init_ms,
        detail: format!(
            "{} (in parallel; {})",
            renderer.adapter_info(),
            renderer.init_times()
        ),
    }]);
    Ok(renderer)
}

pub(super) fn render_mean(args: &RenderArgs) -> Result<()> {
    #[cfg(not(feature = "face"))]
    if let Some(image) = &args.photo {
        bail!(
            "{}: this build has no face pipeline (cargo feature `face`): render the mean face or --face FILE.obj",
            image.display()
        );
    }
    #[cfg(feature = "face")]
    if let Some(image) = &args.photo {
        return photo(&PhotoArgs {
            image: image.clone(),
            output: args.output.clone(),
            view: args.view.clone(),
            choice: ChoiceArgs {
                prefer: glyptic::detect::FaceChoice::Largest,
                hair: glyptic::pipeline::Hair::Photo,
                caricature: glyptic::shapemodel::Caricature::default(),
                expression: glyptic::pipeline::PORTRAIT_EXPRESSION,
                glasses: GlassesArg::Carve,
                detail: 1.0,
                stipple: 1.0,
                engraved_lines: 1.0,
                shadows: 1.0,
                photo_modelling: glyptic::gem::PHOTO_MODELLING,
                tone_match: glyptic::gem::TONE_MATCH,
                likeness_search: 0,
                shading: 1.0,
                warp: 1.0,
            },
            landmarks_out: None,
            obj: None,
            make: args.make.clone(),
            json: args.json,
        });
    }
    let start = Instant::now();
    let params = args.view.params()?;
    check_outputs(
        args.face.as_deref(),
        std::iter::once(args.output.as_path()).chain(args.make.outputs()),
    )?;
    output_kind(&args.output, &params)?;
    let renderer_thread = spawn_renderer(params.clone());
    let (mesh, stages) = glyptic::stage::record(|| -> Result<_> {
        let (face, triangles) = match &args.face {
            Some(path) => timed(
                "load face",
                || read_face_obj(path),
                |(p, t)| format!("{} vertices, {} triangles", p.len() / 3, t.len()),
            )?,
            None => {
                let sfm = glyptic::assets::sfm_dir();
                let model = timed(
                    "load face model",
                    || glyptic::shapemodel::SurreyModel::load_dir(&sfm),
                    |m| format!("{} vertices (mean face)", m.shape.num_vertices()),
                )?;
                (model.instance(&[], &[]), model.shape.triangles.clone())
            }
        };
        let cameo = args.view.cameo();
        let mesh = glyptic::pipeline::gem::build_gem(&face, &triangles, &cameo)?;
        Ok((mesh, face, triangles, cameo))
    });
    note_stages(&stages);
    let (mesh, face, triangles, cameo) = mesh?;
    let source = match &args.face {
        Some(path) => source_label(path),
        None => "the mean face".to_string(),
    };
    let made = make_files(
        &args.make,
        &face,
        &triangles,
        &cameo,
        None,
        (&mesh, &params),
        &source,
    )?;
    let mut renderer = join_renderer(renderer_thread)?;
    let png = render_png(&mut renderer, &mesh, &params, &args.output)?;
    // All or nothing: every file staged, then all put in place together.
    let mut staged = Staged::new();
    if let Some(obj) = &args.make.gem_obj {
        stage_gem_obj(&mut staged, obj, &mesh, &source)?;
    }
    stage_made(&mut staged, made)?;
    stage(&mut staged, &args.output, &png)?;
    commit(staged)?;
    note_stages(&[Stage {
        name: "total",
        ms: start.elapsed().as_secs_f64() * 1e3,
        detail: args.output.display().to_string(),
    }]);
    if args.json {
        let mut outputs = vec![("image", Some(args.output.as_path()))];
        outputs.extend(args.make.named());
        let outputs = Outputs::of(&outputs);
        crate::report::print("render", Run::so_far(source, outputs, start));
    }
    Ok(())
}

/// Renders the gem and encodes its PNG, printing the stages (`output` names it in errors).
pub(super) fn render_png(
    renderer: &mut Renderer,
    mesh: &glyptic::render::Mesh,
    params: &RenderParams,
    output: &Path,
) -> Result<Vec<u8>> {
    let kind = output_kind(output, params)?;
    let (png, stages) = glyptic::stage::record(|| {
        glyptic::pipeline::gem::render_encoded(renderer, mesh, params, kind)
    });
    note_stages(&stages);
    png.with_context(|| output.display().to_string())
}

/// The image format the output's name asks for, refused before any work where it cannot
/// hold the gem (an unknown extension; a transparent backdrop in JPEG).
pub(super) fn output_kind(
    output: &Path,
    params: &RenderParams,
) -> Result<glyptic::pipeline::gem::ImageKind> {
    use glyptic::pipeline::gem::ImageKind;
    if crate::values::is_stdio(output) {
        return Ok(ImageKind::Png);
    }
    let kind = ImageKind::from_path(output).ok_or_else(|| {
        anyhow!(
            "{}: name the image .png or .jpg (the format follows the extension)",
            output.display()
        )
    })?;
    if kind == ImageKind::Jpeg && params.transparent {
        bail!(
            "{}: JPEG has no transparency: write a .png for --background transparent",
            output.display()
        );
    }
    Ok(kind)
}

/// A face mesh from an OBJ file: positions `[x0, y0, z0, ...]` and triangles.
fn read_face_obj(path: &Path) -> Result<(Vec<f32>, Vec<[u32; 3]>)> {
    let text = glyptic::files::read_text_limited(path, glyptic::files::MAX_MESH_BYTES)
        .with_context(|| format!("{}: cannot read the face mesh", path.display()))?;
    let mesh = glyptic::gem::parse_obj(&text)
        .with_context(|| format!("{}: cannot read the face mesh", path.display()))?;
    if mesh.1.is_empty() {
        bail!("{}: the face mesh has no triangles", path.display());
    }
    // Said now, before the GPU and the cameo: the builder would refuse it too, unnamed.
    // (`parse_obj` has refused non-finite coordinates already.)
    glyptic::gem::check_face_mesh(&mesh.0, &mesh.1)
        .with_context(|| format!("{}: cannot carve this face mesh", path.display()))?;
    Ok(mesh)
}

#[cfg(feature = "face")]
pub(super) fn photo(args: &PhotoArgs) -> Result<()> {
    let start = Instant::now();
    let params = args.view.params()?;
    check_outputs(
        [args.image.as_path()],
        [
            Some(args.output.as_path()),
            args.landmarks_out.as_deref(),
            args.obj.as_deref(),
        ]
        .into_iter()
        .flatten()
        .chain(args.make.outputs()),
    )?;
    output_kind(&args.output, &params)?;
    let image_path = &args.image;

    // The GPU device and pipelines are independent of the face: start them now.
    let renderer_thread = spawn_renderer(params.clone());
    let (made, stages) = glyptic::stage::record(|| -> Result<_> {
        // The photo decodes on a second thread while the models load here; a file that is
        // no photo is still said first, whatever the models did.
        let (img, pipeline) = glyptic::stage::alongside(
            || -> Result<_> {
                if crate::values::is_stdio(image_path) {
                    decode_stdin()
                } else {
                    Ok(glyptic::pipeline::gem::decode(image_path)?)
                }
            },
            || args.choice.gem_pipeline(&args.view, detector_threads()),
        );
        let img = img?;
        let mut pipeline = pipeline?;
        let gem = pipeline
            .image(&img)
            .with_context(|| image_path.display().to_string())?;
        Ok((pipeline, gem))
    });
    note_stages(&stages);
    let (pipeline, gem) = made?;
    let triangles = &pipeline.face.model.shape.triangles;

    let made = make_files(
        &args.make,
        &gem.face.portrait,
        triangles,
        &gem.cameo,
        gem.detail.as_ref(),
        (&gem.mesh, &params),
        &source_label(image_path),
    )?;
    let mut renderer = join_renderer(renderer_thread)?;
    let png = render_png(&mut renderer, &gem.mesh, &params, &args.output)?;
    // Everything succeeded: now write, all or nothing, so a failure above or here leaves
    // no output behind and no existing file changed.
    let mut staged = Staged::new();
    stage_made(&mut staged, made)?;
    let t = Instant::now();
    if let Some(pts) = &args.landmarks_out {
        stage(
            &mut staged,
            pts,
            glyptic::landmarks::pts::write_pts(&gem.face.landmarks).as_bytes(),
        )?;
    }
    if let Some(obj) = &args.obj {
        let comment = format!(
            "glyptic fitted face from {}\nSurrey Face Model mesh, model millimetres (non-commercial licence)",
            source_label(image_path)
        );
        stage(
            &mut staged,
            obj,
            gem::to_obj(&gem.face.mesh, triangles, &comment).as_bytes(),
        )?;
    }
    if let Some(obj) = &args.make.gem_obj {
        stage_gem_obj(&mut staged, obj, &gem.mesh, &source_label(image_path))?;
    }
    let to_stdout = crate::values::is_stdio(&args.output);
    if !to_stdout {
        stage(&mut staged, &args.output, &png)?;
    }
    commit(staged)?;
    if to_stdout {
        crate::outputs::write_stdout(&png, "the image")?;
    }
    note_stages(&[
        Stage {
            name: "write",
            ms: t.elapsed().as_secs_f64() * 1e3,
            detail: args.output.display().to_string(),
        },
        Stage {
            name: "total",
            ms: start.elapsed().as_secs_f64() * 1e3,
            detail: String::new(),
        },
    ]);
    if args.json {
        #[derive(serde::Serialize)]
        struct PhotoReport {
            #[serde(flatten)]
            run: Run,
            face: crate::report::Face,
            faces_found: usize,
            person: Option<serde_json::Value>,
        }
        let face = &gem.face;
        let mut outputs = vec![
            ("image", Some(args.output.as_path())),
            ("landmarks", args.landmarks_out.as_deref()),
            ("obj", args.obj.as_deref()),
        ];
        outputs.extend(args.make.named());
        let outputs = Outputs::of(&outputs);
        crate::report::print(
            "photo",
            PhotoReport {
                run: Run::so_far(image_path.display().to_string(), outputs, start),
                face: crate::report::Face {
                    bbox: Some(face.detection.bbox),
                    score: Some(face.detection.score),
                    landmarks: face.landmarks.clone(),
                    pose: Some(Pose::of(&face.fit.pose)),
                    reprojection_px: Some(face.fit.reprojection_px),
                },
                faces_found: face.faces_found,
                person: gem.person.as_ref().map(glyptic::pipeline::gem::person_json),
            },
        );
    }
    Ok(())
}

/// The one photo's detector threads: the cores but one (the renderer starts and the models
/// load beside it), at most 8 (a 640-pixel frame's convolutions gain little past that). On
/// two cores: one, as before (measured: a second thread there only competed with the GPU's
/// start, issue #42).
#[cfg(feature = "face")]
fn detector_threads() -> usize {
    (glyptic_core::par::cores().saturating_sub(1)).clamp(1, 8)
}
