//! The kiosk's clock and counters: times and counts since it started and rates over the
//! last seconds, for the status line and the trace.

use std::time::{Duration, Instant};

/// Times and counts since the kiosk started: the status line's and the trace's figures.
pub(super) struct Timeline {
    /// Gems built, and the newest one's build time.
    pub(super) gem_count: u64,
    pub(super) gem_ms: f64,
    pub(super) render_rate: Rate,
    pub(super) face_rate: Rate,
    pub(super) render_ms: f64,
    pub(super) frames: u64,
    pub(super) started: Instant,
    pub(super) first_frame_s: Option<f64>,
    pub(super) first_gem_s: Option<f64>,
    /// A fingerprint of the gem shown (changes with its shape).
    pub(super) gem_print: u64,
    /// When the first frame showing a gem was presented (a preview at [`super::window::PREVIEW_SCALE`]), and
    /// the first at full resolution, seconds from start.
    pub(super) first_gem_frame_s: Option<f64>,
    pub(super) full_gem_frame_s: Option<f64>,
    /// Face updates taken from the face thread, and the newest one's latency from capture.
    pub(super) face_updates: u64,
    pub(super) face_latency_ms: f64,
    /// The newest update's frame index: frames the face thread has processed, less one.
    pub(super) face_frame: u64,
    /// The longest the event loop spent taking news from the other threads, ms (it never
    /// waits for them: this is the cost of a look).
    pub(super) poll_max_ms: f64,
}

/// Rates over the last second.
#[derive(Default)]
pub(super) struct Rate {
    times: std::collections::VecDeque<Instant>,
}

impl Rate {
    pub(super) fn tick(&mut self) {
        let now = Instant::now();
        self.times.push_back(now);
        while self
            .times
            .front()
            .is_some_and(|t| now.duration_since(*t) > Duration::from_secs(2))
        {
            self.times.pop_front();
        }
    }

    pub(super) fn per_second(&self) -> f64 {
        match (self.times.front(), self.times.back()) {
            (Some(a), Some(b)) if self.times.len() > 1 => {
                (self.times.len() - 1) as f64 / b.duration_since(*a).as_secs_f64().max(1e-3)
            }
            _ => 0.0,
        }
    }
}
