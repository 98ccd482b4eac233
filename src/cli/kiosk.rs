//! `glyptic kiosk`: the museum window. A visitor's face becomes a cameo, live.
//!
//! Threads: the window's event loop (this module: input, controls, rendering), a gem thread
//! that builds cameos from face meshes (the fitted face, or the ease back to the default face),
//! and with the `face` feature the capture and face threads of [`glyptic::stream`]. All hand
//! over through one-slot channels where the newest item wins: the window never waits for them.
//!
//! The gem is rendered into its own texture only when something it shows changes (a new gem,
//! a control, the orbit, the size); every frame then draws that texture and the controls
//! (egui) into the window's surface. On a CPU rasteriser a gem frame costs tenths of a second
//! while a controls frame costs milliseconds, so buttons answer at once.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow};
use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::window::{Fullscreen, Window, WindowId};

use glyptic::capture::latest::{LatestReceiver, LatestSender, latest};
use glyptic::gem::View;
use glyptic::gem::{CameoBuilder, CameoParams, HairStyle};
use glyptic::kiosk::{Controls, KioskConfig, Orbit, blend_faces, idle_weight};
use glyptic::render::{Material, Mesh, RenderParams, Renderer};

#[derive(clap::Args, Debug, Clone)]
pub struct KioskArgs {
    /// Webcam N (/dev/videoN) [config: camera; default 0].
    #[arg(long, value_name = "N", conflicts_with = "video")]
    pub camera: Option<u32>,
    /// Play this video file, looping, instead of a camera [config: video].
    #[arg(long, value_name = "FILE")]
    pub video: Option<PathBuf>,
    /// Fill the screen [config: fullscreen].
    #[arg(long)]
    pub fullscreen: bool,
    /// Kiosk defaults (TOML): camera, video, material, portrait, sss, sss_strength,
    /// idle_seconds, ease_seconds, fullscreen, width, height, render_scale.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Window size WIDTHxHEIGHT when not full-screen [config: width, height].
    #[arg(long)]
    pub size: Option<super::Size>,
    /// Quit after presenting this many frames (scripted runs).
    #[arg(long, value_name = "N")]
    pub frames: Option<u64>,
    /// Quit after this many seconds (scripted runs).
    #[arg(long, value_name = "S")]
    pub seconds: Option<f64>,
    /// When quitting, save the last presented frame (controls included) as PNG.
    #[arg(long, value_name = "FILE.png")]
    pub screenshot: Option<PathBuf>,
    /// Where the "Save" button writes its PNGs.
    #[arg(long, value_name = "DIR", default_value = ".")]
    pub snapshots: PathBuf,
    /// Print one JSON line per presented frame to stdout (frame, gem, controls, orbit, status).
    #[arg(long)]
    pub trace: bool,
}

pub fn kiosk(args: &KioskArgs) -> Result<()> {
    let mut config = match &args.config {
        Some(path) => KioskConfig::load(path)?,
        None => KioskConfig::default(),
    };
    if let Some(n) = args.camera {
        config.camera = n;
        config.video = None;
    }
    if let Some(v) = &args.video {
        config.video = Some(v.clone());
    }
    config.fullscreen |= args.fullscreen;
    if let Some(s) = args.size {
        (config.width, config.height) = (s.width, s.height);
    }
    config
        .check(args.config.as_deref().unwrap_or(Path::new("command line")))
        .map_err(|e| anyhow!(e))?;
    std::fs::create_dir_all(&args.snapshots)
        .with_context(|| format!("{}: cannot create", args.snapshots.display()))?;

    let event_loop = EventLoop::new().context("opening the display (is DISPLAY set?)")?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let mut app = App {
        args: args.clone(),
        config,
        started: Instant::now(),
        running: None,
        error: None,
    };
    event_loop.run_app(&mut app).context("window event loop")?;
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

struct App {
    args: KioskArgs,
    config: KioskConfig,
    started: Instant,
    running: Option<Running>,
    /// Why the kiosk had to stop (it stops only when it cannot show anything).
    error: Option<anyhow::Error>,
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.running.is_some() {
            return;
        }
        match Running::new(event_loop, &self.config, self.started) {
            Ok(r) => self.running = Some(r),
            Err(e) => {
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let Some(r) = self.running.as_mut() else {
            return;
        };
        let response = r.egui_state.on_window_event(&r.window, &event);
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => r.resize(size.width, size.height),
            WindowEvent::RedrawRequested => match r.frame(&self.args) {
                Ok(Continue::Yes) => {}
                Ok(Continue::Quit) => {
                    if let Err(e) = r.finish(&self.args) {
                        self.error = Some(e);
                    }
                    event_loop.exit();
                }
                Err(e) => {
                    self.error = Some(e);
                    event_loop.exit();
                }
            },
            _ => {}
        }
        if response.repaint {
            r.window.request_redraw();
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        if let Some(r) = self.running.as_mut() {
            // Poll the gem and face threads about 60 times a second; draw when needed.
            if r.poll() {
                r.window.request_redraw();
            }
            event_loop.set_control_flow(ControlFlow::WaitUntil(
                Instant::now() + Duration::from_millis(16),
            ));
        }
    }
}

/// The first gem's resolution, of the window's (per side).
const PREVIEW_SCALE: f32 = 0.5;

enum Continue {
    Yes,
    Quit,
}

/// A cameo built by the gem thread.
struct BuiltGem {
    mesh: Arc<Mesh>,
    ms: f64,
}

/// What the gem thread says once, beside its cameos.
enum GemNote {
    /// The model is loaded: the default face (model mm) for easing back.
    Ready { default_face: Arc<Vec<f32>> },
    /// The model or the builder could not be made: no cameo will come.
    Failed(String),
}

/// A cameo to build: a face (model mm) and its hair (the classical style for the default face
/// or before the visitor's hair is known).
struct GemJob {
    face: Vec<f32>,
    hair: HairStyle,
}

/// The gem thread: builds a cameo for each face mesh it is given (the newest wins) and starts
/// with the model's mean face. A job with other hair than the last costs a new
/// [`CameoBuilder`] (the sculpted head under the new hair, ~35 ms), on this thread.
struct GemThread {
    faces: LatestSender<GemJob>,
    /// Each cameo built, or why a face made none (newest wins).
    out: LatestReceiver<Result<BuiltGem, String>>,
    /// Notes that the newest cameo must not replace.
    notes: crossbeam_channel::Receiver<GemNote>,
}

impl GemThread {
    fn spawn(portrait: View) -> Result<Self> {
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

/// The visitor's face, from the capture and face threads (feature `face`).
#[cfg(feature = "face")]
mod live {
    use super::*;
    use glyptic::capture::{Capture, CaptureEvent, CaptureOptions, FrameSource};
    use glyptic::stream::{FaceStream, StreamEvent};
    use glyptic::track::{TrackOptions, Tracker};

    /// What the face side reports to the window.
    pub enum FaceNews {
        /// A processed frame: the fitted face (model mm) if there was one, the frame's index in
        /// the stream and its latency from capture, ms.
        Update {
            face: Option<Vec<f32>>,
            /// The visitor's hair once the person thread has settled it.
            hair: Option<glyptic::gem::HairStyle>,
            frame: u64,
            latency_ms: f64,
        },
        Status(String),
    }

    /// Starts the models loading and the stream on a thread of its own; the window polls.
    pub struct Live {
        stream: Option<FaceStream>,
        starting: Option<crossbeam_channel::Receiver<Result<FaceStream, String>>>,
    }

    fn open_source(config: &KioskConfig) -> Box<dyn FrameSource> {
        match &config.video {
            #[cfg(feature = "video")]
            Some(path) => Box::new(glyptic::capture::video::VideoSource::new(
                path.clone(),
                true,
            )),
            #[cfg(not(feature = "video"))]
            Some(path) => Box::new(super::super::track::Failed(format!(
                "{}: this build reads no video files (cargo feature `video`)",
                path.display()
            ))),
            #[cfg(feature = "webcam")]
            None => Box::new(glyptic::capture::camera::CameraSource::new(config.camera)),
            #[cfg(not(feature = "webcam"))]
            None => Box::new(super::super::track::Failed(
                "this build has no webcam support (cargo feature `webcam`)".into(),
            )),
        }
    }

    impl Live {
        pub fn start(config: &KioskConfig) -> Result<Self> {
            let (tx, rx) = crossbeam_channel::bounded(1);
            let config = config.clone();
            std::thread::Builder::new()
                .name("face setup".into())
                .spawn(move || {
                    let started = (|| -> Result<FaceStream> {
                        // A missing video is said before the models load (a second).
                        if let Some(path) = &config.video
                            && !path.exists()
                        {
                            anyhow::bail!("{}: video not found", path.display());
                        }
                        let pipeline = glyptic::pipeline::FacePipeline::load(
                            &glyptic::assets::ModelPaths::locate(),
                        )?;
                        let tracker = Tracker::new(pipeline, TrackOptions::default());
                        let hair = config.visitor_hair;
                        let capture =
                            Capture::spawn(move || open_source(&config), CaptureOptions::default());
                        Ok(FaceStream::spawn_with(
                            capture,
                            tracker,
                            glyptic::stream::StreamOptions {
                                builder: None,
                                hair,
                                models: Some(glyptic::assets::ModelPaths::locate()),
                            },
                        ))
                    })();
                    let _ = tx.send(started.map_err(|e| format!("{e:#}")));
                })
                .context("starting the face set-up thread")?;
            Ok(Live {
                stream: None,
                starting: Some(rx),
            })
        }

        /// News since the last call, newest face last.
        pub fn poll(&mut self) -> Vec<FaceNews> {
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
                        news.push(FaceNews::Status(format!("no face tracking: {e}")));
                    }
                    Err(crossbeam_channel::TryRecvError::Empty) => {}
                    Err(crossbeam_channel::TryRecvError::Disconnected) => self.starting = None,
                }
            }
            let Some(stream) = &self.stream else {
                return news;
            };
            for e in stream.events().try_iter() {
                news.push(FaceNews::Status(match e {
                    StreamEvent::Capture(CaptureEvent::Started { source }) => {
                        format!("camera: {source}")
                    }
                    StreamEvent::Capture(CaptureEvent::Unavailable { reason, .. }) => {
                        format!("no camera: {reason}")
                    }
                    StreamEvent::Capture(CaptureEvent::Resumed { .. }) => "camera: back".into(),
                    StreamEvent::Capture(CaptureEvent::BadFrame { reason, .. }) => {
                        format!("camera: bad frame ({reason})")
                    }
                    StreamEvent::Capture(CaptureEvent::Ended { .. }) => "camera: ended".into(),
                    StreamEvent::Capture(CaptureEvent::Failed { error }) => {
                        format!("no camera: {error}")
                    }
                    StreamEvent::Error { error, .. } => format!("face: {error}"),
                }));
            }
            if let Ok(Some(u)) = stream.updates().try_recv() {
                news.push(FaceNews::Update {
                    hair: u.hair,
                    face: u.face.map(|f| f.portrait),
                    frame: u.frame_index,
                    latency_ms: u.latency_ms,
                });
            }
            news
        }
    }
}

/// The gem's own texture, drawn by egui as the window's background.
struct GemLayer {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    id: egui::TextureId,
    size: [u32; 2],
}

/// Rates over the last second.
#[derive(Default)]
struct Rate {
    times: std::collections::VecDeque<Instant>,
}

impl Rate {
    fn tick(&mut self) {
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

    fn per_second(&self) -> f64 {
        match (self.times.front(), self.times.back()) {
            (Some(a), Some(b)) if self.times.len() > 1 => {
                (self.times.len() - 1) as f64 / b.duration_since(*a).as_secs_f64().max(1e-3)
            }
            _ => 0.0,
        }
    }
}

struct Running {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    surface_config: wgpu::SurfaceConfiguration,
    /// The surface's format without sRGB encoding (the composite and egui encode).
    view_format: wgpu::TextureFormat,
    renderer: Renderer,
    egui_ctx: egui::Context,
    egui_state: egui_winit::State,
    egui_renderer: egui_wgpu::Renderer,
    layer: Option<GemLayer>,
    /// The gem needs rendering again.
    dirty: bool,
    base: RenderParams,
    controls: Controls,
    orbit: Orbit,
    render_scale: f32,
    idle_seconds: f32,
    ease_seconds: f32,
    gems: GemThread,
    #[cfg(feature = "face")]
    live: live::Live,
    default_face: Option<Arc<Vec<f32>>>,
    /// The hair of the cameo's default face, and the visitor's as last read (the default's
    /// until then).
    default_hair: HairStyle,
    visitor_hair: HairStyle,
    /// Glasses found on a visitor are carved (config key `glasses`).
    #[cfg_attr(not(feature = "face"), allow(dead_code))]
    carve_glasses: bool,
    /// The last face seen and when.
    last_face: Option<(Vec<f32>, Instant)>,
    /// The idle weight last sent to the gem thread.
    sent_weight: f32,
    gem: Option<Arc<Mesh>>,
    gem_count: u64,
    gem_ms: f64,
    status: String,
    face_status: String,
    render_rate: Rate,
    face_rate: Rate,
    render_ms: f64,
    frames: u64,
    started: Instant,
    first_frame_s: Option<f64>,
    first_gem_s: Option<f64>,
    snapshot_request: bool,
    last_screen: Option<image::RgbaImage>,
    /// A message shown for a few seconds (saved snapshot, errors).
    toast: Option<(String, Instant)>,
    /// Each control's rectangle in window pixels `[x, y, w, h]`, for scripted runs.
    control_rects: Vec<(&'static str, [f32; 4])>,
    /// A fingerprint of the gem shown (changes with its shape).
    gem_print: u64,
    /// When the first frame showing a gem was presented (a preview at [`PREVIEW_SCALE`]), and
    /// the first at full resolution, seconds from start.
    first_gem_frame_s: Option<f64>,
    full_gem_frame_s: Option<f64>,
    /// Face updates taken from the face thread, and the newest one's latency from capture.
    face_updates: u64,
    face_latency_ms: f64,
    /// The newest update's frame index: frames the face thread has processed, less one.
    face_frame: u64,
    /// The longest the event loop spent taking news from the other threads, ms (it never
    /// waits for them: this is the cost of a look).
    poll_max_ms: f64,
}

impl Running {
    fn new(event_loop: &ActiveEventLoop, config: &KioskConfig, started: Instant) -> Result<Self> {
        let mut attributes = Window::default_attributes()
            .with_title("glyptic")
            .with_inner_size(winit::dpi::LogicalSize::new(config.width, config.height));
        if config.fullscreen {
            attributes = attributes.with_fullscreen(Some(Fullscreen::Borderless(None)));
        }
        let window = Arc::new(
            event_loop
                .create_window(attributes)
                .context("creating the window")?,
        );
        let gems = GemThread::spawn(config.portrait)?;
        #[cfg(feature = "face")]
        let live = live::Live::start(config)?;

        let display = event_loop.owned_display_handle();
        let instance = wgpu::Instance::new(
            wgpu::InstanceDescriptor::new_with_display_handle(Box::new(display)).with_env(),
        );
        let surface = instance
            .create_surface(Arc::clone(&window))
            .context("creating the window's surface")?;
        let renderer = Renderer::new_for_surface(&instance, &surface, true)?;
        let size = window.inner_size();
        let (surface_config, view_format) =
            surface_config(&surface, &renderer, size.width.max(1), size.height.max(1))?;
        surface.configure(renderer.device(), &surface_config);

        let egui_ctx = egui::Context::default();
        style(&egui_ctx);
        let egui_state = egui_winit::State::new(
            egui_ctx.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(renderer.device().limits().max_texture_dimension_2d as usize),
        );
        let egui_renderer = egui_wgpu::Renderer::new(
            renderer.device(),
            view_format,
            egui_wgpu::RendererOptions::default(),
        );
        let base = RenderParams {
            background: [0.10, 0.11, 0.13],
            hair_layer: config.hair_layer,
            ..RenderParams::default()
        };
        window.request_redraw();
        Ok(Running {
            window,
            surface,
            surface_config,
            view_format,
            renderer,
            egui_ctx,
            egui_state,
            egui_renderer,
            layer: None,
            dirty: true,
            base,
            controls: Controls::from_config(config),
            orbit: Orbit::default(),
            render_scale: config.render_scale,
            idle_seconds: config.idle_seconds,
            ease_seconds: config.ease_seconds,
            gems,
            #[cfg(feature = "face")]
            live,
            default_face: None,
            default_hair: config.portrait.cameo().hair,
            visitor_hair: config.portrait.cameo().hair,
            carve_glasses: config.glasses,
            last_face: None,
            sent_weight: 1.0,
            gem: None,
            gem_count: 0,
            gem_ms: 0.0,
            status: "loading the face model".into(),
            face_status: if cfg!(feature = "face") {
                "loading the face tracker".into()
            } else {
                "this build has no face tracking: the default face".into()
            },
            render_rate: Rate::default(),
            face_rate: Rate::default(),
            render_ms: 0.0,
            frames: 0,
            started,
            first_frame_s: None,
            first_gem_s: None,
            snapshot_request: false,
            last_screen: None,
            toast: None,
            control_rects: Vec::new(),
            gem_print: 0,
            first_gem_frame_s: None,
            full_gem_frame_s: None,
            face_updates: 0,
            face_latency_ms: 0.0,
            face_frame: 0,
            poll_max_ms: 0.0,
        })
    }

    fn resize(&mut self, width: u32, height: u32) {
        // A minimised window has no size: keep the old surface until it comes back.
        if width == 0 || height == 0 {
            return;
        }
        self.surface_config.width = width;
        self.surface_config.height = height;
        self.surface
            .configure(self.renderer.device(), &self.surface_config);
        self.dirty = true;
        self.window.request_redraw();
    }

    /// Takes what the gem and face threads have; true if the window should be drawn.
    fn poll(&mut self) -> bool {
        let t = Instant::now();
        let changed = self.take_news();
        self.poll_max_ms = self.poll_max_ms.max(t.elapsed().as_secs_f64() * 1e3);
        changed
    }

    fn take_news(&mut self) -> bool {
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
                    self.gem_print = built.mesh.fingerprint();
                    self.gem = Some(built.mesh);
                    self.gem_ms = built.ms;
                    self.gem_count += 1;
                    self.dirty = true;
                    if self.first_gem_s.is_none() {
                        self.first_gem_s = Some(self.started.elapsed().as_secs_f64());
                    }
                }
                Err(e) => self.status = e,
            }
            changed = true;
        }
        #[cfg(feature = "face")]
        for news in self.live.poll() {
            use live::FaceNews;
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
                    self.face_rate.tick();
                    self.face_updates += 1;
                    self.face_frame = frame;
                    self.face_latency_ms = latency_ms;
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
    fn ease_back(&mut self) -> bool {
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

    /// Draws one frame: the controls, and the gem if it changed.
    fn frame(&mut self, args: &KioskArgs) -> Result<Continue> {
        if let Some(error) = self.renderer.take_gpu_error() {
            self.toast = Some((format!("GPU: {error}"), Instant::now()));
        }
        let raw_input = self.egui_state.take_egui_input(&self.window);
        let before = (self.controls.clone(), self.orbit);
        let status = self.status_line();
        let mut ui = UiFrame {
            controls: &mut self.controls,
            orbit: &mut self.orbit,
            layer: self.layer.as_ref().map(|l| l.id),
            status,
            toast: self
                .toast
                .as_ref()
                .filter(|(_, t)| t.elapsed() < Duration::from_secs(4))
                .map(|(m, _)| m.clone()),
            gem_rect: None,
            snapshot: false,
            rects: Vec::new(),
        };
        let output = self.egui_ctx.run_ui(raw_input, |ui_root| ui.draw(ui_root));
        let (gem_rect, snapshot) = (ui.gem_rect, ui.snapshot);
        let ppp = output.pixels_per_point;
        self.control_rects = ui
            .rects
            .iter()
            .map(|(k, r)| {
                let p = |v: f32| (v * ppp).round();
                (*k, [p(r.min.x), p(r.min.y), p(r.width()), p(r.height())])
            })
            .collect();
        self.snapshot_request |= snapshot;
        if (self.controls.clone(), self.orbit) != before {
            self.dirty = true;
        }
        if before.0.frozen && !self.controls.frozen {
            // Unfrozen: show the newest face again.
            if let Some((face, _)) = &self.last_face {
                let _ = self.gems.faces.send(GemJob {
                    face: face.clone(),
                    hair: self.visitor_hair,
                });
                self.sent_weight = 0.0;
            }
        }
        self.egui_state
            .handle_platform_output(&self.window, output.platform_output);

        // The gem's texture follows the area it is shown in. The very first gem is rendered
        // at half the resolution, then at full: on a CPU rasteriser that puts it on screen
        // about twice as soon after start-up.
        if let Some(rect) = gem_rect {
            let preview = self.gem.is_some() && self.first_gem_frame_s.is_none();
            let scale = ppp * self.render_scale * if preview { PREVIEW_SCALE } else { 1.0 };
            let size = [
                ((rect.width() * scale).round() as u32).clamp(16, 4096),
                ((rect.height() * scale).round() as u32).clamp(16, 4096),
            ];
            if self.layer.as_ref().is_none_or(|l| l.size != size) {
                self.make_layer(size);
            }
        }

        // egui's texture changes (the font atlas among them) are kept even when no surface
        // texture comes this frame: egui sends each change once.
        for (id, deltas) in &output.textures_delta.set {
            for delta in deltas {
                self.egui_renderer.update_texture(
                    self.renderer.device(),
                    self.renderer.queue(),
                    *id,
                    delta,
                );
            }
        }
        let frame = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(f)
            | wgpu::CurrentSurfaceTexture::Suboptimal(f) => Some(f),
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                // Reconfigure and try on the next frame.
                self.surface
                    .configure(self.renderer.device(), &self.surface_config);
                None
            }
            other => {
                self.toast = Some((format!("window surface: {other:?}"), Instant::now()));
                None
            }
        };
        let Some(frame) = frame else {
            for id in &output.textures_delta.free {
                self.egui_renderer.free_texture(id);
            }
            self.window.request_redraw();
            return Ok(Continue::Yes);
        };
        let view = frame.texture.create_view(&wgpu::TextureViewDescriptor {
            format: Some(self.view_format),
            ..Default::default()
        });
        let device = self.renderer.device().clone();
        let queue = self.renderer.queue().clone();
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("kiosk frame"),
        });
        let t = Instant::now();
        let mut rendered_gem = false;
        if self.dirty
            && let (Some(gem), Some(layer)) = (&self.gem, &self.layer)
        {
            let params = RenderParams {
                width: layer.size[0],
                height: layer.size[1],
                style_time_s: self.started.elapsed().as_secs_f32(),
                ..self.controls.apply(&self.base, &self.orbit)
            };
            let drawn = if params.styles.iter().any(|s| s.is_serial()) {
                // Dithering runs on the CPU: read the gem back, dither it, and upload it to the
                // layer (only when the gem changes: it is still).
                self.renderer.render(gem, &params).map(|image| {
                    queue.write_texture(
                        layer.texture.as_image_copy(),
                        &image,
                        wgpu::TexelCopyBufferLayout {
                            offset: 0,
                            bytes_per_row: Some(4 * image.width()),
                            rows_per_image: None,
                        },
                        layer.texture.size(),
                    );
                })
            } else {
                self.renderer.render_to_view(
                    &mut encoder,
                    gem,
                    &params,
                    &layer.view,
                    wgpu::TextureFormat::Rgba8Unorm,
                )
            };
            match drawn {
                Ok(()) => {
                    self.dirty = false;
                    rendered_gem = true;
                }
                Err(e) => {
                    self.toast = Some((format!("render: {e}"), Instant::now()));
                    self.dirty = false;
                }
            }
        }
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [self.surface_config.width, self.surface_config.height],
            pixels_per_point: ppp,
        };
        let jobs = self.egui_ctx.tessellate(output.shapes, ppp);
        let extra =
            self.egui_renderer
                .update_buffers(&device, &queue, &mut encoder, &jobs, &screen);
        {
            let mut pass = encoder
                .begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("kiosk controls"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: &view,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color {
                                r: 0.01,
                                g: 0.012,
                                b: 0.016,
                                a: 1.0,
                            }),
                            store: wgpu::StoreOp::Store,
                        },
                    })],
                    ..Default::default()
                })
                .forget_lifetime();
            self.egui_renderer.render(&mut pass, &jobs, &screen);
        }
        let can_copy = self
            .surface_config
            .usage
            .contains(wgpu::TextureUsages::COPY_SRC);
        let want_copy = self.snapshot_request || args.screenshot.is_some();
        if want_copy && !can_copy {
            self.toast = Some(("this window cannot be copied".into(), Instant::now()));
            self.snapshot_request = false;
        }
        let capture = (can_copy && want_copy)
            .then(|| ScreenCopy::encode(&device, &mut encoder, &frame.texture));
        queue.submit(extra.into_iter().chain([encoder.finish()]));
        if rendered_gem {
            // Only a gem frame is timed, and only here do we wait for the GPU.
            let _ = device.poll(wgpu::PollType::wait_indefinitely());
            self.render_ms = t.elapsed().as_secs_f64() * 1e3;
            self.render_rate.tick();
            if self.controls.animates(self.render_ms) {
                self.dirty = true;
            }
        }
        if let Some(copy) = capture {
            match copy.read(&device, self.view_format) {
                Ok(image) => {
                    if self.snapshot_request {
                        self.save_snapshot(&image, &args.snapshots);
                        self.snapshot_request = false;
                    }
                    self.last_screen = Some(image);
                }
                Err(e) => self.toast = Some((format!("screenshot: {e}"), Instant::now())),
            }
        }
        self.window.pre_present_notify();
        queue.present(frame);
        for id in &output.textures_delta.free {
            self.egui_renderer.free_texture(id);
        }
        self.frames += 1;
        if self.first_frame_s.is_none() {
            self.first_frame_s = Some(self.started.elapsed().as_secs_f64());
        }
        if rendered_gem {
            let now = Some(self.started.elapsed().as_secs_f64());
            if self.first_gem_frame_s.is_none() {
                self.first_gem_frame_s = now;
                // The preview: the full resolution follows on the next frame.
                self.dirty = true;
            } else if self.full_gem_frame_s.is_none() {
                self.full_gem_frame_s = now;
            }
        }
        if args.trace {
            println!("{}", self.trace_line(rendered_gem));
        }
        let out_of_frames = args.frames.is_some_and(|n| self.frames >= n);
        let out_of_time = args
            .seconds
            .is_some_and(|s| self.started.elapsed().as_secs_f64() >= s);
        if out_of_frames || out_of_time {
            return Ok(Continue::Quit);
        }
        if self.dirty
            || output
                .viewport_output
                .values()
                .any(|v| v.repaint_delay.is_zero())
        {
            self.window.request_redraw();
        }
        Ok(Continue::Yes)
    }

    fn make_layer(&mut self, size: [u32; 2]) {
        let device = self.renderer.device();
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("kiosk gem layer"),
            size: wgpu::Extent3d {
                width: size[0],
                height: size[1],
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8Unorm,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let view = texture.create_view(&Default::default());
        let id = match &self.layer {
            Some(old) => {
                self.egui_renderer.update_egui_texture_from_wgpu_texture(
                    device,
                    &view,
                    wgpu::FilterMode::Linear,
                    old.id,
                );
                old.id
            }
            None => {
                self.egui_renderer
                    .register_native_texture(device, &view, wgpu::FilterMode::Linear)
            }
        };
        self.layer = Some(GemLayer {
            texture,
            view,
            id,
            size,
        });
        self.dirty = true;
    }

    fn status_line(&self) -> String {
        let mut s = format!("{} · {}", self.face_status, self.status);
        if self.render_rate.per_second() > 0.0 || self.render_ms > 0.0 {
            s += &format!(
                " · gem {:.0} ms render, {:.1} ms build",
                self.render_ms, self.gem_ms
            );
        }
        let face_fps = self.face_rate.per_second();
        if face_fps > 0.0 {
            s += &format!(" · face {face_fps:.0}/s");
        }
        s
    }

    fn save_snapshot(&mut self, image: &image::RgbaImage, dir: &Path) {
        let stamp = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_millis())
            .unwrap_or(0);
        let path = dir.join(format!("glyptic-{stamp}.png"));
        let message = match super::write_png(image.clone(), &path) {
            Ok(()) => format!("saved {}", path.display()),
            Err(e) => format!("not saved: {e:#}"),
        };
        self.toast = Some((message, Instant::now()));
    }

    fn trace_line(&self, rendered_gem: bool) -> serde_json::Value {
        serde_json::json!({
            "frame": self.frames,
            "t_s": self.started.elapsed().as_secs_f64(),
            "gem_rendered": rendered_gem,
            "gems": self.gem_count,
            "render_ms": self.render_ms,
            "gem_ms": self.gem_ms,
            "material": match self.controls.material { Material::Marble => "marble", Material::Agate => "agate" },
            "sss": self.controls.sss,
            "sss_label": self.controls.sss_label(),
            "style": self.controls.style.map_or("none", |s| s.name()),
            "engraving": self.controls.engraving,
            "lamp": self.controls.lamp,
            "sss_strength": self.controls.sss_strength,
            "frozen": self.controls.frozen,
            "yaw_deg": self.orbit.yaw_deg,
            "pitch_deg": self.orbit.pitch_deg,
            "zoom": self.orbit.zoom,
            "status": self.status_line(),
            "first_frame_s": self.first_frame_s,
            "first_gem_s": self.first_gem_s,
            "gem_print": format!("{:016x}", self.gem_print),
            "first_gem_frame_s": self.first_gem_frame_s,
            "full_gem_frame_s": self.full_gem_frame_s,
            "face_updates": self.face_updates,
            "face_latency_ms": self.face_latency_ms,
            "face_frame": self.face_frame,
            "poll_max_ms": self.poll_max_ms,
            "rss_kb": resident_kb(),
            "controls": self.control_rects.iter().map(|(k, r)| (k.to_string(), serde_json::json!(r))).collect::<serde_json::Map<_, _>>(),
        })
    }

    /// On quitting: the screenshot and a summary line.
    fn finish(&mut self, args: &KioskArgs) -> Result<()> {
        if let Some(path) = &args.screenshot {
            let image = self
                .last_screen
                .as_ref()
                .ok_or_else(|| anyhow!("no frame was captured for the screenshot"))?;
            super::write_png(image.clone(), path)?;
        }
        eprintln!(
            "kiosk: {} frames, {} gems, {} face updates; first frame after {:.2} s, first gem \
             shown after {}",
            self.frames,
            self.gem_count,
            self.face_updates,
            self.first_frame_s.unwrap_or(f64::NAN),
            self.first_gem_frame_s
                .map_or("-".into(), |s| format!("{s:.2} s")),
        );
        Ok(())
    }
}

/// Resident memory of this process, kB (Linux; 0 where unknown).
fn resident_kb() -> u64 {
    std::fs::read_to_string("/proc/self/statm")
        .ok()
        .and_then(|s| s.split_whitespace().nth(1)?.parse::<u64>().ok())
        .map_or(0, |pages| pages * 4)
}

/// Chooses the surface's format (the composite and egui write display values themselves, so a
/// view without sRGB encoding) and usage (copies out for screenshots where allowed).
fn surface_config(
    surface: &wgpu::Surface<'_>,
    renderer: &Renderer,
    width: u32,
    height: u32,
) -> Result<(wgpu::SurfaceConfiguration, wgpu::TextureFormat)> {
    let caps = renderer.surface_capabilities(surface);
    let eight_bit = |f: &wgpu::TextureFormat| {
        matches!(
            f.remove_srgb_suffix(),
            wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Rgba8Unorm
        )
    };
    let format = caps
        .formats
        .iter()
        .copied()
        .find(eight_bit)
        .or_else(|| caps.formats.first().copied())
        .ok_or_else(|| anyhow!("the window's surface offers no format"))?;
    let view_format = format.remove_srgb_suffix();
    let mut usage = wgpu::TextureUsages::RENDER_ATTACHMENT;
    if caps.usages.contains(wgpu::TextureUsages::COPY_SRC) {
        usage |= wgpu::TextureUsages::COPY_SRC;
    }
    let config = wgpu::SurfaceConfiguration {
        usage,
        format,
        width,
        height,
        present_mode: wgpu::PresentMode::AutoVsync,
        desired_maximum_frame_latency: 2,
        color_space: wgpu::SurfaceColorSpace::Auto,
        alpha_mode: caps
            .alpha_modes
            .first()
            .copied()
            .unwrap_or(wgpu::CompositeAlphaMode::Auto),
        view_formats: if view_format == format {
            vec![]
        } else {
            vec![view_format]
        },
    };
    Ok((config, view_format))
}

/// A copy of the presented frame on its way to the CPU.
struct ScreenCopy {
    buffer: wgpu::Buffer,
    width: u32,
    height: u32,
    padded_row: u32,
}

impl ScreenCopy {
    fn encode(
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        texture: &wgpu::Texture,
    ) -> Self {
        let (width, height) = (texture.width(), texture.height());
        let padded_row = (width * 4).div_ceil(256) * 256;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("kiosk screenshot"),
            size: u64::from(padded_row) * u64::from(height),
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded_row),
                    rows_per_image: Some(height),
                },
            },
            wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
        );
        ScreenCopy {
            buffer,
            width,
            height,
            padded_row,
        }
    }

    fn read(self, device: &wgpu::Device, format: wgpu::TextureFormat) -> Result<image::RgbaImage> {
        let slice = self.buffer.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| anyhow!("{e}"))?;
        rx.recv()
            .map_err(|e| anyhow!("{e}"))?
            .map_err(|e| anyhow!("{e}"))?;
        let bgra = matches!(
            format,
            wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb
        );
        let mut pixels = Vec::with_capacity((self.width * self.height * 4) as usize);
        {
            let data = slice.get_mapped_range().map_err(|e| anyhow!("{e}"))?;
            for row in data
                .chunks(self.padded_row as usize)
                .take(self.height as usize)
            {
                for px in row[..(self.width * 4) as usize].chunks_exact(4) {
                    if bgra {
                        pixels.extend_from_slice(&[px[2], px[1], px[0], 255]);
                    } else {
                        pixels.extend_from_slice(&[px[0], px[1], px[2], 255]);
                    }
                }
            }
        }
        self.buffer.unmap();
        image::RgbaImage::from_raw(self.width, self.height, pixels)
            .ok_or_else(|| anyhow!("screenshot smaller than the window"))
    }
}

/// Finger-sized controls: 56-point buttons, a thick slider, large text, a gold pressed state. A press counts as a
/// tap however long it is held (visitors press slowly, and a CPU-rendered frame can take half
/// a second) and however much a finger wobbles.
fn style(ctx: &egui::Context) {
    ctx.options_mut(|o| {
        o.input_options.max_click_duration = 5.0;
        o.input_options.max_click_dist = 12.0;
    });
    ctx.global_style_mut(|s| {
        s.spacing.interact_size = egui::vec2(56.0, 56.0);
        s.spacing.button_padding = egui::vec2(18.0, 12.0);
        s.spacing.item_spacing = egui::vec2(12.0, 10.0);
        s.spacing.slider_width = 260.0;
        s.spacing.slider_rail_height = 14.0;
        // Pressed: gold and a little larger, so a finger sees its tap land.
        let pressed = &mut s.visuals.widgets.active;
        pressed.bg_fill = egui::Color32::from_rgb(0xc9, 0x9a, 0x2e);
        pressed.weak_bg_fill = pressed.bg_fill;
        pressed.fg_stroke = egui::Stroke::new(2.0, egui::Color32::BLACK);
        pressed.expansion = 4.0;
        for (text_style, size) in [
            (egui::TextStyle::Button, 24.0),
            (egui::TextStyle::Body, 22.0),
            (egui::TextStyle::Small, 18.0),
        ] {
            if let Some(font) = s.text_styles.get_mut(&text_style) {
                font.size = size;
            }
        }
    });
}

/// One frame of the controls.
/// A button that shows `on` as selected and flips it when pressed; `label` says the state.
fn toggle(ui: &mut egui::Ui, on: &mut bool, label: &str) -> egui::Response {
    let r = ui.add(egui::Button::selectable(*on, label));
    if r.clicked() {
        *on = !*on;
    }
    r
}

struct UiFrame<'a> {
    controls: &'a mut Controls,
    orbit: &'a mut Orbit,
    layer: Option<egui::TextureId>,
    status: String,
    toast: Option<String>,
    /// Where the gem is shown (points).
    gem_rect: Option<egui::Rect>,
    snapshot: bool,
    /// Where each control is (points), for scripted runs.
    rects: Vec<(&'static str, egui::Rect)>,
}

impl UiFrame<'_> {
    fn draw(&mut self, root: &mut egui::Ui) {
        egui::Panel::top("status").show(root, |ui| {
            ui.add(egui::Label::new(egui::RichText::new(&self.status).size(18.0)).truncate());
        });
        egui::Panel::bottom("controls").show(root, |ui| {
            ui.add_space(6.0);
            // Three rows: the stone, the glow, the portrait.
            ui.horizontal(|ui| {
                for (material, name, key) in [
                    (Material::Marble, "Marble", "marble"),
                    (Material::Agate, "Agate", "agate"),
                ] {
                    let on = self.controls.material == material;
                    let r = ui.add(egui::Button::selectable(on, name));
                    if r.clicked() {
                        self.controls.material = material;
                    }
                    self.rects.push((key, r.rect));
                }
                ui.separator();
                let label = self.controls.sss_label();
                let r = toggle(ui, &mut self.controls.sss, label);
                self.rects.push(("sss", r.rect));
            });
            ui.horizontal(|ui| {
                // The slider takes the row but the reset button's room.
                ui.spacing_mut().slider_width = (ui.available_width() - 130.0).clamp(120.0, 600.0);
                let r = ui.add_enabled(
                    self.controls.sss,
                    egui::Slider::new(&mut self.controls.sss_strength, 0.0..=1.0).show_value(false),
                );
                self.rects.push(("strength", r.rect));
                let r = ui.button("Reset");
                if r.clicked() {
                    self.controls.reset_strength();
                }
                self.rects.push(("reset", r.rect));
            });
            ui.horizontal(|ui| {
                let label = self.controls.freeze_label();
                let r = toggle(ui, &mut self.controls.frozen, label);
                self.rects.push(("freeze", r.rect));
                let r = ui.button("Save picture");
                if r.clicked() {
                    self.snapshot = true;
                }
                self.rects.push(("save", r.rect));
                let r = ui.button("Front view");
                if r.clicked() {
                    *self.orbit = Orbit::default();
                }
                self.rects.push(("front", r.rect));
            });
            ui.horizontal(|ui| {
                let r = ui.add(egui::Button::selectable(
                    self.controls.style.is_some(),
                    self.controls.style_label(),
                ));
                if r.clicked() {
                    self.controls.next_style();
                }
                self.rects.push(("style", r.rect));
                let label = self.controls.engraving_label();
                let r = toggle(ui, &mut self.controls.engraving, label);
                self.rects.push(("border", r.rect));
                let label = self.controls.lamp_label();
                let r = toggle(ui, &mut self.controls.lamp, label);
                self.rects.push(("lamp", r.rect));
            });
            if let Some(t) = &self.toast {
                ui.label(t);
            }
            ui.add_space(6.0);
        });
        egui::CentralPanel::default()
            .frame(egui::Frame::NONE)
            .show(root, |ui| {
                let rect = ui.max_rect();
                self.gem_rect = Some(rect);
                self.rects.push(("gem", rect));
                if let Some(id) = self.layer {
                    ui.painter().image(
                        id,
                        rect,
                        egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0)),
                        egui::Color32::WHITE,
                    );
                }
                // Orbit and zoom only on the gem itself: a drag that starts on a control
                // belongs to the control, so the camera never moves while a slider is dragged.
                let response = ui.interact(rect, egui::Id::unique("gem view"), egui::Sense::drag());
                if response.dragged() {
                    let d = response.drag_delta();
                    self.orbit.drag(d.x, d.y);
                }
                if response.hovered() || response.dragged() {
                    let (zoom, scroll) = ui.input(|i| (i.zoom_delta(), i.smooth_scroll_delta.y));
                    if zoom != 1.0 {
                        self.orbit.zoom_by(zoom);
                    }
                    if scroll != 0.0 {
                        self.orbit.zoom_by((scroll / 400.0).exp());
                    }
                }
            });
    }
}
