//! The scene pass's group 1: the engraving's maps and the lamp's shadow cube, placeholders
//! until a frame needs them.

// The GPU objects' shared formats, uniforms and imports (this file is a part of `gpu`).
use super::*;

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
    pub engraving_key: Option<(crate::surface::PlanarFrame, crate::surface::EngravingParams)>,
    pub bind_group: wgpu::BindGroup,
}

pub(super) fn map_texture(
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

pub(super) fn shadow_cube(device: &wgpu::Device, size: u32) -> (wgpu::Texture, wgpu::TextureView) {
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
        key: (crate::surface::PlanarFrame, crate::surface::EngravingParams),
        engraving: &crate::surface::Engraving,
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
