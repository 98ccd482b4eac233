//! The capture thread: pulls frames from a [`FrameSource`] and hands the newest one on through a
//! [`latest`] channel, stamped with when it was read, so the consumer can measure latency.
//!
//! Faults never stop the consumer: a source that is unavailable (camera missing or unplugged)
//! is retried with exponential back-off and reported as [`CaptureEvent::Unavailable`]; a bad
//! frame is skipped and counted; the end of a file or a fatal error ends the thread with an
//! event saying why. Events go through their own bounded channel and are dropped (and counted)
//! rather than block capture if nobody reads them.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crossbeam_channel::Receiver;
use image::RgbImage;

use super::latest::{LatestReceiver, LatestSender, latest};
use super::source::{FrameSource, SourceError};

/// A captured frame.
#[derive(Clone, Debug)]
pub struct Frame {
    pub image: Arc<RgbImage>,
    /// Position in the stream of frames read (0-based, bad frames not counted).
    pub index: u64,
    /// Seconds since the stream started: the source's own time when it has one (videos),
    /// else the time the frame was read.
    pub time_s: f64,
    /// When the frame was read: latency is measured from here.
    pub captured: Instant,
    /// The file the frame came from (folders, photos).
    pub path: Option<PathBuf>,
}

/// Exponential back-off between attempts to reach an unavailable source.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Backoff {
    pub initial: Duration,
    pub max: Duration,
    pub factor: f64,
}

impl Default for Backoff {
    /// 0.25 s, doubling to at most 4 s: a camera plugged back in is picked up within seconds,
    /// and a missing one costs a few opening attempts a minute.
    fn default() -> Self {
        Backoff {
            initial: Duration::from_millis(250),
            max: Duration::from_secs(4),
            factor: 2.0,
        }
    }
}

impl Backoff {
    /// The wait before attempt `n + 1` after `n` failed ones (`n >= 1`).
    pub fn delay(&self, failures: u32) -> Duration {
        let k = self
            .factor
            .max(1.0)
            .powi(failures.saturating_sub(1).min(64) as i32);
        self.initial.mul_f64(k.min(1e6)).min(self.max)
    }
}

/// Settings of the capture thread.
#[derive(Clone, Debug)]
pub struct CaptureOptions {
    /// Play sources that have a frame rate (video files) in real time instead of as fast as
    /// they decode.
    pub pace: bool,
    pub backoff: Backoff,
    /// Capacity of the event channel.
    pub event_capacity: usize,
}

impl Default for CaptureOptions {
    fn default() -> Self {
        CaptureOptions {
            pace: true,
            backoff: Backoff::default(),
            event_capacity: 64,
        }
    }
}

/// What happened to the source, for status lines.
#[derive(Clone, Debug, PartialEq)]
pub enum CaptureEvent {
    /// The first frame arrived.
    Started { source: String },
    /// The source could not be reached; another attempt follows after `retry_in`.
    Unavailable {
        reason: String,
        attempt: u32,
        retry_in: Duration,
    },
    /// Frames flow again after `failed_attempts` unavailable ones.
    Resumed { failed_attempts: u32 },
    /// A frame or file was skipped; `count` so far.
    BadFrame { reason: String, count: u64 },
    /// The source ended (end of file, last photo); `note` says why if it ended early.
    Ended { note: Option<String> },
    /// The source failed for good.
    Failed { error: String },
}

/// One line for a log or a status line.
impl std::fmt::Display for CaptureEvent {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CaptureEvent::Started { source } => write!(f, "{source}: first frame"),
            CaptureEvent::Unavailable {
                reason,
                attempt,
                retry_in,
            } => write!(
                f,
                "unavailable ({reason}); attempt {attempt}, next in {:.1} s",
                retry_in.as_secs_f64()
            ),
            CaptureEvent::Resumed { failed_attempts } => {
                write!(f, "frames again after {failed_attempts} failed attempts")
            }
            CaptureEvent::BadFrame { reason, count } => {
                write!(f, "frame skipped ({reason}); {count} so far")
            }
            CaptureEvent::Ended { note: Some(note) } => write!(f, "ended: {note}"),
            CaptureEvent::Ended { note: None } => write!(f, "ended"),
            CaptureEvent::Failed { error } => write!(f, "failed: {error}"),
        }
    }
}

/// Totals of a capture run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CaptureSummary {
    pub frames: u64,
    pub bad_frames: u64,
    /// Failed attempts to reach an unavailable source.
    pub unavailable: u64,
    /// Frames replaced by a newer one before the consumer took them.
    pub replaced: u64,
    /// Events dropped because nobody read them.
    pub events_dropped: u64,
    /// Why the source ended, if it did (end of file, fatal error).
    pub end: Option<String>,
}

/// A running capture thread. Dropping it stops the thread.
pub struct Capture {
    frames: LatestReceiver<Frame>,
    events: Receiver<CaptureEvent>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<CaptureSummary>>,
}

impl Capture {
    /// Starts a thread reading from the source `make` builds (on that thread, so sources need
    /// not be `Send`).
    pub fn spawn<F>(make: F, opts: CaptureOptions) -> Capture
    where
        F: FnOnce() -> Box<dyn FrameSource> + Send + 'static,
    {
        let (tx, frames) = latest();
        let (etx, events) = crossbeam_channel::bounded(opts.event_capacity.max(1));
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let thread = std::thread::Builder::new()
            .name("capture".into())
            .spawn(move || {
                let mut source = make();
                run(source.as_mut(), &tx, &etx, &flag, &opts)
            })
            .ok();
        Capture {
            frames,
            events,
            stop,
            thread,
        }
    }

    /// The newest frame (newest wins: frames not taken in time are replaced).
    pub fn frames(&self) -> &LatestReceiver<Frame> {
        &self.frames
    }

    /// Status events, oldest first.
    pub fn events(&self) -> &Receiver<CaptureEvent> {
        &self.events
    }

    /// Whether the thread has finished (source ended or failed).
    pub fn finished(&self) -> bool {
        self.thread.as_ref().is_none_or(|t| t.is_finished())
    }

    /// Stops the thread and returns its totals.
    pub fn stop(mut self) -> CaptureSummary {
        self.stop_and_join()
    }

    fn stop_and_join(&mut self) -> CaptureSummary {
        self.stop.store(true, Ordering::Relaxed);
        match self.thread.take().map(|t| t.join()) {
            Some(Ok(summary)) => summary,
            Some(Err(_)) => CaptureSummary {
                end: Some("the capture thread panicked".into()),
                ..CaptureSummary::default()
            },
            None => CaptureSummary {
                end: Some("the capture thread could not be started".into()),
                ..CaptureSummary::default()
            },
        }
    }
}

impl Drop for Capture {
    fn drop(&mut self) {
        if self.thread.is_some() {
            self.stop_and_join();
        }
    }
}

/// Sleeps up to `d`, waking early when `stop` is set. Returns whether to go on.
fn sleep_unless_stopped(d: Duration, stop: &AtomicBool) -> bool {
    let until = Instant::now() + d;
    loop {
        if stop.load(Ordering::Relaxed) {
            return false;
        }
        let now = Instant::now();
        if now >= until {
            return true;
        }
        std::thread::sleep((until - now).min(Duration::from_millis(20)));
    }
}

fn run(
    source: &mut dyn FrameSource,
    tx: &LatestSender<Frame>,
    events: &crossbeam_channel::Sender<CaptureEvent>,
    stop: &AtomicBool,
    opts: &CaptureOptions,
) -> CaptureSummary {
    let mut summary = CaptureSummary::default();
    let emit = |summary: &mut CaptureSummary, e: CaptureEvent| {
        if events.try_send(e).is_err() {
            summary.events_dropped += 1;
        }
    };
    let start = Instant::now();
    // Source time of the first frame and when it was read, for pacing.
    let mut clock: Option<(f64, Instant)> = None;
    let mut failures = 0u32;
    while !stop.load(Ordering::Relaxed) {
        let raw = match source.next_frame() {
            Ok(Some(raw)) => raw,
            Ok(None) => {
                let note = source.end_note();
                summary.end = Some(note.clone().unwrap_or_else(|| "end of source".into()));
                emit(&mut summary, CaptureEvent::Ended { note });
                break;
            }
            Err(SourceError::Unavailable { reason, .. }) => {
                failures += 1;
                summary.unavailable += 1;
                let retry_in = opts.backoff.delay(failures);
                emit(
                    &mut summary,
                    CaptureEvent::Unavailable {
                        reason,
                        attempt: failures,
                        retry_in,
                    },
                );
                if !sleep_unless_stopped(retry_in, stop) {
                    break;
                }
                continue;
            }
            Err(SourceError::BadFrame { reason, .. }) => {
                summary.bad_frames += 1;
                let count = summary.bad_frames;
                emit(&mut summary, CaptureEvent::BadFrame { reason, count });
                continue;
            }
            Err(e @ SourceError::Fatal { .. }) => {
                summary.end = Some(e.to_string());
                emit(
                    &mut summary,
                    CaptureEvent::Failed {
                        error: e.to_string(),
                    },
                );
                break;
            }
        };
        let captured = Instant::now();
        if summary.frames == 0 {
            emit(
                &mut summary,
                CaptureEvent::Started {
                    source: source.name(),
                },
            );
        }
        if failures > 0 {
            emit(
                &mut summary,
                CaptureEvent::Resumed {
                    failed_attempts: failures,
                },
            );
            failures = 0;
        }
        let time_s = match raw.time_s {
            Some(t) if opts.pace && source.frame_rate().is_some() => {
                let (t0, wall0) = *clock.get_or_insert((t, captured));
                let due = wall0 + Duration::from_secs_f64((t - t0).max(0.0));
                if !sleep_unless_stopped(due.saturating_duration_since(captured), stop) {
                    break;
                }
                t
            }
            Some(t) => t,
            None => captured.duration_since(start).as_secs_f64(),
        };
        let frame = Frame {
            image: Arc::new(raw.image),
            index: summary.frames,
            time_s,
            // Paced frames count as captured when they are due, not when decoded early.
            captured: Instant::now(),
            path: raw.path,
        };
        summary.frames += 1;
        if tx.send(frame).is_err() {
            summary.end = Some("the consumer stopped".into());
            break;
        }
    }
    summary.replaced = tx.replaced();
    summary
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::capture::source::RawFrame;
    use std::collections::VecDeque;

    /// A scripted source standing in for a device: each call pops the next scripted result.
    struct Scripted {
        script: VecDeque<Result<Option<RawFrame>, SourceError>>,
    }

    fn frame(v: u8) -> Result<Option<RawFrame>, SourceError> {
        Ok(Some(RawFrame::new(RgbImage::from_pixel(
            4,
            4,
            image::Rgb([v, v, v]),
        ))))
    }

    fn unavailable() -> Result<Option<RawFrame>, SourceError> {
        Err(SourceError::Unavailable {
            source_name: "camera 0".into(),
            reason: "No such file or directory".into(),
        })
    }

    impl FrameSource for Scripted {
        fn name(&self) -> String {
            "scripted".into()
        }
        fn next_frame(&mut self) -> Result<Option<RawFrame>, SourceError> {
            self.script.pop_front().unwrap_or(Ok(None))
        }
    }

    fn fast() -> CaptureOptions {
        CaptureOptions {
            pace: false,
            backoff: Backoff {
                initial: Duration::from_millis(1),
                max: Duration::from_millis(4),
                factor: 2.0,
            },
            event_capacity: 64,
        }
    }

    fn spawn(script: Vec<Result<Option<RawFrame>, SourceError>>) -> Capture {
        Capture::spawn(
            move || {
                Box::new(Scripted {
                    script: script.into(),
                })
            },
            fast(),
        )
    }

    fn drain_until_end(cap: &Capture) -> (Vec<u8>, Vec<CaptureEvent>) {
        let mut values = Vec::new();
        while let Ok(f) = cap.frames().recv() {
            values.push(f.image.get_pixel(0, 0)[0]);
        }
        (values, cap.events().try_iter().collect())
    }

    #[test]
    fn backoff_doubles_up_to_its_cap() {
        let b = Backoff::default();
        let ms: Vec<u128> = (1..=7).map(|n| b.delay(n).as_millis()).collect();
        assert_eq!(ms, [250, 500, 1000, 2000, 4000, 4000, 4000]);
        assert_eq!(b.delay(u32::MAX), b.max);
    }

    #[test]
    fn missing_camera_is_retried_with_backoff_until_it_appears() {
        let cap = spawn(vec![unavailable(), unavailable(), unavailable(), frame(7)]);
        let (values, events) = drain_until_end(&cap);
        assert_eq!(values, [7]);
        let attempts: Vec<(u32, Duration)> = events
            .iter()
            .filter_map(|e| match e {
                CaptureEvent::Unavailable {
                    attempt, retry_in, ..
                } => Some((*attempt, *retry_in)),
                _ => None,
            })
            .collect();
        let ms = Duration::from_millis;
        assert_eq!(attempts, [(1, ms(1)), (2, ms(2)), (3, ms(4))]);
        assert!(events.contains(&CaptureEvent::Resumed { failed_attempts: 3 }));
        let summary = cap.stop();
        assert_eq!((summary.frames, summary.unavailable), (1, 3));
    }

    #[test]
    fn camera_vanishing_mid_run_keeps_the_last_frame_and_resumes() {
        let cap = spawn(vec![
            frame(1),
            frame(2),
            unavailable(),
            unavailable(),
            frame(3),
        ]);
        let (values, events) = drain_until_end(&cap);
        // Newest wins, so earlier frames may have been replaced; the last always arrives.
        assert_eq!(values.last(), Some(&3));
        assert!(
            matches!(events.first(), Some(CaptureEvent::Started { .. })),
            "{events:?}"
        );
        assert!(events.contains(&CaptureEvent::Resumed { failed_attempts: 2 }));
        assert!(matches!(
            events.last(),
            Some(CaptureEvent::Ended { note: None })
        ));
    }

    #[test]
    fn bad_frames_are_counted_and_skipped() {
        let bad = || {
            Err(SourceError::BadFrame {
                source_name: "scripted".into(),
                reason: "corrupt".into(),
            })
        };
        let cap = spawn(vec![frame(1), bad(), bad(), frame(2)]);
        let (values, events) = drain_until_end(&cap);
        assert_eq!(values.last(), Some(&2));
        let counts: Vec<u64> = events
            .iter()
            .filter_map(|e| match e {
                CaptureEvent::BadFrame { count, .. } => Some(*count),
                _ => None,
            })
            .collect();
        assert_eq!(counts, [1, 2]);
        let s = cap.stop();
        assert_eq!((s.frames, s.bad_frames), (2, 2));
    }

    #[test]
    fn fatal_error_ends_capture_with_its_reason() {
        let fatal = Err(SourceError::Fatal {
            source_name: "clip.avi".into(),
            reason: "not a video".into(),
        });
        let cap = spawn(vec![fatal]);
        let (values, events) = drain_until_end(&cap);
        assert!(values.is_empty());
        assert_eq!(
            events,
            [CaptureEvent::Failed {
                error: "clip.avi: not a video".into()
            }]
        );
        assert_eq!(cap.stop().end.as_deref(), Some("clip.avi: not a video"));
    }

    #[test]
    fn a_camera_that_never_comes_back_is_stopped_promptly() {
        let cap = Capture::spawn(
            || {
                Box::new(Scripted {
                    script: std::iter::repeat_with(unavailable).take(1000).collect(),
                })
            },
            CaptureOptions {
                backoff: Backoff {
                    initial: Duration::from_secs(10),
                    ..Backoff::default()
                },
                ..fast()
            },
        );
        std::thread::sleep(Duration::from_millis(50));
        assert!(cap.frames().try_recv().unwrap().is_none());
        let t = Instant::now();
        let summary = cap.stop();
        assert!(
            t.elapsed() < Duration::from_secs(1),
            "stop waits out no back-off"
        );
        assert_eq!(summary.unavailable, 1);
    }

    #[test]
    fn paced_video_plays_in_real_time() {
        let frames = vec![RgbImage::new(4, 4); 6];
        let cap = Capture::spawn(
            move || {
                Box::new(crate::capture::source::MemorySource::new(
                    "m", frames, 100.0,
                ))
            },
            CaptureOptions {
                pace: true,
                ..fast()
            },
        );
        let t = Instant::now();
        let mut times = Vec::new();
        while let Ok(f) = cap.frames().recv() {
            times.push(f.time_s);
        }
        // Six frames at 100 frames/s span 50 ms of source time.
        assert!(
            t.elapsed() >= Duration::from_millis(45),
            "{:?}",
            t.elapsed()
        );
        assert_eq!(times.last(), Some(&0.05));
    }
}
