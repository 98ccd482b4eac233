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
//! A frame is these passes, a module each under `pass/` (its pipelines, targets, uniforms and
//! encode step); `frame.rs` builds the frame in steps (targets, surface detail and mesh upload,
//! uniforms) and runs them; `renderer.rs` owns the device:
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
//!    drawn or blurred. On a GPU whose device has the primitive index the pass runs in its
//!    **compute form** ([`Renderer::set_compute_scene`]): the mesh drawn into a visibility
//!    image (the triangle each MSAA sample sees), then each pixel's triangles shaded once at
//!    its centre in a compute pass and weighted by their samples, the same images within the
//!    goldens' tolerance; four times faster on an H200 (BENCHMARKS.md), no faster on lavapipe,
//!    which keeps the fragment form;
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

mod bilinear;
mod camera;
mod frame;
pub mod inspect;
mod mesh;
mod params;
mod pass;
mod renderer;
pub mod shaders;
pub mod sss;
pub mod styles;
pub mod surface;
mod timing;

pub use self::camera::{FOV_Y_DEG, MAX_PITCH_DEG, ZOOM_RANGE};
pub use self::params::{Lamp, MAX_PIXELS, MarbleParams, Material, RenderError, RenderParams};
pub use self::renderer::Renderer;
pub use self::timing::{InitTimes, PassTimes};
pub use glyptic_core::scene::{
    KEY_LIGHT_AZIMUTH_DEG, KEY_LIGHT_ELEVATION_DEG, Mesh, Region, Vertex, key_light_dir,
};
