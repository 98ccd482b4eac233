//! `glyptic track`: follows the face through a video, a folder, a photo or a webcam and reports
//! speed per stage, latency and what happened to the source.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};

use glyptic::capture::{Capture, CaptureEvent, CaptureOptions, FailedSource, FrameSource};
use glyptic::pipeline::FacePipeline;
use glyptic::stream::{FaceStream, FaceUpdate, StreamEvent};
use glyptic::track::{TrackOptions, Tracker};

use crate::report::Pose;

#[derive(clap::Args, Debug, Clone)]
#[command(after_help = "Examples:
  glyptic track clip.mp4
  glyptic track --camera 0 --frames 300
  glyptic track photos/ --all-frames")]
pub struct TrackArgs {
    /// A video file, a folder of images or a photo (or use --camera).
    #[arg(required_unless_present = "camera")]
    pub source: Option<PathBuf>,
    /// Read webcam N (/dev/videoN) instead.
    #[arg(long, value_name = "N", conflicts_with = "source")]
    pub camera: Option<u32>,
    /// Play a video again from the start when it ends.
    #[arg(long = "loop")]
    pub looping: bool,
    /// Process every frame in order on one thread (offline analysis and benchmarks), instead
    /// of live: a capture thread playing videos in real time with the newest frame winning.
    /// A folder of photos is always read this way (no photo is dropped).
    #[arg(long)]
    pub all_frames: bool,
    /// Stop after this many processed frames.
    #[arg(long, value_name = "N")]
    pub frames: Option<u64>,
    /// Write one JSON object per processed frame (pose, stages, latency) to this file.
    #[arg(long, value_name = "FILE.jsonl",
          value_parser = crate::values::file_named(&["jsonl", "json"], "JSON lines"))]
    pub jsonl: Option<PathBuf>,
    /// Turn smoothing off (each frame's own fit).
    #[arg(long)]
    pub no_smoothing: bool,
    /// Also build each fitted face's cameo on the face thread (stage "gem"), as the kiosk does.
    #[arg(long)]
    pub gem: bool,
    /// The cameo's portrait with --gem.
    #[arg(long, value_enum, default_value_t = glyptic::gem::View::Profile, requires = "gem")]
    pub portrait: glyptic::gem::View,
    /// Which face to pick up when the track starts or is lost (a tracked face is kept).
    #[command(flatten)]
    pub choice: super::ChoiceArgs,
}

fn open_source(args: &TrackArgs) -> Result<Box<dyn FrameSource>> {
    if let Some(index) = args.camera {
        #[cfg(feature = "webcam")]
        return Ok(Box::new(glyptic::capture::camera::CameraSource::new(index)));
        #[cfg(not(feature = "webcam"))]
        bail!("camera {index}: this build has no webcam support (cargo feature `webcam`)");
    }
    let Some(path) = args.source.clone() else {
        bail!("no source given");
    };
    if path.is_dir() {
        return Ok(Box::new(glyptic::capture::FolderSource::new(path)));
    }
    if !path.exists() {
        bail!("{}: file not found", path.display());
    }
    if glyptic::capture::source::is_image_path(&path) {
        return Ok(Box::new(glyptic::capture::ImageFileSource::new(path)));
    }
    #[cfg(feature = "video")]
    return Ok(Box::new(
        glyptic::capture::video_process::VideoProcess::new(path, args.looping),
    ));
    #[cfg(not(feature = "video"))]
    bail!(
        "{}: this build reads no video files (cargo feature `video`)",
        path.display()
    );
}

/// Per-stage times collected over a run.
#[derive(Default)]
struct StageTimes {
    by_name: Vec<(&'static str, Vec<f64>)>,
}

impl StageTimes {
    fn add(&mut self, name: &'static str, ms: f64) {
        match self.by_name.iter_mut().find(|(n, _)| *n == name) {
            Some((_, v)) => v.push(ms),
            None => self.by_name.push((name, vec![ms])),
        }
    }

    /// The per-stage table, on stderr with the other stage tables (nothing with `-q`).
    fn print(&self) {
        if crate::report::quiet() {
            return;
        }
        for (name, v) in &self.by_name {
            let (med, p95, n) = quantiles(v);
            crate::report::complain(format_args!(
                "  {name:<18} median {med:>7.2} ms   p95 {p95:>7.2} ms   ({n} frames)"
            ));
        }
    }
}

fn quantiles(v: &[f64]) -> (f64, f64, usize) {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let at = |q: f64| s[((s.len() - 1) as f64 * q).round() as usize];
    if s.is_empty() {
        return (f64::NAN, f64::NAN, 0);
    }
    (at(0.5), at(0.95), s.len())
}

/// One frame of `--jsonl`: a report line of its own (schema and command included), the face
/// as in every report plus what tracking adds.
fn json_line(update: &FaceUpdate) -> Result<String, serde_json::Error> {
    /// The tracked face: the smoothed pose in `yaw_deg`..., the frame's own fit in `raw`.
    #[derive(serde::Serialize)]
    struct Tracked<'a> {
        #[serde(flatten)]
        face: crate::report::Face,
        detected: bool,
        raw: Pose,
        identity_frames: usize,
        expression: &'a [f32],
    }
    #[derive(serde::Serialize)]
    struct Line<'a> {
        frame: u64,
        time_s: f64,
        latency_ms: f64,
        face: Option<Tracked<'a>>,
        note: &'a Option<String>,
        stages: &'a [glyptic::stage::Stage],
    }
    let face = update.face.as_ref().map(|f| Tracked {
        face: crate::report::Face {
            landmarks: f.landmarks.clone(),
            pose: Some(Pose::of(&f.pose)),
            reprojection_px: Some(f.raw.reprojection_px),
            ..Default::default()
        },
        detected: f.detected,
        raw: Pose::of(&f.raw.pose),
        identity_frames: f.identity_frames,
        expression: &f.expression,
    });
    serde_json::to_string(&crate::report::Report {
        schema: crate::report::SCHEMA,
        command: "track",
        body: Line {
            frame: update.frame_index,
            time_s: update.time_s,
            latency_ms: update.latency_ms,
            face,
            note: &update.note,
            stages: &update.stages,
        },
    })
}

pub fn track(args: &TrackArgs) -> Result<()> {
    let (pipeline, load) =
        glyptic::stage::record(|| FacePipeline::load(&glyptic::assets::ModelPaths::locate()));
    crate::report::note_stages(&load);
    let mut pipeline = pipeline?;
    args.choice.apply_face(&mut pipeline);
    let options = TrackOptions {
        smoothing: !args.no_smoothing,
        ..TrackOptions::default()
    };
    let mut tracker = Tracker::new(pipeline, options);
    let builder = if args.gem {
        Some(glyptic::gem::CameoBuilder::new(&args.portrait.cameo())?)
    } else {
        None
    };
    crate::outputs::check_outputs(args.source.as_deref(), args.jsonl.as_deref())?;
    let mut jsonl = match &args.jsonl {
        Some(p) => Some(std::io::BufWriter::new(
            std::fs::File::create(p).with_context(|| format!("{}: cannot create", p.display()))?,
        )),
        None => None,
    };
    let limit = args.frames.unwrap_or(u64::MAX);
    let mut times = StageTimes::default();
    let (mut processed, mut with_face, mut errors) = (0u64, 0u64, 0u64);
    let mut record = |u: &FaceUpdate, times: &mut StageTimes| -> Result<()> {
        for s in &u.stages {
            times.add(s.name, s.ms);
        }
        times.add("latency", u.latency_ms);
        if let Some(w) = jsonl.as_mut() {
            let line = json_line(u).context("a frame as JSON")?;
            writeln!(w, "{line}").context("writing the JSON lines")?;
        }
        Ok(())
    };
    let start = Instant::now();
    let mut last_status = Instant::now();
    let mut detections = 0;
    let mut end_note = None;
    // A folder's photos are separate pictures, not a live stream: every one is processed.
    let every_frame = args.all_frames || args.source.as_deref().is_some_and(Path::is_dir);
    if every_frame {
        let mut source = open_source(args)?;
        let clock = Instant::now();
        let mut index = 0u64;
        let mut warm = Vec::new();
        while processed < limit {
            let raw = match source.next_frame() {
                Ok(Some(raw)) => raw,
                Ok(None) => {
                    end_note = source.end_note();
                    break;
                }
                Err(e @ glyptic::capture::SourceError::BadFrame { .. }) => {
                    tracing::warn!("skipped: {e}");
                    errors += 1;
                    continue;
                }
                Err(e) => return Err(e.into()),
            };
            let frame = glyptic::capture::Frame {
                time_s: raw.time_s.unwrap_or_else(|| clock.elapsed().as_secs_f64()),
                image: std::sync::Arc::new(raw.image),
                index,
                captured: Instant::now(),
                path: raw.path,
            };
            index += 1;
            processed += 1;
            match tracker.process(&frame.image, frame.time_s) {
                Ok(step) => {
                    let mut u = FaceUpdate::new(&frame, step);
                    if let Some(b) = &builder {
                        u.build_gem(b, tracker.triangles(), &mut warm);
                    }
                    with_face += u64::from(u.face.is_some());
                    record(&u, &mut times)?;
                }
                Err(e) => {
                    errors += 1;
                    tracing::warn!("frame {}: {e}", frame.index);
                }
            }
        }
        detections = tracker.detections();
    } else {
        let make_args = args.clone();
        // Check the source opens before starting threads, for a clear error.
        open_source(&make_args)?;
        let capture = Capture::spawn(
            move || {
                open_source(&make_args).unwrap_or_else(|e| Box::new(FailedSource(e.to_string())))
            },
            CaptureOptions::default(),
        );
        // The visitor's hair is read on a person thread, as in the kiosk (with --gem).
        let hair = builder.is_some() && args.choice.hair == glyptic::pipeline::Hair::Photo;
        let stream = FaceStream::spawn_with(
            capture,
            tracker,
            glyptic::stream::StreamOptions {
                builder,
                hair,
                models: Some(glyptic::assets::ModelPaths::locate()),
                likeness: None,
                detail: glyptic::gem::DetailParams::default(),
            },
        );
        while processed < limit {
            for e in stream.events().try_iter() {
                match e {
                    StreamEvent::Capture(CaptureEvent::Ended { note }) => end_note = note,
                    // A run is analysis, not a kiosk: a source that cannot be reached before
                    // its first frame, or fails for good, ends it (it used to retry forever).
                    StreamEvent::Capture(CaptureEvent::Unavailable { reason, .. })
                        if processed == 0 =>
                    {
                        bail!("{}: {reason}", source_name(args))
                    }
                    StreamEvent::Capture(CaptureEvent::Failed { error }) => {
                        // The source's error names it already (the file said once).
                        let (name, said) = (source_name(args), error.to_string());
                        if said.contains(&name) {
                            bail!("{said}")
                        }
                        bail!("{name}: {said}")
                    }
                    StreamEvent::Capture(e) => tracing::warn!("capture: {e}"),
                    StreamEvent::Error { frame_index, error } => {
                        tracing::warn!("frame {frame_index}: {error}")
                    }
                }
            }
            match stream.updates().recv_timeout(Duration::from_millis(200)) {
                Ok(Some(u)) => {
                    processed += 1;
                    with_face += u64::from(u.face.is_some());
                    record(&u, &mut times)?;
                }
                Ok(None) => {}
                Err(_) => break,
            }
            if last_status.elapsed() > Duration::from_secs(5) {
                last_status = Instant::now();
                tracing::info!(
                    "{processed} frames, {:.1} frames/s",
                    processed as f64 / start.elapsed().as_secs_f64()
                );
            }
        }
        if let Some((summary, _)) = stream.stop() {
            errors += summary.errors;
            detections = summary.detections;
            say!(
                "capture: {} frames read, {} replaced by newer ones before processing, {} bad, {} unavailable attempts",
                summary.capture.frames,
                summary.capture.replaced,
                summary.capture.bad_frames,
                summary.capture.unavailable
            );
        }
    }
    if let Some(mut w) = jsonl {
        w.flush().context("writing the JSON lines")?;
    }
    let secs = start.elapsed().as_secs_f64();
    say!(
        "{processed} frames processed in {secs:.2} s ({:.1} frames/s): {with_face} with a face, \
         {detections} full-frame detections, {errors} errors",
        processed as f64 / secs
    );
    if let Some(note) = end_note {
        say!("source: {note}");
    }
    times.print();
    if processed == 0 {
        bail!("{}: no frame could be read", source_name(args));
    }
    Ok(())
}

/// How the source is named in errors: its path, or the camera.
fn source_name(args: &TrackArgs) -> String {
    match (&args.source, args.camera) {
        (Some(path), _) => path.display().to_string(),
        (None, Some(n)) => format!("camera {n} (/dev/video{n})"),
        (None, None) => "the source".into(),
    }
}
