//! The shadow pass (with a lamp): the mesh's distance from the lamp into the six Depth32Float
//! faces of a cube (1024 x 1024 each), one draw per face, each with its own uniform; the
//! scene pass compares against it (a nine-tap percentage-closer filter). The cube itself lives
//! with the scene's other surface maps ([`super::maps`]).

use bytemuck::{Pod, Zeroable};

use super::common::{self, Draw, LampAt, uniform_entry};
use crate::camera;
use crate::mesh::MeshBuffers;
use crate::shaders;
use crate::timing::{Stamps, TimedPass};

/// Side of each face of the lamp's shadow cube, texels.
pub(crate) const SHADOW_SIZE: u32 = 1024;
pub(crate) const SHADOW_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// The shadow cube's near plane, mm.
const LAMP_NEAR_MM: f32 = 0.1;

/// Uniforms of one shadow-cube face; mirrors `Face` in `shadow.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct ShadowFaceUniform {
    view_proj: [[f32; 4]; 4],
    /// xyz lamp position (mm), w 1 / far (1/mm).
    lamp: [f32; 4],
}

/// Depth only, one draw per cube face, each with its own uniform.
pub(crate) struct ShadowPass {
    pipeline: wgpu::RenderPipeline,
    uniforms: Vec<wgpu::Buffer>,
    bind_groups: Vec<wgpu::BindGroup>,
}

impl ShadowPass {
    pub fn new(device: &wgpu::Device) -> Self {
        let module = common::module(device, "glyptic shadow", shaders::SHADOW);
        let layout = common::layout(
            device,
            "glyptic shadow layout",
            &[uniform_entry(0, wgpu::ShaderStages::VERTEX_FRAGMENT)],
        );
        let uniforms: Vec<wgpu::Buffer> = (0..6)
            .map(|_| {
                common::uniform_buffer(
                    device,
                    "glyptic shadow face uniform",
                    size_of::<ShadowFaceUniform>() as u64,
                )
            })
            .collect();
        let bind_groups = uniforms
            .iter()
            .map(|buffer| {
                common::bind_group(
                    device,
                    "glyptic shadow face",
                    &layout,
                    &[buffer.as_entire_binding()],
                )
            })
            .collect();
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("glyptic shadow pipeline layout"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = common::mesh_pipeline(
            device,
            &common::MeshPipeline {
                label: "glyptic shadow pipeline",
                layout: &pipeline_layout,
                module: &module,
                entries: ["vs_main", "fs_main"],
                constants: &[],
                buffers: &[Some(common::vertices(&common::POSITIONS))],
                depth: SHADOW_FORMAT,
                samples: 1,
                targets: &[],
            },
        );
        Self {
            pipeline,
            uniforms,
            bind_groups,
        }
    }

    /// Each face's view from the lamp.
    pub fn write_uniforms(&self, queue: &wgpu::Queue, lamp: &LampAt) {
        let (position, far) = (lamp.position, lamp.far);
        for (face, buffer) in self.uniforms.iter().enumerate() {
            let u = ShadowFaceUniform {
                view_proj: camera::cube_face_view_proj(position, face, LAMP_NEAR_MM, far)
                    .to_cols_array_2d(),
                lamp: [position.x, position.y, position.z, 1.0 / far],
            };
            queue.write_buffer(buffer, 0, bytemuck::bytes_of(&u));
        }
    }

    /// The mesh's distance from the lamp into each of `faces` (+x, -x, +y, -y, +z, -z).
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        faces: &[wgpu::TextureView],
        buffers: &MeshBuffers,
        draw: Draw,
        stamps: &mut Stamps<'_>,
    ) {
        for (view, group) in faces.iter().zip(&self.bind_groups) {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("glyptic shadow pass"),
                color_attachments: &[],
                depth_stencil_attachment: Some(common::cleared_depth(view, wgpu::StoreOp::Store)),
                timestamp_writes: stamps.writes(TimedPass::Shadow),
                ..Default::default()
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, group, &[]);
            common::bind_mesh(&mut pass, buffers, &draw, false);
            pass.draw_indexed(0..draw.count, 0, 0..1);
        }
    }
}

/// A cube of six depth faces `size` texels a side, and its cube view.
pub(crate) fn cube(device: &wgpu::Device, size: u32) -> (wgpu::Texture, wgpu::TextureView) {
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("glyptic shadow cube"),
        size: wgpu::Extent3d {
            width: size,
            height: size,
            depth_or_array_layers: 6,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: SHADOW_FORMAT,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::RENDER_ATTACHMENT,
        view_formats: &[],
    });
    let view = texture.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::Cube),
        ..Default::default()
    });
    (texture, view)
}
