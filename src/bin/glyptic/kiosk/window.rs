//! The kiosk's window: the winit surface, the renderer sharing its device with egui, and one
//! frame: the controls every time, the gem into its own texture only when something it shows
//! changed (a new gem, a control, the orbit, the size).
//!
//! The window's state is owned parts: the [`Screen`] (window, surface, renderer, egui: made
//! once, resized, drawn into), the gem thread under supervision ([`GemWorker`]: its jobs and
//! restarts), the staff's ([`Staff`]), the times ([`Timeline`]); `news`, `visit` and `trace`
//! add the update steps (what the workers sent, the visitor, the trace line). A frame is [`Running::frame`]: update the controls,
//! render the gem if it changed, draw the controls over it, present.

use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Result, anyhow};
use winit::event_loop::ActiveEventLoop;

use glyptic::kiosk::{Controls, KioskConfig, MOVING, Orbit, Presence};
use glyptic::render::{Mesh, RenderParams};

use super::gem_thread::GemWorker;
use super::portrait::Portrait;
use super::run::{Continue, Fault, KioskArgs};
use super::screen::{Screen, ScreenCopy};
use super::staff::Staff;
use super::timeline::{Rate, Timeline};
use super::ui::UiFrame;

/// The first gem's resolution, of the window's (per side).
pub(super) const PREVIEW_SCALE: f32 = 0.5;

pub(super) struct Running {
    /// The window, its surface, the renderer and egui.
    pub(super) screen: Screen,
    /// The gem needs rendering again.
    pub(super) dirty: bool,
    /// When the visitor last turned or zoomed the gem; within [`MOVING`]`.hold_s` of it the
    /// gem is drawn as a moving frame.
    pub(super) moved_at: Option<Instant>,
    /// The gem on screen is a moving frame (the still one is still to come).
    pub(super) drawn_moving: bool,
    /// The coarse mesh moving frames draw, and the gem it was made from.
    pub(super) moving_gem: Option<(Arc<Mesh>, Mesh)>,
    pub(super) base: RenderParams,
    pub(super) controls: Controls,
    pub(super) orbit: Orbit,
    pub(super) render_scale: f32,
    /// The gem thread, restarted when it dies.
    pub(super) gems: GemWorker,
    /// Why the kiosk cannot go on (set by a worker that cannot be restarted): the window
    /// closes and the process exits 1.
    pub(super) fatal: Option<anyhow::Error>,
    #[cfg(feature = "face")]
    pub(super) live: super::face_thread::Live,
    /// Which face the gem carves: the visitor's, the default, or a step of the ease between.
    pub(super) portrait: Portrait,
    pub(super) gem: Option<Arc<Mesh>>,
    pub(super) status: String,
    pub(super) face_status: String,
    pub(super) snapshot_request: bool,
    pub(super) last_screen: Option<image::RgbaImage>,
    /// A message shown for a few seconds (saved snapshot, errors).
    pub(super) toast: Option<(String, Instant)>,
    /// Each control's rectangle in window pixels `[x, y, w, h]`, for scripted runs.
    pub(super) control_rects: Vec<(&'static str, [f32; 4])>,
    /// Times and counts for the status line and the trace.
    pub(super) timeline: Timeline,
    /// The configuration (the controls go back to it when a visitor leaves).
    pub(super) config: KioskConfig,
    /// Whether anyone is there, and since when the attract mode runs and its last step.
    pub(super) presence: Presence,
    pub(super) attract_since: Option<Instant>,
    pub(super) attract_frame_at: Option<Instant>,
    pub(super) staff: Staff,
    pub(super) modifiers: winit::keyboard::ModifiersState,
    /// The newest frame had a face; the gem shown is the visitor's; frames are coming.
    pub(super) face_now: bool,
    pub(super) visitor_gem: bool,
    pub(super) camera_ok: bool,
    pub(super) cursor_hidden: bool,
}

impl Running {
    pub(super) fn new(
        event_loop: &ActiveEventLoop,
        config: &KioskConfig,
        started: Instant,
        staff_open: bool,
    ) -> Result<Self> {
        let window = Screen::open(event_loop, config)?;
        let cursor_hidden = config.hides_cursor();
        let fault = Fault::from_env();
        let gem_fault = match fault {
            Some(Fault::Gem(f)) => Some(f),
            _ => None,
        };
        let gems = GemWorker::spawn(config.cameo(), gem_fault)?;
        #[cfg(feature = "face")]
        let live = super::face_thread::Live::start(
            config,
            match fault {
                Some(Fault::CapturePanic { at }) => Some(at),
                _ => None,
            },
        )?;

        let screen = Screen::new(event_loop, window)?;
        let base = RenderParams {
            background: [0.10, 0.11, 0.13],
            hair_layer: config.hair_layer,
            ..RenderParams::default()
        };
        screen.window.request_redraw();
        Ok(Running {
            screen,
            dirty: true,
            moved_at: None,
            drawn_moving: false,
            moving_gem: None,
            base,
            controls: Controls::from_config(config),
            orbit: Orbit::default(),
            render_scale: config.render_scale,
            gems,
            fatal: None,
            #[cfg(feature = "face")]
            live,
            portrait: Portrait::new(config),
            gem: None,
            status: "loading the face model".into(),
            config: config.clone(),
            presence: Presence::new(config, 0.0),
            attract_since: None,
            attract_frame_at: None,
            staff: Staff::new(staff_open, config.staff_pin().ok().flatten()),
            modifiers: Default::default(),
            face_now: false,
            visitor_gem: false,
            camera_ok: false,
            cursor_hidden,
            face_status: if cfg!(feature = "face") {
                "loading the face tracker".into()
            } else {
                "this build has no face tracking: the default face".into()
            },
            snapshot_request: false,
            last_screen: None,
            toast: None,
            control_rects: Vec::new(),

            timeline: Timeline {
                gem_count: 0,
                gem_ms: 0.0,
                render_rate: Rate::default(),
                face_rate: Rate::default(),
                render_ms: 0.0,
                frames: 0,
                started,
                first_frame_s: None,
                first_gem_s: None,
                gem_print: 0,
                first_gem_frame_s: None,
                full_gem_frame_s: None,
                face_updates: 0,
                face_latency_ms: 0.0,
                face_frame: 0,
                poll_max_ms: 0.0,
            },
        })
    }

    pub(super) fn resize(&mut self, width: u32, height: u32) {
        if self.screen.resize(width, height) {
            self.dirty = true;
            self.screen.window.request_redraw();
        }
    }

    /// Draws one frame: the controls, and the gem if it changed.
    pub(super) fn frame(&mut self, args: &KioskArgs) -> Result<Continue> {
        if self.staff.quit {
            return Ok(Continue::Quit);
        }
        if let Some(error) = self.screen.renderer.take_gpu_error() {
            self.note_problem(format!("GPU: {error}"));
        }
        let (output, gem_rect) = self.controls_step();
        let ppp = output.pixels_per_point;
        self.fit_layer(gem_rect, ppp);
        self.screen.update_textures(&output.textures_delta);
        let acquired = self.screen.acquire().unwrap_or_else(|problem| {
            self.note_problem(problem);
            None
        });
        let Some((frame, view)) = acquired else {
            // No texture this frame (the surface reconfigured, or a problem noted): try again.
            self.screen.free_textures(&output.textures_delta);
            self.screen.window.request_redraw();
            return Ok(Continue::Yes);
        };
        let device = self.screen.renderer.device().clone();
        let queue = self.screen.renderer.queue().clone();
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("kiosk frame"),
        });
        let t = Instant::now();
        let rendered_gem = self.draw_gem(&mut encoder, &queue);
        let extra = self
            .screen
            .draw_controls(&mut encoder, &view, output.shapes, ppp);
        let can_copy = self.screen.can_copy();
        let want_copy = self.snapshot_request || args.screenshot.is_some();
        if want_copy && !can_copy {
            self.note_problem("this window cannot be copied (no snapshot, no screenshot)");
            if self.snapshot_request {
                self.toast = Some((self.config.texts.not_saved.clone(), Instant::now()));
            }
            self.snapshot_request = false;
        }
        let capture = (can_copy && want_copy)
            .then(|| ScreenCopy::encode(&device, &mut encoder, &frame.texture));
        queue.submit(extra.into_iter().chain([encoder.finish()]));
        if rendered_gem {
            // Only a gem frame is timed, and only here do we wait for the GPU.
            let _ = device.poll(wgpu::PollType::wait_indefinitely());
            self.timeline.render_ms = t.elapsed().as_secs_f64() * 1e3;
            self.timeline.render_rate.tick();
            if self.controls.animates(self.timeline.render_ms) {
                self.dirty = true;
            }
        }
        if let Some(copy) = capture {
            match self.screen.read_copy(copy) {
                Ok(image) => {
                    if self.snapshot_request {
                        self.save_snapshot(&image, &args.snapshots);
                        self.snapshot_request = false;
                    }
                    self.last_screen = Some(image);
                }
                Err(e) => self.note_problem(format!("screenshot: {e}")),
            }
        }
        self.screen.present(frame);
        self.screen.free_textures(&output.textures_delta);
        self.count_frame(rendered_gem);
        if args.trace {
            say!("{}", self.trace_line(rendered_gem));
        }
        let out_of_frames = args.frames.is_some_and(|n| self.timeline.frames >= n);
        let out_of_time = args
            .seconds
            .is_some_and(|s| self.timeline.started.elapsed().as_secs_f64() >= s);
        if out_of_frames || out_of_time {
            return Ok(Continue::Quit);
        }
        if self.drawn_moving && !self.moving() {
            // The hand rests: the still frame, at full quality.
            self.dirty = true;
        }
        if self.dirty
            || self.drawn_moving
            || output
                .viewport_output
                .values()
                .any(|v| v.repaint_delay.is_zero())
        {
            self.screen.window.request_redraw();
        }
        Ok(Continue::Yes)
    }

    /// Runs the controls for this frame: what the visitor changed takes effect (the gem is
    /// marked for rendering; unfreezing shows the newest face again).
    fn controls_step(&mut self) -> (egui::FullOutput, Option<egui::Rect>) {
        let raw_input = self.screen.input();
        // A press, a touch, a scroll or a pinch is a visitor: taken before the controls run,
        // so that a tap that wakes the kiosk from attract mode also takes effect.
        let touched = raw_input.events.iter().any(|e| {
            matches!(
                e,
                egui::Event::PointerButton { pressed: true, .. }
                    | egui::Event::MouseWheel { .. }
                    | egui::Event::Zoom(_)
                    | egui::Event::Touch {
                        phase: egui::TouchPhase::Start,
                        ..
                    }
            )
        });
        if touched {
            self.visitor_seen();
        }
        let before = (self.controls.clone(), self.orbit);
        let prompt = self.config.texts.get(self.prompt()).to_owned();
        let caption = self.caption();
        let staff = self.staff.open.then(|| self.staff_view());
        let pad = self.staff.pad.as_ref().map(|p| super::ui::PadView {
            dots: p.digits.len(),
            said: p.said.clone(),
        });
        let mut ui = UiFrame {
            controls: &mut self.controls,
            labels: &self.config.labels,
            orbit: &mut self.orbit,
            layer: self.screen.layer.as_ref().map(|l| l.id),
            prompt,
            caption,
            staff,
            pad,
            pad_inputs: Vec::new(),
            toast: self
                .toast
                .as_ref()
                .filter(|(_, t)| t.elapsed() < Duration::from_secs(4))
                .map(|(m, _)| m.clone()),
            gem_rect: None,
            snapshot: false,
            close_staff: false,
            quit: false,
            corner_held: false,
            rects: Vec::new(),
        };
        let mut output = self
            .screen
            .egui_ctx
            .run_ui(raw_input, |ui_root| ui.draw(ui_root));
        let (gem_rect, snapshot) = (ui.gem_rect, ui.snapshot);
        let (close_staff, quit, corner_held) = (ui.close_staff, ui.quit, ui.corner_held);
        let pad_inputs = std::mem::take(&mut ui.pad_inputs);
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
        if close_staff {
            self.staff.open = false;
        }
        if quit {
            tracing::info!("kiosk: quit by the staff (the staff panel)");
            self.staff.quit = true;
        }
        let now = self.now_s();
        if self.config.staff_gesture && self.staff.gesture.update(now, corner_held) {
            self.ask_for_staff("corner");
        }
        for input in pad_inputs {
            self.pad_input(input);
        }
        self.pad_step();
        if self.cursor_hidden {
            // egui would show the cursor again over a button (its pointing hand).
            output.platform_output.cursor_icon = egui::CursorIcon::None;
        }
        if (self.controls.clone(), self.orbit) != before {
            self.dirty = true;
        }
        if self.orbit != before.1 {
            self.moved_at = Some(Instant::now());
        }
        if before.0.frozen && !self.controls.frozen {
            // Unfrozen: show the newest face again.
            if let Some(job) = self.portrait.newest() {
                self.gems.send(job);
            }
        }
        self.screen
            .platform_output(std::mem::take(&mut output.platform_output));
        (output, gem_rect)
    }

    /// Renders the gem into its layer if it changed; true if it did.
    fn draw_gem(&mut self, encoder: &mut wgpu::CommandEncoder, queue: &wgpu::Queue) -> bool {
        let mut rendered_gem = false;
        let moving = self.moving();
        if self.dirty
            && moving
            && let Some(gem) = &self.gem
            && self
                .moving_gem
                .as_ref()
                .is_none_or(|(from, _)| !Arc::ptr_eq(from, gem))
        {
            self.moving_gem = Some((Arc::clone(gem), gem.simplified(MOVING.max_triangles)));
        }
        if self.dirty
            && let (Some(gem), Some(layer)) = (&self.gem, &self.screen.layer)
        {
            let gem = match &self.moving_gem {
                Some((_, coarse)) if moving => coarse,
                _ => gem.as_ref(),
            };
            let still = RenderParams {
                width: layer.size[0],
                height: layer.size[1],
                style_time_s: self.timeline.started.elapsed().as_secs_f32(),
                ..self.controls.apply(&self.base, &self.orbit)
            };
            let params = if moving { MOVING.apply(still) } else { still };
            let drawn = if params.styles.iter().any(|s| s.is_serial()) {
                // Dithering runs on the CPU: read the gem back, dither it, and upload it to the
                // layer (only when the gem changes: it is still).
                self.screen.renderer.render(gem, &params).map(|image| {
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
                self.screen.renderer.render_to_view(
                    encoder,
                    gem,
                    &params,
                    &layer.view,
                    wgpu::TextureFormat::Rgba8Unorm,
                )
            };
            match drawn {
                Ok(()) => {
                    self.dirty = false;
                    self.drawn_moving = moving;
                    rendered_gem = true;
                }
                Err(e) => {
                    self.note_problem(format!("render: {e}"));
                    self.dirty = false;
                }
            }
        }
        rendered_gem
    }

    /// Counts a presented frame and notes the first ones (the trace's start-up figures).
    fn count_frame(&mut self, rendered_gem: bool) {
        self.timeline.frames += 1;
        if self.timeline.first_frame_s.is_none() {
            self.timeline.first_frame_s = Some(self.timeline.started.elapsed().as_secs_f64());
        }
        if rendered_gem {
            let now = Some(self.timeline.started.elapsed().as_secs_f64());
            if self.timeline.first_gem_frame_s.is_none() {
                self.timeline.first_gem_frame_s = now;
                // The preview: the full resolution follows on the next frame.
                self.dirty = true;
            } else if self.timeline.full_gem_frame_s.is_none() {
                self.timeline.full_gem_frame_s = now;
            }
        }
    }

    /// Whether the gem is moving: turned or zoomed within the last [`MOVING`]`.hold_s`.
    fn moving(&self) -> bool {
        self.attracting()
            || self
                .moved_at
                .is_some_and(|t| t.elapsed().as_secs_f32() < MOVING.hold_s)
    }

    /// Sizes the gem's texture to the area it is shown in (`ppp` pixels a point).
    fn fit_layer(&mut self, gem_rect: Option<egui::Rect>, ppp: f32) {
        // The gem's texture follows the area it is shown in. The very first gem is rendered
        // at half the resolution, then at full: on a CPU rasteriser that puts it on screen
        // about twice as soon after start-up.
        let Some(rect) = gem_rect else {
            return;
        };
        {
            let preview = self.gem.is_some() && self.timeline.first_gem_frame_s.is_none();
            let scale = ppp
                * self.render_scale
                * if preview { PREVIEW_SCALE } else { 1.0 }
                * if self.moving() { MOVING.scale } else { 1.0 };
            let size = [
                ((rect.width() * scale).round() as u32).clamp(16, 4096),
                ((rect.height() * scale).round() as u32).clamp(16, 4096),
            ];
            if self.screen.fit_layer(size) {
                self.dirty = true;
            }
        }
    }

    pub(super) fn save_snapshot(&mut self, image: &image::RgbaImage, dir: &Path) {
        let stamp = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_millis())
            .unwrap_or(0);
        let path = dir.join(format!("glyptic-{stamp}.png"));
        // The folder is bounded (count and bytes, as configured): past either, nothing is
        // written and the staff panel says why; nothing is deleted.
        let (count, bytes) = snapshots_in(dir);
        let (max, max_bytes) = (
            u64::from(self.config.snapshots_max),
            u64::from(self.config.snapshots_max_mb) << 20,
        );
        let full = (count >= max || bytes >= max_bytes).then(|| {
            format!(
                "snapshot not saved: {} holds {count} pictures, {} MB (snapshots_max {max}, \
                 snapshots_max_mb {})",
                dir.display(),
                bytes >> 20,
                max_bytes >> 20
            )
        });
        if let Some(why) = full {
            self.note_problem(why);
            self.toast = Some((self.config.texts.not_saved.clone(), Instant::now()));
            return;
        }
        // The visitor hears that it worked or not; the path and the reason go to the log.
        let message = match crate::outputs::write_png(image.clone(), &path) {
            Ok(()) => {
                tracing::info!("kiosk: saved {}", path.display());
                self.config.texts.saved.clone()
            }
            Err(e) => {
                self.note_problem(format!("snapshot not saved: {e:#}"));
                self.config.texts.not_saved.clone()
            }
        };
        self.toast = Some((message, Instant::now()));
    }

    /// On quitting: the screenshot and a summary line.
    pub(super) fn finish(&mut self, args: &KioskArgs) -> Result<()> {
        if let Some(path) = &args.screenshot {
            let image = self
                .last_screen
                .as_ref()
                .ok_or_else(|| anyhow!("no frame was captured for the screenshot"))?;
            crate::outputs::write_png(image.clone(), path)?;
        }
        tracing::info!(
            "kiosk: {} frames, {} gems, {} face updates; first frame after {:.2} s, first gem \
             shown after {}",
            self.timeline.frames,
            self.timeline.gem_count,
            self.timeline.face_updates,
            self.timeline.first_frame_s.unwrap_or(f64::NAN),
            self.timeline
                .first_gem_frame_s
                .map_or("-".into(), |s| format!("{s:.2} s")),
        );
        Ok(())
    }
}

/// The Save button's pictures in `dir` (`glyptic-*.png`): how many, and their bytes.
fn snapshots_in(dir: &Path) -> (u64, u64) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return (0, 0);
    };
    entries
        .flatten()
        .filter(|e| {
            let name = e.file_name();
            let name = name.to_string_lossy();
            name.starts_with("glyptic-") && name.ends_with(".png")
        })
        .filter_map(|e| e.metadata().ok().filter(|m| m.is_file()))
        .fold((0, 0), |(n, b), m| (n + 1, b + m.len()))
}
