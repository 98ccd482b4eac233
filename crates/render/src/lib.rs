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
pub mod shaders;
pub mod sss;
pub mod styles;
pub mod surface;
mod timing;

use std::sync::{Arc, Mutex};

use self::gpu::{MeshBuffers, Pipelines, Targets};

pub use self::camera::{FOV_Y_DEG, MAX_PITCH_DEG, ZOOM_RANGE};
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

/// The stone the gem is cut from: one type for the renderer, the kiosk's TOML (`"marble"`,
/// `"agate"`, `"shell"`, `"jasperware"`) and the command line (`--material`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Material {
    /// White statuary marble with a few quiet grey veins, polished (a faint, sharp highlight).
    #[default]
    Marble,
    /// Multilayer agate: red ground, white relief, brown hair (Phong, exponent 500).
    Agate,
    /// Shell: a cream figure on a salmon-orange ground that glows through the thin parts.
    Shell,
    /// Wedgwood's jasperware: a white relief on a pale blue ground, matte.
    Jasperware,
}

impl Material {
    /// Every stone, in the order the kiosk offers them.
    pub const ALL: [Material; 4] = [
        Material::Marble,
        Material::Agate,
        Material::Shell,
        Material::Jasperware,
    ];

    /// The stone's name as the command line and the TOML spell it.
    pub fn name(self) -> &'static str {
        match self {
            Material::Marble => "marble",
            Material::Agate => "agate",
            Material::Shell => "shell",
            Material::Jasperware => "jasperware",
        }
    }

    /// A layered stone's description (None: marble, one stone throughout).
    pub fn layers(self) -> Option<&'static glyptic_core::stone::Layers> {
        match self {
            Material::Marble => None,
            Material::Agate => Some(&glyptic_core::stone::AGATE),
            Material::Shell => Some(&glyptic_core::stone::SHELL),
            Material::Jasperware => Some(&glyptic_core::stone::JASPERWARE),
        }
    }
}

/// Controls of the marble veins: quiet, directional grey lines whose contrast stays below the
/// relief's own shading (the carving, not the stone, should be what the eye reads).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MarbleParams {
    /// 0..1: how wide and soft a vein is.
    pub vein_softness: f32,
    /// 0..1: how faint the veins and the stone's cloudiness are (1 = a plain white stone; 0 =
    /// veins about 12 % darker than the white at their core).
    pub vein_lightness: f32,
}

impl Default for MarbleParams {
    fn default() -> Self {
        Self {
            vein_softness: 0.5,
            vein_lightness: 0.3,
        }
    }
}

/// What to draw and how.
#[derive(Clone, Debug)]
pub struct RenderParams {
    /// Output size in pixels (1 ..= the device's texture limit, at most [`MAX_PIXELS`] pixels).
    pub width: u32,
    pub height: u32,
    pub material: Material,
    /// Orbit angle about the vertical axis (degrees); 0 looks at the front, positive moves the
    /// camera towards +X (to the viewer's right).
    pub yaw_deg: f32,
    /// Orbit elevation (degrees; positive looks down from above), kept within +-89.
    pub pitch_deg: f32,
    /// How many times closer than the distance at which the whole cameo fits the frame, within
    /// [`ZOOM_RANGE`].
    pub zoom: f32,
    pub marble: MarbleParams,
    /// Backdrop colour at the image centre, display (sRGB-encoded) values 0..1; the composite
    /// adds a gentle top-light gradient and vignette around it.
    pub background: [f32; 3],
    /// No backdrop: the image's alpha is the gem's coverage (its colour unpremultiplied), for
    /// putting the gem onto something else. Takes no gallery styles.
    pub transparent: bool,
    /// Subsurface scattering in the stone (gold never scatters); `None` turns the pass off.
    pub sss: Option<crate::sss::SssParams>,
    /// Gallery styles applied after the composite, in order. Toon, painterly, fish-eye and
    /// chromatic aberration are GPU passes; dithering (serial) and whatever follows it run on
    /// the CPU after the readback (a window's frame takes GPU styles only).
    pub styles: Vec<crate::styles::Style>,
    /// Time for the styles that move (the chromatic aberration), seconds.
    pub style_time_s: f32,
    /// An engraved border on the ground (parallax occlusion and normal mapping); `None`: a
    /// plain polished ground.
    pub engraving: Option<surface::EngravingParams>,
    /// A point lamp casting shadows (a cube depth map); `None`: the key light alone.
    pub lamp: Option<Lamp>,
    /// Agate only: the hair cut from a third, brown layer on top of the white (`false`: the
    /// hair stays white like the face).
    pub hair_layer: bool,
    /// 4x MSAA in the scene pass where the device has it (`false`: one sample a pixel, for
    /// frames that must be quick rather than smooth-edged: on a CPU rasteriser MSAA is about
    /// two thirds of the scene pass; the kiosk drops it while the gem moves).
    pub antialias: bool,
}

/// A point lamp fixed to the gem (it stays put while the camera orbits, so its shadows turn
/// with the stone), casting shadows through a cube depth map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lamp {
    /// Position from the mesh's bounding-box centre, mm.
    pub offset_mm: [f32; 3],
    /// Brightness at the bounding-box centre, relative to the key light alone.
    pub intensity: f32,
    /// The key light's strength while the lamp is on (1: unchanged): dimmed so that the lamp
    /// leads and its shadows read.
    pub key_light: f32,
}

impl Default for Lamp {
    /// Upper left, raking at about 25 degrees over the ground: the relief's cast shadows fall
    /// to the lower right, the way a cameo is photographed.
    fn default() -> Self {
        Lamp {
            offset_mm: [-60.0, 55.0, 38.0],
            intensity: 0.85,
            key_light: 0.55,
        }
    }
}

impl Default for RenderParams {
    fn default() -> Self {
        Self {
            width: 640,
            height: 800,
            material: Material::Marble,
            yaw_deg: 0.0,
            pitch_deg: 0.0,
            zoom: 1.0,
            marble: MarbleParams::default(),
            background: [0.16, 0.18, 0.22],
            transparent: false,
            sss: Some(crate::sss::SssParams::default()),
            styles: Vec::new(),
            style_time_s: 0.0,
            engraving: None,
            lamp: None,
            hair_layer: true,
            antialias: true,
        }
    }
}

/// Largest image rendered, in pixels (16.8 Mpx, e.g. 4096 x 4096). The MSAA targets cost about
/// 100 bytes per pixel, so this caps one frame's memory near 1.7 GB.
pub const MAX_PIXELS: u64 = 4096 * 4096;

/// Why a frame (or the renderer) could not be made.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error("no usable graphics adapter: {0}")]
    NoAdapter(String),
    #[error("could not open the graphics device: {0}")]
    Device(String),
    #[error("the mesh is empty ({vertices} vertices, {indices} indices)")]
    EmptyMesh { vertices: usize, indices: usize },
    #[error("{count} indices do not make whole triangles")]
    IndicesNotTriangles { count: usize },
    #[error("index {position} is {value} but the mesh has {vertex_count} vertices")]
    IndexOutOfRange {
        position: usize,
        value: u32,
        vertex_count: usize,
    },
    #[error("vertex {index} has a position, normal or relief that is NaN or infinite")]
    NonFiniteVertex { index: usize },
    #[error("vertex {index} has region {value}, not one of 0 (ground) ..= 3 (gold)")]
    InvalidRegion { index: usize, value: u32 },
    #[error("the mesh needs a {bytes}-byte buffer; the device allows {max}")]
    MeshTooLarge { bytes: u64, max: u64 },
    #[error(
        "image size {width}x{height} is outside 1..={max_side} per side and {max_pixels} pixels"
    )]
    InvalidSize {
        width: u32,
        height: u32,
        max_side: u32,
        max_pixels: u64,
    },
    #[error("invalid render parameter: {0}")]
    InvalidParams(String),
    #[error("GPU error: {0}")]
    Gpu(String),
    #[error("could not read the image back: {0}")]
    Readback(String),
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

impl RenderParams {
    /// The checks that need no device: finite numbers, options that go together, each part's
    /// ranges. The renderer adds its device's limits; a command line asks this alone when it
    /// is read, so a contradiction is refused before any work (issue #40).
    pub fn check(&self) -> Result<(), RenderError> {
        let params = self;
        let (w, h) = (params.width, params.height);
        if w == 0 || h == 0 || u64::from(w) * u64::from(h) > MAX_PIXELS {
            return Err(RenderError::InvalidParams(format!(
                "image size {w}x{h}: a side of 0 or more than {MAX_PIXELS} pixels"
            )));
        }
        let m = &params.marble;
        let numbers = [
            ("yaw_deg", params.yaw_deg),
            ("pitch_deg", params.pitch_deg),
            ("zoom", params.zoom),
            ("marble.vein_softness", m.vein_softness),
            ("marble.vein_lightness", m.vein_lightness),
            ("background[0]", params.background[0]),
            ("background[1]", params.background[1]),
            ("background[2]", params.background[2]),
        ];
        if let Some((name, value)) = numbers.iter().find(|(_, v)| !v.is_finite()) {
            return Err(RenderError::InvalidParams(format!("{name} is {value}")));
        }
        if params.transparent && !params.styles.is_empty() {
            return Err(RenderError::InvalidParams(
                "a transparent backdrop takes no gallery styles (they paint an opaque picture)"
                    .into(),
            ));
        }
        if let Some(sss) = &params.sss {
            sss.validate()
                .map_err(|e| RenderError::InvalidParams(format!("subsurface scattering: {e}")))?;
        }
        if let Some(e) = &params.engraving {
            let [i0, i1] = e.inset_mm;
            let ok = i0.is_finite()
                && i1.is_finite()
                && 0.0 <= i0
                && i0 < i1
                && i1 <= 50.0
                && e.depth_mm.is_finite()
                && 0.0 < e.depth_mm
                && e.depth_mm <= 5.0
                && e.groove > 0.0
                && e.groove <= 1.0
                && (16..=2048).contains(&e.size);
            if !ok {
                return Err(RenderError::InvalidParams(format!(
                    "engraving: insets 0 <= outer < inner <= 50 mm, depth in (0, 5] mm, groove in (0, 1], size 16..=2048 texels; got {e:?}"
                )));
            }
        }
        if let Some(l) = &params.lamp {
            let ok = l.offset_mm.iter().all(|c| c.is_finite())
                && l.offset_mm.iter().map(|c| c * c).sum::<f32>() > 1.0
                && (0.0..=100.0).contains(&l.intensity)
                && (0.0..=1.0).contains(&l.key_light);
            if !ok {
                return Err(RenderError::InvalidParams(format!(
                    "lamp: a finite offset more than 1 mm from the centre, an intensity in 0..=100 and a key light in 0..=1; got {l:?}"
                )));
            }
        }
        Ok(())
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
