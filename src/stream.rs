//! The face thread: takes the newest frame from a [`Capture`], tracks the face, and hands the
//! newest result on through a [`latest`] channel, so the renderer always gets the freshest
//! face and never waits (it keeps drawing the last one it has).
//!
//! Each update carries the frame's capture time and index, the per-stage times, and the latency
//! from capture to hand-over; capture events are passed on beside it. A frame the pipeline
//! fails on (no face, a broken model call) is an update without a face and a reason, counted
//! in the summary; it never ends the stream.
//!
//! With a [`CameoBuilder`] the face thread also rebuilds the cameo mesh after each fit (stage
//! "gem"), so the render thread only draws: it never builds geometry.
//!
//! With [`StreamOptions::hair`] a person thread reads the visitor's hair, beard and moustache
//! ([`crate::person`]) from the newest frame with a face whenever it is free (one frame at a
//! time: it never holds up the face thread), and [`HairSmoother`] settles what it finds, so a
//! new hairstyle reaches the updates ([`FaceUpdate::hair`]) only when several frames agree.
//!
//! Units: milliseconds for stage times and latency, seconds for frame times.
//!
//! Length: 672 lines of code, then its unit tests (102 lines), kept beside what they test.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use std::collections::VecDeque;

use image::RgbImage;

use crate::capture::{Capture, CaptureEvent, CaptureSummary, Frame, LatestReceiver, latest};
use crate::gem::silhouette::Silhouette;
use crate::gem::{CameoBuilder, CameoParams, HairCarving, HairStyle};
use crate::pipeline::Stage;
use crate::render::Mesh;
use crate::track::{TrackStep, TrackedFace, Tracker};

/// One processed frame.
#[derive(Clone, Debug)]
pub struct FaceUpdate {
    pub frame_index: u64,
    /// The frame's time in its stream, seconds.
    pub time_s: f64,
    pub captured: Instant,
    /// Milliseconds from capture to this update.
    pub latency_ms: f64,
    pub face: Option<TrackedFace>,
    /// The cameo built around `face` (when the stream has a [`CameoBuilder`]), gem mm.
    pub gem: Option<Arc<Mesh>>,
    /// Why there is no face (or why the track was lost on this frame).
    pub note: Option<String>,
    pub stages: Vec<Stage>,
    /// The visitor's hair as the person thread has settled it (with [`StreamOptions::hair`],
    /// once some frames have been read; on every update with a face from then on).
    pub hair: Option<HairStyle>,
}

/// Settles the hair styles read from a stream of frames: a style is taken when most of the
/// last [`HairSmoother::WINDOW`] readings agree on bald or not, beard or not, moustache or
/// not and glasses or not, its sizes the median of the readings that agree; and it replaces the one in use only
/// when it differs visibly (so the cameo is not rebuilt for noise).
#[derive(Clone, Debug, Default)]
pub struct HairSmoother {
    readings: VecDeque<HairStyle>,
    settled: Option<HairStyle>,
}

/// The share of the hair's outline grid that must change sides for the settled hair to be
/// rebuilt (about a finger's width all round a head).
const SILHOUETTE_MOVED: f32 = 0.02;

impl HairSmoother {
    /// Readings weighed together.
    pub const WINDOW: usize = 5;
    /// Readings needed before a first style.
    pub const FIRST: usize = 3;

    /// Forgets the readings (a new visitor).
    pub fn reset(&mut self) {
        self.readings.clear();
        self.settled = None;
    }

    /// The style in use.
    pub fn settled(&self) -> Option<HairStyle> {
        self.settled
    }

    /// Adds a reading; returns the new style when the one in use changes.
    pub fn push(&mut self, style: HairStyle) -> Option<HairStyle> {
        let finite = [
            style.volume,
            style.end,
            style.curl,
            style.beard,
            style.beard_jaw,
            style.moustache,
        ]
        .iter()
        .all(|v| v.is_finite());
        if !finite {
            return None;
        }
        if self.readings.len() == Self::WINDOW {
            self.readings.pop_front();
        }
        self.readings.push_back(style);
        if self.readings.len() < Self::FIRST {
            return None;
        }
        let n = self.readings.len();
        let most =
            |f: &dyn Fn(&HairStyle) -> bool| 2 * self.readings.iter().filter(|s| f(s)).count() > n;
        let bald = most(&|s| s.bald);
        let beard = most(&|s| s.beard > 0.0);
        let moustache = most(&|s| s.moustache > 0.0);
        let glasses = most(&|s| s.glasses);
        let ears_shown = most(&|s| s.ears_shown);
        let median = |keep: &dyn Fn(&HairStyle) -> bool, get: &dyn Fn(&HairStyle) -> f32| {
            let mut v: Vec<f32> = self.readings.iter().filter(|s| keep(s)).map(get).collect();
            v.sort_by(f32::total_cmp);
            v.get(v.len() / 2).copied().unwrap_or(0.0)
        };
        let scalp = |s: &HairStyle| s.bald == bald;
        let bearded = |s: &HairStyle| (s.beard > 0.0) == beard;
        let new = HairStyle {
            bald,
            volume: median(&scalp, &|s| s.volume),
            end: median(&scalp, &|s| s.end),
            curl: median(&scalp, &|s| s.curl),
            // The commonest carving among the agreeing readings (locks on a tie: the last
            // of the largest counts wins).
            carving: {
                let count = |c: HairCarving| {
                    self.readings
                        .iter()
                        .filter(|s| scalp(s) && s.carving == c)
                        .count()
                };
                [
                    HairCarving::Stippled,
                    HairCarving::Curls,
                    HairCarving::Locks,
                ]
                .into_iter()
                .max_by_key(|&c| count(c))
                .unwrap_or_default()
            },
            beard: if beard {
                median(&bearded, &|s| s.beard)
            } else {
                0.0
            },
            beard_jaw: if beard {
                median(&bearded, &|s| s.beard_jaw)
            } else {
                0.0
            },
            moustache: if moustache {
                median(&|s| s.moustache > 0.0, &|s| s.moustache)
            } else {
                0.0
            },
            glasses,
            ears_shown,
            outline: {
                let with = |s: &HairStyle| scalp(s) && s.outline.is_some();
                let part = |k: usize| median(&with, &|s| s.outline.map_or(0.0, |o| o[k]));
                self.readings.iter().any(with).then(|| [part(0), part(1)])
            },
            // The newest reading's fall among those that agree (a fall is a shape: a median
            // per row of different readings would be none of them).
            fall: self
                .readings
                .iter()
                .rev()
                .find(|s| scalp(s) && s.fall.is_some())
                .and_then(|s| s.fall),
            // The silhouette: the cell-wise median of the agreeing readings' signed distances.
            silhouette: Silhouette::median(
                self.readings
                    .iter()
                    .filter(|s| scalp(s))
                    .filter_map(|s| s.silhouette.as_ref()),
            ),
        };
        let visible = |a: &HairStyle, b: &HairStyle| {
            a.bald != b.bald
                || (a.beard > 0.0) != (b.beard > 0.0)
                || (a.moustache > 0.0) != (b.moustache > 0.0)
                || a.glasses != b.glasses
                || a.ears_shown != b.ears_shown
                || a.carving != b.carving
                || (a.volume - b.volume).abs() > 3.0
                || (a.end - b.end).abs() > 15.0
                || (a.curl - b.curl).abs() > 0.2
                || (a.beard - b.beard).abs() > 2.0
                || (a.beard_jaw - b.beard_jaw).abs() > 0.25
                || (a.moustache - b.moustache).abs() > 1.5
                || match (&a.silhouette, &b.silhouette) {
                    (Some(x), Some(y)) => x.differs(y) > SILHOUETTE_MOVED,
                    (x, y) => x.is_some() != y.is_some(),
                }
        };
        if self.settled.is_none_or(|old| visible(&old, &new)) {
            self.settled = Some(new);
            return Some(new);
        }
        None
    }
}

/// What the face thread does besides tracking.
#[derive(Clone, Debug, Default)]
pub struct StreamOptions {
    /// Build each fitted face's cameo with this builder (stage "gem").
    pub builder: Option<CameoBuilder>,
    /// Read the visitor's hair on a person thread ([`FaceUpdate::hair`]); with a builder, the
    /// cameo then carries it.
    pub hair: bool,
    /// Where the person thread loads the person segmentation from (`segmenter`, `onnxruntime`);
    /// without it, or when it does not load, hair is read from colour alone.
    pub models: Option<crate::assets::ModelPaths>,
    /// Steer each visitor's portrait identity towards their face with the recognition network
    /// ([`crate::identity`]), once their identity is held, on the person thread (the face
    /// thread and the window never wait for it); `None`: the landmark fit's identity. Needs
    /// `models` (the network).
    pub likeness: Option<crate::identity::SearchOptions>,
    /// How the visitor's own detail is carved, read on the frame the identity is steered
    /// with ([`crate::gem::FaceDetail`]; the stipple's depth among it).
    pub detail: crate::gem::DetailParams,
}

/// A job for the identity search: one frame of a held track.
struct IdentityJob {
    track: u64,
    fit: crate::fit::Fit,
    start: Vec<f32>,
}

/// What the person thread read from one frame.
#[derive(Default)]
struct PersonReading {
    hair: Option<HairStyle>,
    /// The track, the identity the search found for it, and the shape its shading added
    /// ([`crate::photometric::displacement`]; `None` when the frame could not say).
    steered: Option<(u64, Steered)>,
}

/// The person thread: reads hair from frames handed to it one at a time, and steers a held
/// track's identity when asked.
struct PersonWorker {
    /// `None` once dropping: the thread sees the channel close and ends.
    jobs: Option<crate::capture::LatestSender<PersonJob>>,
    results: LatestReceiver<PersonReading>,
    busy: bool,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Drop for PersonWorker {
    /// Waits for the thread's current work (a model still loading, a search under way), so
    /// nothing it logs comes after the stream has ended (nor ONNX Runtime's complaints about
    /// a process ending under a session it is building).
    fn drop(&mut self) {
        self.jobs = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// A frame, its landmarks, perhaps an identity search to run, and the frame's fitted face
/// (model mm) with its pose: the light on it tells a shadowed jaw from a beard.
type PersonJob = (
    Arc<RgbImage>,
    Vec<[f32; 2]>,
    Option<IdentityJob>,
    Option<(crate::fit::Pose, Vec<f32>)>,
);

impl PersonWorker {
    fn spawn(
        models: Option<crate::assets::ModelPaths>,
        hair: bool,
        triangles: Vec<[u32; 3]>,
        likeness: Option<(
            crate::identity::SearchOptions,
            Arc<crate::shapemodel::SurreyModel>,
        )>,
        detail: crate::gem::DetailParams,
    ) -> Option<Self> {
        let (jobs, inbox) = latest::<PersonJob>();
        let (send, results) = latest();
        let thread = std::thread::Builder::new()
            .name("person".into())
            .spawn(move || {
                // The person segmentation, when it loads (else colour alone).
                let mut segmenter = models.as_ref().filter(|_| hair).and_then(|m| {
                    crate::detect::PersonSegmenter::load(&m.segmenter, &m.onnxruntime).ok()
                });
                // The recognition network, on this thread's one core.
                let mut net = models
                    .as_ref()
                    .filter(|_| likeness.is_some())
                    .and_then(|m| {
                        crate::detect::FaceEmbedder::load(&m.recogniser, &m.onnxruntime, 1)
                            .map_err(|e| {
                                tracing::warn!(
                                    "{e}; the portrait keeps the landmark fit's identity"
                                )
                            })
                            .ok()
                    });
                while let Ok((image, landmarks, identity, face)) = inbox.recv() {
                    let mut reading = PersonReading::default();
                    if hair {
                        let mask = segmenter
                            .as_mut()
                            .and_then(|s| s.segment(&image, &landmarks).ok());
                        // The light on the fitted face (none: the darkness alone).
                        let grey = image::imageops::grayscale(image.as_ref());
                        let light = face.and_then(|(pose, mesh)| {
                            crate::photometric::fit(
                                &grey,
                                &landmarks,
                                &mesh,
                                &triangles,
                                &pose,
                                &crate::photometric::ShadingParams::light_only(),
                            )
                            .ok()
                        });
                        // A frame the person cannot be read from is no reading.
                        reading.hair = crate::person::analyse_shaded(
                            &image,
                            &landmarks,
                            mask.as_ref(),
                            light
                                .as_ref()
                                .map(|l| &l.expected as &dyn crate::person::Shading),
                        )
                        .ok()
                        .map(|p| crate::gem::hair_style(&p));
                    }
                    if let (Some(job), Some(net), Some((opts, model))) =
                        (identity, net.as_mut(), likeness.as_ref())
                    {
                        reading.steered =
                            steer(net, model, opts, &detail, &image, &landmarks, &job)
                                .map_err(|e| {
                                    tracing::warn!("cannot steer the visitor's identity: {e}")
                                })
                                .ok()
                                .map(|s| (job.track, s));
                    }
                    if send.send(reading).is_err() {
                        return;
                    }
                }
            })
            .ok()?;
        Some(PersonWorker {
            jobs: Some(jobs),
            results,
            busy: false,
            thread: Some(thread),
        })
    }
}

/// What the person thread found for a held track on one of its frames.
struct Steered {
    /// The identity the search found.
    shape: Vec<f32>,
    /// The shape read from the frame's shading and its landmarks beyond the model's reach
    /// (one model-frame displacement per vertex); `None` when the frame could not say.
    relief: Option<Vec<f32>>,
    /// The frame's own detail, as the photo path carves it ([`crate::gem::FaceDetail`]).
    detail: Option<Arc<crate::gem::FaceDetail>>,
}

/// The identity search on one frame of a held track ([`crate::pipeline::gem::steer_identity`]),
/// then the face's shape read from that frame's shading
/// ([`crate::pipeline::gem::read_shading`]) and its landmarks beyond the model's reach
/// ([`crate::warp`]) as one model-frame displacement, and the frame's detail (brows, irises,
/// the mouth, lines, and its light and dark: [`crate::gem::FaceDetail`]) on the face as the
/// frame shows it.
fn steer(
    net: &mut crate::detect::FaceEmbedder,
    model: &crate::shapemodel::SurreyModel,
    opts: &crate::identity::SearchOptions,
    detail: &crate::gem::DetailParams,
    image: &RgbImage,
    landmarks: &[[f32; 2]],
    job: &IdentityJob,
) -> Result<Steered, String> {
    let grey = image::imageops::grayscale(image);
    let mesh = model.instance(&job.fit.shape, &job.fit.expression);
    let shape = crate::pipeline::gem::steer_identity(
        net, model, image, &grey, landmarks, &job.fit, &mesh, &job.start, opts,
    )?
    .shape;
    let relief = crate::pipeline::gem::read_shading(
        model,
        &grey,
        landmarks,
        &job.fit,
        &shape,
        &crate::photometric::ShadingParams::default(),
    )
    .map(|f| crate::photometric::displacement(&f.offsets, &job.fit.pose));
    // The landmarks the model could not reach, as the photo path carves them (crate::warp).
    let warp = crate::warp::landmark_warp(
        model,
        &mesh,
        landmarks,
        &job.fit.pose,
        &crate::warp::WarpParams::default(),
    )
    .map(|w| w.displacement);
    let detail = {
        let mut seen_mesh = mesh.clone();
        if let Some(w) = &warp {
            crate::photometric::add(&mut seen_mesh, w);
        }
        let seen =
            crate::gem::detail::seen_vertices(&seen_mesh, &model.shape.triangles, &job.fit.pose);
        let light = crate::gem::detail::ToneLight::of_face(&job.fit.pose, &seen_mesh);
        crate::gem::FaceDetail::read(&grey, landmarks, seen, detail, light)
            .map_err(|e| tracing::warn!("cannot read the visitor's detail ({e}); the shape alone"))
            .ok()
            .map(Arc::new)
    };
    let relief = match (relief, warp) {
        (Some(mut r), Some(w)) => {
            crate::photometric::add(&mut r, &w);
            Some(r)
        }
        (r, w) => r.or(w),
    };
    Ok(Steered {
        shape,
        relief,
        detail,
    })
}

impl FaceUpdate {
    /// The update for `frame` from the tracker's step on it; latency counts until now.
    pub fn new(frame: &Frame, step: TrackStep) -> Self {
        let note = match (&step.face, step.lost) {
            (None, lost) => Some(lost.unwrap_or_else(|| "no face".into())),
            (Some(_), lost) => lost,
        };
        FaceUpdate {
            frame_index: frame.index,
            time_s: frame.time_s,
            captured: frame.captured,
            latency_ms: frame.captured.elapsed().as_secs_f64() * 1e3,
            face: step.face,
            gem: None,
            note,
            stages: step.stages,
            hair: None,
        }
    }
}

impl FaceUpdate {
    /// Builds the cameo around this update's face (if it has one) as stage "gem"; latency then
    /// counts until the gem is ready. A cameo that cannot be built leaves a note, no gem.
    /// `warm` carries the previous gem's solve into this one (see
    /// [`CameoBuilder::build_after`]).
    pub fn build_gem(
        &mut self,
        builder: &CameoBuilder,
        triangles: &[[u32; 3]],
        warm: &mut Vec<f32>,
    ) {
        let Some(face) = &self.face else {
            return;
        };
        let (built, stages) = crate::stage::record(|| {
            crate::stage::timed(
                "gem",
                || builder.build_after(&face.portrait, triangles, warm, face.detail.as_deref()),
                |mesh| format!("{} triangles", mesh.indices.len() / 3),
            )
        });
        self.stages.extend(stages);
        match built {
            Ok(mesh) => {
                self.gem = Some(Arc::new(mesh));
            }
            Err(e) => self.note = Some(format!("cameo: {e}")),
        }
        self.latency_ms = self.captured.elapsed().as_secs_f64() * 1e3;
    }
}

/// What the face thread did.
#[derive(Clone, Debug, Default)]
pub struct StreamSummary {
    /// Frames taken from capture and processed.
    pub processed: u64,
    /// Of those, frames with a face.
    pub with_face: u64,
    /// Frames the pipeline failed on (errors, not "no face").
    pub errors: u64,
    /// Frames on which the detector ran on the whole frame.
    pub detections: u64,
    pub capture: CaptureSummary,
}

/// Either an update or a capture event, in the order they happened.
#[derive(Clone, Debug)]
pub enum StreamEvent {
    Capture(CaptureEvent),
    /// The pipeline failed on a frame (the stream goes on).
    Error {
        frame_index: u64,
        error: String,
    },
}

/// A running face thread. Dropping it stops it and its capture thread.
pub struct FaceStream {
    updates: LatestReceiver<FaceUpdate>,
    events: crossbeam_channel::Receiver<StreamEvent>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<(StreamSummary, Tracker)>>,
}

impl FaceStream {
    /// Starts the face thread on `capture`'s frames.
    pub fn spawn(capture: Capture, tracker: Tracker) -> FaceStream {
        Self::spawn_with_gem(capture, tracker, None)
    }

    /// [`FaceStream::spawn`], also building each fitted face's cameo with `builder` on the face
    /// thread. A face whose cameo cannot be built is an update without a gem and a note.
    pub fn spawn_with_gem(
        capture: Capture,
        tracker: Tracker,
        builder: Option<CameoBuilder>,
    ) -> FaceStream {
        Self::spawn_with(
            capture,
            tracker,
            StreamOptions {
                builder,
                hair: false,
                models: None,
                likeness: None,
                detail: crate::gem::DetailParams::default(),
            },
        )
    }

    /// [`FaceStream::spawn`] with the given [`StreamOptions`].
    pub fn spawn_with(capture: Capture, tracker: Tracker, options: StreamOptions) -> FaceStream {
        let StreamOptions {
            mut builder,
            hair,
            models,
            likeness,
            detail,
        } = options;
        let likeness = likeness
            .filter(|_| models.is_some())
            .map(|o| (o, tracker.pipeline.model.clone()));
        let steering = likeness.is_some();
        let triangles = tracker.triangles().to_vec();
        let (tx, updates) = latest();
        let (etx, events) = crossbeam_channel::bounded(256);
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let thread = std::thread::Builder::new()
            .name("face".into())
            .spawn(move || {
                let mut tracker = tracker;
                let mut summary = StreamSummary::default();
                let mut warm = Vec::new();
                let detections_before = tracker.detections();
                let mut person = if hair || steering {
                    PersonWorker::spawn(models, hair, triangles, likeness, detail)
                } else {
                    None
                };
                // The track whose identity was sent to be steered (once per track).
                let mut asked: Option<u64> = None;
                let mut smoother = HairSmoother::default();
                let mut had_face = false;
                while !flag.load(Ordering::Relaxed) {
                    for e in capture.events().try_iter() {
                        let _ = etx.try_send(StreamEvent::Capture(e));
                    }
                    let frame = match capture.frames().recv_timeout(Duration::from_millis(50)) {
                        Ok(Some(frame)) => frame,
                        Ok(None) => continue,
                        Err(_) => break,
                    };
                    summary.processed += 1;
                    let update = match tracker.process(&frame.image, frame.time_s) {
                        Ok(step) => {
                            summary.with_face += u64::from(step.face.is_some());
                            let mut update = FaceUpdate::new(&frame, step);
                            let found = update.face.is_some();
                            if let (Some(worker), Some(face)) = (&mut person, &update.face) {
                                // A face found after none: perhaps a new visitor, whose hair is
                                // read afresh (as the tracker starts a new identity).
                                if !had_face {
                                    smoother.reset();
                                }
                                if let Ok(Some(reading)) = worker.results.try_recv() {
                                    worker.busy = false;
                                    if let Some((track, s)) = reading.steered {
                                        // A track lost meanwhile keeps its own.
                                        tracker.steer(track, s.shape, s.relief, s.detail);
                                    }
                                    let changed = reading.hair.and_then(|s| smoother.push(s));
                                    if let (Some(style), Some(b)) = (changed, &builder) {
                                        let params = CameoParams {
                                            hair: style,
                                            ..b.params().clone()
                                        };
                                        if let Ok(nb) = CameoBuilder::new(&params) {
                                            builder = Some(nb);
                                        }
                                    }
                                }
                                if !worker.busy {
                                    // Once the identity holds, one frame of the track goes to
                                    // the identity search.
                                    let held = face.identity_frames
                                        >= tracker.options.identity_frames.max(1);
                                    let job = (steering && held && asked != Some(face.track)).then(
                                        || IdentityJob {
                                            track: face.track,
                                            fit: face.raw.clone(),
                                            start: face.portrait_shape.clone(),
                                        },
                                    );
                                    if job.is_some() {
                                        asked = Some(face.track);
                                    }
                                    worker.busy = worker.jobs.as_ref().is_some_and(|j| {
                                        j.send((
                                            frame.image.clone(),
                                            face.landmarks.clone(),
                                            job,
                                            hair.then(|| (face.raw.pose, face.mesh.clone())),
                                        ))
                                        .is_ok()
                                    });
                                }
                                if hair {
                                    update.hair = smoother.settled();
                                }
                            }
                            had_face = found;
                            if let Some(b) = &builder {
                                update.build_gem(b, tracker.triangles(), &mut warm);
                            }
                            update
                        }
                        Err(e) => {
                            summary.errors += 1;
                            let _ = etx.try_send(StreamEvent::Error {
                                frame_index: frame.index,
                                error: e.to_string(),
                            });
                            FaceUpdate {
                                frame_index: frame.index,
                                time_s: frame.time_s,
                                captured: frame.captured,
                                latency_ms: frame.captured.elapsed().as_secs_f64() * 1e3,
                                face: None,
                                gem: None,
                                note: Some(e.to_string()),
                                stages: Vec::new(),
                                hair: None,
                            }
                        }
                    };
                    if tx.send(update).is_err() {
                        break;
                    }
                }
                for e in capture.events().try_iter() {
                    let _ = etx.try_send(StreamEvent::Capture(e));
                }
                summary.capture = capture.stop();
                summary.detections = tracker.detections() - detections_before;
                (summary, tracker)
            })
            .ok();
        FaceStream {
            updates,
            events,
            stop,
            thread,
        }
    }

    /// The newest update (newest wins).
    pub fn updates(&self) -> &LatestReceiver<FaceUpdate> {
        &self.updates
    }

    /// Capture events and pipeline errors, oldest first.
    pub fn events(&self) -> &crossbeam_channel::Receiver<StreamEvent> {
        &self.events
    }

    /// Stops both threads; returns the totals and the tracker (models stay loaded).
    pub fn stop(mut self) -> Option<(StreamSummary, Tracker)> {
        self.stop.store(true, Ordering::Relaxed);
        self.thread.take().and_then(|t| t.join().ok())
    }
}

impl Drop for FaceStream {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn style(beard: f32, volume: f32) -> HairStyle {
        HairStyle {
            beard,
            beard_jaw: if beard > 0.0 { 1.0 } else { 0.0 },
            volume,
            ..HairStyle::default()
        }
    }

    /// A first style after three readings; one odd reading in five changes nothing; a change
    /// most readings agree on is taken; noise below what shows is not; NaN readings are
    /// ignored; a reset starts over.
    #[test]
    fn hair_settles_on_what_most_readings_agree_on() {
        let mut s = HairSmoother::default();
        assert_eq!(s.push(style(8.0, 11.0)), None);
        assert_eq!(s.push(style(8.0, 12.0)), None);
        let first = s.push(style(0.0, 11.5)).expect("three readings");
        assert_eq!(first.beard, 8.0, "two bearded of three");
        assert_eq!(first.volume, 11.5);
        // Noise and a single shaven reading: nothing to rebuild.
        assert_eq!(s.push(style(8.5, 12.5)), None);
        assert_eq!(s.push(style(0.0, 11.0)), None);
        assert_eq!(s.settled(), Some(first));
        // The beard goes (the visitor turned, or it was never there): taken once most of the
        // last five agree (8, 0, 8.5, 0, 0).
        let shaven = s.push(style(0.0, 11.0)).expect("three shaven of five");
        assert_eq!((shaven.beard, shaven.beard_jaw), (0.0, 0.0));
        // Big hair: the volume's median moves past 3 mm.
        let mut big = None;
        for _ in 0..3 {
            big = big.or(s.push(style(0.0, 25.0)));
        }
        assert!(big.is_some_and(|b| b.volume == 25.0), "{big:?}");
        assert_eq!(s.push(style(f32::NAN, 11.0)), None);
        s.reset();
        assert_eq!(s.settled(), None);
        assert_eq!(s.push(style(0.0, 11.0)), None);
    }

    /// The settled silhouette is the median of the readings': a slightly different outline
    /// rebuilds nothing, hair grown out by a third of a face length does.
    #[test]
    fn the_hair_silhouette_settles_on_the_median_outline() {
        use crate::person::{HairMask, MASK_COLS, MASK_ROWS};
        let with = |radius: f32| {
            let mut share = [[0.0; MASK_COLS]; MASK_ROWS];
            for (r, row) in share.iter_mut().enumerate() {
                for (c, x) in row.iter_mut().enumerate() {
                    let [s, t] = HairMask::centre(r, c);
                    *x = f32::from(u8::from(s.hypot(t + 0.6) < radius));
                }
            }
            let plain = style(0.0, 11.0);
            HairStyle {
                silhouette: Some(Silhouette::from_mask(&HairMask { share }, &plain, 0.0)),
                ..plain
            }
        };
        let mut s = HairSmoother::default();
        s.push(with(0.5));
        s.push(with(0.55));
        let first = s.push(with(0.5)).expect("three readings");
        let outline = first.silhouette.expect("a silhouette");
        assert_eq!(outline, with(0.5).silhouette.expect("one"), "the median");
        assert_eq!(s.push(with(0.52)), None, "noise");
        let mut grown = None;
        for _ in 0..3 {
            grown = grown.or(s.push(with(0.85)));
        }
        let grown = grown.and_then(|g| g.silhouette).expect("rebuilt");
        assert!(
            grown.at(0.0, 30.0 + 0.6 * 115.0 + 0.8 * 115.0) > 0.0,
            "{grown:?}"
        );
    }

    /// The carving is the readings' commonest (locks on a tie): one curly reading among
    /// straight ones changes nothing, most readings curly rebuild in curls.
    #[test]
    fn the_hairs_carving_is_the_commonest_reading() {
        let with = |carving: HairCarving| HairStyle {
            carving,
            ..style(0.0, 11.0)
        };
        let mut s = HairSmoother::default();
        s.push(with(HairCarving::Locks));
        s.push(with(HairCarving::Curls));
        let first = s.push(with(HairCarving::Locks)).expect("three readings");
        assert_eq!(first.carving, HairCarving::Locks);
        assert_eq!(s.push(with(HairCarving::Curls)), None, "a tie keeps locks");
        let curly = s
            .push(with(HairCarving::Curls))
            .expect("three curly of five");
        assert_eq!(curly.carving, HairCarving::Curls);
    }
}
