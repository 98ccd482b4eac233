//! What the kiosk says about itself: the status line on screen, the `--trace` JSON line per
//! presented frame (what the scripted kiosk tests and benchmarks read), rates and memory.

use std::time::{Duration, Instant};

use super::window::Running;

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

impl Running {
    pub(super) fn status_line(&self) -> String {
        let mut s = format!("{} · {}", self.face_status, self.status);
        if self.timeline.render_rate.per_second() > 0.0 || self.timeline.render_ms > 0.0 {
            s += &format!(
                " · gem {:.0} ms render, {:.1} ms build",
                self.timeline.render_ms, self.timeline.gem_ms
            );
        }
        let face_fps = self.timeline.face_rate.per_second();
        if face_fps > 0.0 {
            s += &format!(" · face {face_fps:.0}/s");
        }
        s
    }

    /// Times the face side was restarted after it died (none without the face pipeline).
    pub(super) fn face_restarts(&self) -> u64 {
        #[cfg(feature = "face")]
        return self.live.restarts.count;
        #[cfg(not(feature = "face"))]
        0
    }

    pub(super) fn trace_line(&self, rendered_gem: bool) -> serde_json::Value {
        let mut line = serde_json::json!({
            "frame": self.timeline.frames,
            "t_s": self.timeline.started.elapsed().as_secs_f64(),
            "gem_rendered": rendered_gem,
            "gems": self.timeline.gem_count,
            "render_ms": self.timeline.render_ms,
            "gem_moving": self.drawn_moving,
            "gem_size": self.layer.as_ref().map(|l| l.size),
            "gem_ms": self.timeline.gem_ms,
            "material": self.controls.material.name(),
            "sss": self.controls.sss,
            "sss_label": self.controls.sss_label(&self.config.labels),
            "style": self.controls.style.map_or("none", |s| s.name()),
            "engraving": self.controls.engraving,
            "lamp": self.controls.lamp,
            "sss_strength": self.controls.sss_strength,
            "frozen": self.controls.frozen,
            "yaw_deg": self.orbit.yaw_deg,
            "pitch_deg": self.orbit.pitch_deg,
            "zoom": self.orbit.zoom,
            "status": self.status_line(),
            "mode": self.presence.mode().name(),
            "prompt": self.prompt().name(),
            "prompt_text": self.config.texts.get(self.prompt()),
            "caption": self.caption().is_some(),
            "staff": self.staff.open,
            "problems": self.staff.problems,
            "cursor_hidden": self.cursor_hidden,
            "window": [self.surface_config.width, self.surface_config.height],
            "first_frame_s": self.timeline.first_frame_s,
            "first_gem_s": self.timeline.first_gem_s,
            "gem_print": format!("{:016x}", self.timeline.gem_print),
            "first_gem_frame_s": self.timeline.first_gem_frame_s,
            "full_gem_frame_s": self.timeline.full_gem_frame_s,
            "face_updates": self.timeline.face_updates,
            "face_latency_ms": self.timeline.face_latency_ms,
            "face_frame": self.timeline.face_frame,
            "poll_max_ms": self.timeline.poll_max_ms,
            "gem_restarts": self.gem_restarts.count,
            "face_restarts": self.face_restarts(),
            "rss_kb": resident_kb(),
            "controls": self.control_rects.iter().map(|(k, r)| (k.to_string(), serde_json::json!(r))).collect::<serde_json::Map<_, _>>(),
        });
        // (Added apart: one more key in the literal passes `json!`'s recursion limit.)
        line["pin_pad"] = serde_json::json!(self.staff.pad.as_ref().map(|p| p.said.clone()));
        line
    }
}

/// Resident memory of this process, kB (Linux; 0 where unknown).
pub(super) fn resident_kb() -> u64 {
    std::fs::read_to_string("/proc/self/statm")
        .ok()
        .and_then(|s| s.split_whitespace().nth(1)?.parse::<u64>().ok())
        .map_or(0, |pages| pages * 4)
}
