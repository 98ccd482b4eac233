//! What the passes share: the descriptors they all write alike, the pipelines they build on
//! first use, and what a frame's steps decided about the draw (the mesh's ranges, the lamp).

use crate::mesh::{Bounds, MeshBuffers};
use crate::params::Lamp;

/// Byte and index ranges of the uploaded mesh.
#[derive(Clone, Copy)]
pub(crate) struct Draw {
    pub vertex_bytes: u64,
    pub index_bytes: u64,
    pub tangent_bytes: u64,
    pub count: u32,
    /// The engraved band's triangles are drawn last, from this index.
    pub band_start: u32,
}

/// Sets the mesh's vertices (slot 0), its tangent frames (slot 1, with `tangents`) and its
/// indices for a draw of `draw`'s ranges.
pub(crate) fn bind_mesh(
    pass: &mut wgpu::RenderPass<'_>,
    buffers: &MeshBuffers,
    draw: &Draw,
    tangents: bool,
) {
    pass.set_vertex_buffer(0, buffers.vertices.slice(..draw.vertex_bytes));
    if tangents {
        pass.set_vertex_buffer(1, buffers.tangents.slice(..draw.tangent_bytes));
    }
    pass.set_index_buffer(
        buffers.indices.slice(..draw.index_bytes),
        wgpu::IndexFormat::Uint32,
    );
}

/// The lamp of a frame: where it is (mm) and the shadow cube's far plane (mm).
#[derive(Clone, Copy)]
pub(crate) struct LampAt {
    pub lamp: Lamp,
    pub position: glam::Vec3,
    pub far: f32,
}

impl LampAt {
    /// `lamp` placed relative to the mesh of `bounds`; the far plane holds the whole mesh.
    pub fn new(lamp: Lamp, bounds: &Bounds) -> Self {
        let offset = glam::Vec3::from(lamp.offset_mm);
        Self {
            lamp,
            position: glam::Vec3::from(bounds.center) + offset,
            far: offset.length() + 1.05 * bounds.radius + 1.0,
        }
    }
}

/// A WGSL module from its source.
pub(crate) fn module(device: &wgpu::Device, label: &str, source: &str) -> wgpu::ShaderModule {
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    })
}

/// A uniform buffer of `size` bytes the queue writes each frame.
pub(crate) fn uniform_buffer(device: &wgpu::Device, label: &str, size: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// A bilinear sampler clamped at the edges (`mipmaps`: filtering between levels too).
pub(crate) fn linear_clamp(device: &wgpu::Device, label: &str, mipmaps: bool) -> wgpu::Sampler {
    device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some(label),
        address_mode_u: wgpu::AddressMode::ClampToEdge,
        address_mode_v: wgpu::AddressMode::ClampToEdge,
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        mipmap_filter: if mipmaps {
            wgpu::MipmapFilterMode::Linear
        } else {
            Default::default()
        },
        ..Default::default()
    })
}

/// A layout entry (one resource, no array).
fn entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    ty: wgpu::BindingType,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty,
        count: None,
    }
}

pub(crate) fn uniform_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
) -> wgpu::BindGroupLayoutEntry {
    let ty = wgpu::BindingType::Buffer {
        ty: wgpu::BufferBindingType::Uniform,
        has_dynamic_offset: false,
        min_binding_size: None,
    };
    entry(binding, visibility, ty)
}

/// A float texture for the fragment stage. Textures read with `textureLoad` only are declared
/// unfilterable so that any float format (and GL) is accepted; the SSS pass samples its colour
/// input bilinearly, which needs it filterable.
pub(crate) fn texture_entry(binding: u32, filterable: bool) -> wgpu::BindGroupLayoutEntry {
    texture_of(
        binding,
        wgpu::TextureSampleType::Float { filterable },
        wgpu::TextureViewDimension::D2,
    )
}

/// A texture of `sample_type` and `view_dimension` for the fragment stage.
pub(crate) fn texture_of(
    binding: u32,
    sample_type: wgpu::TextureSampleType,
    view_dimension: wgpu::TextureViewDimension,
) -> wgpu::BindGroupLayoutEntry {
    let ty = wgpu::BindingType::Texture {
        sample_type,
        view_dimension,
        multisampled: false,
    };
    entry(binding, wgpu::ShaderStages::FRAGMENT, ty)
}

/// A filtering sampler for the stages of `visibility`.
pub(crate) fn sampler_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
) -> wgpu::BindGroupLayoutEntry {
    let ty = wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering);
    entry(binding, visibility, ty)
}

/// A write-only storage image of `format` for a compute pass.
pub(crate) fn storage_entry(
    binding: u32,
    format: wgpu::TextureFormat,
    view_dimension: wgpu::TextureViewDimension,
) -> wgpu::BindGroupLayoutEntry {
    let ty = wgpu::BindingType::StorageTexture {
        access: wgpu::StorageTextureAccess::WriteOnly,
        format,
        view_dimension,
    };
    entry(binding, wgpu::ShaderStages::COMPUTE, ty)
}

/// `entry` seen by the compute stage instead.
pub(crate) fn for_compute(entry: wgpu::BindGroupLayoutEntry) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        visibility: wgpu::ShaderStages::COMPUTE,
        ..entry
    }
}

pub(crate) fn layout(
    device: &wgpu::Device,
    label: &str,
    entries: &[wgpu::BindGroupLayoutEntry],
) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries,
    })
}

/// A bind group of `resources` at bindings 0, 1, 2... in order.
pub(crate) fn bind_group(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    resources: &[wgpu::BindingResource<'_>],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry<'_>> = resources
        .iter()
        .enumerate()
        .map(|(binding, resource)| wgpu::BindGroupEntry {
            binding: binding as u32,
            resource: resource.clone(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}

/// A full-screen-triangle pipeline (no vertex buffers, no depth) writing one target.
pub(crate) fn fullscreen_pipeline(
    device: &wgpu::Device,
    label: &str,
    module: &wgpu::ShaderModule,
    layout: &wgpu::BindGroupLayout,
    format: wgpu::TextureFormat,
    constants: &[(&str, f64)],
) -> wgpu::RenderPipeline {
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &[Some(layout)],
        immediate_size: 0,
    });
    let options = wgpu::PipelineCompilationOptions {
        constants,
        ..Default::default()
    };
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(&pipeline_layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_main"),
            compilation_options: options.clone(),
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: None,
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some("fs_main"),
            compilation_options: options,
            targets: &[color_target(format)],
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// A compute pipeline of `module`'s `cs_main` over one bind group of `layout`, with its
/// override `constants`.
pub(crate) fn compute_pipeline(
    device: &wgpu::Device,
    label: &str,
    module: &wgpu::ShaderModule,
    layout: &wgpu::BindGroupLayout,
    constants: &[(&str, f64)],
) -> wgpu::ComputePipeline {
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &[Some(layout)],
        immediate_size: 0,
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(&pipeline_layout),
        module,
        entry_point: Some("cs_main"),
        compilation_options: wgpu::PipelineCompilationOptions {
            constants,
            ..Default::default()
        },
        cache: None,
    })
}

/// What a pass that draws the mesh asks of its pipeline; the rest is the same for every such
/// pass: triangles, both faces (the gem module's winding is not part of the contract: the
/// shaders turn the normal towards the viewer), a written depth buffer, nearer wins.
pub(crate) struct MeshPipeline<'a> {
    pub label: &'a str,
    pub layout: &'a wgpu::PipelineLayout,
    pub module: &'a wgpu::ShaderModule,
    /// The vertex and fragment entry points.
    pub entries: [&'a str; 2],
    pub constants: &'a [(&'a str, f64)],
    pub buffers: &'a [Option<wgpu::VertexBufferLayout<'a>>],
    pub depth: wgpu::TextureFormat,
    pub samples: u32,
    pub targets: &'a [Option<wgpu::ColorTargetState>],
}

/// The mesh's positions alone (location 0, the vertices' first field), for the passes that
/// need nothing else of them (the shadow cube, the visibility image).
pub(crate) const POSITIONS: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![0 => Float32x3];

/// The vertex buffer of [`glyptic_core::scene::Vertex`]es, read as `attributes`.
pub(crate) fn vertices(attributes: &[wgpu::VertexAttribute]) -> wgpu::VertexBufferLayout<'_> {
    wgpu::VertexBufferLayout {
        array_stride: size_of::<glyptic_core::scene::Vertex>() as wgpu::BufferAddress,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes,
    }
}

pub(crate) fn mesh_pipeline(device: &wgpu::Device, p: &MeshPipeline<'_>) -> wgpu::RenderPipeline {
    let options = wgpu::PipelineCompilationOptions {
        constants: p.constants,
        ..Default::default()
    };
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(p.label),
        layout: Some(p.layout),
        vertex: wgpu::VertexState {
            module: p.module,
            entry_point: Some(p.entries[0]),
            compilation_options: options.clone(),
            buffers: p.buffers,
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: Some(depth_less(p.depth)),
        multisample: wgpu::MultisampleState {
            count: p.samples,
            ..Default::default()
        },
        fragment: Some(wgpu::FragmentState {
            module: p.module,
            entry_point: Some(p.entries[1]),
            compilation_options: options,
            targets: p.targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// A depth attachment cleared to the far plane; `store`: kept after the pass (a shadow cube)
/// or not (a z-buffer only drawn against).
pub(crate) fn cleared_depth(
    view: &wgpu::TextureView,
    store: wgpu::StoreOp,
) -> wgpu::RenderPassDepthStencilAttachment<'_> {
    wgpu::RenderPassDepthStencilAttachment {
        view,
        depth_ops: Some(wgpu::Operations {
            load: wgpu::LoadOp::Clear(1.0),
            store,
        }),
        stencil_ops: None,
    }
}

/// A written depth buffer, nearer wins.
pub(crate) fn depth_less(format: wgpu::TextureFormat) -> wgpu::DepthStencilState {
    wgpu::DepthStencilState {
        format,
        depth_write_enabled: Some(true),
        depth_compare: Some(wgpu::CompareFunction::Less),
        stencil: Default::default(),
        bias: Default::default(),
    }
}

pub(crate) fn color_target(format: wgpu::TextureFormat) -> Option<wgpu::ColorTargetState> {
    Some(wgpu::ColorTargetState {
        format,
        blend: None,
        write_mask: wgpu::ColorWrites::ALL,
    })
}

/// A 2D image of `samples` samples a pixel with `usage`, and its view.
pub(crate) fn image(
    device: &wgpu::Device,
    label: &str,
    format: wgpu::TextureFormat,
    size: wgpu::Extent3d,
    (samples, usage): (u32, wgpu::TextureUsages),
) -> wgpu::TextureView {
    device
        .create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size,
            mip_level_count: 1,
            sample_count: samples,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        })
        .create_view(&Default::default())
}

/// An image one pass writes and the next reads (single sample): the scene pass's resolved
/// targets, the SSS images, a style chain's images; `storage` where a compute pass writes it.
pub(crate) fn pass_image(
    device: &wgpu::Device,
    label: &str,
    format: wgpu::TextureFormat,
    size: wgpu::Extent3d,
    storage: bool,
) -> wgpu::TextureView {
    let mut usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
    if storage {
        usage |= wgpu::TextureUsages::STORAGE_BINDING;
    }
    image(device, label, format, size, (1, usage))
}

/// The attachment of a full-screen pass that writes every pixel of `view`, cleared to `clear`.
pub(crate) fn overwrite(
    view: &wgpu::TextureView,
    clear: wgpu::Color,
) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load: wgpu::LoadOp::Clear(clear),
            store: wgpu::StoreOp::Store,
        },
    })
}

/// One full-screen triangle with `pipeline` and its bind group into `view`.
pub(crate) fn draw_fullscreen(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    pipeline: &wgpu::RenderPipeline,
    group: &wgpu::BindGroup,
    view: &wgpu::TextureView,
    timestamp_writes: Option<wgpu::RenderPassTimestampWrites<'_>>,
) {
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[overwrite(view, wgpu::Color::BLACK)],
        timestamp_writes,
        ..Default::default()
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, group, &[]);
    pass.draw(0..3, 0..1);
}

/// One compute dispatch of 8 x 8-pixel workgroups over a `size` image.
pub(crate) fn dispatch_image(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    group: &wgpu::BindGroup,
    size: [u32; 2],
    timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
) {
    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(label),
        timestamp_writes,
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, group, &[]);
    pass.dispatch_workgroups(size[0].div_ceil(8), size[1].div_ceil(8), 1);
}

/// A pipeline kept per key among those built on first use.
pub(crate) struct Built<K, P> {
    built: Vec<(K, P)>,
}

impl<K: PartialEq + Copy, P> Default for Built<K, P> {
    fn default() -> Self {
        Self { built: Vec::new() }
    }
}

impl<K: PartialEq + Copy, P> Built<K, P> {
    /// Builds the pipeline of `key` with `make` if there is none yet.
    pub fn ensure(&mut self, key: K, make: impl FnOnce() -> P) {
        if self.get(key).is_none() {
            let pipeline = make();
            self.built.push((key, pipeline));
        }
    }

    pub fn get(&self, key: K) -> Option<&P> {
        self.built.iter().find(|(k, _)| *k == key).map(|(_, p)| p)
    }
}
