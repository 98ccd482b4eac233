//! The kiosk's visitors and staff: presence (a face or a touch), the reset when a visitor
//! leaves, the attract mode, the visitor's prompt, the staff panel and keys, and the log of
//! problems (to stderr, hence the journal under systemd, and to the staff panel; never to the
//! visitor). The rules themselves are the library's [`glyptic::kiosk::visitor`], tested alone.

use std::time::Instant;

use glyptic::kiosk::{
    ATTRACT, Change, Controls, Mode, Orbit, PinOutcome, Prompt, Situation, StaffAction, prompt,
    staff_action,
};

use super::staff::{LOG_LINES, PAD_IDLE_S, PadInput, PinPad};
use super::ui::StaffView;
use super::window::Running;

impl Running {
    /// Seconds since the kiosk started: the presence's clock.
    pub(super) fn now_s(&self) -> f64 {
        self.timeline.started.elapsed().as_secs_f64()
    }

    /// A problem for the staff: logged (stderr, the journal) and listed on the staff panel; a
    /// problem repeated in a row is counted, not listed again.
    pub(super) fn note_problem(&mut self, what: impl Into<String>) {
        let what = what.into();
        let now = self.now_s();
        self.staff.problems += 1;
        match self.staff.log.back_mut() {
            Some((t, last, n)) if *last == what => {
                *t = now;
                *n += 1;
                // Repeats (a camera retried every second) are logged now and then, not each time.
                if n.is_power_of_two() {
                    tracing::warn!("{what} (x{n})");
                }
            }
            _ => {
                tracing::warn!("{what}");
                self.staff.log.push_back((now, what, 1));
                while self.staff.log.len() > LOG_LINES {
                    self.staff.log.pop_front();
                }
            }
        }
    }

    /// A face or a touch: somebody is here.
    pub(super) fn visitor_seen(&mut self) {
        if let Some(change) = self.presence.seen(self.now_s()) {
            self.on_change(change);
        }
    }

    /// The presence's clock and the attract mode's motion; true if the gem must be drawn.
    pub(super) fn visit_step(&mut self) -> bool {
        let mut changed = false;
        if let Some(change) = self.presence.tick(self.now_s()) {
            self.on_change(change);
            changed = true;
        }
        changed | self.attract_step()
    }

    fn on_change(&mut self, change: Change) {
        match change {
            Change::Arrived => {
                tracing::info!("kiosk: a visitor");
                self.attract_since = None;
                self.reset_controls();
            }
            Change::Left => {
                tracing::info!("kiosk: the visitor left; every control back as configured");
                self.visitor_gem = false;
                self.reset_controls();
            }
            Change::Attract => {
                tracing::info!("kiosk: nobody for a while: attract mode");
                self.attract_since = Some(Instant::now());
                self.attract_frame_at = None;
            }
        }
        self.dirty = true;
    }

    /// Every control as configured, the portrait live and facing front.
    fn reset_controls(&mut self) {
        self.controls = Controls::from_config(&self.config);
        self.orbit = Orbit::default();
        self.moved_at = None;
    }

    /// In attract mode, the next step of the swing when it is due: a frame every
    /// [`glyptic::kiosk::Attract::frame_interval`], never while the last is still to be drawn.
    fn attract_step(&mut self) -> bool {
        let Some(since) = self.attract_since else {
            return false;
        };
        let due = self.attract_frame_at.is_none_or(|t| {
            t.elapsed().as_secs_f64() >= ATTRACT.frame_interval(self.timeline.render_ms)
        });
        if self.presence.mode() != Mode::Attract || self.gem.is_none() || self.dirty || !due {
            return false;
        }
        let t = since.elapsed().as_secs_f64();
        self.orbit = ATTRACT.orbit(t);
        self.controls.material = ATTRACT.material(t, self.config.material);
        self.moved_at = Some(Instant::now());
        self.attract_frame_at = Some(Instant::now());
        self.dirty = true;
        true
    }

    /// In attract mode the gem is always drawn as a moving frame: between two steps there
    /// is no time for a still one.
    pub(super) fn attracting(&self) -> bool {
        self.attract_since.is_some() && self.presence.mode() == Mode::Attract
    }

    pub(super) fn prompt(&self) -> Prompt {
        prompt(&Situation {
            ready: self.portrait.default_face.is_some(),
            camera: self.camera_ok,
            mode: self.presence.mode(),
            face: self.face_now,
            visitor_gem: self.visitor_gem,
            frozen: self.controls.frozen,
        })
    }

    /// The attract caption (title, line), in attract mode once a gem is shown.
    pub(super) fn caption(&self) -> Option<(String, String)> {
        (self.presence.mode() == Mode::Attract && self.gem.is_some()).then(|| {
            let t = &self.config.texts;
            (t.attract_title.clone(), t.attract.clone())
        })
    }

    /// A key press: the staff's chords (see [`staff_action`]), or the PIN pad's digits,
    /// Backspace, Return and Escape while it asks.
    pub(super) fn key(&mut self, key: &str) {
        if self.staff.pad.is_some() {
            let input = match key {
                "BackSpace" => Some(PadInput::Back),
                "Return" => Some(PadInput::Enter),
                "Escape" => Some(PadInput::Cancel),
                d if d.len() == 1 && d.as_bytes()[0].is_ascii_digit() => {
                    d.chars().next().map(PadInput::Digit)
                }
                _ => None,
            };
            if let Some(input) = input {
                self.pad_input(input);
            }
            return;
        }
        let (ctrl, shift) = (self.modifiers.control_key(), self.modifiers.shift_key());
        match staff_action(key, ctrl, shift, self.staff.open, self.config.fullscreen) {
            // With a PIN, quitting is for the staff who opened the panel with it.
            Some(StaffAction::Quit) if self.staff.open || self.staff.pin.is_none() => {
                tracing::info!("kiosk: quit by the staff ({key})");
                self.staff.quit = true;
            }
            Some(StaffAction::Quit) => self.ask_for_staff(key),
            Some(StaffAction::TogglePanel) if self.staff.open => self.staff.open = false,
            Some(StaffAction::TogglePanel) => self.ask_for_staff(key),
            Some(StaffAction::ClosePanel) => self.staff.open = false,
            None => {}
        }
    }

    /// Someone asks for the staff panel (`how`: the key or the gesture): with a PIN
    /// configured the pad asks for it first; without, the keys open the panel and the
    /// corner opens nothing (a visitor's finger must not reach Quit).
    pub(super) fn ask_for_staff(&mut self, how: &str) {
        if self.staff.open {
            return;
        }
        let now = self.now_s();
        match &self.staff.pin {
            Some(_) => {
                let said = match self.staff.gate.paused(now) {
                    Some(s) => format!("Paused: try again in {s:.0} s"),
                    None => "Staff PIN".to_string(),
                };
                self.staff.pad = Some(PinPad {
                    digits: String::new(),
                    said,
                    touched_s: now,
                });
            }
            None if how == "corner" => {
                if !self.staff.gesture_noted {
                    self.staff.gesture_noted = true;
                    tracing::warn!(
                        "kiosk: the corner was held, but it opens the staff panel only with \
                         staff_pin set in the configuration (`glyptic kiosk --hash-pin`)"
                    );
                }
            }
            None => {
                tracing::info!("kiosk: staff panel opened ({how})");
                self.staff.open = true;
            }
        }
    }

    /// A key or button of the PIN pad.
    pub(super) fn pad_input(&mut self, input: PadInput) {
        let now = self.now_s();
        let (Some(pad), Some(pin)) = (self.staff.pad.as_mut(), self.staff.pin.as_ref()) else {
            return;
        };
        pad.touched_s = now;
        match input {
            PadInput::Digit(d) if pad.digits.len() < *glyptic::pin::DIGITS.end() => {
                pad.digits.push(d)
            }
            PadInput::Digit(_) => {}
            PadInput::Back => {
                pad.digits.pop();
            }
            PadInput::Cancel => self.staff.pad = None,
            PadInput::Enter => {
                let attempt = std::mem::take(&mut pad.digits);
                match self.staff.gate.submit(pin, &attempt, now) {
                    PinOutcome::Open => {
                        tracing::info!("kiosk: staff panel opened (PIN)");
                        self.staff.pad = None;
                        self.staff.open = true;
                    }
                    PinOutcome::Wrong { tries_left } => {
                        pad.said = format!("Wrong PIN: {tries_left} more before a pause");
                    }
                    PinOutcome::Paused { seconds } => {
                        pad.said = format!("Paused: try again in {seconds:.0} s");
                        self.note_problem(format!(
                            "wrong staff PINs: the pad pauses {seconds:.0} s"
                        ));
                    }
                }
            }
        }
    }

    /// Closes a PIN pad nobody has touched for a while.
    pub(super) fn pad_step(&mut self) {
        let now = self.now_s();
        if self
            .staff
            .pad
            .as_ref()
            .is_some_and(|p| now - p.touched_s > PAD_IDLE_S)
        {
            self.staff.pad = None;
        }
    }

    /// What the staff panel shows now.
    pub(super) fn staff_view(&self) -> StaffView {
        let tl = &self.timeline;
        let up = tl.started.elapsed().as_secs();
        let rows = vec![
            (
                "mode",
                format!("{} ({})", self.presence.mode().name(), self.prompt().name()),
            ),
            (
                "up",
                format!("{}:{:02}:{:02}", up / 3600, up / 60 % 60, up % 60),
            ),
            ("camera", self.face_status.clone()),
            ("gem maker", self.status.clone()),
            (
                "gems",
                format!(
                    "{} made, last {:.0} ms; drawn in {:.0} ms",
                    tl.gem_count, tl.gem_ms, tl.render_ms
                ),
            ),
            (
                "faces",
                format!(
                    "{:.1}/s, {:.0} ms from capture, frame {}",
                    tl.face_rate.per_second(),
                    tl.face_latency_ms,
                    tl.face_frame
                ),
            ),
            (
                "memory",
                format!("{:.0} MB", glyptic::memory::resident_kb() as f64 / 1024.0),
            ),
            (
                "restarts",
                format!(
                    "gem maker {}, face tracking {}",
                    self.gems.restarts.count,
                    self.face_restarts()
                ),
            ),
            (
                "window",
                format!(
                    "{}x{}{}{}",
                    self.screen.surface_config.width,
                    self.screen.surface_config.height,
                    if self.config.fullscreen {
                        ", full screen"
                    } else {
                        ""
                    },
                    if self.cursor_hidden {
                        ", cursor hidden"
                    } else {
                        ""
                    }
                ),
            ),
            ("frames", format!("{} presented", tl.frames)),
        ];
        StaffView {
            rows,
            log: self.staff.lines(),
        }
    }
}
