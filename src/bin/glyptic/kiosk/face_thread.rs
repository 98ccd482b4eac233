//! The face side of the kiosk (feature `face`): the models load on a set-up thread, then
//! [`glyptic::stream`]'s capture, face and person threads run; the window polls [`Live`] for
//! news and never waits for it.

use anyhow::{Context, Result};

use glyptic::capture::{Capture, CaptureEvent, CaptureOptions, FrameSource};
use glyptic::kiosk::KioskConfig;
use glyptic::stream::{FaceStream, StreamEvent};
use glyptic::track::{TrackOptions, Tracker};

/// What the face side reports to the window.
pub(super) enum FaceNews {
    /// A processed frame: the fitted face (model mm) if there was one, the frame's index in
    /// the stream and its latency from capture, ms.
    Update {
        face: Option<Vec<f32>>,
        /// The visitor's detail, once read from one of their frames (carved with the face).
        detail: Option<std::sync::Arc<glyptic::gem::FaceDetail>>,
        /// The visitor's hair once the person thread has settled it (boxed: its silhouette
        /// grid is some kilobytes).
        hair: Option<Box<glyptic::gem::HairStyle>>,
        frame: u64,
        latency_ms: f64,
    },
    Status(String),
    /// Something went wrong (for the staff panel and the log); `camera_down`: no frames come.
    Trouble {
        what: String,
        camera_down: bool,
    },
    /// The face side died more often than it may be restarted: the kiosk cannot go on.
    Fatal(String),
}

/// Starts the models loading and the stream on a thread of its own; the window polls.
pub(super) struct Live {
    config: KioskConfig,
    stream: Option<FaceStream>,
    starting: Option<crossbeam_channel::Receiver<Result<FaceStream, String>>>,
    pub(super) restarts: super::restarts::Restarts,
}

/// A frame source that panics at its Nth frame ([`super::run::Fault::CapturePanic`], for tests):
/// the capture thread dies, and with it the face side.
struct Faulty {
    inner: Box<dyn FrameSource>,
    at: u64,
    frames: u64,
}

impl FrameSource for Faulty {
    fn name(&self) -> String {
        self.inner.name()
    }

    fn next_frame(
        &mut self,
    ) -> Result<Option<glyptic::capture::RawFrame>, glyptic::capture::SourceError> {
        self.frames += 1;
        if self.frames == self.at {
            panic!("injected fault: capture-panic at frame {}", self.at);
        }
        self.inner.next_frame()
    }

    fn frame_rate(&self) -> Option<f64> {
        self.inner.frame_rate()
    }
}

pub(super) fn open_source(config: &KioskConfig) -> Box<dyn FrameSource> {
    match &config.video {
        // A photo: seen as a camera pointed at it would see it.
        Some(path) if glyptic::capture::source::is_image_path(path) => {
            Box::new(glyptic::capture::StillSource::new(path.clone(), 10.0))
        }
        #[cfg(feature = "video")]
        Some(path) => Box::new(glyptic::capture::video_process::VideoProcess::new(
            path.clone(),
            true,
        )),
        #[cfg(not(feature = "video"))]
        Some(path) => Box::new(glyptic::capture::FailedSource(format!(
            "{}: this build reads no video files (cargo feature `video`)",
            path.display()
        ))),
        #[cfg(feature = "webcam")]
        None => Box::new(glyptic::capture::camera::CameraSource::new(config.camera)),
        #[cfg(not(feature = "webcam"))]
        None => Box::new(glyptic::capture::FailedSource(
            "this build has no webcam support (cargo feature `webcam`)".into(),
        )),
    }
}

impl Live {
    /// Starts the face side; `capture_fault`: the first capture panics at this frame (tests).
    pub(super) fn start(config: &KioskConfig, capture_fault: Option<u64>) -> Result<Self> {
        Ok(Live {
            config: config.clone(),
            stream: None,
            starting: Some(Self::spawn_setup(config, capture_fault)?),
            restarts: Default::default(),
        })
    }

    /// Loads the models and starts the stream on a thread of its own.
    fn spawn_setup(
        config: &KioskConfig,
        fault: Option<u64>,
    ) -> Result<crossbeam_channel::Receiver<Result<FaceStream, String>>> {
        let (tx, rx) = crossbeam_channel::bounded(1);
        let config = config.clone();
        std::thread::Builder::new()
            .name("face setup".into())
            .spawn(move || {
                let started = (|| -> Result<FaceStream> {
                    let pipeline = glyptic::pipeline::FacePipeline::load(
                        &glyptic::assets::ModelPaths::locate(),
                    )?;
                    let tracker = Tracker::new(pipeline, TrackOptions::default());
                    let hair = config.visitor_hair;
                    let detail = config.detail();
                    let likeness = (config.likeness_search > 0).then(|| {
                        glyptic::identity::SearchOptions::with_faces(
                            config.likeness_search as usize,
                        )
                    });
                    let capture = Capture::spawn(
                        move || match fault {
                            Some(at) => Box::new(Faulty {
                                inner: open_source(&config),
                                at,
                                frames: 0,
                            }),
                            None => open_source(&config),
                        },
                        CaptureOptions::default(),
                    );
                    Ok(FaceStream::spawn_with(
                        capture,
                        tracker,
                        glyptic::stream::StreamOptions {
                            builder: None,
                            hair,
                            models: Some(glyptic::assets::ModelPaths::locate()),
                            likeness,
                            detail,
                        },
                    ))
                })();
                let _ = tx.send(started.map_err(|e| format!("{e:#}")));
            })
            .context("starting the face set-up thread")?;
        Ok(rx)
    }

    /// The face side stopped (a thread died): start it again, unless it died too often.
    fn restart(&mut self) -> FaceNews {
        self.stream = None;
        if let Err(times) = self.restarts.died() {
            tracing::error!("face tracking stopped again: giving up");
            return FaceNews::Fatal(format!("face tracking stopped {times}"));
        }
        tracing::error!("face tracking stopped (a worker thread died); restarting it");
        match Self::spawn_setup(&self.config, None) {
            Ok(rx) => {
                self.starting = Some(rx);
                FaceNews::Trouble {
                    what: "face tracking stopped; restarting".into(),
                    camera_down: true,
                }
            }
            Err(e) => FaceNews::Fatal(format!("{e:#}")),
        }
    }

    /// News since the last call, newest face last.
    pub(super) fn poll(&mut self) -> Vec<FaceNews> {
        let mut news = Vec::new();
        if let Some(rx) = &self.starting {
            match rx.try_recv() {
                Ok(Ok(stream)) => {
                    self.stream = Some(stream);
                    self.starting = None;
                    news.push(FaceNews::Status("camera: starting".into()));
                }
                Ok(Err(e)) => {
                    self.starting = None;
                    news.push(FaceNews::Trouble {
                        what: format!("no face tracking: {e}"),
                        camera_down: true,
                    });
                }
                Err(crossbeam_channel::TryRecvError::Empty) => {}
                Err(crossbeam_channel::TryRecvError::Disconnected) => self.starting = None,
            }
        }
        let Some(stream) = &self.stream else {
            return news;
        };
        for e in stream.events().try_iter() {
            let trouble = |what: String, camera_down| FaceNews::Trouble { what, camera_down };
            news.push(match e {
                StreamEvent::Capture(CaptureEvent::Started { source }) => {
                    FaceNews::Status(format!("camera: {source}"))
                }
                StreamEvent::Capture(CaptureEvent::Unavailable { reason, .. }) => {
                    trouble(format!("no camera: {reason}"), true)
                }
                StreamEvent::Capture(CaptureEvent::Resumed { .. }) => {
                    FaceNews::Status("camera: back".into())
                }
                StreamEvent::Capture(CaptureEvent::BadFrame { reason, .. }) => {
                    trouble(format!("camera: bad frame ({reason})"), false)
                }
                StreamEvent::Capture(CaptureEvent::Ended { .. }) => {
                    trouble("camera: ended".into(), true)
                }
                StreamEvent::Capture(CaptureEvent::Failed { error }) => {
                    trouble(format!("no camera: {error}"), true)
                }
                StreamEvent::Error { error, .. } => trouble(format!("face: {error}"), false),
            });
        }
        match stream.updates().try_recv() {
            Ok(Some(u)) => news.push(FaceNews::Update {
                hair: u.hair.map(Box::new),
                detail: u.face.as_ref().and_then(|f| f.detail.clone()),
                face: u.face.map(|f| f.portrait),
                frame: u.frame_index,
                latency_ms: u.latency_ms,
            }),
            Ok(None) => {}
            // The kiosk's sources never end (videos loop, cameras are waited for): a closed
            // stream is a dead thread.
            Err(_) => news.push(self.restart()),
        }
        news
    }
}
