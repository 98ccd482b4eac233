//! `glyptic batch DIR -o OUTDIR`: every image of a folder to a gem PNG.
//!
//! Face workers (one per core by default, each with its own detector session, sharing the
//! landmark and face models) feed one render thread (the software rasteriser spreads each frame
//! over the cores itself). A bad image is recorded and skipped; the CSV lists every image with
//! its status and per-stage times, in input order. The exports (`--stl`, `--heightmap`,
//! `--gltf`) are made on the face workers and written beside each gem, named after it.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use indicatif::{ProgressBar, ProgressStyle};

use glyptic::pipeline::{GemPipeline, GemPipelineError};
use glyptic::render::Renderer;

use super::ViewArgs;
use crate::report::{Outputs as Written, Run};

#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:
  glyptic batch photos/ -o gems/
  glyptic batch photos/ -o gems/ --jobs 2 --csv report.csv --material agate
  glyptic batch photos/ -o gems/ --stl --heightmap --gltf
      beside each NAME-gem.png: NAME-gem.stl, NAME-height.png and NAME-gem.glb

Exit codes: 0 every photo made a gem; 1 some did not (the CSV says which and why) or the run
could not start; 2 a bad option; 130 (SIGINT) or 143 (SIGTERM): interrupted, the images in
hand finished and the CSV written (a second signal ends it at once).")]
pub struct BatchArgs {
    /// Folder of photos (JPEG, PNG, PPM, BMP, TIFF, WebP; not recursive).
    pub dir: PathBuf,
    /// Folder for the gems (`NAME-gem.png` for each `NAME.ext`); made if missing.
    #[arg(short, long, value_name = "OUTDIR")]
    pub output: PathBuf,
    /// Face workers, 1 or more (default and most: one per core).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..))]
    pub jobs: Option<u16>,
    /// Per-image status and times (default: OUTDIR/batch.csv).
    #[arg(long, value_name = "FILE.csv", value_parser = crate::values::file_named(&["csv"], "CSV"))]
    pub csv: Option<PathBuf>,
    /// Also write each stone for a 3D printer as OUTDIR/NAME-gem.stl (as `photo --stl`:
    /// binary STL in mm, a closed solid on a flat slab).
    #[arg(long)]
    pub stl: bool,
    /// The slab's thickness below the ground, mm (with --stl).
    #[arg(long, default_value_t = 3.0, value_name = "MM",
          value_parser = crate::values::finite_in::<f32>(0.1, 100.0))]
    pub base: f32,
    /// Also write each relief for a CNC router as OUTDIR/NAME-height.png (as `photo
    /// --heightmap`: 16-bit grey, its mm per level in the PNG's text).
    #[arg(long)]
    pub heightmap: bool,
    /// Also write each cameo for a 3D viewer as OUTDIR/NAME-gem.glb (as `photo --gltf`:
    /// binary glTF 2.0).
    #[arg(long)]
    pub gltf: bool,
    #[command(flatten)]
    pub view: ViewArgs,
    #[command(flatten)]
    pub choice: super::ChoiceArgs,
    /// Report as one JSON object on stdout (each image's status, times and gem; the run's
    /// totals) instead of the summary line, without the progress bar.
    #[arg(long)]
    pub json: bool,
}

/// One image's outcome.
#[derive(Clone, Debug, Default)]
struct Row {
    input: PathBuf,
    output: Option<PathBuf>,
    /// The exports written beside the gem, by kind (`stl`, `heightmap`, `gltf`).
    exports: Vec<(&'static str, PathBuf)>,
    status: &'static str,
    faces: usize,
    stages: Vec<(&'static str, f64)>,
    error: String,
    /// What was read of the person (hair, beard, moustache, glasses), for `--json`.
    person: Option<serde_json::Value>,
}

const CSV_STAGES: [&str; 10] = [
    "decode",
    "detect",
    "landmarks",
    "fit",
    "segment",
    "person",
    "gem",
    "render",
    "encode",
    "write",
];

/// One image's files: the gem and the exports asked for.
#[derive(Clone, Debug)]
struct Outputs {
    gem: PathBuf,
    make: super::make::MakeArgs,
}

impl Outputs {
    /// The exports by kind, as the JSON report names them.
    fn exports(&self) -> Vec<(&'static str, PathBuf)> {
        [
            ("stl", &self.make.stl),
            ("heightmap", &self.make.heightmap),
            ("gltf", &self.make.gltf),
        ]
        .into_iter()
        .filter_map(|(kind, p)| p.clone().map(|p| (kind, p)))
        .collect()
    }
}

/// Each image's files in `out_dir`, named after it: `NAME-gem.png` and beside it
/// `NAME-gem.stl`, `NAME-height.png`, `NAME-gem.glb` (those asked for).
fn outputs_for(files: &[PathBuf], out_dir: &Path, args: &BatchArgs) -> Vec<Outputs> {
    output_names(files)
        .into_iter()
        .map(|name| {
            let file = |suffix: &str| out_dir.join(format!("{name}{suffix}"));
            Outputs {
                gem: file("-gem.png"),
                make: super::make::MakeArgs {
                    gem_obj: None,
                    stl: args.stl.then(|| file("-gem.stl")),
                    base: args.base,
                    heightmap: args.heightmap.then(|| file("-height.png")),
                    gltf: args.gltf.then(|| file("-gem.glb")),
                },
            }
        })
        .collect()
}

/// Output names: `NAME`, or `NAME.ext` for names shared by several inputs; a name that
/// still clashes (`a.jpg`, `a.png` and `a.jpg.ppm` give `a.jpg` twice) gets `-2`, `-3`, ...
/// in input order, so every input has its own files.
fn output_names(files: &[PathBuf]) -> Vec<String> {
    let stem = |p: &Path| {
        p.file_stem()
            .map_or(String::new(), |s| s.to_string_lossy().into_owned())
    };
    let mut count = std::collections::HashMap::new();
    for f in files {
        *count.entry(stem(f)).or_insert(0usize) += 1;
    }
    let names: Vec<String> = files
        .iter()
        .map(|f| {
            let s = stem(f);
            if count[&s] > 1 {
                f.file_name()
                    .map_or(s.clone(), |n| n.to_string_lossy().into_owned())
            } else {
                s
            }
        })
        .collect();
    let mut taken = std::collections::HashSet::new();
    names
        .into_iter()
        .map(|name| {
            let (mut candidate, mut k) = (name.clone(), 1);
            while !taken.insert(candidate.clone()) {
                k += 1;
                candidate = format!("{name}-{k}");
            }
            candidate
        })
        .collect()
}

/// The output folder, made with its missing parents; removed again (those it made, if still
/// empty) when the batch ends before writing its CSV, so a refused run leaves no empty tree.
struct OutFolder {
    /// The folders made, deepest first.
    made: Vec<PathBuf>,
    keep: bool,
}

impl OutFolder {
    fn make(dir: &Path) -> Result<Self> {
        let made: Vec<PathBuf> = dir
            .ancestors()
            .take_while(|d| !d.as_os_str().is_empty() && !d.exists())
            .map(Path::to_path_buf)
            .collect();
        std::fs::create_dir_all(dir)
            .with_context(|| format!("{}: cannot make the output folder", dir.display()))?;
        Ok(OutFolder { made, keep: false })
    }
}

impl Drop for OutFolder {
    fn drop(&mut self) {
        if !self.keep {
            for d in &self.made {
                if std::fs::remove_dir(d).is_err() {
                    break;
                }
            }
        }
    }
}

/// The CSV: a header, then one row an image (RFC 4180 quoting by the `csv` crate).
fn write_csv(path: &Path, rows: &[Row]) -> Result<()> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut header: Vec<String> = ["input", "output", "status", "faces"]
        .map(String::from)
        .into();
    header.extend(CSV_STAGES.iter().map(|s| format!("{s}_ms")));
    header.extend(["total_ms", "error"].map(String::from));
    w.write_record(&header)?;
    for r in rows {
        let mut record = vec![
            r.input.display().to_string(),
            r.output
                .as_ref()
                .map(|p| p.display().to_string())
                .unwrap_or_default(),
            r.status.to_string(),
            r.faces.to_string(),
        ];
        record.extend(CSV_STAGES.iter().map(|s| {
            r.stages
                .iter()
                .find(|(n, _)| n == s)
                .map(|(_, ms)| format!("{ms:.2}"))
                .unwrap_or_default()
        }));
        let total = r.stages.iter().map(|(_, ms)| ms).fold(0.0, |a, b| a + b);
        record.push(format!("{total:.2}"));
        record.push(r.error.clone());
        w.write_record(&record)?;
    }
    let bytes = w
        .into_inner()
        .map_err(|e| anyhow::anyhow!("writing the CSV: {}", e.error()))?;
    crate::outputs::write_atomic(path, &bytes)
}

/// Decode, detect, landmarks, fit, person and relief for one image, its stages into `row`.
fn face_job(
    pipeline: &mut GemPipeline,
    input: &Path,
    row: &mut Row,
) -> Result<glyptic::pipeline::gem::PhotoGem, GemPipelineError> {
    let (made, stages) = glyptic::stage::record(|| pipeline.photo(input));
    row.stages.extend(stages.iter().map(|s| (s.name, s.ms)));
    let made = made?;
    row.faces = made.face.faces_found;
    Ok(made)
}

/// The exports `make` asks for of one image's gem (stage `export`), in memory.
fn export_job(
    pipeline: &GemPipeline,
    gem: &glyptic::pipeline::gem::PhotoGem,
    make: &super::make::MakeArgs,
    view: &glyptic::render::RenderParams,
    input: &Path,
    row: &mut Row,
) -> Result<super::make::Made> {
    if make.outputs().next().is_none() {
        return Ok(super::make::Made {
            files: Vec::new(),
            ms: 0.0,
        });
    }
    let (made, stages) = glyptic::stage::record(|| {
        glyptic::stage::timed(
            "make files",
            || {
                super::make::make_files(
                    make,
                    &gem.face.portrait,
                    &pipeline.face.model.shape.triangles,
                    &gem.cameo,
                    gem.detail.as_ref(),
                    (&gem.mesh, view),
                    &super::make::source_label(input),
                )
            },
            |m| {
                m.files
                    .iter()
                    .map(|f| f.2.as_str())
                    .collect::<Vec<_>>()
                    .join("; ")
            },
        )
    });
    row.stages.extend(stages.iter().map(|s| (s.name, s.ms)));
    made
}

pub fn batch(args: &BatchArgs) -> Result<()> {
    let view = args.view.params()?;
    let start = Instant::now();
    let files = glyptic::capture::source::list_images(&args.dir)?;
    if files.is_empty() {
        bail!(
            "{}: no images (looked for {})",
            args.dir.display(),
            glyptic::capture::source::IMAGE_EXTENSIONS.join(", ")
        );
    }
    if args.output.exists() && !args.output.is_dir() {
        bail!(
            "{}: not a folder (the gems go into a folder, made if missing)",
            args.output.display()
        );
    }
    let mut out_folder = OutFolder::make(&args.output)?;
    let outputs = outputs_for(&files, &args.output, args);
    let csv = args
        .csv
        .clone()
        .unwrap_or_else(|| args.output.join("batch.csv"));
    // No gem, export or the CSV may replace a photo of the batch, nor each other.
    crate::outputs::check_outputs(
        files.iter().map(PathBuf::as_path),
        outputs
            .iter()
            .flat_map(|o| std::iter::once(o.gem.as_path()).chain(o.make.outputs()))
            .chain([csv.as_path()]),
    )?;
    // Never more workers than cores: each holds a decoded photo and its buffers, and more
    // would only multiply the memory a hostile image can take, not the speed.
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let jobs = args
        .jobs
        .map_or(cores, usize::from)
        .clamp(1, cores.min(files.len()));

    // The GPU comes up while the models load.
    let renderer_thread = super::photo::spawn_renderer(view.clone());
    let models = glyptic::assets::ModelPaths::locate();
    // One detector and segmentation session per worker, sharing the landmark and face models;
    // a missing segmentation model is reported once.
    // One detector thread each: the workers already fill the cores.
    let mut pipelines = vec![args.choice.gem_pipeline(&args.view, 1)?];
    for _ in 1..jobs {
        let p = pipelines[0].fork(&models)?;
        pipelines.push(p);
    }
    let mut renderer: Renderer = renderer_thread.join()?.0;
    let loaded_ms = start.elapsed().as_secs_f64() * 1e3;

    let bar = if crate::report::quiet() || args.json {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(files.len() as u64)
    };
    bar.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} [{elapsed_precise}, {eta} left] {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );

    // The first SIGINT/SIGTERM stops the batch after the images in hand: the CSV is
    // written (the rest marked "interrupted") and the exit code says the signal.
    let interruptible = crate::signals::Interruptible::new();
    let files = Arc::new(files);
    let next = Arc::new(AtomicUsize::new(0));
    // Bounded: workers wait while the renderer is behind rather than piling up meshes.
    type Job = (
        usize,
        Row,
        Option<(glyptic::render::Mesh, super::make::Made)>,
    );
    let (tx, rx) = crossbeam_channel::bounded::<Job>(jobs);
    let mut rows: Vec<Row> = files
        .iter()
        .map(|f| Row {
            input: f.clone(),
            ..Row::default()
        })
        .collect();
    std::thread::scope(|scope| -> Result<()> {
        for mut pipeline in pipelines {
            let (files, next, tx) = (files.clone(), next.clone(), tx.clone());
            let (outputs, view, interruptible) = (&outputs, &view, &interruptible);
            scope.spawn(move || {
                loop {
                    if interruptible.asked().is_some() {
                        break;
                    }
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(input) = files.get(i) else { break };
                    let mut row = Row {
                        input: input.clone(),
                        ..Row::default()
                    };
                    // A panic in one image must not take the batch down.
                    let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(
                        || -> Result<_, (&'static str, String)> {
                            let gem = face_job(&mut pipeline, input, &mut row).map_err(|e| {
                                let status = if e.is_no_face() { "no face" } else { "error" };
                                (status, format!("{e:#}"))
                            })?;
                            let made = export_job(
                                &pipeline,
                                &gem,
                                &outputs[i].make,
                                view,
                                input,
                                &mut row,
                            )
                            .map_err(|e| ("error", format!("{e:#}")))?;
                            row.person =
                                gem.person.as_ref().map(glyptic::pipeline::gem::person_json);
                            Ok((gem.mesh, made))
                        },
                    ));
                    let mesh = match outcome {
                        Ok(Ok(made)) => Some(made),
                        Ok(Err((status, error))) => {
                            row.status = status;
                            row.error = error;
                            None
                        }
                        Err(_) => {
                            row.status = "error";
                            row.error = "internal error (panic) on this image".into();
                            None
                        }
                    };
                    if tx.send((i, row, mesh)).is_err() {
                        break;
                    }
                }
            });
        }
        drop(tx);
        for (i, mut row, mesh) in rx.iter() {
            let name = row
                .input
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            if interruptible.asked().is_some() {
                row.status = "interrupted";
                row.error = "the batch was interrupted before this image was written".into();
            } else if let Some((mesh, made)) = mesh {
                let (written, stages) = glyptic::stage::record(|| -> Result<()> {
                    let png = glyptic::pipeline::gem::render_png(&mut renderer, &mesh, &view)?;
                    glyptic::stage::timed(
                        "write",
                        || {
                            // An image's files together or not at all: an image marked
                            // "error" in the CSV has none of them.
                            let mut staged = glyptic::files::Staged::new();
                            for (path, bytes, _) in &made.files {
                                crate::outputs::stage(&mut staged, path, bytes)?;
                            }
                            crate::outputs::stage(&mut staged, &outputs[i].gem, &png)?;
                            crate::outputs::commit(staged)
                        },
                        |_| String::new(),
                    )
                });
                row.stages.extend(stages.iter().map(|s| (s.name, s.ms)));
                match written {
                    Ok(()) => {
                        row.status = "ok";
                        row.output = Some(outputs[i].gem.clone());
                        row.exports = outputs[i].exports();
                    }
                    Err(e) => {
                        row.status = "error";
                        row.error = format!("{e:#}");
                    }
                }
            }
            if row.status != "ok" && row.status != "interrupted" {
                let line = format!("skipped {name}: {}", row.error);
                if bar.is_hidden() {
                    crate::report::complain(format_args!("{line}"));
                } else {
                    bar.println(line);
                }
            }
            bar.set_message(name);
            bar.inc(1);
            rows[i] = row;
        }
        Ok(())
    })?;
    bar.finish_and_clear();
    let asked = interruptible.asked();
    for row in rows.iter_mut().filter(|r| r.status.is_empty()) {
        row.status = "interrupted";
        row.error = "the batch was interrupted before this image".into();
    }
    write_csv(&csv, &rows)?;
    out_folder.keep = true;
    drop(interruptible);
    let ok = rows.iter().filter(|r| r.status == "ok").count();
    let secs = start.elapsed().as_secs_f64();
    // The one renderer's share of the run after start-up: near 100 % it is what limits the
    // rate, not the face workers.
    let render_s: f64 = rows
        .iter()
        .flat_map(|r| r.stages.iter())
        .filter(|(name, _)| *name == "render")
        .map(|(_, ms)| ms / 1e3)
        .sum();
    let working_s = (secs - loaded_ms / 1e3).max(1e-9);
    if args.json {
        /// One image of the batch: what it became, or why not.
        #[derive(serde::Serialize)]
        struct Image<'a> {
            input: String,
            status: &'a str,
            error: Option<&'a str>,
            faces: usize,
            outputs: Written,
            person: &'a Option<serde_json::Value>,
            stages: Vec<glyptic::stage::Stage>,
        }
        #[derive(serde::Serialize)]
        struct BatchReport<'a> {
            #[serde(flatten)]
            run: Run,
            images: usize,
            ok: usize,
            face_workers: usize,
            startup_ms: f64,
            images_per_s: f64,
            renderer_busy: f64,
            results: Vec<Image<'a>>,
        }
        let results = rows
            .iter()
            .map(|r| {
                let mut pairs: Vec<(&'static str, Option<&Path>)> =
                    vec![("image", r.output.as_deref())];
                pairs.extend(r.exports.iter().map(|(kind, p)| (*kind, Some(p.as_path()))));
                Image {
                    input: r.input.display().to_string(),
                    status: r.status,
                    error: (!r.error.is_empty()).then_some(r.error.as_str()),
                    faces: r.faces,
                    outputs: Written::of(&pairs),
                    person: &r.person,
                    stages: r
                        .stages
                        .iter()
                        .map(|&(name, ms)| glyptic::stage::Stage {
                            name,
                            ms,
                            detail: String::new(),
                        })
                        .collect(),
                }
            })
            .collect();
        crate::report::print(
            "batch",
            BatchReport {
                run: Run::so_far(
                    args.dir.display().to_string(),
                    Written::of(&[("csv", Some(csv.as_path()))]),
                    start,
                ),
                images: rows.len(),
                ok,
                face_workers: jobs,
                startup_ms: loaded_ms,
                images_per_s: rows.len() as f64 / working_s,
                renderer_busy: render_s / working_s,
                results,
            },
        );
    } else {
        say!(
            "{ok} of {} images made into gems in {secs:.1} s ({:.2} images/s after {:.1} s start-up, {jobs} face workers; the renderer busy {:.0} % of that time); per-image status and times in {}",
            rows.len(),
            rows.len() as f64 / working_s,
            loaded_ms / 1e3,
            100.0 * render_s / working_s,
            csv.display()
        );
    }
    if let Some(signal) = asked {
        return Err(crate::signals::Interrupted {
            signal,
            what: format!(
                "{ok} of {} images made into gems before it; the rest are marked \"interrupted\" in {}",
                rows.len(),
                csv.display()
            ),
        }
        .into());
    }
    if ok < rows.len() {
        bail!(
            "{} of {} images failed (see {})",
            rows.len() - ok,
            rows.len(),
            csv.display()
        );
    }
    Ok(())
}
