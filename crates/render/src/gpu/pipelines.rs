//! Pipelines, layouts and uniform buffers: built once with the device (the scene variants and
//! styles on first use).

use bytemuck::Zeroable;
use wgpu::util::DeviceExt;

use super::{
    CompositeUniform, DEPTH_FORMAT, DEPTH_MASK_FORMAT, DIFFUSE_FORMAT, FrameUniform, NOISE_FORMAT,
    OUTPUT_FORMAT, SHADOW_FORMAT, SPECULAR_FORMAT, SSS_FORMAT, SSS_UNIFORM_FLOATS,
    ShadowFaceUniform,
};
use crate::shaders;
use crate::styles::Style;
use glyptic_core::scene::Vertex;

/// Pipelines, layouts and uniform buffers: created once with the device.
pub(crate) struct Pipelines {
    /// MSAA samples of an antialiased frame (4, or 1 where the device cannot resolve them).
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
    /// The compute pass that bakes the noise volume and its layout, built on first use.
    noise_bake: Option<(wgpu::ComputePipeline, wgpu::BindGroupLayout)>,
    /// The shadow pass: depth only, one draw per cube face, each with its own uniform.
    pub shadow: wgpu::RenderPipeline,
    pub shadow_uniforms: Vec<wgpu::Buffer>,
    pub shadow_bind_groups: Vec<wgpu::BindGroup>,
    /// Composite pipelines by output format (the image's, a window's), built on first use.
    composite: Vec<((wgpu::TextureFormat, bool), wgpu::RenderPipeline)>,
    composite_module: wgpu::ShaderModule,
    pub composite_layout: wgpu::BindGroupLayout,
    pub composite_uniform: wgpu::Buffer,
    /// The composite as a compute pass writing the output image (where the device has
    /// compute): its layout, made with the device, and its pipelines by transparency, built on
    /// first use.
    pub composite_compute_layout: Option<wgpu::BindGroupLayout>,
    composite_compute: Vec<(bool, wgpu::ComputePipeline)>,
    pub sss: wgpu::RenderPipeline,
    pub sss_layout: wgpu::BindGroupLayout,
    /// The same blur as a compute pass and its layout (the fragment pass's bindings and the
    /// storage image it writes), where the device has compute shaders.
    pub sss_compute: Option<(wgpu::ComputePipeline, wgpu::BindGroupLayout)>,
    /// Horizontal and vertical pass uniforms.
    pub sss_uniforms: [wgpu::Buffer; 2],
    pub linear_clamp: wgpu::Sampler,
    /// Edge antialiasing for one-sample frames: pipelines by output format, built on first use.
    pub edge_aa_layout: wgpu::BindGroupLayout,
    edge_aa_module: wgpu::ShaderModule,
    edge_aa: Vec<(wgpu::TextureFormat, wgpu::RenderPipeline)>,
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

pub(super) fn uniform_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
) -> wgpu::BindGroupLayoutEntry {
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
pub(super) fn texture_entry(binding: u32, filterable: bool) -> wgpu::BindGroupLayoutEntry {
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
pub(super) fn fullscreen_pipeline(
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
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(&pipeline_layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_main"),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants,
                ..Default::default()
            },
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: None,
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some("fs_main"),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants,
                ..Default::default()
            },
            targets: &[color_target(format)],
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// A written depth buffer, nearer wins.
pub(super) fn depth_less(format: wgpu::TextureFormat) -> wgpu::DepthStencilState {
    wgpu::DepthStencilState {
        format,
        depth_write_enabled: Some(true),
        depth_compare: Some(wgpu::CompareFunction::Less),
        stencil: Default::default(),
        bias: Default::default(),
    }
}

pub(super) fn color_target(format: wgpu::TextureFormat) -> Option<wgpu::ColorTargetState> {
    Some(wgpu::ColorTargetState {
        format,
        blend: None,
        write_mask: wgpu::ColorWrites::ALL,
    })
}

/// Which surface effects a scene pipeline has compiled in (the shader's `ENGRAVING` and
/// `LAMP` override constants). On a CPU rasteriser even untaken branches cost: the plain scene
/// pass ran about 1.6 times as long with both compiled in and switched off by uniforms.
/// Also which MSAA sample count it draws with (a frame may ask for none), and whether it reads
/// the slowly varying noise from the baked volume (`BAKED_NOISE`) or computes it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct SceneVariant {
    pub engraving: bool,
    pub lamp: bool,
    pub samples: u32,
    pub baked_noise: bool,
}

pub(super) fn scene_pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    layout: &wgpu::PipelineLayout,
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
        8 => Float32,   // transmitted key light
    ];
    let constants = [
        ("ENGRAVING", f64::from(u8::from(variant.engraving))),
        ("LAMP", f64::from(u8::from(variant.lamp))),
        ("BAKED_NOISE", f64::from(u8::from(variant.baked_noise))),
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
            count: variant.samples,
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
    pub fn new(device: &wgpu::Device, samples: u32, compute: bool) -> Self {
        let scene_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("glyptic scene"),
            source: wgpu::ShaderSource::Wgsl(shaders::SCENE.as_str().into()),
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
                wgpu::BindGroupLayoutEntry {
                    binding: 5,
                    visibility: fragment,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::D3,
                        multisampled: false,
                    },
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
        let plain = SceneVariant {
            engraving: false,
            lamp: false,
            samples,
            baked_noise: false,
        };
        let scene = vec![(
            plain,
            scene_pipeline(device, &scene_module, &scene_pipeline_layout, plain),
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
            (OUTPUT_FORMAT, false),
            fullscreen_pipeline(
                device,
                "glyptic composite pipeline",
                &composite_module,
                &composite_layout,
                OUTPUT_FORMAT,
                &[("TRANSPARENT", 0.0)],
            ),
        )];

        let composite_compute_layout = compute.then(|| {
            let c = wgpu::ShaderStages::COMPUTE;
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("glyptic composite compute layout"),
                entries: &[
                    uniform_entry(0, c),
                    wgpu::BindGroupLayoutEntry {
                        visibility: c,
                        ..texture_entry(1, false)
                    },
                    wgpu::BindGroupLayoutEntry {
                        visibility: c,
                        ..texture_entry(2, false)
                    },
                    wgpu::BindGroupLayoutEntry {
                        binding: 3,
                        visibility: c,
                        ty: wgpu::BindingType::StorageTexture {
                            access: wgpu::StorageTextureAccess::WriteOnly,
                            format: OUTPUT_FORMAT,
                            view_dimension: wgpu::TextureViewDimension::D2,
                        },
                        count: None,
                    },
                ],
            })
        });

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
            &[],
        );
        let sss_compute = compute.then(|| sss_compute_pipeline(device, &sss_module));
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

        let edge_aa_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("glyptic edge aa layout"),
            entries: &[
                texture_entry(0, true),
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        });
        let edge_aa_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("glyptic edge aa"),
            source: wgpu::ShaderSource::Wgsl(shaders::EDGE_AA.into()),
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
            noise_bake: None,
            shadow,
            shadow_uniforms,
            shadow_bind_groups,
            composite,
            composite_module,
            composite_layout,
            composite_uniform,
            composite_compute_layout,
            composite_compute: Vec::new(),
            sss,
            sss_layout,
            sss_compute,
            sss_uniforms,
            linear_clamp,
            edge_aa_layout,
            edge_aa_module,
            edge_aa: Vec::new(),
            style_layout,
            style_modules,
            style_pipelines: Vec::new(),
            style_uniforms,
        }
    }
}

/// The SSS blur's compute pipeline (`cs_main` in `sss.wgsl`) and its layout: the fragment
/// pass's uniform, colour, depth and sampler, and the Rgba16Float image it writes.
fn sss_compute_pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
) -> (wgpu::ComputePipeline, wgpu::BindGroupLayout) {
    let compute = wgpu::ShaderStages::COMPUTE;
    let texture = |binding, filterable| wgpu::BindGroupLayoutEntry {
        visibility: compute,
        ..texture_entry(binding, filterable)
    };
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("glyptic sss compute layout"),
        entries: &[
            uniform_entry(0, compute),
            texture(1, true),
            texture(2, false),
            wgpu::BindGroupLayoutEntry {
                binding: 3,
                visibility: compute,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 4,
                visibility: compute,
                ty: wgpu::BindingType::StorageTexture {
                    access: wgpu::StorageTextureAccess::WriteOnly,
                    format: SSS_FORMAT,
                    view_dimension: wgpu::TextureViewDimension::D2,
                },
                count: None,
            },
        ],
    });
    let pipeline = compute_pipeline(device, "glyptic sss compute", module, &layout, &[]);
    (pipeline, layout)
}

/// A compute pipeline of `module`'s `cs_main` over one bind group of `layout`, with its
/// override `constants`.
fn compute_pipeline(
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

impl Pipelines {
    /// Builds the scene pipeline of `variant` if there is none yet.
    pub fn ensure_scene(&mut self, device: &wgpu::Device, variant: SceneVariant) {
        if !self.scene.iter().any(|(v, _)| *v == variant) {
            let pipeline = scene_pipeline(
                device,
                &self.scene_module,
                &self.scene_pipeline_layout,
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

    /// Builds the composite pipeline for `format`, with the backdrop or without
    /// (`transparent`: the shader's `TRANSPARENT`), if there is none yet.
    pub fn ensure_composite(
        &mut self,
        device: &wgpu::Device,
        format: wgpu::TextureFormat,
        transparent: bool,
    ) {
        if !self
            .composite
            .iter()
            .any(|(k, _)| *k == (format, transparent))
        {
            let pipeline = fullscreen_pipeline(
                device,
                "glyptic composite pipeline",
                &self.composite_module,
                &self.composite_layout,
                format,
                &[("TRANSPARENT", f64::from(u8::from(transparent)))],
            );
            self.composite.push(((format, transparent), pipeline));
        }
    }

    /// Builds the compute composite (`transparent` or not) if there is none yet and the
    /// device has compute.
    pub fn ensure_composite_compute(&mut self, device: &wgpu::Device, transparent: bool) {
        let Some(layout) = &self.composite_compute_layout else {
            return;
        };
        if self
            .composite_compute
            .iter()
            .any(|(t, _)| *t == transparent)
        {
            return;
        }
        let pipeline = compute_pipeline(
            device,
            "glyptic composite compute",
            &self.composite_module,
            layout,
            &[("TRANSPARENT", f64::from(u8::from(transparent)))],
        );
        self.composite_compute.push((transparent, pipeline));
    }

    /// The compute composite, if built.
    pub fn composite_compute(&self, transparent: bool) -> Option<&wgpu::ComputePipeline> {
        self.composite_compute
            .iter()
            .find(|(t, _)| *t == transparent)
            .map(|(_, p)| p)
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
            let pipeline = fullscreen_pipeline(
                device,
                style.name(),
                module,
                &self.style_layout,
                format,
                &[],
            );
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

    /// Builds the edge antialiasing pass writing `format` if there is none yet.
    pub fn ensure_edge_aa(&mut self, device: &wgpu::Device, format: wgpu::TextureFormat) {
        if !self.edge_aa.iter().any(|(f, _)| *f == format) {
            let pipeline = fullscreen_pipeline(
                device,
                "glyptic edge aa pipeline",
                &self.edge_aa_module,
                &self.edge_aa_layout,
                format,
                &[],
            );
            self.edge_aa.push((format, pipeline));
        }
    }

    /// The edge antialiasing pass writing `format` (see [`Pipelines::ensure_edge_aa`]).
    pub fn edge_aa(&self, format: wgpu::TextureFormat) -> Option<&wgpu::RenderPipeline> {
        self.edge_aa
            .iter()
            .find(|(f, _)| *f == format)
            .map(|(_, p)| p)
    }

    /// The composite pipeline for `format` (see [`Pipelines::ensure_composite`]).
    pub fn composite(
        &self,
        format: wgpu::TextureFormat,
        transparent: bool,
    ) -> Option<&wgpu::RenderPipeline> {
        self.composite
            .iter()
            .find(|(k, _)| *k == (format, transparent))
            .map(|(_, p)| p)
    }

    /// The noise volume's bake pipeline, if built.
    pub fn noise_bake_pipeline(&self) -> Option<&wgpu::ComputePipeline> {
        self.noise_bake.as_ref().map(|(p, _)| p)
    }

    /// The noise volume's bake (compute pipeline and its layout: the volume's uniform and the
    /// storage texture it writes), built on first use.
    pub fn noise_bake(
        &mut self,
        device: &wgpu::Device,
    ) -> &(wgpu::ComputePipeline, wgpu::BindGroupLayout) {
        self.noise_bake.get_or_insert_with(|| {
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("glyptic noise volume"),
                source: wgpu::ShaderSource::Wgsl(shaders::NOISE_VOLUME.into()),
            });
            let compute = wgpu::ShaderStages::COMPUTE;
            let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("glyptic noise volume layout"),
                entries: &[
                    uniform_entry(0, compute),
                    wgpu::BindGroupLayoutEntry {
                        binding: 1,
                        visibility: compute,
                        ty: wgpu::BindingType::StorageTexture {
                            access: wgpu::StorageTextureAccess::WriteOnly,
                            format: NOISE_FORMAT,
                            view_dimension: wgpu::TextureViewDimension::D3,
                        },
                        count: None,
                    },
                ],
            });
            let pipeline = compute_pipeline(device, "glyptic noise volume", &module, &layout, &[]);
            (pipeline, layout)
        })
    }
}
