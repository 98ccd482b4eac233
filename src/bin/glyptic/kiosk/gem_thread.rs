//! The kiosk's gem thread: cameos from face meshes (the fitted face, or the ease back to the
//! default face), the newest job winning, so the window never waits for a relief solve.

use std::sync::Arc;
use std::time::Instant;

use anyhow::{Context, Result};

use glyptic::capture::latest::{LatestReceiver, LatestSender, latest};
use glyptic::gem::{CameoBuilder, CameoParams, HairStyle, View};
use glyptic::render::Mesh;

/// A cameo built by the gem thread.
pub(super) struct BuiltGem {
    pub(super) mesh: Arc<Mesh>,
    pub(super) ms: f64,
}

/// What the gem thread says once, beside its cameos.
pub(super) enum GemNote {
    /// The model is loaded: the default face (model mm) for easing back.
    Ready { default_face: Arc<Vec<f32>> },
    /// The model or the builder could not be made: no cameo will come.
    Failed(String),
}

/// A cameo to build: a face (model mm) and its hair (the classical style for the default face
/// or before the visitor's hair is known).
pub(super) struct GemJob {
    pub(super) face: Vec<f32>,
    pub(super) hair: HairStyle,
}

/// The gem thread: builds a cameo for each face mesh it is given (the newest wins) and starts
/// with the model's mean face. A job with other hair than the last costs a new
/// [`CameoBuilder`] (the sculpted head under the new hair, ~35 ms), on this thread.
pub(super) struct GemThread {
    pub(super) faces: LatestSender<GemJob>,
    /// Each cameo built, or why a face made none (newest wins).
    pub(super) out: LatestReceiver<Result<BuiltGem, String>>,
    /// Notes that the newest cameo must not replace.
    pub(super) notes: crossbeam_channel::Receiver<GemNote>,
}

impl GemThread {
    pub(super) fn spawn(portrait: View) -> Result<Self> {
        let (faces, jobs) = latest::<GemJob>();
        let (send, out) = latest::<Result<BuiltGem, String>>();
        let (note_tx, notes) = crossbeam_channel::bounded(4);
        std::thread::Builder::new()
            .name("gem".into())
            .spawn(move || {
                let params = portrait.cameo();
                let setup = (|| -> Result<_> {
                    let dir = glyptic::assets::sfm_dir();
                    let model = glyptic::shapemodel::SurreyModel::load_dir(&dir)
                        .with_context(|| format!("{}: the face model", dir.display()))?;
                    let builder = CameoBuilder::new(&params)?;
                    Ok((
                        model.instance(&[], &[]),
                        model.shape.triangles.clone(),
                        builder,
                    ))
                })();
                let (mean, triangles, mut builder) = match setup {
                    Ok(s) => s,
                    Err(e) => {
                        let _ = note_tx.try_send(GemNote::Failed(format!("{e:#}")));
                        return;
                    }
                };
                let _ = note_tx.try_send(GemNote::Ready {
                    default_face: Arc::new(mean.clone()),
                });
                let mut face = mean.clone();
                let mut hair = params.hair;
                let mut warm = Vec::new();
                loop {
                    if hair != builder.params().hair {
                        let with_hair = CameoParams {
                            hair,
                            ..params.clone()
                        };
                        // Parameters that passed once pass again; should they not, the
                        // previous hair stays.
                        if let Ok(b) = CameoBuilder::new(&with_hair) {
                            builder = b;
                        }
                    }
                    // A visitor's faces follow each other: each solve starts from the last.
                    // The default face starts cold, so it is always the same gem.
                    if face == mean {
                        warm.clear();
                    }
                    let t = Instant::now();
                    let built = builder
                        .build_after(&face, &triangles, &mut warm)
                        .map(|mesh| BuiltGem {
                            mesh: Arc::new(mesh),
                            ms: t.elapsed().as_secs_f64() * 1e3,
                        })
                        .map_err(|e| format!("cameo: {e}"));
                    if send.send(built).is_err() {
                        return;
                    }
                    match jobs.recv() {
                        Ok(next) => (face, hair) = (next.face, next.hair),
                        Err(_) => return,
                    }
                }
            })
            .context("starting the gem thread")?;
        Ok(GemThread { faces, out, notes })
    }
}
