//! The kiosk's gem thread: cameos from face meshes (the fitted face, or the ease back to the
//! default face), the newest job winning, so the window never waits for a relief solve.

use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};

use glyptic::capture::latest::{LatestReceiver, LatestSender, latest};
use glyptic::gem::{CameoBuilder, CameoParams, HairStyle};
use glyptic::render::Mesh;

use super::restarts::Restarts;

/// How often the gem thread gives freed memory back ([`glyptic::memory::Trimmer`]): a trim
/// walks every heap, a gem is built every 0.1-0.2 s.
const TRIM_PERIOD: Duration = Duration::from_secs(2);

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
    /// The thread panicked (the message); the window restarts it.
    Died(String),
}

/// Gem threads panic on their Nth cameo: every one, or only the first (a test fault, see
/// [`super::run::Fault`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct GemFault {
    pub(super) at: u64,
    pub(super) every_thread: bool,
}

/// A cameo to build: a face (model mm) and its hair (the classical style for the default face
/// or before the visitor's hair is known).
#[derive(Clone)]
pub(super) struct GemJob {
    pub(super) face: Vec<f32>,
    pub(super) hair: HairStyle,
    /// The visitor's detail read from one of their frames (attached to the face's vertices);
    /// `None` for the default face.
    pub(super) detail: Option<Arc<glyptic::gem::FaceDetail>>,
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
    /// Starts the thread. Its first cameo is `first` (a restarted thread carries on with the
    /// last face it was given) or the model's mean face.
    pub(super) fn spawn(
        params: CameoParams,
        first: Option<GemJob>,
        fault: Option<GemFault>,
    ) -> Result<Self> {
        let (faces, jobs) = latest::<GemJob>();
        let (send, out) = latest::<Result<BuiltGem, String>>();
        let (note_tx, notes) = crossbeam_channel::bounded(4);
        std::thread::Builder::new()
            .name("gem".into())
            .spawn(move || {
                let died = note_tx.clone();
                let run = std::panic::AssertUnwindSafe(|| {
                    work(params, first, fault, &jobs, &send, &note_tx)
                });
                if let Err(panic) = std::panic::catch_unwind(run) {
                    let why = panic
                        .downcast_ref::<&str>()
                        .map(|s| s.to_string())
                        .or_else(|| panic.downcast_ref::<String>().cloned())
                        .unwrap_or_else(|| "a panic".into());
                    let _ = died.try_send(GemNote::Died(why));
                }
            })
            .context("starting the gem thread")?;
        Ok(GemThread { faces, out, notes })
    }
}

/// The gem thread under supervision: the jobs given to it (the last kept, so that a restarted
/// thread carries on with it), its restarts, and what a restart needs (the cameo's parameters,
/// the fault injected for tests).
pub(super) struct GemWorker {
    thread: GemThread,
    cameo: CameoParams,
    last_job: Option<GemJob>,
    fault: Option<GemFault>,
    pub(super) restarts: Restarts,
}

impl GemWorker {
    pub(super) fn spawn(cameo: CameoParams, fault: Option<GemFault>) -> Result<Self> {
        Ok(Self {
            thread: GemThread::spawn(cameo.clone(), None, fault)?,
            cameo,
            last_job: None,
            fault,
            restarts: Restarts::default(),
        })
    }

    /// Hands a face to the thread (the newest wins), keeping it for a restarted thread.
    pub(super) fn send(&mut self, job: GemJob) {
        self.last_job = Some(job.clone());
        let _ = self.thread.faces.send(job);
    }

    /// The notes the thread has sent since the last look.
    pub(super) fn notes(&self) -> Vec<GemNote> {
        self.thread.notes.try_iter().collect()
    }

    /// The newest cameo (or why a face made none); `Err` when the thread has ended.
    pub(super) fn built(&self) -> Result<Option<Result<BuiltGem, String>>, ()> {
        self.thread.out.try_recv().map_err(|_| ())
    }

    /// The thread died: starts another that carries on with the last face. `Err` when it
    /// cannot go on: it died more than [`super::restarts::MAX_RESTARTS`] times a minute, or
    /// the new thread could not start.
    pub(super) fn restart(&mut self, why: &str) -> Result<()> {
        if let Err(times) = self.restarts.died() {
            tracing::error!("the gem thread died again ({why}): giving up");
            anyhow::bail!("the gem thread died {times} (last: {why})");
        }
        let fault = self.fault.filter(|f| f.every_thread);
        self.thread = GemThread::spawn(self.cameo.clone(), self.last_job.clone(), fault)
            .context("restarting the gem thread")?;
        Ok(())
    }
}

/// The gem thread's work: load the model, then one cameo per job until the window goes.
fn work(
    params: CameoParams,
    first: Option<GemJob>,
    fault: Option<GemFault>,
    jobs: &LatestReceiver<GemJob>,
    send: &LatestSender<Result<BuiltGem, String>>,
    note_tx: &crossbeam_channel::Sender<GemNote>,
) {
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
    let (mut face, mut hair, mut detail) = match first {
        Some(job) => (job.face, job.hair, job.detail),
        None => (mean.clone(), params.hair, None),
    };
    let mut warm = Vec::new();
    let mut built_count = 0u64;
    // Each gem's grids are freed here; their pages go back (glyptic::memory).
    let mut trimmer = glyptic::memory::Trimmer::new(TRIM_PERIOD);
    loop {
        built_count += 1;
        if fault.is_some_and(|f| f.at == built_count) {
            panic!("injected fault: gem-panic at cameo {built_count}");
        }
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
            .build_after(&face, &triangles, &mut warm, detail.as_deref())
            .map(|mesh| BuiltGem {
                mesh: Arc::new(mesh),
                ms: t.elapsed().as_secs_f64() * 1e3,
            })
            .map_err(|e| format!("cameo: {e}"));
        if send.send(built).is_err() {
            return;
        }
        trimmer.tick();
        match jobs.recv() {
            Ok(next) => (face, hair, detail) = (next.face, next.hair, next.detail),
            Err(_) => return,
        }
    }
}
