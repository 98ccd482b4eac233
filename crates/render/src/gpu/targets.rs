//! Frame targets (rebuilt only when the image size changes), the style chain's images, and
//! the mesh buffers (grown only when a mesh does not fit).

use super::pipelines::Pipelines;
use super::{
    DEPTH_FORMAT, DEPTH_MASK_FORMAT, DIFFUSE_FORMAT, OUTPUT_BYTES_PER_PIXEL, OUTPUT_FORMAT,
    SPECULAR_FORMAT, SSS_FORMAT, STYLE_FORMAT,
};
use crate::styles::Style;
use glyptic_core::scene::Vertex;

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

/// Everything sized by the output image: the output and its readback at the frame's size, the
/// scene and SSS images at the crop's ([`crate::camera::Crop`]: the part of the frame the gem
/// covers), which the composite places in the frame.
pub(crate) struct Targets {
    pub width: u32,
    pub height: u32,
    /// Size of the scene and SSS images (at most the frame's).
    pub scene: [u32; 2],
    /// MSAA samples of the scene targets.
    pub samples: u32,
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
    /// The same for the compute pass, each with its output image (where it is built).
    pub sss_compute_bind_groups: Option<[wgpu::BindGroup; 2]>,
    /// Composite reading the blurred diffuse (SSS on).
    pub composite_sss_bind_group: wgpu::BindGroup,
    /// The compute composite's, SSS off and on, each writing `output` (where it is built).
    pub composite_compute_bind_groups: Option<[wgpu::BindGroup; 2]>,
}

/// An image one pass writes and the next reads (single sample): the scene pass's resolved
/// targets, the SSS images, a style chain's images.
pub(super) fn pass_image(
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

/// The two images a chain of passes after the composite (the gallery styles, then the edge
/// antialiasing) passes between (the composite writes the first; pass `i` reads
/// `views[i % 2]`), and each place's bind group (its uniform, its input).
pub(crate) struct StyleTargets {
    pub views: [wgpu::TextureView; 2],
    pub bind_groups: Vec<wgpu::BindGroup>,
    /// The edge antialiasing pass reading `views[0]` or `views[1]` (it runs last).
    pub edge_aa_bind_groups: [wgpu::BindGroup; 2],
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
        let edge_aa_bind_groups = [0, 1].map(|i| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("glyptic edge aa bind group"),
                layout: &pipelines.edge_aa_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::TextureView(&views[i]),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::Sampler(&pipelines.linear_clamp),
                    },
                ],
            })
        });
        StyleTargets {
            views,
            bind_groups,
            edge_aa_bind_groups,
        }
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
    pub fn new(
        device: &wgpu::Device,
        pipelines: &Pipelines,
        width: u32,
        height: u32,
        scene: [u32; 2],
        samples: u32,
    ) -> Self {
        let size = wgpu::Extent3d {
            width: scene[0],
            height: scene[1],
            depth_or_array_layers: 1,
        };
        let output_size = wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        };
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
            size: output_size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: OUTPUT_FORMAT,
            // Written as a storage image by the compute composite where there is one.
            usage: if pipelines.composite_compute_layout.is_some() {
                wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::COPY_SRC
                    | wgpu::TextureUsages::STORAGE_BINDING
            } else {
                wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC
            },
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
        // The composite's inputs; the compute form also binds the image it writes (3).
        let composite_group = |label,
                               layout: &wgpu::BindGroupLayout,
                               diffuse_view: &wgpu::TextureView,
                               output: Option<&wgpu::TextureView>| {
            let mut entries = vec![
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
            ];
            entries.extend(output.map(|view| wgpu::BindGroupEntry {
                binding: 3,
                resource: wgpu::BindingResource::TextureView(view),
            }));
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout,
                entries: &entries,
            })
        };
        let composite_bind_group = composite_group(
            "glyptic composite bind group",
            &pipelines.composite_layout,
            &diffuse.view,
            None,
        );
        // Written as storage images where the blur can run as a compute pass.
        let sss_image = |label| {
            let mut usage =
                wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
            if pipelines.sss_compute.is_some() {
                usage |= wgpu::TextureUsages::STORAGE_BINDING;
            }
            device
                .create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size,
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: SSS_FORMAT,
                    usage,
                    view_formats: &[],
                })
                .create_view(&Default::default())
        };
        let sss_temp = sss_image("glyptic sss temp");
        let sss_out = sss_image("glyptic sss out");
        // The blur's inputs; the compute form also binds the image it writes (4).
        let sss_group = |label,
                         layout: &wgpu::BindGroupLayout,
                         uniform: &wgpu::Buffer,
                         colour: &wgpu::TextureView,
                         output: Option<&wgpu::TextureView>| {
            let mut entries = vec![
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
            ];
            entries.extend(output.map(|view| wgpu::BindGroupEntry {
                binding: 4,
                resource: wgpu::BindingResource::TextureView(view),
            }));
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout,
                entries: &entries,
            })
        };
        let [uh, uv] = &pipelines.sss_uniforms;
        let fragment = &pipelines.sss_layout;
        let sss_bind_groups = [
            sss_group("glyptic sss horizontal", fragment, uh, &diffuse.view, None),
            sss_group("glyptic sss vertical", fragment, uv, &sss_temp, None),
        ];
        let sss_compute_bind_groups = pipelines.sss_compute.as_ref().map(|(_, layout)| {
            [
                sss_group(
                    "glyptic sss compute horizontal",
                    layout,
                    uh,
                    &diffuse.view,
                    Some(&sss_temp),
                ),
                sss_group(
                    "glyptic sss compute vertical",
                    layout,
                    uv,
                    &sss_temp,
                    Some(&sss_out),
                ),
            ]
        });
        let composite_sss_bind_group = composite_group(
            "glyptic composite (sss)",
            &pipelines.composite_layout,
            &sss_out,
            None,
        );
        let composite_compute_bind_groups =
            pipelines.composite_compute_layout.as_ref().map(|layout| {
                [
                    composite_group(
                        "glyptic composite compute",
                        layout,
                        &diffuse.view,
                        Some(&output_view),
                    ),
                    composite_group(
                        "glyptic composite compute (sss)",
                        layout,
                        &sss_out,
                        Some(&output_view),
                    ),
                ]
            });
        Self {
            width,
            height,
            scene,
            samples,
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
            sss_compute_bind_groups,
            composite_sss_bind_group,
            composite_compute_bind_groups,
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
pub(super) const MIN_MESH_BUFFER: u64 = 64 * 1024;

pub(super) fn grown(needed: u64, max: u64) -> u64 {
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
