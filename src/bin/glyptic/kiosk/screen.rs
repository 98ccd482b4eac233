//! The kiosk's screen, the part of the window that touches the GPU: the winit window, its
//! surface, the renderer sharing its device with egui, egui's state and renderer, and the
//! gem's own texture ([`GemLayer`]) that egui draws as the window's background. Made once
//! ([`Screen::open`], [`Screen::new`]), resized ([`Screen::resize`]), and each frame: the
//! controls' input ([`Screen::input`]), egui's texture changes, the surface's texture
//! ([`Screen::acquire`]), the controls drawn over it ([`Screen::draw_controls`]), a copy for a
//! screenshot ([`ScreenCopy`]) and the present ([`Screen::present`]). It knows nothing of the
//! visitor, the gem's parameters or the workers.

use std::sync::Arc;

use anyhow::{Context, Result, anyhow};
use winit::event_loop::ActiveEventLoop;
use winit::window::{Fullscreen, Window};

use glyptic::kiosk::KioskConfig;
use glyptic::render::Renderer;

use super::ui::style;

/// The gem's own texture, drawn by egui as the window's background.
pub(super) struct GemLayer {
    pub(super) texture: wgpu::Texture,
    pub(super) view: wgpu::TextureView,
    pub(super) id: egui::TextureId,
    pub(super) size: [u32; 2],
}

pub(super) struct Screen {
    pub(super) window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    pub(super) surface_config: wgpu::SurfaceConfiguration,
    /// The surface's format without sRGB encoding (the composite and egui encode).
    view_format: wgpu::TextureFormat,
    pub(super) renderer: Renderer,
    pub(super) egui_ctx: egui::Context,
    pub(super) egui_state: egui_winit::State,
    egui_renderer: egui_wgpu::Renderer,
    pub(super) layer: Option<GemLayer>,
}

impl Screen {
    /// The window, full screen and without a cursor where the configuration asks.
    pub(super) fn open(event_loop: &ActiveEventLoop, config: &KioskConfig) -> Result<Arc<Window>> {
        let mut attributes = Window::default_attributes()
            .with_title("glyptic")
            .with_inner_size(winit::dpi::LogicalSize::new(config.width, config.height));
        if config.fullscreen {
            // The monitor's own size at its origin, undecorated: full screen with no window
            // manager (a kiosk's X server alone); a window manager also gets the request.
            let monitor = event_loop
                .primary_monitor()
                .or_else(|| event_loop.available_monitors().next());
            if let Some(m) = monitor.as_ref().filter(|m| m.size().width > 0) {
                attributes = attributes
                    .with_position(m.position())
                    .with_inner_size(m.size());
            }
            attributes = attributes
                .with_decorations(false)
                .with_fullscreen(Some(Fullscreen::Borderless(monitor)));
        }
        let window = Arc::new(
            event_loop
                .create_window(attributes)
                .context("creating the window")?,
        );
        if config.hides_cursor() {
            window.set_cursor_visible(false);
        }
        window.focus_window();
        Ok(window)
    }

    /// The window's surface, the renderer on an adapter that presents to it, and egui.
    pub(super) fn new(event_loop: &ActiveEventLoop, window: Arc<Window>) -> Result<Self> {
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
        egui_ctx.set_zoom_factor(glyptic::kiosk::controls_zoom(
            size.width,
            window.scale_factor(),
        ));
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
        Ok(Self {
            window,
            surface,
            surface_config,
            view_format,
            renderer,
            egui_ctx,
            egui_state,
            egui_renderer,
            layer: None,
        })
    }

    /// The surface at the window's new size and the controls scaled to it; false for a
    /// minimised window (no size: the old surface is kept until it comes back).
    pub(super) fn resize(&mut self, width: u32, height: u32) -> bool {
        if width == 0 || height == 0 {
            return false;
        }
        self.surface_config.width = width;
        self.surface_config.height = height;
        self.surface
            .configure(self.renderer.device(), &self.surface_config);
        self.egui_ctx.set_zoom_factor(glyptic::kiosk::controls_zoom(
            width,
            self.window.scale_factor(),
        ));
        true
    }

    /// The window's input since the last frame, for egui.
    pub(super) fn input(&mut self) -> egui::RawInput {
        self.egui_state.take_egui_input(&self.window)
    }

    /// Hands egui's platform output (cursor, clipboard) to the window.
    pub(super) fn platform_output(&mut self, output: egui::PlatformOutput) {
        self.egui_state.handle_platform_output(&self.window, output);
    }

    /// egui's texture changes (the font atlas among them), kept even when no surface texture
    /// comes this frame: egui sends each change once.
    pub(super) fn update_textures(&mut self, delta: &egui::TexturesDelta) {
        for (id, deltas) in &delta.set {
            for delta in deltas {
                self.egui_renderer.update_texture(
                    self.renderer.device(),
                    self.renderer.queue(),
                    *id,
                    delta,
                );
            }
        }
    }

    /// Frees the textures egui no longer uses (after the frame that last drew them).
    pub(super) fn free_textures(&mut self, delta: &egui::TexturesDelta) {
        for id in &delta.free {
            self.egui_renderer.free_texture(id);
        }
    }

    /// The surface's next texture and a view of it without sRGB encoding; `Ok(None)` when it
    /// had to be reconfigured (try on the next frame), an error naming what the surface said.
    pub(super) fn acquire(
        &mut self,
    ) -> Result<Option<(wgpu::SurfaceTexture, wgpu::TextureView)>, String> {
        let frame = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(f)
            | wgpu::CurrentSurfaceTexture::Suboptimal(f) => f,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface
                    .configure(self.renderer.device(), &self.surface_config);
                return Ok(None);
            }
            other => return Err(format!("window surface: {other:?}")),
        };
        let view = frame.texture.create_view(&wgpu::TextureViewDescriptor {
            format: Some(self.view_format),
            ..Default::default()
        });
        Ok(Some((frame, view)))
    }

    /// Tessellates egui's shapes and draws the controls over the whole window (`view`), the
    /// gem's layer among them; returns egui's own command buffers, submitted before `encoder`.
    pub(super) fn draw_controls(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        view: &wgpu::TextureView,
        shapes: Vec<egui::epaint::ClippedShape>,
        pixels_per_point: f32,
    ) -> Vec<wgpu::CommandBuffer> {
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [self.surface_config.width, self.surface_config.height],
            pixels_per_point,
        };
        let jobs = self.egui_ctx.tessellate(shapes, pixels_per_point);
        let extra = self.egui_renderer.update_buffers(
            self.renderer.device(),
            self.renderer.queue(),
            encoder,
            &jobs,
            &screen,
        );
        let mut pass = encoder
            .begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("kiosk controls"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view,
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
        extra
    }

    /// Whether the surface's textures can be copied out (snapshots, screenshots).
    pub(super) fn can_copy(&self) -> bool {
        self.surface_config
            .usage
            .contains(wgpu::TextureUsages::COPY_SRC)
    }

    /// Reads back a copy of the frame encoded with [`ScreenCopy::encode`].
    pub(super) fn read_copy(&self, copy: ScreenCopy) -> Result<image::RgbaImage> {
        copy.read(self.renderer.device(), self.view_format)
    }

    /// Shows `frame`.
    pub(super) fn present(&self, frame: wgpu::SurfaceTexture) {
        self.window.pre_present_notify();
        self.renderer.queue().present(frame);
    }

    /// The gem's texture at `size` (a new one, registered with egui under the old one's id);
    /// false if it already has that size.
    pub(super) fn fit_layer(&mut self, size: [u32; 2]) -> bool {
        if self.layer.as_ref().is_some_and(|l| l.size == size) {
            return false;
        }
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
        true
    }
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
pub(super) struct ScreenCopy {
    buffer: wgpu::Buffer,
    width: u32,
    height: u32,
    padded_row: u32,
}

impl ScreenCopy {
    pub(super) fn encode(
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
