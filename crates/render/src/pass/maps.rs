//! The scene pass's group 1: the engraving's height (R8) and tangent-space normal (Rgba8)
//! maps with their mip chains, uploaded once per planar frame; the lamp's shadow cube
//! ([`super::shadow`] draws it); the baked noise's volume ([`super::noise`] bakes it). Each is
//! a one-texel placeholder until a frame needs it.

use super::common;
use super::noise::{self, NoiseBake, NoisePass};
use super::scene::ScenePass;
use super::shadow;
use crate::surface::{Engraving, EngravingParams, NoiseVolume, PlanarFrame};

/// The engraving's height (R8) and normal (Rgba8) maps, `size` texels a side, each from its
/// mip levels.
fn engraving_maps(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    labels: [&str; 2],
    size: u32,
    levels: [Vec<&[u8]>; 2],
) -> [wgpu::TextureView; 2] {
    let formats = [
        wgpu::TextureFormat::R8Unorm,
        wgpu::TextureFormat::Rgba8Unorm,
    ];
    let [heights, normals] = levels;
    [
        map_texture(device, queue, labels[0], formats[0], size, &heights),
        map_texture(device, queue, labels[1], formats[1], size, &normals),
    ]
}

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
    pub volume_box: Option<NoiseVolume>,
    /// A bake the next frame must run before its scene pass.
    pub pending_bake: Option<NoiseBake>,
    /// The volume the last frame wanted and did without (its mesh drawn once so far).
    unbaked: Option<NoiseVolume>,
    /// The shadow cube's faces (+x, -x, +y, -y, +z, -z) as render targets; empty until made.
    pub shadow_faces: Vec<wgpu::TextureView>,
    /// The frame and parameters the engraving was made for, if it was.
    pub engraving_key: Option<(PlanarFrame, EngravingParams)>,
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

impl SurfaceMaps {
    /// Placeholders: a flat one-texel engraving and a one-texel shadow cube (never sampled: the
    /// shader is told there is no engraving and no lamp).
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, scene: &ScenePass) -> Self {
        let [height, normal] = engraving_maps(
            device,
            queue,
            ["glyptic no engraving", "glyptic no engraving normals"],
            1,
            [vec![&[255]], vec![&[128, 128, 255, 255]]],
        );
        let (_, shadow) = shadow::cube(device, 1);
        // One zero voxel: no noise (no mesh has been drawn yet).
        let placeholder = noise::volume_texture(device, [1; 3], wgpu::TextureUsages::COPY_DST);
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
        let bind_group = Self::bind(device, scene, &height, &normal, &shadow, &volume);
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
        scene: &ScenePass,
        height: &wgpu::TextureView,
        normal: &wgpu::TextureView,
        shadow: &wgpu::TextureView,
        volume: &wgpu::TextureView,
    ) -> wgpu::BindGroup {
        common::bind_group(
            device,
            "glyptic surface bind group",
            &scene.surface_layout,
            &[
                wgpu::BindingResource::TextureView(height),
                wgpu::BindingResource::TextureView(normal),
                wgpu::BindingResource::Sampler(&scene.linear_mipmap),
                wgpu::BindingResource::TextureView(shadow),
                wgpu::BindingResource::Sampler(&scene.shadow_sampler),
                wgpu::BindingResource::TextureView(volume),
            ],
        )
    }

    /// Uploads the engraving made for `frame` (and its mip chains).
    pub fn set_engraving(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &ScenePass,
        key: (PlanarFrame, EngravingParams),
        engraving: &Engraving,
    ) {
        let heights: Vec<&[u8]> = engraving.height.iter().map(|l| &l[..]).collect();
        let normals: Vec<&[u8]> = engraving
            .normal
            .iter()
            .map(|l| bytemuck::cast_slice::<[u8; 4], u8>(l))
            .collect();
        [self.height, self.normal] = engraving_maps(
            device,
            queue,
            ["glyptic engraving", "glyptic engraving normals"],
            engraving.size,
            [heights, normals],
        );
        self.engraving_key = Some(key);
        self.rebind(device, scene);
    }

    /// Makes the full-size shadow cube (once).
    pub fn ensure_shadow(&mut self, device: &wgpu::Device, scene: &ScenePass) {
        if !self.shadow_faces.is_empty() {
            return;
        }
        let (texture, view) = shadow::cube(device, shadow::SHADOW_SIZE);
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
        self.rebind(device, scene);
    }

    fn rebind(&mut self, device: &wgpu::Device, scene: &ScenePass) {
        self.bind_group = Self::bind(
            device,
            scene,
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
        noise: &mut NoisePass,
        scene: &ScenePass,
        min: [f32; 3],
        max: [f32; 3],
    ) -> bool {
        let Some(wanted) = NoiseVolume::covering(min, max) else {
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
        let (storage, bake) = noise.bake(device, wanted);
        self.pending_bake = Some(bake);
        self.volume = storage;
        self.volume_box = Some(wanted);
        self.unbaked = None;
        self.rebind(device, scene);
        true
    }
}
