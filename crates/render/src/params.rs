//! What a frame is asked to be and how it can fail: the stone ([`Material`]), the render's
//! parameters ([`RenderParams`], their device-free [`RenderParams::check`]) and the errors.
//! The renderer's passes and the command line share these; they know no GPU. Sizes in pixels,
//! angles in degrees, lengths in millimetres.

use crate::surface;

/// Gallery styles in one chain on the GPU, at most (a frame's timestamp slots and style
/// uniforms are made for this many).
pub(crate) const MAX_GPU_STYLES: usize = 8;

pub use glyptic_core::stone::Material;

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
