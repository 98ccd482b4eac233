//! `glyptic kiosk`: the museum window. A visitor's face becomes a cameo, live.
//!
//! Threads: the window's event loop (input, controls, rendering: `window`), a gem thread
//! that builds cameos from face meshes (the fitted face, or the ease back to the default face),
//! and with the `face` feature the capture and face threads of [`glyptic::stream`]. All hand
//! over through one-slot channels where the newest item wins: the window never waits for them.
//!
//! The gem is rendered into its own texture only when something it shows changes (a new gem,
//! a control, the orbit, the size); every frame then draws that texture and the controls
//! (egui) into the window's surface. On a CPU rasteriser a gem frame costs tenths of a second
//! while a controls frame costs milliseconds, so buttons answer at once.
//!
//! Modules: [`window`] (the surface, one frame), [`news`] (what the window takes from the
//! other threads), [`gem_thread`], [`face_thread`], [`ui`] (the controls), [`trace`] (status,
//! `--trace` lines). The kiosk's state without windows or cameras (configuration, controls,
//! orbit, the ease back) is the library's [`glyptic::kiosk`], tested alone.

#[cfg(feature = "face")]
mod face_thread;
mod gem_thread;
mod news;
mod portrait;
mod restarts;
mod run;
mod screen;
mod staff;
mod timeline;
mod trace;
mod ui;
mod visit;
mod window;

use std::path::Path;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow};
use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::window::WindowId;

use glyptic::kiosk::KioskConfig;

use run::Continue;
pub use run::KioskArgs;
use window::Running;

pub fn kiosk(args: &KioskArgs) -> Result<()> {
    if args.hash_pin {
        return hash_pin();
    }
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
    // A video named at start must be there: a missing file or a folder is a mistake in the
    // set-up, said now with exit 1 (a camera, which may come later, is waited for on screen).
    if let Some(video) = &config.video {
        match std::fs::metadata(video) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                anyhow::bail!("{}: video not found", video.display())
            }
            Err(e) => anyhow::bail!("{}: cannot read the video: {e}", video.display()),
            Ok(m) if !m.is_file() => {
                anyhow::bail!(
                    "{}: not a video file (a folder or a device)",
                    video.display()
                )
            }
            Ok(_) => {}
        }
    }
    // A screenshot that cannot be written is said now, not after the run.
    crate::outputs::check_outputs(config.video.as_deref(), args.screenshot.as_deref())?;
    if args.check {
        return check(&config, args);
    }
    std::fs::create_dir_all(&args.snapshots)
        .with_context(|| format!("{}: cannot create", args.snapshots.display()))?;
    check_output_folders(args)?;

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

/// The snapshots folder (or, not made yet, the folder it would be made in) and the
/// screenshot's folder each take a file (one is made and removed): said at the start, by the
/// run and by `--check` alike, not at the first Save.
fn check_output_folders(args: &KioskArgs) -> Result<()> {
    let snapshots = args
        .snapshots
        .ancestors()
        .map(|d| {
            if d.as_os_str().is_empty() {
                Path::new(".")
            } else {
                d
            }
        })
        .find(|d| d.exists())
        .unwrap_or(Path::new("."));
    crate::outputs::check_writable_folder(snapshots)
        .context("the snapshots folder (--snapshots)")?;
    if let Some(shot) = &args.screenshot {
        crate::outputs::check_writable_folder(crate::outputs::folder_of(shot))
            .context("the screenshot's folder (--screenshot)")?;
    }
    Ok(())
}

/// `--hash-pin`: a PIN from stdin (one line) to the configuration's line, salted from the
/// system's random source.
fn hash_pin() -> Result<()> {
    use std::io::Read as _;
    let mut line = String::new();
    std::io::stdin()
        .take(256)
        .read_to_string(&mut line)
        .context("reading the PIN from stdin")?;
    let mut salt = [0u8; 16];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut salt))
        .context("/dev/urandom: cannot read a salt")?;
    let pin = glyptic::pin::StaffPin::new(line.trim(), salt)
        .map_err(|e| anyhow!("the PIN on stdin: {e}"))?;
    say!("staff_pin = \"{pin}\"");
    Ok(())
}

/// `--check`: tries what the run will do and changes nothing: the models the kiosk loads
/// are there, the video (or photo) gives a frame, the snapshots folder (or, not made yet,
/// the folder it would be made in) and the screenshot's folder take a file (one made and
/// removed); then says what it would show and where.
fn check(config: &KioskConfig, args: &KioskArgs) -> Result<()> {
    let paths = glyptic::assets::ModelPaths::locate();
    // The build without the face pipeline needs only the shape model (the default face).
    let missing: Vec<String> = paths
        .files()
        .into_iter()
        .filter(|(path, _, required)| {
            *required
                && !path.is_file()
                && (cfg!(feature = "face") || path.starts_with(&paths.sfm_dir))
        })
        .map(|(path, what, _)| format!("{what} ({})", path.display()))
        .collect();
    if !missing.is_empty() {
        anyhow::bail!(
            "missing {}: `glyptic setup` fetches what may be fetched, `glyptic doctor` says more",
            missing.join(", ")
        );
    }
    check_output_folders(args)?;
    // The first frame, as the face thread will read it (a camera may come later; the build
    // without the face pipeline reads no video).
    #[cfg(feature = "face")]
    if let Some(video) = &config.video {
        let mut source = face_thread::open_source(config);
        match source.next_frame() {
            Ok(Some(_)) => {}
            Ok(None) => anyhow::bail!("{}: no frame could be read", video.display()),
            Err(e) => return Err(anyhow!(e)),
        }
    }
    let source = match &config.video {
        Some(v) => v.display().to_string(),
        None => format!(
            "camera {} (/dev/video{}; waited for if absent)",
            config.camera, config.camera
        ),
    };
    let screen = if config.fullscreen {
        "full screen".to_string()
    } else {
        format!("a {}x{} window", config.width, config.height)
    };
    say!(
        "kiosk: ready: {source}, {screen}, snapshots to {}, {}",
        args.snapshots.display(),
        args.config
            .as_ref()
            .map_or("default configuration".into(), |c| format!(
                "configuration {}",
                c.display()
            ))
    );
    Ok(())
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
        match Running::new(event_loop, &self.config, self.started, self.args.staff) {
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
        let response = r
            .screen
            .egui_state
            .on_window_event(&r.screen.window, &event);
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::ModifiersChanged(m) => r.modifiers = m.state(),
            WindowEvent::KeyboardInput { event, .. }
                if event.state.is_pressed() && !event.repeat =>
            {
                if let Some(key) = key_name(&event) {
                    r.key(key);
                    r.screen.window.request_redraw();
                }
            }
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
            r.screen.window.request_redraw();
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        if let Some(r) = self.running.as_mut() {
            // Poll the gem and face threads about 60 times a second; draw when needed, and
            // once the run's time is up: the frame quits, even if nothing else asked for one.
            let out_of_time = self
                .args
                .seconds
                .is_some_and(|s| r.timeline.started.elapsed().as_secs_f64() >= s);
            if r.poll() || out_of_time {
                r.screen.window.request_redraw();
            }
            // A worker that cannot be restarted: nothing more can be shown.
            if let Some(e) = r.fatal.take() {
                self.error = Some(e);
                event_loop.exit();
                return;
            }
            event_loop.set_control_flow(ControlFlow::WaitUntil(
                Instant::now() + Duration::from_millis(16),
            ));
        }
    }
}

/// A key's name for the staff's chords ([`glyptic::kiosk::staff_action`]): letters by their
/// place on the keyboard (so Ctrl+Shift+Q is found whatever the layout makes of it).
fn key_name(event: &winit::event::KeyEvent) -> Option<&'static str> {
    use winit::keyboard::{Key, KeyCode, NamedKey, PhysicalKey};
    match (&event.physical_key, &event.logical_key) {
        (PhysicalKey::Code(KeyCode::KeyQ), _) => Some("q"),
        (PhysicalKey::Code(KeyCode::KeyS), _) => Some("s"),
        (_, Key::Named(NamedKey::F12)) => Some("F12"),
        (_, Key::Named(NamedKey::Escape)) => Some("Escape"),
        // The PIN pad's keys, on the top row or the keypad.
        (_, Key::Named(NamedKey::Backspace)) => Some("BackSpace"),
        (_, Key::Named(NamedKey::Enter)) => Some("Return"),
        (PhysicalKey::Code(code), _) => {
            const DIGITS: [&str; 10] = ["0", "1", "2", "3", "4", "5", "6", "7", "8", "9"];
            let k = match code {
                KeyCode::Digit0 | KeyCode::Numpad0 => 0,
                KeyCode::Digit1 | KeyCode::Numpad1 => 1,
                KeyCode::Digit2 | KeyCode::Numpad2 => 2,
                KeyCode::Digit3 | KeyCode::Numpad3 => 3,
                KeyCode::Digit4 | KeyCode::Numpad4 => 4,
                KeyCode::Digit5 | KeyCode::Numpad5 => 5,
                KeyCode::Digit6 | KeyCode::Numpad6 => 6,
                KeyCode::Digit7 | KeyCode::Numpad7 => 7,
                KeyCode::Digit8 | KeyCode::Numpad8 => 8,
                KeyCode::Digit9 | KeyCode::Numpad9 => 9,
                _ => return None,
            };
            Some(DIGITS[k])
        }
        _ => None,
    }
}
