//! Which face the kiosk's gem carves: the visitor's newest face and hair while they are there,
//! eased back to the default face (the model's mean, with the configured hair) when nobody has
//! been seen for `idle_seconds`, over `ease_seconds`. It decides the jobs for the gem thread
//! and remembers what it last sent; it knows nothing of windows or threads. Faces are model
//! meshes in millimetres; times are seconds.

use std::sync::Arc;
use std::time::Instant;

use glyptic::gem::HairStyle;
use glyptic::kiosk::{KioskConfig, blend_faces, idle_weight};

use super::gem_thread::GemJob;

pub(super) struct Portrait {
    /// The default face, once the gem thread has loaded the model.
    pub(super) default_face: Option<Arc<Vec<f32>>>,
    /// The default face's hair, and the visitor's as last read (the default's until then).
    default_hair: HairStyle,
    visitor_hair: HairStyle,
    /// Glasses found on a visitor are carved (config key `glasses`).
    #[cfg_attr(not(feature = "face"), allow(dead_code))]
    carve_glasses: bool,
    /// The last face seen and when.
    last_face: Option<(Vec<f32>, Instant)>,
    /// The visitor's detail as last read (carved with their face and its ease back; dropped
    /// at the default face).
    visitor_detail: Option<Arc<glyptic::gem::FaceDetail>>,
    /// The default face's weight in the last job sent (0: the visitor's own face).
    sent_weight: f32,
    idle_seconds: f32,
    ease_seconds: f32,
}

impl Portrait {
    pub(super) fn new(config: &KioskConfig) -> Self {
        let hair = config.cameo().hair;
        Self {
            default_face: None,
            default_hair: hair,
            visitor_hair: hair,
            carve_glasses: config.glasses,
            last_face: None,
            visitor_detail: None,
            sent_weight: 1.0,
            idle_seconds: config.idle_seconds,
            ease_seconds: config.ease_seconds,
        }
    }

    /// The visitor's hair as the face side read it (glasses kept only where they are carved).
    #[cfg_attr(not(feature = "face"), allow(dead_code))]
    pub(super) fn read_hair(&mut self, hair: &HairStyle) {
        self.visitor_hair = HairStyle {
            glasses: hair.glasses && self.carve_glasses,
            ..*hair
        };
    }

    /// A face seen now, with the visitor's detail once read (`None`: keep the last, as a
    /// visitor's frames before the person thread has read theirs); the job that shows it
    /// unless the gem is `frozen`.
    #[cfg_attr(not(feature = "face"), allow(dead_code))]
    pub(super) fn seen(
        &mut self,
        face: Vec<f32>,
        detail: Option<Arc<glyptic::gem::FaceDetail>>,
        frozen: bool,
    ) -> Option<GemJob> {
        if detail.is_some() {
            self.visitor_detail = detail;
        }
        let job = (!frozen).then(|| {
            self.sent_weight = 0.0;
            GemJob {
                face: face.clone(),
                hair: self.visitor_hair,
                detail: self.visitor_detail.clone(),
            }
        });
        self.last_face = Some((face, Instant::now()));
        job
    }

    /// The newest face again (the gem unfrozen), if one was seen.
    pub(super) fn newest(&mut self) -> Option<GemJob> {
        let (face, _) = self.last_face.as_ref()?;
        self.sent_weight = 0.0;
        Some(GemJob {
            face: face.clone(),
            hair: self.visitor_hair,
            detail: self.visitor_detail.clone(),
        })
    }

    /// Whether the gem the thread just built is the visitor's own face (not the default, not
    /// a step of the ease).
    pub(super) fn shows_visitor(&self) -> bool {
        self.sent_weight == 0.0 && self.last_face.is_some()
    }

    /// When nobody has been seen for a while, the next step of the ease back to the default
    /// face (`Some(None)`: a step was due but the faces could not be blended); `None` when no
    /// step is due.
    pub(super) fn ease(&mut self) -> Option<Option<GemJob>> {
        let (Some((face, seen)), Some(default)) = (&self.last_face, &self.default_face) else {
            return None;
        };
        let w = idle_weight(
            seen.elapsed().as_secs_f32(),
            self.idle_seconds,
            self.ease_seconds,
        );
        if w <= self.sent_weight + 0.02 && !(w >= 1.0 && self.sent_weight < 1.0) {
            return None;
        }
        let Some(blend) = blend_faces(face, default, w) else {
            return Some(None);
        };
        // Back at the default face, the classical hair again and no visitor's detail.
        if w >= 1.0 {
            self.visitor_hair = self.default_hair;
            self.visitor_detail = None;
        }
        self.sent_weight = w;
        Some(Some(GemJob {
            face: blend,
            hair: self.visitor_hair,
            detail: self.visitor_detail.clone(),
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn portrait(idle_seconds: f32, ease_seconds: f32) -> Portrait {
        let config = KioskConfig {
            idle_seconds,
            ease_seconds,
            ..KioskConfig::default()
        };
        let mut p = Portrait::new(&config);
        p.default_face = Some(Arc::new(vec![0.0; 6]));
        p
    }

    #[test]
    fn a_seen_face_is_sent_unless_frozen_and_eases_back_to_the_default_when_idle() {
        let mut p = portrait(0.0, 0.0);
        assert!(p.ease().is_none(), "no face seen: nothing to ease");
        assert!(p.seen(vec![3.0; 6], None, true).is_none(), "frozen: no job");
        assert!(!p.shows_visitor(), "the frozen gem is still the default");
        let job = p.seen(vec![3.0; 6], None, false).expect("a job");
        assert_eq!(job.face, vec![3.0; 6]);
        assert!(p.shows_visitor());
        // No idle time and no ease: the default face at once, with the default hair.
        let eased = p.ease().expect("a step").expect("blended");
        assert_eq!(eased.face, vec![0.0; 6]);
        assert!(!p.shows_visitor());
        assert!(p.ease().is_none(), "at the default: nothing more");
        let again = p.newest().expect("the newest face");
        assert_eq!(again.face, vec![3.0; 6]);
    }

    #[test]
    fn a_visitor_still_there_is_not_eased_and_glasses_follow_the_configuration() {
        let mut p = portrait(60.0, 5.0);
        p.seen(vec![1.0; 6], None, false);
        assert!(p.ease().is_none(), "seen just now");
        p.carve_glasses = false;
        p.read_hair(&HairStyle {
            glasses: true,
            ..HairStyle::default()
        });
        let job = p.newest().expect("a job");
        assert!(
            !job.hair.glasses,
            "glasses are not carved when the configuration says so"
        );
    }

    #[test]
    fn faces_of_another_size_are_not_blended() {
        let mut p = portrait(0.0, 0.0);
        p.seen(vec![1.0; 3], None, false);
        assert!(matches!(p.ease(), Some(None)));
    }

    /// A FaceDetail read from a flat grey frame (what the jobs carry is all that matters here).
    fn detail() -> glyptic::gem::FaceDetail {
        let lm: Vec<[f32; 2]> = (0..68)
            .map(|k| {
                let t = k as f32 * 0.37;
                [200.0 + 80.0 * t.cos(), 200.0 + 90.0 * t.sin()]
            })
            .collect();
        let img = image::GrayImage::from_pixel(400, 400, image::Luma([128]));
        glyptic::gem::FaceDetail::read(&img, &lm, Vec::new(), &Default::default(), None)
            .expect("detail")
    }

    #[test]
    fn the_visitors_detail_goes_with_their_face_until_the_default_face() {
        let mut p = portrait(0.0, 0.0);
        let d = Arc::new(detail());
        let job = p.seen(vec![3.0; 6], Some(d.clone()), false).expect("a job");
        assert!(job.detail.as_ref().is_some_and(|j| Arc::ptr_eq(j, &d)));
        // The visitor's next frames, before another reading, keep it.
        let job = p.seen(vec![3.5; 6], None, false).expect("a job");
        assert!(job.detail.as_ref().is_some_and(|j| Arc::ptr_eq(j, &d)));
        assert!(p.newest().expect("the newest face").detail.is_some());
        // Nobody there: the default face, without the visitor's detail.
        let back = p.ease().expect("a step due").expect("the faces blend");
        assert!(back.detail.is_none());
        assert!(p.newest().expect("the newest face").detail.is_none());
    }
}
