//! The commands that look at one stage alone: `landmarks` (faces and their 68 points), `fit`
//! (the morphable model on a landmark file) and `kernel` (the scattering kernel's taps).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, anyhow, bail};

use glyptic::gem;

#[cfg(feature = "face")]
use super::ChoiceArgs;
use super::{OnOff, SssArgs};
use crate::outputs::{check_outputs, write_atomic};
use crate::report::{Outputs, Pose, Run};
use crate::values::Size;

#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:
  glyptic kernel 21
  glyptic kernel 25 --profile burley --strength 0.8")]
pub struct KernelArgs {
    /// Taps (odd, 3..=65).
    #[arg(value_parser = crate::values::odd_taps)]
    pub taps: usize,
    /// How much light scatters, 0..=1.
    #[arg(long, default_value_t = glyptic::sss::DEFAULT_STRENGTH, value_name = "S",
          allow_negative_numbers = true, value_parser = crate::values::finite_in::<f32>(0.0, 1.0))]
    pub strength: f32,
    /// Diffusion profile.
    #[arg(long, value_enum, default_value_t = glyptic::sss::Profile::Marble)]
    pub profile: glyptic::sss::Profile,
}

#[cfg(feature = "face")]
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:
  glyptic landmarks portrait.jpg
  glyptic landmarks group.jpg --json --max-faces 5
  glyptic landmarks portrait.jpg --pts face.pts

Exit codes: 0 faces found; 1 no face, or an error; 2 a bad option.")]
pub struct LandmarksArgs {
    /// A photo (JPEG, PNG, PPM, ...).
    pub image: PathBuf,
    /// Print one JSON object: `{"faces": [{"box": [x, y, w, h], "score": s, "points": [[x, y],
    /// ...68]}], "times_ms": {...}}`, image pixels, 0-based, subject first (see --prefer).
    #[arg(long)]
    pub json: bool,
    /// At most this many faces (the first in --prefer's order); at least 1.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub max_faces: Option<u32>,
    #[command(flatten)]
    pub choice: ChoiceArgs,
    /// Also write the subject's landmarks as iBUG .pts (1-based, as menpo reads them).
    #[arg(long, value_name = "FILE.pts", value_parser = crate::values::file_named(&["pts"], "iBUG points"))]
    pub pts: Option<PathBuf>,
}

#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:
  glyptic fit --landmarks face.pts --size 817x1024
  glyptic fit --landmarks face.pts --size 1280x960 --fov 60 --json --obj face.obj")]
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
    /// Outer iterations, 1 to 100.
    #[arg(long, default_value_t = 5, allow_negative_numbers = true,
          value_parser = clap::value_parser!(u32).range(1..=100))]
    pub iterations: u32,
    /// Use a perspective (pinhole) camera with this horizontal field of view, degrees, centred
    /// on the image; for faces close to the camera (a webcam: about 60). Default: orthographic.
    #[arg(long, value_name = "DEG", allow_negative_numbers = true,
          value_parser = crate::values::finite_in::<f64>(1.0, 170.0))]
    pub fov: Option<f64>,
    /// Fit this many times and report the median time (the model is loaded once).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    pub repeat: u32,
    /// Also write the fitted face mesh (model millimetres) as Wavefront OBJ.
    #[arg(long, value_name = "FILE.obj", value_parser = crate::values::file_named(&["obj"], "Wavefront OBJ"))]
    pub obj: Option<PathBuf>,
}

/// `glyptic landmarks`: detection and 68 landmarks per face, with per-stage times.
#[cfg(feature = "face")]
pub(super) fn find_landmarks(args: &LandmarksArgs) -> Result<()> {
    let start = std::time::Instant::now();
    let path = &args.image;
    check_outputs([path.as_path()], args.pts.as_deref())?;
    let (found, stages) = glyptic::stage::record(|| -> Result<_> {
        let img = glyptic::pipeline::gem::decode(path)?;
        let mut pipeline =
            glyptic::pipeline::LandmarkPipeline::load(&glyptic::assets::ModelPaths::locate())?;
        args.choice.apply(&mut pipeline.detect_options);
        let mut detections = pipeline
            .detect(&img)
            .with_context(|| path.display().to_string())?;
        if let Some(n) = args.max_faces {
            detections.truncate(n as usize);
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
    crate::report::note_stages(&stages);
    if args.json {
        #[derive(serde::Serialize)]
        struct LandmarksReport {
            #[serde(flatten)]
            run: Run,
            width: u32,
            height: u32,
            faces: Vec<crate::report::Face>,
        }
        let written = args.pts.as_deref().filter(|_| !faces.is_empty());
        crate::report::print(
            "landmarks",
            LandmarksReport {
                run: Run::so_far(
                    path.display().to_string(),
                    Outputs::of(&[("landmarks", written)]),
                    start,
                ),
                width: img.width(),
                height: img.height(),
                faces: faces
                    .iter()
                    .map(|f| crate::report::Face {
                        bbox: Some(f.detection.bbox),
                        score: Some(f.detection.score),
                        landmarks: f.points.clone(),
                        ..Default::default()
                    })
                    .collect(),
            },
        );
    } else {
        // (A faceless image is said once, as the error below.)
        for (i, f) in faces.iter().enumerate() {
            let [x, y, w, h] = f.detection.bbox;
            say!(
                "face {}: box {x:.0},{y:.0} {w:.0}x{h:.0}, score {:.2}, 68 landmarks",
                i + 1,
                f.detection.score
            );
        }
    }
    // A faceless image is a failure (exit 1), after the report: a script must not take an
    // empty list for landmarks.
    if faces.is_empty() {
        match args.pts {
            Some(_) => bail!(
                "{}: no face found, so no landmarks to write",
                path.display()
            ),
            None => bail!("{}: no face found", path.display()),
        }
    }
    Ok(())
}

pub(super) fn fit_landmarks(args: &FitArgs) -> Result<()> {
    let start = Instant::now();
    check_outputs([args.landmarks.as_path()], args.obj.as_deref())?;
    let path = &args.landmarks;
    let text = glyptic::files::read_text_limited(path, glyptic::files::MAX_TEXT_BYTES)
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
        iterations: args.iterations as usize,
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
        /// The fit: pose, the orthographic (or perspective) camera, the model's coefficients.
        #[derive(serde::Serialize)]
        struct FitReport {
            #[serde(flatten)]
            run: Run,
            #[serde(flatten)]
            pose: Pose,
            scale_px_per_mm: f64,
            /// Where the model origin projects, image pixels (x right, y down): with the
            /// rotation and scale this is the whole orthographic camera.
            translation_px: [f64; 2],
            rotation: [[f64; 3]; 3],
            shape: Vec<f32>,
            expression: Vec<f32>,
            expression_names: Vec<String>,
            reprojection_px: f64,
            max_reprojection_px: f64,
            mapped_landmarks: usize,
            noise_mm: f64,
            iterations: usize,
            fit_ms: f64,
            load_ms: f64,
            contour: bool,
            camera: &'static str,
            depth_mm: Option<f64>,
        }
        let stage = |name, ms| glyptic::stage::Stage {
            name,
            ms,
            detail: String::new(),
        };
        crate::report::note_stages(&[stage("load face model", load_ms), stage("fit", fit_ms)]);
        let outputs = Outputs::of(&[("obj", args.obj.as_deref())]);
        crate::report::print(
            "fit",
            FitReport {
                run: Run::so_far(path.display().to_string(), outputs, start),
                pose: Pose::of(&fit.pose),
                scale_px_per_mm: fit.pose.scale,
                translation_px: [fit.pose.translation.x, -fit.pose.translation.y],
                rotation: std::array::from_fn(|r| {
                    std::array::from_fn(|c| fit.pose.rotation[(r, c)])
                }),
                shape: fit.shape.clone(),
                expression: fit.expression.clone(),
                expression_names: model.blendshapes.names.clone(),
                reprojection_px: fit.reprojection_px,
                max_reprojection_px: fit.max_reprojection_px,
                mapped_landmarks: fit.mapped_landmarks,
                noise_mm: fit.noise_mm,
                iterations: fit.iterations,
                fit_ms,
                load_ms,
                contour: !args.no_contour,
                camera: if fit.perspective.is_some() {
                    "perspective"
                } else {
                    "orthographic"
                },
                depth_mm: fit.perspective.map(|p| p.depth_mm()),
            },
        );
    } else {
        crate::report::note_stages(&[glyptic::stage::Stage {
            name: "load face model",
            ms: load_ms,
            detail: format!("{} vertices", model.shape.num_vertices()),
        }]);
        say!(
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

/// `glyptic kernel N`.
pub(super) fn print_kernel(args: &KernelArgs) -> Result<()> {
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
    say!(
        "# {} taps, {:?} profile, strength {:.3} {:.3} {:.3}, range {} (= the blur radius)",
        p.taps,
        p.profile,
        p.strength[0],
        p.strength[1],
        p.strength[2],
        k.range
    );
    say!("# offset  weight r g b (sums {r:.6} {g:.6} {b:.6})");
    say!("{}", k.to_text().trim_end_matches('\n'));
    Ok(())
}
