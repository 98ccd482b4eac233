//! What the window takes from the gem and face threads each time it looks (about 60 times a
//! second, never waiting), and the ease back to the default face when nobody is there.

use std::time::Instant;

#[cfg(feature = "face")]
use glyptic::gem::HairStyle;
use glyptic::kiosk::{blend_faces, idle_weight};

use super::gem_thread::{GemJob, GemNote};
use super::window::Running;

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
        for note in self.gems.notes.try_iter() {
            match note {
                GemNote::Ready { default_face } => {
                    self.default_face = Some(default_face);
                    self.status = "ready".into();
                }
                GemNote::Failed(e) => self.status = e,
            }
            changed = true;
        }
        if let Ok(Some(built)) = self.gems.out.try_recv() {
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
                            let _ = self.gems.faces.send(GemJob {
                                face: face.clone(),
                                hair: self.visitor_hair,
                            });
                            self.sent_weight = 0.0;
                        }
                        self.last_face = Some((face, Instant::now()));
                    }
                }
                FaceNews::Status(s) => self.face_status = s,
            }
            changed = true;
        }
        changed |= self.ease_back();
        changed
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
            let _ = self.gems.faces.send(GemJob {
                face: blend,
                hair: self.visitor_hair,
            });
            self.sent_weight = w;
        }
        true
    }
}
