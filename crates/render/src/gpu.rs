//! The GPU objects: pipelines and uniform buffers (built once per device), frame targets
//! (rebuilt only when the image size changes) and mesh buffers (grown only when a mesh does not
//! fit). Nothing here is created per frame.
//!
//! Targets of the scene pass, all the output's size (multisampled when the device allows 4x MSAA
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
//! are uploaded once per planar frame. Both live in `SurfaceMaps` (one-texel placeholders until a
//! frame needs them) and are bound as the scene pass's group 1.
//!
//! The composite pass reads the resolved (or blurred) `diffuse` and `specular` and writes the Rgba8Unorm
//! `output` (sRGB-encoded by the shader), which is copied into a mappable buffer with rows padded
//! to 256 bytes.

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use super::Vertex;
use super::shaders;
use crate::styles::Style;

pub(crate) const DIFFUSE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub(crate) const SPECULAR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub(crate) const DEPTH_MASK_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg16Float;
pub(crate) const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
pub(crate) const SSS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub(crate) const OUTPUT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
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

/// Pipelines, layouts and uniform buffers: created once with the device.
pub(crate) struct Pipelines {
    pub samples: u32,
    /// Scene pipelines by variant (the plain one built at start, the others on first use).
    scene: Vec<(SceneVariant, wgpu::RenderPipeline)>,
    scene_module: wgpu::ShaderModule,
    scene_pipeline_layout: wgpu::PipelineLayout,
    pub frame_uniform: wgpu::Buffer,
    pub scene_bind_group: wgpu::BindGroup,
    /// Group 1 of the scene pass: the engraving's maps and the lamp's shadow cube.
    pub surface_layout: wgpu::BindGroupLayout,
    /// Mipmapped, clamped at the edges: the engraving's maps.
    pub linear_mipmap: wgpu::Sampler,
    /// Depth comparison (less-equal) for the shadow cube, filtered (2x2 PCF where supported).
    pub shadow_sampler: wgpu::Sampler,
    /// The shadow pass: depth only, one draw per cube face, each with its own uniform.
    pub shadow: wgpu::RenderPipeline,
    pub shadow_uniforms: Vec<wgpu::Buffer>,
    pub shadow_bind_groups: Vec<wgpu::BindGroup>,
    /// Composite pipelines by output format (the image's, a window's), built on first use.
    composite: Vec<(wgpu::TextureFormat, wgpu::RenderPipeline)>,
    composite_module: wgpu::ShaderModule,
    pub composite_layout: wgpu::BindGroupLayout,
    pub composite_uniform: wgpu::Buffer,
    pub sss: wgpu::RenderPipeline,
    pub sss_layout: wgpu::BindGroupLayout,
    /// Horizontal and vertical pass uniforms.
    pub sss_uniforms: [wgpu::Buffer; 2],
    pub linear_clamp: wgpu::Sampler,
    /// Gallery style passes: layout, modules, pipelines by (style, output format) built on
    /// first use, and one uniform buffer per place in a chain.
    pub style_layout: wgpu::BindGroupLayout,
    style_modules: Vec<(Style, wgpu::ShaderModule)>,
    style_pipelines: Vec<((Style, wgpu::TextureFormat), wgpu::RenderPipeline)>,
    pub style_uniforms: Vec<wgpu::Buffer>,
}

/// Styles in one chain on the GPU, at most.
pub(crate) const MAX_GPU_STYLES: usize = 8;
/// The ping-pong targets of a style chain (display values, like the output).
pub(crate) const STYLE_FORMAT: wgpu::TextureFormat = OUTPUT_FORMAT;

fn uniform_entry(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A float texture for the fragment stage. Textures read with `textureLoad` only are declared
/// unfilterable so that any float format (and GL) is accepted; the SSS pass samples its colour
/// input bilinearly, which needs it filterable.
fn texture_entry(binding: u32, filterable: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable },
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    }
}

/// A full-screen-triangle pipeline (no vertex buffers, no depth) writing one target.
fn fullscreen_pipeline(
    device: &wgpu::Device,
    label: &str,
    module: &wgpu::ShaderModule,
    layout: &wgpu::BindGroupLayout,
    format: wgpu::TextureFormat,
) -> wgpu::RenderPipeline {
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &[Some(layout)],
        immediate_size: 0,
    });
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(&pipeline_layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: None,
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: &[color_target(format)],
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// A written depth buffer, nearer wins.
fn depth_less(format: wgpu::TextureFormat) -> wgpu::DepthStencilState {
    wgpu::DepthStencilState {
        format,
        depth_write_enabled: Some(true),
        depth_compare: Some(wgpu::CompareFunction::Less),
        stencil: Default::default(),
        bias: Default::default(),
    }
}

fn color_target(format: wgpu::TextureFormat) -> Option<wgpu::ColorTargetState> {
    Some(wgpu::ColorTargetState {
        format,
        blend: None,
        write_mask: wgpu::ColorWrites::ALL,
    })
}

/// Which surface effects a scene pipeline has compiled in (the shader's `ENGRAVING` and
/// `LAMP` override constants). On a CPU rasteriser even untaken branches cost: the plain scene
/// pass ran about 1.6 times as long with both compiled in and switched off by uniforms.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct SceneVariant {
    pub engraving: bool,
    pub lamp: bool,
}

fn scene_pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    layout: &wgpu::PipelineLayout,
    samples: u32,
    variant: SceneVariant,
) -> wgpu::RenderPipeline {
    let attributes = wgpu::vertex_attr_array![
        0 => Float32x3, // position
        1 => Float32x3, // normal
        2 => Float32,   // relief
        3 => Uint32,    // region
        4 => Float32,   // hair
        6 => Float32,   // occlusion
        7 => Float32,   // key light
    ];
    let constants = [
        ("ENGRAVING", f64::from(u8::from(variant.engraving))),
        ("LAMP", f64::from(u8::from(variant.lamp))),
    ];
    let options = wgpu::PipelineCompilationOptions {
        constants: &constants,
        ..Default::default()
    };
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("glyptic scene pipeline"),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_main"),
            compilation_options: options.clone(),
            buffers: &[
                Some(wgpu::VertexBufferLayout {
                    array_stride: size_of::<Vertex>() as wgpu::BufferAddress,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &attributes,
                }),
                // Tangent frames (surface::tangents), a buffer of their own: only frames with
                // the engraving compute them.
                Some(wgpu::VertexBufferLayout {
                    array_stride: 16,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &wgpu::vertex_attr_array![5 => Float32x4],
                }),
            ],
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            // The gem module's winding is not part of the contract: draw both faces and let
            // the shader turn the normal towards the viewer.
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: Some(depth_less(DEPTH_FORMAT)),
        multisample: wgpu::MultisampleState {
            count: samples,
            ..Default::default()
        },
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some("fs_main"),
            compilation_options: options,
            targets: &[
                color_target(DIFFUSE_FORMAT),
                color_target(SPECULAR_FORMAT),
                color_target(DEPTH_MASK_FORMAT),
            ],
        }),
        multiview_mask: None,
        cache: None,
    })
}

impl Pipelines {
    pub fn new(device: &wgpu::Device, samples: u32) -> Self {
        let scene_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("glyptic scene"),
            source: wgpu::ShaderSource::Wgsl(shaders::SCENE.into()),
        });
        let composite_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("glyptic composite"),
            source: wgpu::ShaderSource::Wgsl(shaders::COMPOSITE.into()),
        });

        let frame_uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("glyptic frame uniform"),
            contents: bytemuck::bytes_of(&FrameUniform::zeroed()),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let scene_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("glyptic scene layout"),
            entries: &[uniform_entry(0, wgpu::ShaderStages::VERTEX_FRAGMENT)],
        });
        let scene_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("glyptic scene bind group"),
            layout: &scene_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: frame_uniform.as_entire_binding(),
            }],
        });
        let fragment = wgpu::ShaderStages::FRAGMENT;
        let surface_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("glyptic surface layout"),
            entries: &[
                texture_entry(0, true),
                texture_entry(1, true),
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: fragment,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 3,
                    visibility: fragment,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Depth,
                        view_dimension: wgpu::TextureViewDimension::Cube,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 4,
                    visibility: fragment,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison),
                    count: None,
                },
            ],
        });
        let linear_mipmap = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("glyptic linear mipmap"),
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });
        let shadow_sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("glyptic shadow"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            compare: Some(wgpu::CompareFunction::LessEqual),
            ..Default::default()
        });
        let scene_pipeline_layout =
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("glyptic scene pipeline layout"),
                bind_group_layouts: &[Some(&scene_layout), Some(&surface_layout)],
                immediate_size: 0,
            });
        let scene = vec![(
            SceneVariant::default(),
            scene_pipeline(
                device,
                &scene_module,
                &scene_pipeline_layout,
                samples,
                SceneVariant::default(),
            ),
        )];

        let shadow_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("glyptic shadow"),
            source: wgpu::ShaderSource::Wgsl(shaders::SHADOW.into()),
        });
        let shadow_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("glyptic shadow layout"),
            entries: &[uniform_entry(0, wgpu::ShaderStages::VERTEX_FRAGMENT)],
        });
        let shadow_uniforms: Vec<wgpu::Buffer> = (0..6)
            .map(|_| {
                device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("glyptic shadow face uniform"),
                    size: size_of::<ShadowFaceUniform>() as u64,
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            })
            .collect();
        let shadow_bind_groups = shadow_uniforms
            .iter()
            .map(|buffer| {
                device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("glyptic shadow face"),
                    layout: &shadow_layout,
                    entries: &[wgpu::BindGroupEntry {
                        binding: 0,
                        resource: buffer.as_entire_binding(),
                    }],
                })
            })
            .collect();
        let shadow_pipeline_layout =
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("glyptic shadow pipeline layout"),
                bind_group_layouts: &[Some(&shadow_layout)],
                immediate_size: 0,
            });
        let shadow = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("glyptic shadow pipeline"),
            layout: Some(&shadow_pipeline_layout),
            vertex: wgpu::VertexState {
                module: &shadow_module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: size_of::<Vertex>() as wgpu::BufferAddress,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &wgpu::vertex_attr_array![0 => Float32x3],
                })],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: Some(depth_less(SHADOW_FORMAT)),
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &shadow_module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &[],
            }),
            multiview_mask: None,
            cache: None,
        });

        let composite_uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("glyptic composite uniform"),
            contents: bytemuck::bytes_of(&CompositeUniform::zeroed()),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let composite_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("glyptic composite layout"),
            entries: &[
                uniform_entry(0, wgpu::ShaderStages::FRAGMENT),
                texture_entry(1, false),
                texture_entry(2, false),
            ],
        });
        let composite = vec![(
            OUTPUT_FORMAT,
            fullscreen_pipeline(
                device,
                "glyptic composite pipeline",
                &composite_module,
                &composite_layout,
                OUTPUT_FORMAT,
            ),
        )];

        let sss_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("glyptic sss"),
            source: wgpu::ShaderSource::Wgsl(shaders::SSS.into()),
        });
        let sss_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("glyptic sss layout"),
            entries: &[
                uniform_entry(0, wgpu::ShaderStages::FRAGMENT),
                texture_entry(1, true),
                texture_entry(2, false),
                wgpu::BindGroupLayoutEntry {
                    binding: 3,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        });
        let sss = fullscreen_pipeline(
            device,
            "glyptic sss pipeline",
            &sss_module,
            &sss_layout,
            SSS_FORMAT,
        );
        let sss_uniform = |label| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: (SSS_UNIFORM_FLOATS * 4) as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let sss_uniforms = [
            sss_uniform("glyptic sss horizontal"),
            sss_uniform("glyptic sss vertical"),
        ];
        let linear_clamp = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("glyptic linear clamp"),
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });

        let style_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("glyptic style layout"),
            entries: &[
                uniform_entry(0, wgpu::ShaderStages::FRAGMENT),
                texture_entry(1, false),
            ],
        });
        let style_modules = [
            (Style::Toon, shaders::TOON),
            (Style::FishEye, shaders::FISHEYE),
            (Style::Chromatic, shaders::CHROMATIC),
            (Style::Painterly, shaders::PAINTERLY),
        ]
        .into_iter()
        .map(|(style, source)| {
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(style.name()),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
            (style, module)
        })
        .collect();
        let style_uniforms = (0..MAX_GPU_STYLES)
            .map(|_| {
                device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("glyptic style uniform"),
                    size: 32,
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            })
            .collect();

        Self {
            samples,
            scene,
            scene_module,
            scene_pipeline_layout,
            frame_uniform,
            scene_bind_group,
            surface_layout,
            linear_mipmap,
            shadow_sampler,
            shadow,
            shadow_uniforms,
            shadow_bind_groups,
            composite,
            composite_module,
            composite_layout,
            composite_uniform,
            sss,
            sss_layout,
            sss_uniforms,
            linear_clamp,
            style_layout,
            style_modules,
            style_pipelines: Vec::new(),
            style_uniforms,
        }
    }
}

impl Pipelines {
    /// Builds the composite pipeline for `format` if there is none yet.
    /// Builds the scene pipeline of `variant` if there is none yet.
    pub fn ensure_scene(&mut self, device: &wgpu::Device, variant: SceneVariant) {
        if !self.scene.iter().any(|(v, _)| *v == variant) {
            let pipeline = scene_pipeline(
                device,
                &self.scene_module,
                &self.scene_pipeline_layout,
                self.samples,
                variant,
            );
            self.scene.push((variant, pipeline));
        }
    }

    pub fn scene(&self, variant: SceneVariant) -> Option<&wgpu::RenderPipeline> {
        self.scene
            .iter()
            .find(|(v, _)| *v == variant)
            .map(|(_, p)| p)
    }

    pub fn ensure_composite(&mut self, device: &wgpu::Device, format: wgpu::TextureFormat) {
        if !self.composite.iter().any(|(f, _)| *f == format) {
            let pipeline = fullscreen_pipeline(
                device,
                "glyptic composite pipeline",
                &self.composite_module,
                &self.composite_layout,
                format,
            );
            self.composite.push((format, pipeline));
        }
    }

    /// Builds the pass of `style` writing `format` if there is none yet and the style has a
    /// GPU pass ([`Pipelines::style`] then finds it).
    pub fn ensure_style(
        &mut self,
        device: &wgpu::Device,
        style: Style,
        format: wgpu::TextureFormat,
    ) {
        if self
            .style_pipelines
            .iter()
            .any(|(k, _)| *k == (style, format))
        {
            return;
        }
        if let Some((_, module)) = self.style_modules.iter().find(|(s, _)| *s == style) {
            let pipeline =
                fullscreen_pipeline(device, style.name(), module, &self.style_layout, format);
            self.style_pipelines.push(((style, format), pipeline));
        }
    }

    /// The pass of `style` writing `format` (see [`Pipelines::ensure_style`]).
    pub fn style(
        &self,
        style: Style,
        format: wgpu::TextureFormat,
    ) -> Option<&wgpu::RenderPipeline> {
        self.style_pipelines
            .iter()
            .find(|(k, _)| *k == (style, format))
            .map(|(_, p)| p)
    }

    /// The composite pipeline for `format` (see [`Pipelines::ensure_composite`]).
    pub fn composite(&self, format: wgpu::TextureFormat) -> Option<&wgpu::RenderPipeline> {
        self.composite
            .iter()
            .find(|(f, _)| *f == format)
            .map(|(_, p)| p)
    }
}

/// A scene-pass colour target: the single-sample texture later passes read, and, with MSAA, the
/// multisampled texture drawn into and resolved from.
pub(crate) struct ColorTarget {
    /// Single-sample view (keeps its texture alive).
    pub view: wgpu::TextureView,
    pub msaa: Option<wgpu::TextureView>,
}

impl ColorTarget {
    fn new(
        device: &wgpu::Device,
        label: &str,
        format: wgpu::TextureFormat,
        size: wgpu::Extent3d,
        samples: u32,
    ) -> Self {
        let view = pass_image(device, label, format, size);
        let msaa = (samples > 1).then(|| {
            device
                .create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size,
                    mip_level_count: 1,
                    sample_count: samples,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                    view_formats: &[],
                })
                .create_view(&Default::default())
        });
        Self { view, msaa }
    }

    /// The attachment for the scene pass: cleared to zero (= no coverage), resolved if MSAA.
    pub fn attachment(&self) -> wgpu::RenderPassColorAttachment<'_> {
        let (view, resolve_target, store) = match &self.msaa {
            Some(msaa) => (msaa, Some(&self.view), wgpu::StoreOp::Discard),
            None => (&self.view, None, wgpu::StoreOp::Store),
        };
        wgpu::RenderPassColorAttachment {
            view,
            depth_slice: None,
            resolve_target,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                store,
            },
        }
    }
}

/// Everything sized by the output image.
pub(crate) struct Targets {
    pub width: u32,
    pub height: u32,
    pub diffuse: ColorTarget,
    pub specular: ColorTarget,
    pub depth_mask: ColorTarget,
    pub depth: wgpu::TextureView,
    pub output: wgpu::Texture,
    pub output_view: wgpu::TextureView,
    /// Mappable copy of `output`, rows padded to `padded_row` bytes.
    pub readback: wgpu::Buffer,
    pub padded_row: u32,
    /// Composite reading the unblurred diffuse (SSS off).
    pub composite_bind_group: wgpu::BindGroup,
    pub sss_temp: wgpu::TextureView,
    pub sss_out: wgpu::TextureView,
    /// SSS horizontal (diffuse -> temp) and vertical (temp -> out) inputs.
    pub sss_bind_groups: [wgpu::BindGroup; 2],
    /// Composite reading the blurred diffuse (SSS on).
    pub composite_sss_bind_group: wgpu::BindGroup,
}

/// An image one pass writes and the next reads (single sample): the scene pass's resolved
/// targets, the SSS images, a style chain's images.
fn pass_image(
    device: &wgpu::Device,
    label: &str,
    format: wgpu::TextureFormat,
    size: wgpu::Extent3d,
) -> wgpu::TextureView {
    device
        .create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        })
        .create_view(&Default::default())
}

/// The attachment of a full-screen pass that writes every pixel of `view`.
pub(crate) fn overwrite(view: &wgpu::TextureView) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
            store: wgpu::StoreOp::Store,
        },
    })
}

/// A style pass's uniform (`Style` in style_common.wgsl), or `None` for a serial style (done
/// on the CPU: [`Style::is_serial`]).
pub(crate) fn style_uniform(style: Style, time_s: f32) -> Option<[f32; 8]> {
    use crate::styles::{
        ChromaticParams, FishEyeParams, PainterlyParams, ToonParams, chromatic_offsets,
    };
    match style {
        Style::Toon => {
            let t = ToonParams::default();
            Some([
                t.levels as f32,
                t.edge_low,
                t.edge_high,
                t.threshold,
                0.0,
                0.0,
                0.0,
                0.0,
            ])
        }
        Style::FishEye => {
            let f = FishEyeParams::default();
            Some([f.strength, f.power, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
        }
        Style::Chromatic => {
            let [r, g, b] = chromatic_offsets(&ChromaticParams {
                time_s,
                ..ChromaticParams::default()
            });
            Some([r[0], r[1], g[0], g[1], b[0], b[1], 0.0, 0.0])
        }
        Style::Painterly => {
            let p = PainterlyParams::default();
            let radius = |i: usize| p.radii.get(i).copied().unwrap_or(0.0);
            Some([
                radius(0),
                radius(1),
                radius(2),
                p.jitter,
                1.0 / p.difference,
                (p.seed >> 16) as f32,
                p.radii.len().min(3) as f32,
                (p.seed & 0xffff) as f32,
            ])
        }
        Style::Dither => None,
    }
}

/// The two images a style chain passes between (the composite writes the first; pass `i`
/// reads `views[i % 2]`), and each place's bind group (its uniform, its input).
pub(crate) struct StyleTargets {
    pub views: [wgpu::TextureView; 2],
    pub bind_groups: Vec<wgpu::BindGroup>,
}

impl StyleTargets {
    pub fn new(device: &wgpu::Device, pipelines: &Pipelines, width: u32, height: u32) -> Self {
        let size = wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        };
        let views = [0, 1].map(|_| pass_image(device, "glyptic style image", STYLE_FORMAT, size));
        let bind_groups = pipelines
            .style_uniforms
            .iter()
            .enumerate()
            .map(|(i, uniform)| {
                device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("glyptic style bind group"),
                    layout: &pipelines.style_layout,
                    entries: &[
                        wgpu::BindGroupEntry {
                            binding: 0,
                            resource: uniform.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: 1,
                            resource: wgpu::BindingResource::TextureView(&views[i % 2]),
                        },
                    ],
                })
            })
            .collect();
        StyleTargets { views, bind_groups }
    }
}

/// Bytes per readback row: `width` pixels rounded up to wgpu's 256-byte copy alignment.
pub(crate) fn padded_row_bytes(width: u32) -> u64 {
    let unpadded = u64::from(width) * u64::from(OUTPUT_BYTES_PER_PIXEL);
    let align = u64::from(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    unpadded.div_ceil(align) * align
}

impl Targets {
    /// Sizes must have been checked against the device limits by the caller.
    pub fn new(device: &wgpu::Device, pipelines: &Pipelines, width: u32, height: u32) -> Self {
        let size = wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        };
        let samples = pipelines.samples;
        let diffuse = ColorTarget::new(device, "glyptic diffuse", DIFFUSE_FORMAT, size, samples);
        let specular = ColorTarget::new(device, "glyptic specular", SPECULAR_FORMAT, size, samples);
        let depth_mask = ColorTarget::new(
            device,
            "glyptic depth+mask",
            DEPTH_MASK_FORMAT,
            size,
            samples,
        );
        let depth = device
            .create_texture(&wgpu::TextureDescriptor {
                label: Some("glyptic z-buffer"),
                size,
                mip_level_count: 1,
                sample_count: samples,
                dimension: wgpu::TextureDimension::D2,
                format: DEPTH_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                view_formats: &[],
            })
            .create_view(&Default::default());
        let output = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("glyptic output"),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: OUTPUT_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let output_view = output.create_view(&Default::default());
        let padded_row = padded_row_bytes(width);
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("glyptic readback"),
            size: padded_row * u64::from(height),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let composite_group = |label, diffuse_view: &wgpu::TextureView| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout: &pipelines.composite_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: pipelines.composite_uniform.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(diffuse_view),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: wgpu::BindingResource::TextureView(&specular.view),
                    },
                ],
            })
        };
        let composite_bind_group = composite_group("glyptic composite bind group", &diffuse.view);
        let sss_temp = pass_image(device, "glyptic sss temp", SSS_FORMAT, size);
        let sss_out = pass_image(device, "glyptic sss out", SSS_FORMAT, size);
        let sss_group = |label, uniform: &wgpu::Buffer, colour: &wgpu::TextureView| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout: &pipelines.sss_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: uniform.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(colour),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: wgpu::BindingResource::TextureView(&depth_mask.view),
                    },
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: wgpu::BindingResource::Sampler(&pipelines.linear_clamp),
                    },
                ],
            })
        };
        let [uh, uv] = &pipelines.sss_uniforms;
        let sss_bind_groups = [
            sss_group("glyptic sss horizontal", uh, &diffuse.view),
            sss_group("glyptic sss vertical", uv, &sss_temp),
        ];
        let composite_sss_bind_group = composite_group("glyptic composite (sss)", &sss_out);
        Self {
            width,
            height,
            diffuse,
            specular,
            depth_mask,
            depth,
            output,
            output_view,
            readback,
            // Checked by the caller: at most max_buffer_size / height, far below u32::MAX.
            padded_row: u32::try_from(padded_row).unwrap_or(u32::MAX),
            composite_bind_group,
            sss_temp,
            sss_out,
            sss_bind_groups,
            composite_sss_bind_group,
        }
    }
}

/// Vertex and index buffers that keep their capacity between frames.
pub(crate) struct MeshBuffers {
    pub vertices: wgpu::Buffer,
    /// One tangent frame ([f32; 4]) per vertex.
    pub tangents: wgpu::Buffer,
    pub indices: wgpu::Buffer,
}

/// Bytes of the tangent frames of a mesh with `vertex_bytes` of vertices.
pub(crate) fn tangent_bytes(vertex_bytes: u64) -> u64 {
    vertex_bytes / size_of::<Vertex>() as u64 * 16
}

/// Smallest buffer allocated, so small meshes do not reallocate as they grow a little.
const MIN_MESH_BUFFER: u64 = 64 * 1024;

fn grown(needed: u64, max: u64) -> u64 {
    needed
        .max(MIN_MESH_BUFFER)
        .checked_next_power_of_two()
        .unwrap_or(needed)
        .min(max)
        .max(needed)
}

impl MeshBuffers {
    /// Buffers holding at least the given byte counts (both no larger than `max`).
    pub fn new(device: &wgpu::Device, vertex_bytes: u64, index_bytes: u64, max: u64) -> Self {
        let buffer = |label, size, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: grown(size, max),
                usage: usage | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        Self {
            vertices: buffer("glyptic vertices", vertex_bytes, wgpu::BufferUsages::VERTEX),
            tangents: buffer(
                "glyptic tangents",
                tangent_bytes(vertex_bytes),
                wgpu::BufferUsages::VERTEX,
            ),
            indices: buffer("glyptic indices", index_bytes, wgpu::BufferUsages::INDEX),
        }
    }

    pub fn fits(&self, vertex_bytes: u64, index_bytes: u64) -> bool {
        self.vertices.size() >= vertex_bytes
            && self.tangents.size() >= tangent_bytes(vertex_bytes)
            && self.indices.size() >= index_bytes
    }
}

/// Side of each face of the lamp's shadow cube, texels.
pub(crate) const SHADOW_SIZE: u32 = 1024;
pub(crate) const SHADOW_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// The scene pass's group 1: the engraving's height and normal maps and the lamp's shadow
/// cube. Each starts as a one-texel placeholder and is made for real by the first frame that
/// needs it (the engraving again when the mesh's planar frame changes).
pub(crate) struct SurfaceMaps {
    height: wgpu::TextureView,
    normal: wgpu::TextureView,
    shadow: wgpu::TextureView,
    /// The shadow cube's faces (+x, -x, +y, -y, +z, -z) as render targets; empty until made.
    pub shadow_faces: Vec<wgpu::TextureView>,
    /// The frame and parameters the engraving was made for, if it was.
    pub engraving_key: Option<(super::surface::PlanarFrame, super::surface::EngravingParams)>,
    pub bind_group: wgpu::BindGroup,
}

fn map_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    label: &str,
    format: wgpu::TextureFormat,
    size: u32,
    levels: &[&[u8]],
) -> wgpu::TextureView {
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: size,
            height: size,
            depth_or_array_layers: 1,
        },
        mip_level_count: levels.len().max(1) as u32,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    let bytes_per_texel = format.block_copy_size(None).unwrap_or(4);
    for (level, data) in levels.iter().enumerate() {
        let side = (size >> level).max(1);
        queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &texture,
                mip_level: level as u32,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            data,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(side * bytes_per_texel),
                rows_per_image: None,
            },
            wgpu::Extent3d {
                width: side,
                height: side,
                depth_or_array_layers: 1,
            },
        );
    }
    texture.create_view(&Default::default())
}

fn shadow_cube(device: &wgpu::Device, size: u32) -> (wgpu::Texture, wgpu::TextureView) {
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

impl SurfaceMaps {
    /// Placeholders: a flat one-texel engraving and a one-texel shadow cube (never sampled: the
    /// shader is told there is no engraving and no lamp).
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, pipelines: &Pipelines) -> Self {
        let height = map_texture(
            device,
            queue,
            "glyptic no engraving",
            wgpu::TextureFormat::R8Unorm,
            1,
            &[&[255]],
        );
        let normal = map_texture(
            device,
            queue,
            "glyptic no engraving normals",
            wgpu::TextureFormat::Rgba8Unorm,
            1,
            &[&[128, 128, 255, 255]],
        );
        let (_, shadow) = shadow_cube(device, 1);
        let bind_group = Self::bind(device, pipelines, &height, &normal, &shadow);
        SurfaceMaps {
            height,
            normal,
            shadow,
            shadow_faces: Vec::new(),
            engraving_key: None,
            bind_group,
        }
    }

    fn bind(
        device: &wgpu::Device,
        pipelines: &Pipelines,
        height: &wgpu::TextureView,
        normal: &wgpu::TextureView,
        shadow: &wgpu::TextureView,
    ) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("glyptic surface bind group"),
            layout: &pipelines.surface_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(height),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(normal),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::Sampler(&pipelines.linear_mipmap),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::TextureView(shadow),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::Sampler(&pipelines.shadow_sampler),
                },
            ],
        })
    }

    /// Uploads the engraving made for `frame` (and its mip chains).
    pub fn set_engraving(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pipelines: &Pipelines,
        key: (super::surface::PlanarFrame, super::surface::EngravingParams),
        engraving: &super::surface::Engraving,
    ) {
        let heights: Vec<&[u8]> = engraving.height.iter().map(|l| &l[..]).collect();
        let normals: Vec<&[u8]> = engraving
            .normal
            .iter()
            .map(|l| bytemuck::cast_slice::<[u8; 4], u8>(l))
            .collect();
        self.height = map_texture(
            device,
            queue,
            "glyptic engraving",
            wgpu::TextureFormat::R8Unorm,
            engraving.size,
            &heights,
        );
        self.normal = map_texture(
            device,
            queue,
            "glyptic engraving normals",
            wgpu::TextureFormat::Rgba8Unorm,
            engraving.size,
            &normals,
        );
        self.engraving_key = Some(key);
        self.bind_group = Self::bind(device, pipelines, &self.height, &self.normal, &self.shadow);
    }

    /// Makes the full-size shadow cube (once).
    pub fn ensure_shadow(&mut self, device: &wgpu::Device, pipelines: &Pipelines) {
        if !self.shadow_faces.is_empty() {
            return;
        }
        let (texture, view) = shadow_cube(device, SHADOW_SIZE);
        self.shadow_faces = (0..6)
            .map(|face| {
                texture.create_view(&wgpu::TextureViewDescriptor {
                    label: Some("glyptic shadow face"),
                    dimension: Some(wgpu::TextureViewDimension::D2),
                    base_array_layer: face,
                    array_layer_count: Some(1),
                    ..Default::default()
                })
            })
            .collect();
        self.shadow = view;
        self.bind_group = Self::bind(device, pipelines, &self.height, &self.normal, &self.shadow);
    }
}
