//! Sub-commands. Each stage prints one line with its time.

#[cfg(feature = "face")]
mod batch;
#[cfg(feature = "face")]
pub mod track;

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, anyhow, bail};
use clap::{Parser, Subcommand, ValueEnum};

use glyptic::gem;
use glyptic::render::{Material, RenderParams, Renderer};
use glyptic::stage::{Stage, timed};

#[derive(Parser, Debug)]
#[command(
    name = "glyptic",
    version,
    about = "Turns a face into an engraved gem: a cameo portrait in marble or agate."
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
    /// More on stderr: -v each stage as it ends and the libraries' notes, -vv debug, -vvv
    /// everything (`RUST_LOG`, when set, decides instead).
    #[arg(short, long, global = true, action = clap::ArgAction::Count, conflicts_with = "quiet")]
    pub verbose: u8,
    /// Errors only: no stage table, no warnings, no progress bar.
    #[arg(short, long, global = true)]
    pub quiet: bool,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Makes a gem image from a portrait photo.
    #[cfg(feature = "face")]
    Photo(PhotoArgs),
    /// Renders the cameo with the Surrey model's mean face (no photo needed).
    Render(RenderArgs),
    /// Fits the face model to a landmark file (iBUG .pts, 1-based) and reports pose and error.
    Fit(FitArgs),
    /// Finds the faces in an image and their 68 iBUG landmarks.
    #[cfg(feature = "face")]
    Landmarks(LandmarksArgs),
    /// Follows the face through a video, folder, photo or webcam; reports speed per stage.
    #[cfg(feature = "face")]
    Track(track::TrackArgs),
    /// Makes a gem from every photo in a folder (all cores), with a CSV of status and times.
    #[cfg(feature = "face")]
    Batch(batch::BatchArgs),
    /// The museum window: the visitor's face as a live cameo, with touch controls.
    Kiosk(crate::kiosk::KioskArgs),
    /// Prints the subsurface-scattering kernel: one line per tap, `offset  r g b`, centre first.
    Kernel(KernelArgs),
}

#[derive(clap::Args, Debug)]
pub struct KernelArgs {
    /// Taps (odd, 3..=65).
    pub taps: usize,
    /// How much light scatters, 0..=1.
    #[arg(long, default_value_t = glyptic::sss::DEFAULT_STRENGTH, value_name = "S")]
    pub strength: f32,
    /// Diffusion profile.
    #[arg(long, value_enum, default_value_t = glyptic::sss::Profile::Marble)]
    pub profile: glyptic::sss::Profile,
}

#[cfg(feature = "face")]
#[derive(clap::Args, Debug)]
pub struct LandmarksArgs {
    /// A photo (JPEG, PNG, PPM, ...).
    pub image: PathBuf,
    /// Print one JSON object: `{"faces": [{"box": [x, y, w, h], "score": s, "points": [[x, y],
    /// ...68]}], "times_ms": {...}}`, image pixels, 0-based, subject first (see --prefer).
    #[arg(long)]
    pub json: bool,
    /// At most this many faces (the first in --prefer's order).
    #[arg(long, value_name = "N")]
    pub max_faces: Option<usize>,
    #[command(flatten)]
    pub choice: ChoiceArgs,
    /// Also write the subject's landmarks as iBUG .pts (1-based, as menpo reads them).
    #[arg(long, value_name = "FILE.pts")]
    pub pts: Option<PathBuf>,
}

#[derive(clap::Args, Debug)]
pub struct FitArgs {
    /// 68 landmarks, iBUG .pts (1-based coordinates, as menpo writes them); a landmark that
    /// was not found may be written `nan nan`.
    #[arg(long, value_name = "FILE.pts")]
    pub landmarks: PathBuf,
    /// Size of the image the landmarks belong to, WIDTHxHEIGHT pixels.
    #[arg(long)]
    pub size: Size,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Leave out the contour landmarks (face outline).
    #[arg(long)]
    pub no_contour: bool,
    /// Outer iterations.
    #[arg(long, default_value_t = 5)]
    pub iterations: usize,
    /// Use a perspective (pinhole) camera with this horizontal field of view, degrees, centred
    /// on the image; for faces close to the camera (a webcam: about 60). Default: orthographic.
    #[arg(long, value_name = "DEG")]
    pub fov: Option<f64>,
    /// Fit this many times and report the median time (the model is loaded once).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    pub repeat: u32,
    /// Also write the fitted face mesh (model millimetres) as Wavefront OBJ.
    #[arg(long, value_name = "FILE.obj")]
    pub obj: Option<PathBuf>,
}

#[derive(clap::Args, Debug)]
pub struct RenderArgs {
    /// Output PNG.
    #[arg(short, long)]
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
    /// Also write the whole cameo mesh (gem millimetres, with normals) as Wavefront OBJ.
    #[arg(long, value_name = "FILE.obj")]
    pub gem_obj: Option<PathBuf>,
}

/// How the gem is shown.
#[derive(clap::Args, Debug, Clone)]
pub struct ViewArgs {
    /// Stone of the cameo.
    #[arg(long, value_enum, default_value_t = Material::Marble)]
    pub material: Material,
    /// Image size, WIDTHxHEIGHT pixels.
    #[arg(long, default_value = "640x800")]
    pub size: Size,
    /// Orbit the view around the gem, degrees (0 looks straight at it).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub yaw: f32,
    /// Tilt the view, degrees.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub pitch: f32,
    /// How the portrait is carved: in profile (the classic cameo) or facing the viewer.
    #[arg(long, value_enum, default_value_t = gem::View::Profile)]
    pub portrait: gem::View,
    #[command(flatten)]
    pub sss: SssArgs,
    /// Gallery styles after the render, in order: toon, dither, painterly, fisheye, chromatic
    /// (e.g. `--style toon,fisheye`).
    #[arg(long, value_name = "NAME[,NAME...]")]
    pub style: Option<StyleChain>,
    /// The moment (seconds) the moving styles (chromatic) show.
    #[arg(long, default_value_t = 0.0, value_name = "S")]
    pub style_time: f32,
    /// An engraved Greek-key border round the ground (parallax occlusion mapping).
    #[arg(long, value_enum, default_value_t = OnOff::Off)]
    pub engraving: OnOff,
    /// A raking lamp at the upper left whose shadows the relief casts on the ground.
    #[arg(long, value_enum, default_value_t = OnOff::Off)]
    pub lamp: OnOff,
    /// Agate: cut the hair from a third, brown layer (off: white like the face).
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub hair_layer: OnOff,
}

/// `--style`'s list.
#[derive(Clone, Debug)]
pub struct StyleChain(pub Vec<glyptic::styles::Style>);

impl std::str::FromStr for StyleChain {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        glyptic::styles::Style::parse_chain(s).map(StyleChain)
    }
}

/// Subsurface scattering options (`render`, `photo`, `batch`).
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct SssArgs {
    /// Subsurface scattering: light diffusing through the stone.
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub sss: OnOff,
    /// Blur taps per direction (odd, 3..=65).
    #[arg(long, default_value_t = 21, value_name = "N")]
    pub sss_taps: usize,
    /// How much light scatters, 0..=1 (red's share; green and blue follow the reference balance).
    #[arg(long, default_value_t = glyptic::sss::DEFAULT_STRENGTH, value_name = "S")]
    pub sss_strength: f32,
    /// How far light travels under the surface, mm (the kernel's reach).
    #[arg(long, default_value_t = glyptic::sss::DEFAULT_WIDTH_MM, value_name = "MM")]
    pub sss_width: f32,
    /// Diffusion profile.
    #[arg(long, value_enum, default_value_t = glyptic::sss::Profile::Marble)]
    pub sss_profile: glyptic::sss::Profile,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum OnOff {
    On,
    Off,
}

impl SssArgs {
    /// The kernel parameters (even with `--sss off`, for `glyptic kernel`), validated.
    fn params(&self) -> Result<glyptic::sss::SssParams> {
        let p = glyptic::sss::SssParams {
            taps: self.sss_taps,
            strength: glyptic::sss::SssParams::strength_rgb(self.sss_strength),
            width_mm: self.sss_width,
            profile: self.sss_profile,
            falloff: self.sss_profile.falloff(),
        };
        p.validate().context("subsurface scattering")?;
        Ok(p)
    }
}

impl ViewArgs {
    fn params(&self) -> Result<RenderParams> {
        Ok(RenderParams {
            width: self.size.width,
            height: self.size.height,
            material: self.material,
            yaw_deg: self.yaw,
            pitch_deg: self.pitch,
            sss: match self.sss.sss {
                OnOff::On => Some(self.sss.params()?),
                OnOff::Off => None,
            },
            styles: self.style.clone().map_or_else(Vec::new, |c| c.0),
            style_time_s: self.style_time,
            engraving: (self.engraving == OnOff::On)
                .then(glyptic::render::surface::EngravingParams::default),
            lamp: (self.lamp == OnOff::On).then(glyptic::render::Lamp::default),
            hair_layer: self.hair_layer == OnOff::On,
            ..RenderParams::default()
        })
    }
}

#[cfg(feature = "face")]
/// Which face is the subject when a photo or frame holds several, and what of the photo
/// besides the face goes into the gem.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct ChoiceArgs {
    /// The subject among several faces: the largest, or the one nearest the image's centre
    /// (a kiosk with people passing behind the visitor).
    #[arg(long, value_enum, default_value_t = glyptic::detect::FaceChoice::Largest)]
    pub prefer: glyptic::detect::FaceChoice,
    /// The hair: the person's own, as the photo shows it (bald stays bald, long hair falls
    /// over the shoulders), or the same classical hairstyle for everyone.
    #[arg(long, value_enum, default_value_t = glyptic::pipeline::Hair::Photo)]
    pub hair: glyptic::pipeline::Hair,
    /// The portrait's caricature, GAIN,DETAIL: the gain multiplies the face's difference from
    /// the mean face, the detail (0..1) exaggerates its small, telling differences more than
    /// its large ones. `1,0` carves the fitted face as it is.
    #[arg(long, value_parser = parse_caricature, default_value = "1,0.5")]
    pub caricature: glyptic::shapemodel::Caricature,
    /// How much of the photo's expression the portrait carves: 0 a calm, neutral face (as
    /// classical cameos have), 1 all of it.
    #[arg(long, value_parser = parse_expression, default_value = "0.5")]
    pub expression: f32,
    /// Glasses found on the photo: carved as a cutter would (the rims and temples as ridges on
    /// the face), or left out.
    #[arg(long, value_enum, default_value_t = GlassesArg::Carve)]
    pub glasses: GlassesArg,
}

#[cfg(feature = "face")]
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum GlassesArg {
    Carve,
    Leave,
}

#[cfg(feature = "face")]
fn parse_expression(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if (0.0..=1.0).contains(&v) => Ok(v),
        Ok(v) => Err(format!("{v}: the expression's share must be 0..1")),
        Err(e) => Err(format!("{s:?} is not a number ({e})")),
    }
}

#[cfg(feature = "face")]
fn parse_caricature(s: &str) -> Result<glyptic::shapemodel::Caricature, String> {
    let (g, d) = s
        .split_once(',')
        .ok_or_else(|| format!("{s}: expected GAIN,DETAIL, e.g. 1,0.5"))?;
    let number = |v: &str| {
        v.trim()
            .parse::<f32>()
            .map_err(|e| format!("{s}: {v:?} is not a number ({e})"))
    };
    let c = glyptic::shapemodel::Caricature {
        gain: number(g)?,
        detail: number(d)?,
    };
    if c.is_valid() {
        Ok(c)
    } else {
        Err(format!("{s}: the gain must be 0..4 and the detail 0..1"))
    }
}

#[cfg(feature = "face")]
impl ChoiceArgs {
    pub fn apply(&self, options: &mut glyptic::detect::DetectOptions) {
        options.prefer = self.prefer;
    }

    /// The subject's choice, the portrait's caricature and its share of the expression.
    pub fn apply_face(&self, pipeline: &mut glyptic::pipeline::FacePipeline) {
        self.apply(&mut pipeline.faces.detect_options);
        pipeline.caricature = self.caricature;
        pipeline.portrait_expression = self.expression;
    }

    /// The photo -> gem pipeline with these choices and `view`'s portrait.
    pub fn gem_pipeline(&self, view: &ViewArgs) -> Result<glyptic::pipeline::GemPipeline> {
        let mut p = glyptic::pipeline::GemPipeline::load(
            &glyptic::assets::ModelPaths::locate(),
            view.portrait.cameo(),
            self.hair,
        )?;
        self.apply_face(&mut p.face);
        p.carve_glasses = self.glasses == GlassesArg::Carve;
        Ok(p)
    }
}

/// `WxH` in pixels.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Size {
    pub width: u32,
    pub height: u32,
}

/// Frame sizes accepted on the command line, pixels per side.
const SIZE_RANGE: std::ops::RangeInclusive<u32> = 16..=8192;

impl std::str::FromStr for Size {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let (w, h) = s
            .split_once(['x', 'X'])
            .ok_or_else(|| format!("`{s}` is not WIDTHxHEIGHT"))?;
        let parse = |v: &str| {
            v.trim()
                .parse::<u32>()
                .map_err(|_| format!("`{v}` is not a whole number of pixels"))
        };
        let (width, height) = (parse(w)?, parse(h)?);
        if !SIZE_RANGE.contains(&width) || !SIZE_RANGE.contains(&height) {
            return Err(format!(
                "{width}x{height}: each side must be {}..={} pixels",
                SIZE_RANGE.start(),
                SIZE_RANGE.end()
            ));
        }
        Ok(Size { width, height })
    }
}

#[cfg(feature = "face")]
#[derive(clap::Args, Debug)]
pub struct PhotoArgs {
    /// Portrait photo (JPEG, PNG, PPM, BMP, TIFF, WebP).
    pub image: PathBuf,
    /// Output PNG.
    #[arg(short, long)]
    pub output: PathBuf,
    #[command(flatten)]
    pub view: ViewArgs,
    #[command(flatten)]
    pub choice: ChoiceArgs,
    /// Also write the 68 landmarks as an iBUG .pts file (1-based, like menpo's).
    #[arg(long, value_name = "FILE.pts")]
    pub landmarks_out: Option<PathBuf>,
    /// Also write the fitted face mesh (model millimetres) as Wavefront OBJ.
    #[arg(long, value_name = "FILE.obj")]
    pub obj: Option<PathBuf>,
    /// Also write the whole cameo mesh (gem millimetres, with normals) as Wavefront OBJ.
    #[arg(long, value_name = "FILE.obj")]
    pub gem_obj: Option<PathBuf>,
}

/// `glyptic landmarks`: detection and 68 landmarks per face, with per-stage times.
#[cfg(feature = "face")]
fn find_landmarks(args: &LandmarksArgs) -> Result<()> {
    let path = &args.image;
    let (found, stages) = glyptic::stage::record(|| -> Result<_> {
        let img = glyptic::pipeline::gem::decode(path)?;
        let mut pipeline =
            glyptic::pipeline::LandmarkPipeline::load(&glyptic::assets::ModelPaths::locate())?;
        args.choice.apply(&mut pipeline.detect_options);
        let mut detections = pipeline
            .detect(&img)
            .with_context(|| path.display().to_string())?;
        if let Some(n) = args.max_faces {
            detections.truncate(n);
        }
        let faces = pipeline
            .landmarks(&img, &detections)
            .with_context(|| path.display().to_string())?;
        Ok((img, faces))
    });
    let (img, faces) = found?;
    if let (Some(pts), Some(face)) = (&args.pts, faces.first()) {
        write_atomic(
            pts,
            glyptic::landmarks::pts::write_pts(&face.points).as_bytes(),
        )?;
    }
    if args.json {
        let times: serde_json::Map<String, serde_json::Value> = stages
            .iter()
            .map(|s| (s.name.to_string(), serde_json::json!(s.ms)))
            .collect();
        let faces: Vec<serde_json::Value> = faces
            .iter()
            .map(|f| {
                serde_json::json!({
                    "box": f.detection.bbox, "score": f.detection.score, "points": f.points,
                })
            })
            .collect();
        println!(
            "{}",
            serde_json::json!({ "image": path.display().to_string(), "width": img.width(),
                "height": img.height(), "faces": faces, "times_ms": times })
        );
    } else {
        print_stages(&stages);
        if faces.is_empty() {
            println!("no face found in {}", path.display());
        }
        for (i, f) in faces.iter().enumerate() {
            let [x, y, w, h] = f.detection.bbox;
            println!(
                "face {}: box {x:.0},{y:.0} {w:.0}x{h:.0}, score {:.2}, 68 landmarks",
                i + 1,
                f.detection.score
            );
        }
    }
    if args.pts.is_some() && faces.is_empty() {
        bail!(
            "{}: no face found, so no landmarks to write",
            path.display()
        );
    }
    Ok(())
}

pub fn run(cli: Cli) -> Result<()> {
    QUIET.store(cli.quiet, std::sync::atomic::Ordering::Relaxed);
    match cli.command {
        #[cfg(feature = "face")]
        Command::Photo(args) => photo(&args),
        Command::Render(args) => render_mean(&args),
        Command::Fit(args) => fit_landmarks(&args),
        #[cfg(feature = "face")]
        Command::Landmarks(args) => find_landmarks(&args),
        #[cfg(feature = "face")]
        Command::Track(args) => track::track(&args),
        #[cfg(feature = "face")]
        Command::Batch(args) => batch::batch(&args),
        Command::Kernel(args) => print_kernel(&args),
        Command::Kiosk(args) => crate::kiosk::kiosk(&args),
    }
}

fn fit_landmarks(args: &FitArgs) -> Result<()> {
    check_output_dirs(args.obj.iter())?;
    let path = &args.landmarks;
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let points = glyptic::landmarks::pts::read_pts_with_missing(&text)
        .with_context(|| path.display().to_string())?;
    let (w, h) = (args.size.width as f32, args.size.height as f32);
    let outside = points
        .iter()
        .filter(|p| {
            p[0].is_finite()
                && p[1].is_finite()
                && !(p[0] >= -0.5 * w && p[0] <= 1.5 * w && p[1] >= -0.5 * h && p[1] <= 1.5 * h)
        })
        .count();
    if outside > 0 {
        bail!(
            "{}: {outside} landmarks lie far outside a {}x{} image",
            path.display(),
            args.size.width,
            args.size.height
        );
    }
    let load = Instant::now();
    let model = glyptic::shapemodel::SurreyModel::load_dir(&glyptic::assets::sfm_dir())?;
    let load_ms = load.elapsed().as_secs_f64() * 1e3;
    let opts = glyptic::fit::FitOptions {
        contour: !args.no_contour,
        iterations: args.iterations,
        ..Default::default()
    };
    let intrinsics = match args.fov {
        Some(fov) if fov > 1.0 && fov < 170.0 => {
            Some(glyptic::fit::Intrinsics::from_fov(w as f64, h as f64, fov))
        }
        Some(fov) => bail!("--fov {fov}: the field of view must be between 1 and 170 degrees"),
        None => None,
    };
    let mut times = Vec::with_capacity(args.repeat as usize);
    let mut fitted = None;
    for _ in 0..args.repeat {
        let t = Instant::now();
        let result = match intrinsics {
            Some(k) => glyptic::fit::fit_perspective(&model, &points, &opts, k),
            None => glyptic::fit::fit(&model, &points, &opts),
        };
        fitted = Some(result.with_context(|| path.display().to_string())?);
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    let fit = fitted.ok_or_else(|| anyhow!("no fit was run"))?;
    times.sort_by(f64::total_cmp);
    let fit_ms = times[times.len() / 2];
    let [yaw, pitch, roll] = fit.pose.yaw_pitch_roll_deg();
    if let Some(obj) = &args.obj {
        let mesh = model.instance(&fit.shape, &fit.expression);
        let comment = format!(
            "glyptic fit of {}\nSurrey Face Model mesh, model millimetres (non-commercial licence)",
            path.display()
        );
        write_atomic(
            obj,
            gem::to_obj(&mesh, &model.shape.triangles, &comment).as_bytes(),
        )?;
    }
    if args.json {
        let out = serde_json::json!({
            "yaw_deg": yaw, "pitch_deg": pitch, "roll_deg": roll,
            "scale_px_per_mm": fit.pose.scale,
            // Where the model origin projects, image pixels (x right, y down): with the rotation
            // and scale this is the whole orthographic camera.
            "translation_px": [fit.pose.translation.x, -fit.pose.translation.y],
            "rotation": (0..3).map(|r| (0..3).map(|c| fit.pose.rotation[(r, c)]).collect::<Vec<f64>>()).collect::<Vec<_>>(),
            "shape": fit.shape, "expression": fit.expression,
            "expression_names": model.blendshapes.names,
            "reprojection_px": fit.reprojection_px, "max_reprojection_px": fit.max_reprojection_px,
            "mapped_landmarks": fit.mapped_landmarks, "noise_mm": fit.noise_mm,
            "iterations": fit.iterations, "fit_ms": fit_ms, "load_ms": load_ms,
            "contour": !args.no_contour,
            "camera": if fit.perspective.is_some() { "perspective" } else { "orthographic" },
            "depth_mm": fit.perspective.map(|p| p.depth_mm()),
        });
        println!("{out}");
    } else {
        println!(
            "{:<16} {load_ms:>9.1} ms  {} vertices",
            "load face model",
            model.shape.num_vertices()
        );
        println!(
            "{:<16} {fit_ms:>9.2} ms  yaw {yaw:.1} pitch {pitch:.1} roll {roll:.1} deg, reprojection {:.2} px mean, {:.2} px max over {} mapped landmarks, landmark noise {:.2} mm, {} iterations",
            "fit",
            fit.reprojection_px,
            fit.max_reprojection_px,
            fit.mapped_landmarks,
            fit.noise_mm,
            fit.iterations
        );
    }
    Ok(())
}

/// Fails early, before any work, if an output's folder is missing.
fn check_output_dirs<'a>(outputs: impl IntoIterator<Item = &'a PathBuf>) -> Result<()> {
    for out in outputs {
        if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty())
            && !dir.is_dir()
        {
            bail!("{}: output folder does not exist", dir.display());
        }
    }
    Ok(())
}

/// Starts the GPU device and pipelines on another thread: they do not depend on the face, so
/// they come up while the photo is decoded and fitted.
fn spawn_renderer() -> std::thread::JoinHandle<Result<(Renderer, f64), glyptic::render::RenderError>>
{
    std::thread::spawn(|| {
        let t = Instant::now();
        Renderer::new_headless().map(|r| (r, t.elapsed().as_secs_f64() * 1e3))
    })
}

/// Waits for [`spawn_renderer`] and prints its stage line.
fn join_renderer(
    handle: std::thread::JoinHandle<Result<(Renderer, f64), glyptic::render::RenderError>>,
) -> Result<Renderer> {
    let (renderer, init_ms) = handle
        .join()
        .map_err(|_| anyhow!("the renderer thread panicked"))?
        .context("starting the renderer")?;
    print_stages(&[Stage {
        name: "gpu init",
        ms: init_ms,
        detail: format!("{} (in parallel)", renderer.adapter_info()),
    }]);
    Ok(renderer)
}

fn render_mean(args: &RenderArgs) -> Result<()> {
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
            },
            landmarks_out: None,
            obj: None,
            gem_obj: args.gem_obj.clone(),
        });
    }
    let start = Instant::now();
    let params = args.view.params()?;
    check_output_dirs([&args.output].into_iter().chain(args.gem_obj.as_ref()))?;
    let renderer_thread = spawn_renderer();
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
        Ok(glyptic::pipeline::gem::build_gem(
            &face,
            &triangles,
            &args.view.portrait.cameo(),
        )?)
    });
    print_stages(&stages);
    let mesh = mesh?;
    let mut renderer = join_renderer(renderer_thread)?;
    let png = render_png(&mut renderer, &mesh, &params, &args.output)?;
    if let Some(obj) = &args.gem_obj {
        write_gem_obj(obj, &mesh, "the mean face")?;
    }
    write_atomic(&args.output, &png)?;
    print_stages(&[Stage {
        name: "total",
        ms: start.elapsed().as_secs_f64() * 1e3,
        detail: args.output.display().to_string(),
    }]);
    Ok(())
}

/// Renders the gem and encodes its PNG, printing the stages (`output` names it in errors).
fn render_png(
    renderer: &mut Renderer,
    mesh: &glyptic::render::Mesh,
    params: &RenderParams,
    output: &Path,
) -> Result<Vec<u8>> {
    let (png, stages) =
        glyptic::stage::record(|| glyptic::pipeline::gem::render_png(renderer, mesh, params));
    print_stages(&stages);
    png.with_context(|| output.display().to_string())
}

/// Encodes `rgba` as PNG and writes it whole (or not at all) to `path`.
pub fn write_png(rgba: image::RgbaImage, path: &Path) -> Result<()> {
    let png = glyptic::pipeline::gem::encode_png(rgba)
        .with_context(|| format!("{}: encoding the PNG", path.display()))?;
    write_atomic(path, &png)
}

/// A face mesh from an OBJ file: positions `[x0, y0, z0, ...]` and triangles.
fn read_face_obj(path: &Path) -> Result<(Vec<f32>, Vec<[u32; 3]>)> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read the face mesh", path.display()))?;
    let mesh = glyptic::gem::parse_obj(&text)
        .with_context(|| format!("{}: cannot read the face mesh", path.display()))?;
    if mesh.1.is_empty() {
        bail!("{}: the face mesh has no triangles", path.display());
    }
    Ok(mesh)
}

/// Writes the cameo mesh as OBJ (gem millimetres, normals).
fn write_gem_obj(path: &Path, mesh: &glyptic::render::Mesh, source: &str) -> Result<()> {
    let comment = format!(
        "glyptic cameo from {source}\ngem millimetres: the cameo in the XY plane facing +Z, ground at z = 0"
    );
    write_atomic(path, gem::mesh_to_obj(mesh, &comment).as_bytes())
}

/// `glyptic kernel N`.
fn print_kernel(args: &KernelArgs) -> Result<()> {
    let p = SssArgs {
        sss: OnOff::On,
        sss_taps: args.taps,
        sss_strength: args.strength,
        sss_width: glyptic::sss::SssParams::default().width_mm,
        sss_profile: args.profile,
    }
    .params()?;
    let k = glyptic::sss::kernel(&p)?;
    let [r, g, b] = k.sums();
    println!(
        "# {} taps, {:?} profile, strength {:.3} {:.3} {:.3}, range {} (= the blur radius)",
        p.taps, p.profile, p.strength[0], p.strength[1], p.strength[2], k.range
    );
    println!("# offset  weight r g b (sums {r:.6} {g:.6} {b:.6})");
    print!("{}", k.to_text());
    Ok(())
}

/// Whether `-q` asked for errors only (set once, before any command runs).
static QUIET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// The stage table's lines: name, time, what the stage found (nothing with `-q`).
fn print_stages(stages: &[Stage]) {
    if QUIET.load(std::sync::atomic::Ordering::Relaxed) {
        return;
    }
    for s in stages {
        println!("{:<16} {:>9.1} ms  {}", s.name, s.ms, s.detail);
    }
}

/// Writes `bytes` to `path` through a temporary file in the same folder, so that a failure
/// never leaves a partial file and an existing file is replaced whole.
fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .ok_or_else(|| anyhow!("{}: not a file name", path.display()))?;
    let tmp = dir.join(format!(
        ".{}.{}.tmp",
        name.to_string_lossy(),
        std::process::id()
    ));
    let result = (|| -> std::io::Result<()> {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.with_context(|| format!("{}: cannot write", path.display()))
}

#[cfg(feature = "face")]
fn photo(args: &PhotoArgs) -> Result<()> {
    let start = Instant::now();
    let params = args.view.params()?;
    check_output_dirs(
        [
            Some(&args.output),
            args.landmarks_out.as_ref(),
            args.obj.as_ref(),
            args.gem_obj.as_ref(),
        ]
        .into_iter()
        .flatten(),
    )?;
    let image_path = &args.image;

    // The GPU device and pipelines are independent of the face: start them now.
    let renderer_thread = spawn_renderer();
    let (made, stages) = glyptic::stage::record(|| -> Result<_> {
        let mut pipeline = args.choice.gem_pipeline(&args.view)?;
        let gem = pipeline
            .photo(image_path)
            .with_context(|| image_path.display().to_string())?;
        Ok((pipeline, gem))
    });
    print_stages(&stages);
    let (pipeline, gem) = made?;
    let triangles = &pipeline.face.model.shape.triangles;

    let mut renderer = join_renderer(renderer_thread)?;
    let png = render_png(&mut renderer, &gem.mesh, &params, &args.output)?;
    let t = Instant::now();
    // Everything succeeded: now write, so a failure above leaves no output behind.
    if let Some(pts) = &args.landmarks_out {
        write_atomic(
            pts,
            glyptic::landmarks::pts::write_pts(&gem.face.landmarks).as_bytes(),
        )?;
    }
    if let Some(obj) = &args.obj {
        let comment = format!(
            "glyptic fitted face from {}\nSurrey Face Model mesh, model millimetres (non-commercial licence)",
            image_path.display()
        );
        write_atomic(
            obj,
            gem::to_obj(&gem.face.mesh, triangles, &comment).as_bytes(),
        )?;
    }
    if let Some(obj) = &args.gem_obj {
        write_gem_obj(obj, &gem.mesh, &image_path.display().to_string())?;
    }
    write_atomic(&args.output, &png)?;
    print_stages(&[
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
    Ok(())
}
