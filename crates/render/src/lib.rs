//! Headless wgpu renderer for the engraved gem: procedural marble, layered agate and gold.
//!
//! Input is plain draw data, a [`Mesh`] of [`Vertex`]es in **millimetres**: the cameo lies in the
//! XY plane facing +Z, +Y up, origin at the centre of its base (oval about 44 x 56 mm, relief up
//! to about 8 mm). Each vertex says how far it stands above the ground layer (`relief`, mm) and
//! which [`Region`] it belongs to; the renderer knows nothing of faces or cameras beyond that.
//! Output is an sRGB [`image::RgbaImage`].
//!
//! Assumptions:
//! * Normals are per vertex, in the same space as the positions; their length does not matter
//!   and a zero normal falls back to the facet normal. Winding does not matter (no culling).
//! * Procedural textures use object coordinates (mm), so the stone runs continuously through
//!   every part of the mesh; the model never moves, the camera orbits it.
//! * There is no GPU: the device is lavapipe (Vulkan) or llvmpipe (GL), chosen by wgpu;
//!   `WGPU_BACKEND=vulkan|gl` and `WGPU_ADAPTER_NAME` override the choice.
//!
//! A frame is these passes, one function each in `frame.rs`, which also builds the frame in
//! steps (targets, surface detail and mesh upload, uniforms; the targets are described in
//! `gpu.rs`):
//! * **noise volume** (a mesh's second frame, unless the volume baked before holds it): a
//!   compute pass bakes the noise that varies slowly and never changes between frames (the
//!   marble's cloudiness, the gold's ripple) into a 3D texture over the mesh
//!   ([`surface::NoiseVolume`], 0.35 mm voxels), which the scene pass then reads with one
//!   trilinear fetch instead of five simplex noises. A mesh's first frame computes them (the
//!   bake costs about what it saves in one frame; a photo draws one). The marble's veins stay
//!   per fragment (their warp is too sensitive to be interpolated: BENCHMARKS.md);
//! 0. **shadow** (when [`RenderParams::lamp`] is set): the mesh's distance from the lamp into
//!    the six faces of a cube depth map, which the scene pass compares against (with a
//!    nine-tap percentage-closer filter);
//! 1. **scene**: lit diffuse (linear Rgba16Float), specular (Rgba16Float) and linear depth with a
//!    subsurface-scattering mask, 4x MSAA where the device allows and the frame asks for it
//!    ([`RenderParams::antialias`]), resolved. Its images (and the SSS pass's) cover only the
//!    crop of the frame that holds the mesh's projection: the backdrop round the gem is never
//!    drawn or blurred;
//! 2. **subsurface scattering** (when [`RenderParams::sss`] is set): the resolved diffuse alone is
//!    blurred horizontally, then vertically, with the kernel of [`crate::sss`] (the 2021 system
//!    found that blurring the highlights too made the stone look hazy);
//! 3. **composite**: diffuse (blurred or not) + specular over the backdrop, highlight shoulder,
//!    sRGB encoding. With SSS off the composite reads the scene pass's diffuse directly.
//! 4. **styles** ([`RenderParams::styles`]): the gallery styles on the GPU, in order; the serial
//!    ones (and whatever follows them) on the CPU after the readback;
//! 5. **edge antialiasing** (frames drawn with one sample a pixel): FXAA on the finished frame,
//!    so a frame without MSAA (the kiosk's while the gem turns) has no stair-stepped outline.
//!
//! With [`RenderParams::engraving`] the scene pass also engraves a border into the ground:
//! parallax occlusion mapping over a height map and normal mapping in tangent space, both from
//! [`surface`] (planar texture coordinates over the mesh's XY box; per-vertex tangents with a
//! guard against the degenerate ones on the relief's walls).
//!
//! Matrix maths uses `glam` (GPU-ready, column-major types, the wgpu ecosystem's convention).

mod camera;
mod frame;
mod gpu;
pub mod inspect;
mod mesh;
mod params;
pub mod shaders;
pub mod sss;
pub mod styles;
pub mod surface;
mod timing;

use std::sync::{Arc, Mutex};

use self::gpu::{MeshBuffers, Pipelines, Targets};

pub use self::camera::{FOV_Y_DEG, MAX_PITCH_DEG, ZOOM_RANGE};
pub use self::params::{Lamp, MAX_PIXELS, MarbleParams, Material, RenderError, RenderParams};
pub use self::timing::{InitTimes, PassTimes};
use self::timing::{PassTimer, TimedPass};
pub use glyptic_core::scene::{
    KEY_LIGHT_AZIMUTH_DEG, KEY_LIGHT_ELEVATION_DEG, Mesh, Region, Vertex, key_light_dir,
};

/// The engraving's per-mesh data (triangles reordered band last, tangent frames), kept while
/// the mesh, its planar frame and the band stay the same: the kiosk redraws one gem for every
/// step of an orbit.
struct EngravedMesh {
    key: (u64, surface::PlanarFrame, [f32; 2]),
    indices: Vec<u32>,
    band_start: usize,
    tangents: Vec<[f32; 4]>,
}

/// Ambient light (the 2021 system's 0.2).
const AMBIENT: f32 = 0.2;
/// How much of the key light that passes through a thin part (the mesh's `transmit`) leaves
/// it towards the viewer: light lost at entering and leaving, and to the sides; marble's
/// share, the layered stones' scaled by their scattering.
const TRANSLUCENCY: f32 = 0.6;
/// Intensity of the white key light (raking: the flat ground gets sin 20 degrees of it).
const LIGHT_INTENSITY: f32 = 1.25;
/// Texture-space units per mm for the marble's veins (a few across a 44 x 56 mm cameo; the
/// 2021 shader used position / 500 on a base about 370 units wide).
const TEXTURE_SCALE: f32 = 1.0 / 75.0;
/// The shadow cube's near plane, mm.
const LAMP_NEAR_MM: f32 = 0.1;
/// Shadow comparison: constant depth bias and the percentage-closer filter's radius, mm.
const SHADOW_BIAS_MM: f32 = 0.12;
const SHADOW_PCF_MM: f32 = 0.35;
/// Composite: exposure, vignette strength, vertical gradient strength, dither (8-bit steps).
const COMPOSITE_PARAMS: [f32; 4] = [1.0, 0.45, 0.35, 1.0];

/// How many of `styles`, from the first, have a GPU pass (those before the first serial one).
fn gpu_style_count(styles: &[crate::styles::Style]) -> usize {
    styles.iter().take_while(|s| !s.is_serial()).count()
}

/// Where a frame's composite goes.
#[derive(Clone, Copy)]
enum Output<'a> {
    /// The renderer's own image, read back.
    Image,
    /// A caller's texture view (a window's surface), in a format without sRGB encoding.
    View(&'a wgpu::TextureView, wgpu::TextureFormat),
}

/// Owns the device, the pipelines and the GPU memory reused from frame to frame.
pub struct Renderer {
    adapter: wgpu::Adapter,
    device: wgpu::Device,
    queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    limits: wgpu::Limits,
    pipelines: Pipelines,
    targets: Option<Targets>,
    /// Images and bind groups of a style chain, made on the first frame that has one.
    style_targets: Option<gpu::StyleTargets>,
    mesh_buffers: Option<MeshBuffers>,
    /// The engraving's maps and the shadow cube (placeholders until a frame needs them).
    surface: gpu::SurfaceMaps,
    engraved_mesh: Option<EngravedMesh>,
    /// Errors wgpu reports outside an error scope (e.g. device loss); kept instead of the
    /// default handler, which panics.
    uncaptured: Arc<Mutex<Option<String>>>,
    timer: Option<PassTimer>,
    last_pass_times: Option<PassTimes>,
    /// The passes the last frame timed, in query-slot order.
    timed_passes: Vec<TimedPass>,
    /// Whether the full-screen passes that have a compute form (the SSS blur; the composite
    /// into an image) run as compute passes, where the device has them.
    compute_passes: bool,
    /// Whether the slowly varying noise may be baked once a mesh is drawn a second time
    /// ([`Renderer::set_noise_baking`]).
    noise_baking: bool,
    init: InitTimes,
}

impl Renderer {
    /// Opens the default adapter without a window and builds the pipelines, with 4x MSAA where
    /// the device supports it.
    pub fn new_headless() -> Result<Self, RenderError> {
        Self::new_headless_with(true)
    }

    /// As [`Renderer::new_headless`], choosing whether to antialias. Without MSAA a frame costs
    /// about half as much on a CPU rasteriser (for previews), at the price of jagged silhouettes.
    ///
    /// The primary backends (Vulkan, Metal, DX12) are tried first and GL only where none of
    /// them has an adapter: an instance without GL's EGL start comes up 7-10 ms sooner
    /// (BENCHMARKS.md). `WGPU_BACKEND`, when set, decides alone.
    pub fn new_headless_with(msaa: bool) -> Result<Self, RenderError> {
        let chosen = std::env::var_os("WGPU_BACKEND").is_some();
        let mut instance_ms = 0.0;
        let mut last = None;
        for backends in [wgpu::Backends::PRIMARY, wgpu::Backends::all()] {
            let t = std::time::Instant::now();
            let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle();
            descriptor.backends = backends;
            let instance = wgpu::Instance::new(descriptor.with_env());
            instance_ms += t.elapsed().as_secs_f64() * 1e3;
            match Self::on_adapter(&instance, None, msaa) {
                Ok(mut renderer) => {
                    renderer.init.instance_ms = instance_ms;
                    return Ok(renderer);
                }
                Err(e @ RenderError::NoAdapter(_)) if !chosen => last = Some(e),
                Err(e) => return Err(e),
            }
        }
        Err(last.unwrap_or_else(|| RenderError::NoAdapter("no backend".into())))
    }

    /// A renderer on an adapter that can present to `surface` (made by `instance`), for a
    /// window: frames go to the surface with [`Renderer::render_to_view`].
    pub fn new_for_surface(
        instance: &wgpu::Instance,
        surface: &wgpu::Surface<'_>,
        msaa: bool,
    ) -> Result<Self, RenderError> {
        Self::on_adapter(instance, Some(surface), msaa)
    }

    fn on_adapter(
        instance: &wgpu::Instance,
        surface: Option<&wgpu::Surface<'_>>,
        msaa: bool,
    ) -> Result<Self, RenderError> {
        let ms = |t: std::time::Instant| t.elapsed().as_secs_f64() * 1e3;
        let mut init = InitTimes::default();
        let t = std::time::Instant::now();
        let adapter = pollster::block_on(wgpu::util::initialize_adapter_from_env_or_default(
            instance, surface,
        ))
        .map_err(|e| RenderError::NoAdapter(e.to_string()))?;
        init.adapter_ms = ms(t);
        let t = std::time::Instant::now();
        let info = adapter.get_info();
        // Ask for what the adapter has: bigger images and meshes than WebGPU's defaults.
        let limits = adapter.limits();
        // Timestamps time each pass for benchmarks, where the device offers them (lavapipe does).
        let features = adapter.features() & wgpu::Features::TIMESTAMP_QUERY;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("glyptic renderer"),
            required_features: features,
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| RenderError::Device(e.to_string()))?;

        let uncaptured = Arc::new(Mutex::new(None));
        let sink = Arc::clone(&uncaptured);
        device.on_uncaptured_error(Arc::new(move |error: wgpu::Error| {
            if let Ok(mut slot) = sink.lock() {
                slot.get_or_insert_with(|| error.to_string());
            }
        }));

        init.device_ms = ms(t);
        let t = std::time::Instant::now();
        let samples = if msaa {
            gpu::choose_sample_count(&adapter, device.features())
        } else {
            1
        };
        // The SSS blur as a compute pass where the adapter has compute shaders and storage
        // images of its format (not on downlevel GL without them).
        let compute = adapter
            .get_downlevel_capabilities()
            .flags
            .contains(wgpu::DownlevelFlags::COMPUTE_SHADERS)
            && adapter
                .get_texture_format_features(gpu::SSS_FORMAT)
                .allowed_usages
                .contains(wgpu::TextureUsages::STORAGE_BINDING);
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let pipelines = Pipelines::new(&device, samples, compute);
        init.pipelines_ms = ms(t);
        let t = std::time::Instant::now();
        let surface = gpu::SurfaceMaps::new(&device, &queue, &pipelines);
        if let Some(error) = pollster::block_on(scope.pop()) {
            return Err(RenderError::Gpu(format!("building the pipelines: {error}")));
        }
        let timer = features
            .contains(wgpu::Features::TIMESTAMP_QUERY)
            .then(|| PassTimer::new(&device, &queue));
        let compute_passes = compute && info.device_type != wgpu::DeviceType::Cpu;
        init.rest_ms = ms(t);
        Ok(Self {
            adapter,
            device,
            queue,
            info,
            limits,
            pipelines,
            targets: None,
            style_targets: None,
            mesh_buffers: None,
            surface,
            engraved_mesh: None,
            uncaptured,
            timer,
            last_pass_times: None,
            timed_passes: Vec::new(),
            // Compute on GPUs; a CPU rasteriser (lavapipe) runs both at the same speed
            // (BENCHMARKS.md) and stamps compute passes before their work is done, so its
            // pass times stay truthful with the fragment passes.
            compute_passes,
            noise_baking: true,
            init,
        })
    }

    /// Where this renderer's start went.
    pub fn init_times(&self) -> InitTimes {
        self.init
    }

    /// Whether the full-screen passes run as compute passes where they have that form (the
    /// SSS blur, the composite into an image: the default on a GPU that has compute) or as
    /// fragment passes (the default on a CPU rasteriser). Both give the same image; asking for
    /// compute on a device without it keeps the fragment passes. Returns what is now used.
    pub fn set_compute_passes(&mut self, on: bool) -> bool {
        self.compute_passes = on && self.pipelines.sss_compute.is_some();
        self.compute_passes
    }

    /// Whether the slowly varying noise is baked into a volume from a mesh's second frame
    /// (the default: an interactive view draws many) or always computed per fragment. The
    /// baked noise differs from the computed one by up to a grey level, so a renderer making
    /// one image after another for files (`photo`, `batch`) turns it off: each image is then
    /// what the same input gives alone, whatever came before it (issue #40: a batch's
    /// identical inputs after the first differed in 9,000 pixels).
    pub fn set_noise_baking(&mut self, on: bool) {
        self.noise_baking = on;
    }

    /// Whether the full-screen passes run as compute passes.
    pub fn compute_passes(&self) -> bool {
        self.compute_passes
    }

    /// Adapter, backend and driver, for logs and benchmark tables.
    pub fn adapter_info(&self) -> String {
        let i = &self.info;
        format!(
            "{} ({:?}, {:?}; driver {} {}; {}x MSAA)",
            i.name, i.backend, i.device_type, i.driver, i.driver_info, self.pipelines.samples
        )
    }

    /// GPU time per pass of the last frame rendered, if the device has timestamp queries.
    pub fn last_pass_times(&self) -> Option<&PassTimes> {
        self.last_pass_times.as_ref()
    }

    /// MSAA samples per pixel in the scene pass (4, or 1 where the device cannot resolve them).
    pub fn sample_count(&self) -> u32 {
        self.pipelines.samples
    }

    /// The device, to configure a window's surface and draw overlays with it.
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    pub fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    /// What a window's surface offers on this renderer's adapter (formats, usages).
    pub fn surface_capabilities(&self, surface: &wgpu::Surface<'_>) -> wgpu::SurfaceCapabilities {
        surface.get_capabilities(&self.adapter)
    }

    /// A GPU error reported outside any frame (e.g. device loss, a failed present), once.
    pub fn take_gpu_error(&self) -> Option<String> {
        self.uncaptured.lock().ok().and_then(|mut e| e.take())
    }

    /// Encodes a frame of `mesh` into `encoder`, drawn into `view` (a window's surface texture,
    /// `format` one without sRGB encoding: the composite encodes). The caller submits (after
    /// its overlays, if any) and presents. The same passes as [`Renderer::render`], without the
    /// readback or the pass timestamps (which would wait for the GPU).
    ///
    /// Errors on an invalid mesh or parameters before touching the GPU; GPU errors surface
    /// through [`Renderer::take_gpu_error`] once the frame is submitted.
    pub fn render_to_view(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        mesh: &Mesh,
        params: &RenderParams,
        view: &wgpu::TextureView,
        format: wgpu::TextureFormat,
    ) -> Result<(), RenderError> {
        self.check_params(params)?;
        if format.is_srgb() {
            return Err(RenderError::InvalidParams(format!(
                "output format {format:?} encodes sRGB itself: use its non-sRGB view"
            )));
        }
        let bounds = mesh::validate(mesh, self.limits.max_buffer_size)?;
        if let Some(error) = self.take_gpu_error() {
            return Err(RenderError::Gpu(error));
        }
        self.encode_frame(encoder, mesh, &bounds, params, Output::View(view, format))
    }

    /// Renders `mesh` as described by `params` and reads the image back.
    ///
    /// Errors on an invalid mesh or parameters before touching the GPU, and on any GPU error
    /// (after which the cached targets and buffers are rebuilt on the next call).
    pub fn render(
        &mut self,
        mesh: &Mesh,
        params: &RenderParams,
    ) -> Result<image::RgbaImage, RenderError> {
        self.check_params(params)?;
        let bounds = mesh::validate(mesh, self.limits.max_buffer_size)?;
        if let Some(error) = self.take_gpu_error() {
            return Err(RenderError::Gpu(error));
        }

        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let submitted = self.encode_and_submit(mesh, &bounds, params);
        let errors = [
            pollster::block_on(validation.pop()),
            pollster::block_on(oom.pop()),
        ];
        if let Some(error) = errors.into_iter().flatten().next() {
            // The cached objects may be the culprits (e.g. a failed allocation): start afresh.
            self.targets = None;
            self.style_targets = None;
            self.mesh_buffers = None;
            self.surface = gpu::SurfaceMaps::new(&self.device, &self.queue, &self.pipelines);
            return Err(RenderError::Gpu(error.to_string()));
        }
        submitted?;
        let image = self.read_back();
        if image.is_err() {
            // The readback buffer may be left in a mapping state: rebuild it next time.
            self.targets = None;
        }
        let mut times = self.read_pass_times();
        // The styles from the first one done on the CPU on, in order.
        let cpu_styles = &params.styles[gpu_style_count(&params.styles)..];
        let image = image.map(|img| {
            cpu_styles.iter().fold(img, |img, &style| {
                let t = std::time::Instant::now();
                let img = crate::styles::apply(&img, style, params.style_time_s);
                if let Some(times) = &mut times {
                    times
                        .styles_ms
                        .push((style, t.elapsed().as_secs_f64() * 1e3));
                }
                img
            })
        });
        self.last_pass_times = times;
        image
    }

    fn check_params(&self, params: &RenderParams) -> Result<(), RenderError> {
        let max_side = self.limits.max_texture_dimension_2d;
        let (w, h) = (params.width, params.height);
        let pixels = u64::from(w) * u64::from(h);
        let readback_bytes = gpu::padded_row_bytes(w) * u64::from(h);
        if w == 0
            || h == 0
            || w > max_side
            || h > max_side
            || pixels > MAX_PIXELS
            || readback_bytes > self.limits.max_buffer_size
        {
            return Err(RenderError::InvalidSize {
                width: w,
                height: h,
                max_side,
                max_pixels: MAX_PIXELS,
            });
        }
        params.check()
    }
}

impl Renderer {
    /// Uploads, encodes the passes and the copy into the readback buffer, and submits.
    fn encode_and_submit(
        &mut self,
        mesh: &Mesh,
        bounds: &mesh::Bounds,
        params: &RenderParams,
    ) -> Result<(), RenderError> {
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("glyptic frame"),
            });
        self.encode_frame(&mut encoder, mesh, bounds, params, Output::Image)?;
        let (w, h) = (params.width, params.height);
        let Some(targets) = &self.targets else {
            return Err(RenderError::Gpu("frame resources missing".into()));
        };
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &targets.output,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &targets.readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(targets.padded_row),
                    rows_per_image: Some(h),
                },
            },
            wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
        );
        if let Some(t) = &self.timer {
            // Resolve only what was written: unwritten queries are an error on some backends.
            let n = 2 * self.timed_passes.len() as u32;
            encoder.resolve_query_set(&t.queries, 0..n, &t.resolve, 0);
            encoder.copy_buffer_to_buffer(&t.resolve, 0, &t.read, 0, u64::from(n) * 8);
        }
        self.queue.submit([encoder.finish()]);
        Ok(())
    }

    /// Waits for the frame and copies the padded rows into an image.
    fn read_back(&self) -> Result<image::RgbaImage, RenderError> {
        let Some(targets) = &self.targets else {
            return Err(RenderError::Readback("no frame was rendered".into()));
        };
        let (tx, rx) = std::sync::mpsc::channel();
        let slice = targets.readback.slice(..);
        slice.map_async(wgpu::MapMode::Read, move |result| {
            // The receiver outlives the poll below; a send error cannot matter.
            let _ = tx.send(result);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| RenderError::Readback(e.to_string()))?;
        match rx.try_recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(RenderError::Readback(e.to_string())),
            Err(e) => {
                return Err(RenderError::Readback(format!(
                    "mapping did not finish: {e}"
                )));
            }
        }
        let (w, h) = (targets.width, targets.height);
        let row_bytes = w as usize * 4;
        let mut pixels = Vec::with_capacity(row_bytes * h as usize);
        let copied = (|| {
            let view = slice
                .get_mapped_range()
                .map_err(|e| RenderError::Readback(e.to_string()))?;
            for row in view
                .chunks(targets.padded_row.max(1) as usize)
                .take(h as usize)
            {
                let pixels_of_row = row
                    .get(..row_bytes)
                    .ok_or_else(|| RenderError::Readback("readback row too short".into()))?;
                pixels.extend_from_slice(pixels_of_row);
            }
            Ok(())
        })();
        // Unmapped on every path: a buffer left mapped would fail the next frame's copy.
        targets.readback.unmap();
        copied?;
        image::RgbaImage::from_raw(w, h, pixels)
            .ok_or_else(|| RenderError::Readback("readback smaller than the image".into()))
    }
}

/// sRGB transfer function, decoding (display value -> linear light).
fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The renderer is created on one thread and used on another (the CLI opens the device while the
/// face pipeline runs), so it must stay `Send`.
const _: fn() = || {
    fn send<T: Send>() {}
    send::<Renderer>();
};
