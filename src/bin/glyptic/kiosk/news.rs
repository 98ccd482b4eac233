//! What the window takes from the gem and face threads each time it looks (about 60 times a
//! second, never waiting), and the ease back to the default face when nobody is there.

use std::time::Instant;

use super::gem_thread::GemNote;
use super::window::Running;

/// What [`Running::take_gem_notes`] found: any note, and whether one was the thread's end.
struct GemNotes {
    noted: bool,
    ended: bool,
}

impl Running {
    /// Takes what the gem and face threads have; true if the window should be drawn.
    pub(super) fn poll(&mut self) -> bool {
        let t = Instant::now();
        let changed = self.take_news();
        self.timeline.poll_max_ms = self
            .timeline
            .poll_max_ms
            .max(t.elapsed().as_secs_f64() * 1e3);
        changed
    }

    pub(super) fn take_news(&mut self) -> bool {
        let mut changed = false;
        changed |= self.take_gem_notes().noted;
        // The thread's cameos, or its end: its notes (sent before it ends) say why.
        let built = match self.gems.built() {
            Ok(built) => built,
            Err(_) => {
                if !self.take_gem_notes().ended && self.fatal.is_none() {
                    self.restart_gems("it stopped");
                }
                None
            }
        };
        if let Some(built) = built {
            match built {
                Ok(built) => {
                    // A gem from the visitor's own face (not the default, not an ease).
                    self.visitor_gem = self.portrait.shows_visitor();
                    self.timeline.gem_print = built.mesh.fingerprint();
                    self.gem = Some(built.mesh);
                    self.timeline.gem_ms = built.ms;
                    self.timeline.gem_count += 1;
                    self.dirty = true;
                    if self.timeline.first_gem_s.is_none() {
                        self.timeline.first_gem_s =
                            Some(self.timeline.started.elapsed().as_secs_f64());
                    }
                }
                Err(e) => {
                    self.note_problem(format!("gem: {e}"));
                    self.status = e;
                }
            }
            changed = true;
        }
        #[cfg(feature = "face")]
        for news in self.live.poll() {
            use super::face_thread::FaceNews;
            match news {
                FaceNews::Update {
                    face,
                    detail,
                    hair,
                    frame,
                    latency_ms,
                } => {
                    if let Some(h) = hair {
                        self.portrait.read_hair(&h);
                    }
                    self.timeline.face_rate.tick();
                    self.timeline.face_updates += 1;
                    self.timeline.face_frame = frame;
                    self.timeline.face_latency_ms = latency_ms;
                    self.face_status = if face.is_some() {
                        "face found"
                    } else {
                        "no face"
                    }
                    .into();
                    self.camera_ok = true;
                    self.face_now = face.is_some();
                    if face.is_some() {
                        self.visitor_seen();
                    }
                    if let Some(face) = face
                        && let Some(job) = self.portrait.seen(face, detail, self.controls.frozen)
                    {
                        self.gems.send(job);
                    }
                }
                FaceNews::Status(s) => {
                    tracing::info!("kiosk: {s}");
                    self.camera_ok = true;
                    self.face_status = s;
                }
                FaceNews::Trouble { what, camera_down } => {
                    self.note_problem(what.clone());
                    if camera_down {
                        self.camera_ok = false;
                        self.face_now = false;
                    }
                    self.face_status = what;
                }
                FaceNews::Fatal(e) => {
                    self.face_status = e.clone();
                    self.fatal = Some(anyhow::anyhow!("{e}"));
                }
            }
            changed = true;
        }
        changed |= self.ease_back();
        changed |= self.visit_step();
        changed
    }

    /// The gem thread's notes. A thread that died is restarted; one that could not load its
    /// model ends the kiosk (no cameo could ever be shown).
    fn take_gem_notes(&mut self) -> GemNotes {
        let notes = self.gems.notes();
        let mut taken = GemNotes {
            noted: !notes.is_empty(),
            ended: false,
        };
        for note in notes {
            match note {
                GemNote::Ready { default_face } => {
                    self.portrait.default_face = Some(default_face);
                    self.status = "ready".into();
                }
                GemNote::Failed(e) => {
                    tracing::error!("the gem thread cannot start: {e}");
                    self.status = e.clone();
                    self.fatal = Some(anyhow::anyhow!("{e}"));
                    taken.ended = true;
                }
                GemNote::Died(why) => {
                    self.restart_gems(&why);
                    taken.ended = true;
                }
            }
        }
        taken
    }

    /// The gem thread died: start another that carries on with the last face, keeping the
    /// gem on screen meanwhile; more than [`super::restarts::MAX_RESTARTS`] deaths a minute and the kiosk
    /// cannot go on.
    fn restart_gems(&mut self, why: &str) {
        match self.gems.restart(why) {
            Ok(()) => {
                self.note_problem(format!("the gem thread died ({why}); restarted it"));
                self.status = format!("gem thread restarted ({why})");
            }
            Err(e) => self.fatal = Some(e),
        }
    }

    /// When nobody has been seen for a while, eases the portrait back to the default face.
    pub(super) fn ease_back(&mut self) -> bool {
        if self.controls.frozen {
            return false;
        }
        match self.portrait.ease() {
            None => false,
            Some(job) => {
                if let Some(job) = job {
                    self.gems.send(job);
                }
                true
            }
        }
    }
}
