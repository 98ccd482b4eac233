//! What the kiosk says about itself: the status line on screen, the `--trace` JSON line per
//! presented frame (what the scripted kiosk tests and benchmarks read), rates and memory.

use super::window::Running;

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
            "gem_size": self.screen.layer.as_ref().map(|l| l.size),
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
            "window": [self.screen.surface_config.width, self.screen.surface_config.height],
            "first_frame_s": self.timeline.first_frame_s,
            "first_gem_s": self.timeline.first_gem_s,
            "gem_print": format!("{:016x}", self.timeline.gem_print),
            "first_gem_frame_s": self.timeline.first_gem_frame_s,
            "full_gem_frame_s": self.timeline.full_gem_frame_s,
            "face_updates": self.timeline.face_updates,
            "face_latency_ms": self.timeline.face_latency_ms,
            "face_frame": self.timeline.face_frame,
            "poll_max_ms": self.timeline.poll_max_ms,
            "gem_restarts": self.gems.restarts.count,
            "face_restarts": self.face_restarts(),
            "rss_kb": glyptic::memory::resident_kb(),
            "controls": self.control_rects.iter().map(|(k, r)| (k.to_string(), serde_json::json!(r))).collect::<serde_json::Map<_, _>>(),
        });
        // (Added apart: one more key in the literal passes `json!`'s recursion limit.)
        line["pin_pad"] = serde_json::json!(self.staff.pad.as_ref().map(|p| p.said.clone()));
        line
    }
}
