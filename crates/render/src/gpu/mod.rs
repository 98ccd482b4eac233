//! The GPU objects: pipelines and uniform buffers (built once per device), frame targets
//! (rebuilt only when the image size changes) and mesh buffers (grown only when a mesh does not
//! fit). Nothing here is created per frame.
//!
//! Targets of the scene pass, all the crop's size (the part of the frame the mesh covers, with
//! a margin: `camera::Crop`; multisampled when the device allows 4x MSAA
//! with resolve for these formats, then resolved into single-sample textures):
//! * `diffuse` (Rgba16Float): diffuse radiance, linear; alpha = coverage.
//! * `specular` (Rgba16Float): specular radiance, linear; alpha = coverage.
//! * `depth_mask` (Rg16Float): r = linear view depth mapped to [0, 1] over the frame's depth
//!   range, g = subsurface-scattering strength (0 on gold). Both are premultiplied by coverage
//!   (cleared to 0), so divide by `diffuse.a` for the value at a silhouette pixel.
//! * a Depth32Float z-buffer (never sampled: the linear depth above serves later passes, and
//!   works on GL, which cannot sample depth textures in these shaders).
//!
//! The subsurface-scattering pass (two full-screen draws with one pipeline) blurs the resolved
//! `diffuse` horizontally into `sss_temp` and that vertically into `sss_out` (both Rgba16Float,
//! coverage kept in alpha), reading `depth_mask` for depth and mask.
//!
//! The shadow pass (with a lamp) renders the mesh's distance from the lamp into the six
//! Depth32Float faces of a cube (1024 x 1024 each), sampled by the scene pass with a comparison
//! sampler; the engraving's height (R8) and tangent-space normal (Rgba8) maps, with mip chains,
//! are uploaded once per planar frame; the slowly varying noise (marble's cloudiness, gold's
//! ripple) is baked by a compute pass into an Rgba16Float 3D texture over the mesh
//! (`surface::NoiseVolume`) once, again only when a mesh leaves it. All live in `SurfaceMaps` (one-texel placeholders until a
//! frame needs them) and are bound as the scene pass's group 1.
//!
//! The composite pass reads the resolved (or blurred) `diffuse` and `specular` and writes the Rgba8Unorm
//! `output` (sRGB-encoded by the shader), which is copied into a mappable buffer with rows padded
//! to 256 bytes.

use bytemuck::{Pod, Zeroable};

mod maps;
mod pipelines;
mod targets;

pub(crate) use maps::*;
pub(crate) use pipelines::*;
pub(crate) use targets::*;

pub(crate) const DIFFUSE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub(crate) const SPECULAR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub(crate) const DEPTH_MASK_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg16Float;
pub(crate) const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
pub(crate) const SSS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub(crate) const OUTPUT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// The baked noise (four channels: `noise_baked` in `baked_noise.wgsl`).
pub(crate) const NOISE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
const OUTPUT_BYTES_PER_PIXEL: u32 = 4;

/// Uniforms of the scene pass; mirrors `Frame` in `scene.wgsl` (all 16-byte fields, no padding).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct FrameUniform {
    pub view_proj: [[f32; 4]; 4],
    pub eye: [f32; 4],
    pub light_dir: [f32; 4],
    pub cam_right: [f32; 4],
    pub cam_up: [f32; 4],
    pub cam_fwd: [f32; 4],
    pub marble: [f32; 4],
    pub depth: [f32; 4],
    pub material: [u32; 4],
    /// The engraving: planar frame (centre x, y, half x, half y; mm).
    pub planar: [f32; 4],
    /// The engraving: x on (1) or off (0), y groove depth (mm), z-w the band's outer and inner
    /// inset (mm, with a margin): where the parallax search runs.
    pub engraving: [f32; 4],
    /// The lamp: xyz position (mm), w intensity (0: no lamp).
    pub lamp: [f32; 4],
    /// The lamp's shadow: x far plane (mm), y depth bias (mm), z PCF radius (mm), w the lamp's
    /// distance from the gem's centre (mm; its light falls off from 1 there).
    pub shadow: [f32; 4],
    /// The baked noise: xyz centre of voxel (0, 0, 0) (mm), w 1 / voxel size (1/mm).
    pub volume: [f32; 4],
    /// xyz: 1 / the volume's voxel counts.
    pub volume_texel: [f32; 4],
    /// A layered stone's colours and polish ([`glyptic_core::stone::Layers::uniforms`]).
    pub layers: [[f32; 4]; 5],
}

/// Uniforms of the noise volume's bake; mirrors `Volume` in `noise_volume.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct NoiseVolumeUniform {
    /// xyz centre of voxel (0, 0, 0) (mm), w voxel size (mm).
    pub origin: [f32; 4],
    /// x: the marble's texture scale (1/mm).
    pub params: [f32; 4],
}

/// Uniforms of one shadow-cube face; mirrors `Face` in `shadow.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct ShadowFaceUniform {
    pub view_proj: [[f32; 4]; 4],
    /// xyz lamp position (mm), w 1 / far (1/mm).
    pub lamp: [f32; 4],
}

/// Uniforms of the composite pass; mirrors `Composite` in `composite.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct CompositeUniform {
    pub background: [f32; 4],
    pub params: [f32; 4],
    /// The scene images' place in the frame: x, y of their top left, their width, height (px).
    pub crop: [f32; 4],
    /// The frame's width, height (px); zw unused.
    pub size: [f32; 4],
}

/// Uniforms of one SSS direction; mirrors `Sss` in `sss.wgsl`: params, dir, then
/// [`crate::sss::MAX_TAPS`] taps (rgb weight, offset), as floats.
pub(crate) const SSS_UNIFORM_FLOATS: usize = 4 * (2 + crate::sss::MAX_TAPS);

/// The `Sss` uniform's contents for one direction.
pub(crate) fn sss_uniform(
    kernel: &crate::sss::Kernel,
    radius_mm: f32,
    px_per_mm_at_1mm: f32,
    near: f32,
    range: f32,
    dir: [f32; 2],
) -> Vec<f32> {
    let mut u = vec![0.0f32; SSS_UNIFORM_FLOATS];
    u[..4].copy_from_slice(&[radius_mm, px_per_mm_at_1mm, near, range]);
    let taps = kernel.taps.len().min(crate::sss::MAX_TAPS);
    u[4..8].copy_from_slice(&[dir[0], dir[1], taps as f32, kernel.range]);
    for (slot, t) in u[8..].chunks_exact_mut(4).zip(&kernel.taps) {
        slot.copy_from_slice(&[t.weight[0], t.weight[1], t.weight[2], t.offset]);
    }
    u
}

/// Chooses 4x MSAA if every scene target format supports it with resolve on this adapter, else 1.
///
/// Follows wgpu-core's rule: a device without `TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES` may use
/// only the WebGPU-guaranteed format features, unless the adapter is downlevel (GL), where the
/// adapter's own report applies.
pub(crate) fn choose_sample_count(adapter: &wgpu::Adapter, device_features: wgpu::Features) -> u32 {
    const SAMPLES: u32 = 4;
    let webgpu_formats = adapter
        .get_downlevel_capabilities()
        .flags
        .contains(wgpu::DownlevelFlags::WEBGPU_TEXTURE_FORMAT_SUPPORT);
    let features = |format: wgpu::TextureFormat| {
        if webgpu_formats
            && !device_features.contains(wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES)
        {
            format.guaranteed_format_features(device_features)
        } else {
            adapter.get_texture_format_features(format)
        }
    };
    let resolvable = [DIFFUSE_FORMAT, SPECULAR_FORMAT, DEPTH_MASK_FORMAT]
        .into_iter()
        .all(|f| {
            let flags = features(f).flags;
            flags.sample_count_supported(SAMPLES)
                && flags.contains(wgpu::TextureFormatFeatureFlags::MULTISAMPLE_RESOLVE)
        });
    if resolvable && features(DEPTH_FORMAT).flags.sample_count_supported(SAMPLES) {
        SAMPLES
    } else {
        1
    }
}
