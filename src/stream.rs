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
//! Units: milliseconds for stage times and latency, seconds for frame times.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crate::capture::{Capture, CaptureEvent, CaptureSummary, Frame, LatestReceiver, latest};
use crate::gem::CameoBuilder;
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
        let t = Instant::now();
        let built = builder.build_after(&face.portrait, triangles, warm);
        let ms = t.elapsed().as_secs_f64() * 1e3;
        match built {
            Ok(mesh) => {
                self.stages.push(Stage {
                    name: "gem",
                    ms,
                    detail: format!("{} triangles", mesh.indices.len() / 3),
                });
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
