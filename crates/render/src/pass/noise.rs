//! The noise volume's bake (a mesh's second frame, unless the volume baked before holds it): a
//! compute pass writes the noise that varies slowly and never changes between frames (the
//! marble's cloudiness, the gold's ripple) into an Rgba16Float 3D texture over the mesh
//! ([`NoiseVolume`], 0.35 mm voxels), which the scene pass then reads with one trilinear fetch
//! instead of five simplex noises. The volume itself is one of the scene's surface maps
//! ([`super::maps`]).

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use super::common::{self, uniform_entry};
use super::scene::TEXTURE_SCALE;
use crate::params::RenderError;
use crate::shaders;
use crate::surface::NoiseVolume;

/// The baked noise (four channels: `noise_baked` in `baked_noise.wgsl`).
pub(crate) const NOISE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Side of the bake's workgroups (`@workgroup_size(4, 4, 4)` in `noise_volume.wgsl`).
const BAKE_GROUP: u32 = 4;

/// Uniforms of the noise volume's bake; mirrors `Volume` in `noise_volume.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct NoiseVolumeUniform {
    /// xyz centre of voxel (0, 0, 0) (mm), w voxel size (mm).
    origin: [f32; 4],
    /// x: the marble's texture scale (1/mm).
    params: [f32; 4],
}

/// A noise volume's bake, waiting for the frame that records it: its bind group (uniform and
/// the storage view of the volume) and its workgroup counts.
pub(crate) struct NoiseBake {
    bind_group: wgpu::BindGroup,
    workgroups: [u32; 3],
}

/// The bake's compute pipeline and its layout (the volume's uniform and the storage texture
/// it writes), built on first use.
#[derive(Default)]
pub(crate) struct NoisePass {
    built: Option<(wgpu::ComputePipeline, wgpu::BindGroupLayout)>,
}

impl NoisePass {
    fn built(&mut self, device: &wgpu::Device) -> &(wgpu::ComputePipeline, wgpu::BindGroupLayout) {
        self.built.get_or_insert_with(|| {
            let module = common::module(device, "glyptic noise volume", shaders::NOISE_VOLUME);
            let layout = common::layout(
                device,
                "glyptic noise volume layout",
                &[
                    uniform_entry(0, wgpu::ShaderStages::COMPUTE),
                    common::storage_entry(1, NOISE_FORMAT, wgpu::TextureViewDimension::D3),
                ],
            );
            let pipeline =
                common::compute_pipeline(device, "glyptic noise volume", &module, &layout, &[]);
            (pipeline, layout)
        })
    }

    /// A new volume for `wanted`, and its bake for the next frame to record.
    pub fn bake(
        &mut self,
        device: &wgpu::Device,
        wanted: NoiseVolume,
    ) -> (wgpu::TextureView, NoiseBake) {
        let texture = volume_texture(device, wanted.dims, wgpu::TextureUsages::STORAGE_BINDING);
        let storage = texture.create_view(&Default::default());
        let uniform = NoiseVolumeUniform {
            origin: [
                wanted.origin[0],
                wanted.origin[1],
                wanted.origin[2],
                wanted.voxel_mm,
            ],
            params: [TEXTURE_SCALE, 0.0, 0.0, 0.0],
        };
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("glyptic noise volume uniform"),
            contents: bytemuck::bytes_of(&uniform),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let (_, layout) = self.built(device);
        let bind_group = common::bind_group(
            device,
            "glyptic noise volume bake",
            layout,
            &[
                buffer.as_entire_binding(),
                wgpu::BindingResource::TextureView(&storage),
            ],
        );
        let bake = NoiseBake {
            bind_group,
            workgroups: wanted.dims.map(|d| d.div_ceil(BAKE_GROUP)),
        };
        (storage, bake)
    }

    /// Before the other passes, once: the slowly varying noise baked into the volume.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        bake: &NoiseBake,
    ) -> Result<(), RenderError> {
        let Some((pipeline, _)) = &self.built else {
            return Err(RenderError::Gpu("no noise volume pipeline".into()));
        };
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("glyptic noise volume"),
            // Not timed: lavapipe stamps a compute pass before its work is done (0.01-0.07 ms
            // for ~45 ms of work); bench_render times the bake by the frame's wall time instead.
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &bake.bind_group, &[]);
        let [x, y, z] = bake.workgroups;
        pass.dispatch_workgroups(x, y, z);
        Ok(())
    }
}

/// The volume's texture, `dims` voxels, sampled by the scene and also used as `usage`.
pub(crate) fn volume_texture(
    device: &wgpu::Device,
    dims: [u32; 3],
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some("glyptic noise volume"),
        size: wgpu::Extent3d {
            width: dims[0],
            height: dims[1],
            depth_or_array_layers: dims[2],
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D3,
        format: NOISE_FORMAT,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | usage,
        view_formats: &[],
    })
}
