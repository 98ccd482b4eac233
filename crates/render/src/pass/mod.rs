//! The frame's passes, a module each: what it draws with (pipelines, layouts, uniform buffers:
//! made once with the device, the variants a frame asks for on first use), what it draws into
//! (its targets and their bind groups: made again only when the frame's size or crop changes),
//! its uniforms, and the step that encodes it. Units: millimetres on the stone, pixels on the
//! targets.
//!
//! The order of a frame ([`crate::frame`] runs them): [`noise`] (a mesh's second frame, once),
//! [`shadow`] (with a lamp), [`scene`] (or its compute form, [`scene_compute`]), [`sss`]
//! (with subsurface scattering), [`composite`], then [`chain`] (the GPU gallery styles and the edge antialiasing of one-sample frames).
//! [`maps`] holds the scene pass's second bind group (the engraving's maps, the shadow cube,
//! the baked noise), [`output`] the frame's image and its readback, [`common`] what they all
//! share.

pub(crate) mod chain;
pub(crate) mod common;
pub(crate) mod composite;
pub(crate) mod maps;
pub(crate) mod noise;
pub(crate) mod output;
pub(crate) mod scene;
pub(crate) mod scene_compute;
pub(crate) mod shadow;
pub(crate) mod sss;

/// Every pass's pipelines, made with the device.
pub(crate) struct Passes {
    pub scene: scene::ScenePass,
    pub shadow: shadow::ShadowPass,
    pub noise: noise::NoisePass,
    pub sss: sss::SssPass,
    pub composite: composite::CompositePass,
    pub chain: chain::ChainPasses,
}

impl Passes {
    /// `samples`: the scene's MSAA samples of an antialiased frame; `compute`: whether the
    /// passes with a compute form get one (the device has compute shaders and storage images);
    /// `gpu`: the device is not a CPU rasteriser (where the compute forms are the default).
    pub fn new(device: &wgpu::Device, samples: u32, compute: bool, gpu: bool) -> Self {
        let scene_compute = scene_compute::available(device, compute);
        Self {
            scene: scene::ScenePass::new(device, samples, scene_compute, scene_compute && gpu),
            shadow: shadow::ShadowPass::new(device),
            noise: noise::NoisePass::default(),
            sss: sss::SssPass::new(device, compute),
            composite: composite::CompositePass::new(device, compute),
            chain: chain::ChainPasses::new(device),
        }
    }
}
