//! The scene pass's compute form, for GPUs whose graphics units are few (data-centre chips):
//! the mesh is drawn into a visibility image alone (which triangle each sample sees, one
//! 32-bit float a sample), then a compute pass shades each pixel's triangles at the pixel's
//! centre with the fragment form's own shading (`scene_shade.wgsl`) and writes the same three
//! images, premultiplied by coverage. On an NVIDIA H200 the fragment form's multisampled
//! targets (24 bytes a sample) and their resolve were two thirds of the pass, and fragment
//! shading ran far slower than the same work in a compute shader (BENCHMARKS.md, issue #42).
//!
//! Needs compute shaders, storage images of [`DEPTH_MASK_FORMAT`] and the other two, and the
//! primitive index in the fragment stage (`wgpu::Features::PRIMITIVE_INDEX`). Triangle indices
//! are exact in the float image up to [`MAX_TRIANGLES`]; a larger mesh, or one whose buffers
//! exceed the storage-binding limit, is drawn with the fragment form.

use super::common::{self, Built};
use super::scene::{Detail, SceneInput, SceneVariant};
use crate::params::RenderError;
use crate::shaders;
use crate::timing::{Stamps, TimedPass};
use glyptic_core::scene::Vertex;

/// The visibility image: the triangle seen, plus one (0: none), as a float. R32Float is
/// multisampled on every WebGPU device; R32Uint is not.
pub(crate) const VISIBLE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;
/// The depth-and-mask image of the compute form, a storage image (Rg16Float is not one on
/// every device).
pub(crate) const DEPTH_MASK_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Triangles whose index (plus one) a 32-bit float holds exactly.
pub(crate) const MAX_TRIANGLES: u64 = 1 << 24;

// `scene_shade.wgsl` reads the vertices as 12 words each.
const _: () = assert!(size_of::<Vertex>() == 48);

/// Whether the device can run the compute form (`compute`: compute shaders and storage images
/// of the SSS's format, which is the diffuse's and the specular's).
pub(crate) fn available(device: &wgpu::Device, compute: bool) -> bool {
    compute && device.features().contains(wgpu::Features::PRIMITIVE_INDEX)
}

/// Group 2 of the shading and the pipeline layout of groups 0-2, for one sample count.
struct ShadeLayout {
    group: wgpu::BindGroupLayout,
    pipeline: wgpu::PipelineLayout,
}

/// The compute form's pipelines: the visibility image's (by sample count) and the shading's
/// (by variant; the variant's engraving covers the band's triangles alone).
pub(crate) struct SceneCompute {
    vis_module: wgpu::ShaderModule,
    shade_module: wgpu::ShaderModule,
    vis_layout: wgpu::PipelineLayout,
    vis: Built<u32, wgpu::RenderPipeline>,
    /// For one sample a pixel, and for several.
    single: ShadeLayout,
    multi: ShadeLayout,
    shade: Built<SceneVariant, wgpu::ComputePipeline>,
}

impl SceneCompute {
    /// `scene_layout` (group 0, the frame's uniform) and `surface_layout` (group 1, the
    /// surface maps) must be visible to the compute stage.
    pub fn new(
        device: &wgpu::Device,
        scene_layout: &wgpu::BindGroupLayout,
        surface_layout: &wgpu::BindGroupLayout,
    ) -> Self {
        let vis_module = common::module(device, "glyptic scene visibility", shaders::SCENE_VIS);
        let shade_module = common::module(
            device,
            "glyptic scene shading",
            shaders::SCENE_SHADE.as_str(),
        );
        let vis_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("glyptic scene visibility layout"),
            bind_group_layouts: &[Some(scene_layout)],
            immediate_size: 0,
        });
        let shade_layout = |multisampled: bool| {
            let storage_buffer = |binding| wgpu::BindGroupLayoutEntry {
                binding,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only: true },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            };
            let storage_image = |binding, format| {
                common::storage_entry(binding, format, wgpu::TextureViewDimension::D2)
            };
            let visible = wgpu::BindGroupLayoutEntry {
                binding: if multisampled { 6 } else { 7 },
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled,
                },
                count: None,
            };
            let group = common::layout(
                device,
                "glyptic scene shading layout",
                &[
                    storage_buffer(0),
                    storage_buffer(1),
                    storage_buffer(2),
                    storage_image(3, super::scene::DIFFUSE_FORMAT),
                    storage_image(4, super::scene::SPECULAR_FORMAT),
                    storage_image(5, DEPTH_MASK_FORMAT),
                    visible,
                ],
            );
            let pipeline = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("glyptic scene shading pipeline layout"),
                bind_group_layouts: &[Some(scene_layout), Some(surface_layout), Some(&group)],
                immediate_size: 0,
            });
            ShadeLayout { group, pipeline }
        };
        Self {
            vis_module,
            shade_module,
            vis_layout,
            vis: Built::default(),
            single: shade_layout(false),
            multi: shade_layout(true),
            shade: Built::default(),
        }
    }

    /// Builds the pipelines of `variant` (its sample count's visibility pipeline and its
    /// shading) if there are none yet.
    pub fn ensure(&mut self, device: &wgpu::Device, variant: SceneVariant) {
        let (module, layout) = (&self.vis_module, &self.vis_layout);
        self.vis.ensure(variant.samples, || {
            vis_pipeline(device, module, layout, variant.samples)
        });
        let layout = if variant.samples > 1 {
            &self.multi.pipeline
        } else {
            &self.single.pipeline
        };
        let module = &self.shade_module;
        self.shade
            .ensure(variant, || shade_pipeline(device, module, layout, variant));
    }

    /// The variant the shading of `detail`'s frame runs with: the engraving compiled in where
    /// the frame has its band.
    pub fn variant(detail: &Detail) -> SceneVariant {
        if detail.band_mm.is_some() {
            detail.engraved
        } else {
            detail.plain
        }
    }

    /// Encodes the visibility image's draw and the shading; `uniform`: the scene pass's group
    /// 0 (its uniform).
    pub fn encode(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        input: &SceneInput<'_>,
        uniform: &wgpu::BindGroup,
        stamps: &mut Stamps<'_>,
    ) -> Result<(), RenderError> {
        let SceneInput {
            targets,
            buffers,
            surface,
            detail,
        } = *input;
        let missing = |what: &str| RenderError::Gpu(format!("no scene {what} for this frame"));
        let variant = Self::variant(detail);
        let vis = self
            .vis
            .get(variant.samples)
            .ok_or_else(|| missing("visibility pipeline"))?;
        let shade = self
            .shade
            .get(variant)
            .ok_or_else(|| missing("shading pipeline"))?;
        let visible = targets
            .visible
            .as_ref()
            .ok_or_else(|| missing("visibility image"))?;
        let d = detail.draw;
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("glyptic scene visibility"),
                color_attachments: &[common::overwrite(visible, wgpu::Color::TRANSPARENT)],
                depth_stencil_attachment: Some(common::cleared_depth(
                    &targets.depth,
                    wgpu::StoreOp::Discard,
                )),
                timestamp_writes: stamps.writes(TimedPass::Scene),
                ..Default::default()
            });
            pass.set_pipeline(vis);
            pass.set_bind_group(0, uniform, &[]);
            common::bind_mesh(&mut pass, buffers, &d, false);
            // One draw, band last: the primitive index is the triangle's place in the buffer.
            pass.draw_indexed(0..d.count, 0, 0..1);
        }
        let layout = if variant.samples > 1 {
            &self.multi.group
        } else {
            &self.single.group
        };
        fn buffer(b: &wgpu::Buffer, bytes: u64) -> wgpu::BindingResource<'_> {
            wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer: b,
                offset: 0,
                size: wgpu::BufferSize::new(bytes),
            })
        }
        let image = |binding, view| wgpu::BindGroupEntry {
            binding,
            resource: wgpu::BindingResource::TextureView(view),
        };
        let entry = |binding, resource| wgpu::BindGroupEntry { binding, resource };
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("glyptic scene shading group"),
            layout,
            entries: &[
                entry(0, buffer(&buffers.vertices, d.vertex_bytes)),
                entry(1, buffer(&buffers.tangents, d.tangent_bytes)),
                entry(2, buffer(&buffers.indices, d.index_bytes)),
                image(3, &targets.diffuse.view),
                image(4, &targets.specular.view),
                image(5, &targets.depth_mask.view),
                image(if variant.samples > 1 { 6 } else { 7 }, visible),
            ],
        });
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("glyptic scene shading"),
            timestamp_writes: stamps.compute_writes(TimedPass::SceneShade),
        });
        pass.set_pipeline(shade);
        pass.set_bind_group(0, uniform, &[]);
        pass.set_bind_group(1, surface, &[]);
        pass.set_bind_group(2, &group, &[]);
        let [w, h] = targets.size;
        pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
        Ok(())
    }
}

fn vis_pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    layout: &wgpu::PipelineLayout,
    samples: u32,
) -> wgpu::RenderPipeline {
    common::mesh_pipeline(
        device,
        &common::MeshPipeline {
            label: "glyptic scene visibility pipeline",
            layout,
            module,
            entries: ["vs_vis", "fs_vis"],
            constants: &[],
            buffers: &[Some(common::vertices(&common::POSITIONS))],
            depth: super::scene::DEPTH_FORMAT,
            samples,
            targets: &[common::color_target(VISIBLE_FORMAT)],
        },
    )
}

fn shade_pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    layout: &wgpu::PipelineLayout,
    variant: SceneVariant,
) -> wgpu::ComputePipeline {
    let constants = variant.constants();
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("glyptic scene shading pipeline"),
        layout: Some(layout),
        module,
        entry_point: Some(if variant.samples > 1 {
            "cs_shade_msaa"
        } else {
            "cs_shade"
        }),
        compilation_options: wgpu::PipelineCompilationOptions {
            constants: &constants,
            ..Default::default()
        },
        cache: None,
    })
}
