//! The scene pass's group 1: the engraving's maps, the lamp's shadow cube and the baked noise,
//! placeholders until a frame needs them.

use wgpu::util::DeviceExt;

use super::pipelines::Pipelines;
use super::{NOISE_FORMAT, NoiseVolumeUniform};

/// Side of each face of the lamp's shadow cube, texels.
pub(crate) const SHADOW_SIZE: u32 = 1024;
pub(crate) const SHADOW_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// The scene pass's group 1: the engraving's height and normal maps, the lamp's shadow cube
/// and the baked noise's volume. Each starts as a one-texel placeholder and is made for real by
/// the first frame that needs it (the engraving again when the mesh's planar frame changes, the
/// volume when a mesh leaves it).
pub(crate) struct SurfaceMaps {
    height: wgpu::TextureView,
    normal: wgpu::TextureView,
    shadow: wgpu::TextureView,
    volume: wgpu::TextureView,
    /// Where the noise volume lies, once baked.
    pub volume_box: Option<crate::surface::NoiseVolume>,
    /// A bake the next frame must run before its scene pass.
    pub pending_bake: Option<NoiseBake>,
    /// The volume the last frame wanted and did without (its mesh drawn once so far).
    unbaked: Option<crate::surface::NoiseVolume>,
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

/// A noise volume's bake, waiting for the frame that records it: its bind group (uniform and
/// the storage view of the volume) and its workgroup counts.
pub(crate) struct NoiseBake {
    pub bind_group: wgpu::BindGroup,
    pub workgroups: [u32; 3],
}

/// Side of the bake's workgroups (`@workgroup_size(4, 4, 4)` in `noise_volume.wgsl`).
const BAKE_GROUP: u32 = 4;

fn volume_texture(
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
        // One zero voxel: no noise (no mesh has been drawn yet).
        let placeholder = volume_texture(device, [1; 3], wgpu::TextureUsages::COPY_DST);
        queue.write_texture(
            placeholder.as_image_copy(),
            &[0; 8],
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(8),
                rows_per_image: Some(1),
            },
            wgpu::Extent3d {
                width: 1,
                height: 1,
                depth_or_array_layers: 1,
            },
        );
        let volume = placeholder.create_view(&Default::default());
        let bind_group = Self::bind(device, pipelines, &height, &normal, &shadow, &volume);
        SurfaceMaps {
            height,
            normal,
            shadow,
            volume,
            volume_box: None,
            pending_bake: None,
            unbaked: None,
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
        volume: &wgpu::TextureView,
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
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: wgpu::BindingResource::TextureView(volume),
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
        self.rebind(device, pipelines);
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
        self.rebind(device, pipelines);
    }

    fn rebind(&mut self, device: &wgpu::Device, pipelines: &Pipelines) {
        self.bind_group = Self::bind(
            device,
            pipelines,
            &self.height,
            &self.normal,
            &self.shadow,
            &self.volume,
        );
    }

    /// Whether this frame, of a mesh spanning `min`..`max` (mm), reads the baked noise. It
    /// does where the volume there holds the mesh (and is not more than twice the size it
    /// needs); otherwise a new volume is made when the previous frame wanted the same one (the
    /// bake, about as costly as computing the noise for one frame, pays from the second frame
    /// on; a photo draws one): allocated here, its bake left in `pending_bake` for the frame to
    /// record.
    pub fn ensure_volume(
        &mut self,
        device: &wgpu::Device,
        pipelines: &mut Pipelines,
        min: [f32; 3],
        max: [f32; 3],
        texture_scale: f32,
    ) -> bool {
        let Some(wanted) = crate::surface::NoiseVolume::covering(min, max) else {
            return false;
        };
        if self
            .volume_box
            .is_some_and(|v| v.holds(min, max) && v.voxels() <= 2 * wanted.voxels())
        {
            return true;
        }
        if self.unbaked != Some(wanted) {
            self.unbaked = Some(wanted);
            return false;
        }
        let texture = volume_texture(device, wanted.dims, wgpu::TextureUsages::STORAGE_BINDING);
        let storage = texture.create_view(&Default::default());
        let uniform = NoiseVolumeUniform {
            origin: [
                wanted.origin[0],
                wanted.origin[1],
                wanted.origin[2],
                wanted.voxel_mm,
            ],
            params: [texture_scale, 0.0, 0.0, 0.0],
        };
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("glyptic noise volume uniform"),
            contents: bytemuck::bytes_of(&uniform),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let (_, layout) = pipelines.noise_bake(device);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("glyptic noise volume bake"),
            layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&storage),
                },
            ],
        });
        self.pending_bake = Some(NoiseBake {
            bind_group,
            workgroups: wanted.dims.map(|d| d.div_ceil(BAKE_GROUP)),
        });
        self.volume = storage;
        self.volume_box = Some(wanted);
        self.unbaked = None;
        self.rebind(device, pipelines);
        true
    }
}
