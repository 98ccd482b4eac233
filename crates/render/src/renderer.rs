//! [`Renderer`]: the device, its adapter and queue, and the frames drawn with them, into an
//! image read back ([`Renderer::render`]) or a window's surface ([`Renderer::render_to_view`]).
//! The passes and what frames reuse are [`crate::frame`]'s; this owns the device's start, the
//! checks before a frame, the GPU errors and the readback.

use std::sync::{Arc, Mutex};

use crate::frame::{Frames, Gpu, Output};
use crate::mesh;
use crate::params::{MAX_PIXELS, RenderError, RenderParams};
use crate::pass::Passes;
use crate::pass::chain::gpu_style_count;
use crate::pass::output::padded_row_bytes;
use crate::pass::{scene, sss};
use crate::timing::{InitTimes, PassTimer, PassTimes};
use glyptic_core::scene::Mesh;

/// Owns the device, the pipelines and the GPU memory reused from frame to frame.
pub struct Renderer {
    adapter: wgpu::Adapter,
    device: wgpu::Device,
    queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    limits: wgpu::Limits,
    /// The passes and what frames reuse.
    frames: Frames,
    /// Errors wgpu reports outside an error scope (e.g. device loss); kept instead of the
    /// default handler, which panics.
    uncaptured: Arc<Mutex<Option<String>>>,
    timer: Option<PassTimer>,
    last_pass_times: Option<PassTimes>,
    /// Whether the full-screen passes that have a compute form (the SSS blur; the composite
    /// into an image) run as compute passes, where the device has them.
    compute_passes: bool,
    /// Whether the scene pass runs in its compute form ([`Renderer::set_compute_scene`]).
    compute_scene: bool,
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
        // Timestamps time each pass for benchmarks, where the device offers them (lavapipe
        // does); the primitive index lets the scene pass run in its compute form.
        let features = adapter.features()
            & (wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::PRIMITIVE_INDEX);
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
            scene::choose_sample_count(&adapter, device.features())
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
                .get_texture_format_features(sss::SSS_FORMAT)
                .allowed_usages
                .contains(wgpu::TextureUsages::STORAGE_BINDING);
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let on_gpu = info.device_type != wgpu::DeviceType::Cpu;
        let passes = Passes::new(&device, samples, compute, on_gpu);
        init.pipelines_ms = ms(t);
        let t = std::time::Instant::now();
        let frames = Frames::new(&device, &queue, passes);
        if let Some(error) = pollster::block_on(scope.pop()) {
            return Err(RenderError::Gpu(format!("building the pipelines: {error}")));
        }
        let timer = features
            .contains(wgpu::Features::TIMESTAMP_QUERY)
            .then(|| PassTimer::new(&device, &queue));
        let compute_passes = compute && on_gpu;
        let compute_scene = compute_passes && frames.passes.scene.compute.is_some();
        init.rest_ms = ms(t);
        Ok(Self {
            adapter,
            device,
            queue,
            info,
            limits,
            frames,
            uncaptured,
            timer,
            last_pass_times: None,
            // Compute on GPUs; a CPU rasteriser (lavapipe) runs both at the same speed
            // (BENCHMARKS.md) and stamps compute passes before their work is done, so its
            // pass times stay truthful with the fragment passes.
            compute_passes,
            compute_scene,
            noise_baking: true,
            init,
        })
    }

    /// Draws one small triangle with `params`' stone, light, passes and styles at 16 x 16 and
    /// throws the frame away, so that whatever the real frame will need is built first: the
    /// pipelines, and the shaders a CPU rasteriser (lavapipe) compiles only at their first
    /// draw (about 150 ms there). A caller that has a thread waiting anyway (the photo's
    /// renderer while the face is fitted) takes that off the real frame. The engraving is
    /// left out: its maps follow the gem's outline. The time goes to [`InitTimes`].
    pub fn warm_up(&mut self, params: &RenderParams) -> Result<(), RenderError> {
        use glyptic_core::scene::{Region, Vertex};
        let t = std::time::Instant::now();
        let corner =
            |x: f32, y: f32| Vertex::open([x, y, 1.0], [0.0, 0.0, 1.0], 1.0, Region::Relief);
        let mesh = Mesh {
            vertices: vec![corner(-10.0, -10.0), corner(10.0, -10.0), corner(0.0, 10.0)],
            indices: vec![0, 1, 2],
        };
        let tiny = RenderParams {
            width: 16,
            height: 16,
            engraving: None,
            ..params.clone()
        };
        let drawn = self.render(&mesh, &tiny).map(|_| ());
        self.init.warm_up_ms += t.elapsed().as_secs_f64() * 1e3;
        drawn
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
        self.compute_passes = on && self.frames.passes.sss.has_compute();
        self.compute_passes
    }

    /// Whether the scene pass runs in its compute form (a visibility image drawn, its pixels
    /// shaded in a compute pass: the default on a GPU whose device has the primitive index) or
    /// as a fragment pass (the default on a CPU rasteriser). The images agree within the
    /// goldens' tolerance (the screen derivatives are exact in the compute form, a quad's
    /// differences in the fragment one). Returns what is now used.
    pub fn set_compute_scene(&mut self, on: bool) -> bool {
        self.compute_scene = on && self.frames.passes.scene.compute.is_some();
        self.compute_scene
    }

    /// Whether the scene pass runs in its compute form.
    pub fn compute_scene(&self) -> bool {
        self.compute_scene
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
            i.name,
            i.backend,
            i.device_type,
            i.driver,
            i.driver_info,
            self.frames.passes.scene.samples
        )
    }

    /// GPU time per pass of the last frame rendered, if the device has timestamp queries.
    pub fn last_pass_times(&self) -> Option<&PassTimes> {
        self.last_pass_times.as_ref()
    }

    /// MSAA samples per pixel in the scene pass (4, or 1 where the device cannot resolve them).
    pub fn sample_count(&self) -> u32 {
        self.frames.passes.scene.samples
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
        let (gpu, frames) = self.frame_gpu(false);
        frames.encode(
            &gpu,
            encoder,
            mesh,
            &bounds,
            params,
            Output::View(view, format),
        )
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
            self.frames.reset(&self.device, &self.queue);
            return Err(RenderError::Gpu(error.to_string()));
        }
        submitted?;
        let image = match self.frames.output() {
            Some(output) => output.read(&self.device),
            None => Err(RenderError::Readback("no frame was rendered".into())),
        };
        if image.is_err() {
            // The readback buffer may be left in a mapping state: rebuild it next time.
            self.frames.drop_targets();
        }
        let mut times = self
            .timer
            .as_ref()
            .and_then(|t| t.read(&self.device, &self.frames.timed));
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
        let readback_bytes = padded_row_bytes(w) * u64::from(h);
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
        let (gpu, frames) = self.frame_gpu(true);
        frames.encode(&gpu, &mut encoder, mesh, bounds, params, Output::Image)?;
        let Some(output) = self.frames.output() else {
            return Err(RenderError::Gpu("frame resources missing".into()));
        };
        output.copy_out(&mut encoder);
        if let Some(t) = &self.timer {
            t.resolve(&mut encoder, self.frames.timed.len());
        }
        self.queue.submit([encoder.finish()]);
        Ok(())
    }

    /// What a frame may use of the device, and the frames to draw it with; `image`: a frame
    /// read back (timed where the device has timestamps).
    fn frame_gpu(&mut self, image: bool) -> (Gpu<'_>, &mut Frames) {
        let gpu = Gpu {
            device: &self.device,
            queue: &self.queue,
            max_buffer_size: self.limits.max_buffer_size,
            timer: self.timer.as_ref().filter(|_| image),
            compute_passes: self.compute_passes,
            compute_scene: self.compute_scene,
            max_storage_binding: self.limits.max_storage_buffer_binding_size,
            noise_baking: self.noise_baking,
        };
        (gpu, &mut self.frames)
    }
}

/// The renderer is created on one thread and used on another (the CLI opens the device while the
/// face pipeline runs), so it must stay `Send`.
const _: fn() = || {
    fn send<T: Send>() {}
    send::<Renderer>();
};
