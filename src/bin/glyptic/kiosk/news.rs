//! What the window takes from the gem and face threads each time it looks (about 60 times a
//! second, never waiting), and the ease back to the default face when nobody is there.

use std::time::Instant;

#[cfg(feature = "face")]
use glyptic::gem::HairStyle;
use glyptic::kiosk::{blend_faces, idle_weight};

use super::gem_thread::{GemJob, GemNote, GemThread};
use super::window::Running;

/// A worker thread may die this many times within [`RESTART_WINDOW`] and be restarted; once
/// more and the kiosk exits 1 (a supervisor such as systemd starts it afresh).
pub(super) const MAX_RESTARTS: usize = 3;
pub(super) const RESTART_WINDOW: std::time::Duration = std::time::Duration::from_secs(60);

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
        let notes: Vec<GemNote> = self.gems.notes.try_iter().collect();
        for note in notes {
            match note {
                GemNote::Ready { default_face } => {
                    self.default_face = Some(default_face);
                    self.status = "ready".into();
                }
                // Without the model no cameo can ever be shown: the kiosk cannot go on.
                GemNote::Failed(e) => {
                    tracing::error!("the gem thread cannot start: {e}");
                    self.status = e.clone();
                    self.fatal = Some(anyhow::anyhow!("{e}"));
                }
                GemNote::Died(why) => self.restart_gems(&why),
            }
            changed = true;
        }
        let built = match self.gems.out.try_recv() {
            Ok(built) => built,
            // Gone without a note (the note channel was full): died all the same.
            Err(_) if self.fatal.is_none() => {
                self.restart_gems("it stopped");
                None
            }
            Err(_) => None,
        };
        if let Some(built) = built {
            match built {
                Ok(built) => {
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
                Err(e) => self.status = e,
            }
            changed = true;
        }
        #[cfg(feature = "face")]
        for news in self.live.poll() {
            use super::face_thread::FaceNews;
            match news {
                FaceNews::Update {
                    face,
                    hair,
                    frame,
                    latency_ms,
                } => {
                    if let Some(h) = hair {
                        self.visitor_hair = HairStyle {
                            glasses: h.glasses && self.carve_glasses,
                            ..h
                        };
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
                    if let Some(face) = face {
                        if !self.controls.frozen {
                            self.send_job(GemJob {
                                face: face.clone(),
                                hair: self.visitor_hair,
                            });
                            self.sent_weight = 0.0;
                        }
                        self.last_face = Some((face, Instant::now()));
                    }
                }
                FaceNews::Status(s) => self.face_status = s,
                FaceNews::Fatal(e) => {
                    self.face_status = e.clone();
                    self.fatal = Some(anyhow::anyhow!("{e}"));
                }
            }
            changed = true;
        }
        #[cfg(feature = "face")]
        {
            self.timeline.face_restarts = self.live.restarts;
        }
        changed |= self.ease_back();
        changed
    }

    /// Hands a face to the gem thread, keeping it for a restarted thread.
    fn send_job(&mut self, job: GemJob) {
        self.last_job = Some(job.clone());
        let _ = self.gems.faces.send(job);
    }

    /// The gem thread died: start another that carries on with the last face, keeping the
    /// gem on screen meanwhile; more than [`MAX_RESTARTS`] deaths a minute and the kiosk
    /// cannot go on.
    fn restart_gems(&mut self, why: &str) {
        let now = Instant::now();
        self.gem_deaths
            .retain(|t| now.duration_since(*t) < RESTART_WINDOW);
        self.gem_deaths.push(now);
        if self.gem_deaths.len() > MAX_RESTARTS {
            tracing::error!("the gem thread died again ({why}): giving up");
            self.fatal = Some(anyhow::anyhow!(
                "the gem thread died {} times within {} s (last: {why})",
                self.gem_deaths.len(),
                RESTART_WINDOW.as_secs()
            ));
            return;
        }
        tracing::error!("the gem thread died ({why}); restarting it");
        let fault = self.gem_fault.filter(|f| f.every_thread);
        match GemThread::spawn(self.portrait, self.last_job.clone(), fault) {
            Ok(gems) => {
                self.gems = gems;
                self.timeline.gem_restarts += 1;
                self.status = format!("gem thread restarted ({why})");
            }
            Err(e) => self.fatal = Some(e.context("restarting the gem thread")),
        }
    }

    /// When nobody has been seen for a while, eases the portrait back to the default face.
    pub(super) fn ease_back(&mut self) -> bool {
        if self.controls.frozen {
            return false;
        }
        let (Some((face, seen)), Some(default)) = (&self.last_face, &self.default_face) else {
            return false;
        };
        let w = idle_weight(
            seen.elapsed().as_secs_f32(),
            self.idle_seconds,
            self.ease_seconds,
        );
        if w <= self.sent_weight + 0.02 && !(w >= 1.0 && self.sent_weight < 1.0) {
            return false;
        }
        if let Some(blend) = blend_faces(face, default, w) {
            // Back at the default face, the classical hair again.
            if w >= 1.0 {
                self.visitor_hair = self.default_hair;
            }
            self.send_job(GemJob {
                face: blend,
                hair: self.visitor_hair,
            });
            self.sent_weight = w;
        }
        true
    }
}
