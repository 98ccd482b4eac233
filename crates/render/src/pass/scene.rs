//! The scene pass: the mesh lit into diffuse (linear Rgba16Float), specular (Rgba16Float) and
//! linear depth with the subsurface-scattering mask, 4x MSAA where the device allows and the
//! frame asks for it, resolved; the engraved band's triangles last, with the engraving's
//! pipeline. Its images cover only the crop of the frame that holds the mesh's projection
//! (`camera::Crop`).
//!
//! Its targets (the crop's size; multisampled when the device allows 4x MSAA with resolve for
//! these formats, then resolved into single-sample textures):
//! * `diffuse` (Rgba16Float): diffuse radiance, linear; alpha = coverage.
//! * `specular` (Rgba16Float): specular radiance, linear; alpha = coverage.
//! * `depth_mask` (Rg16Float): r = linear view depth mapped to [0, 1] over the frame's depth
//!   range, g = subsurface-scattering strength (0 on gold). Both are premultiplied by coverage
//!   (cleared to 0), so divide by `diffuse.a` for the value at a silhouette pixel.
//! * a Depth32Float z-buffer (never sampled: the linear depth above serves later passes, and
//!   works on GL, which cannot sample depth textures in these shaders).
//!
//! Group 0 is the frame's uniform ([`FrameUniform`]); group 1 the surface maps
//! ([`super::maps`]).

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use super::common::{self, Built, Draw, LampAt, texture_entry, uniform_entry};
use super::scene_compute::{self, SceneCompute};
use crate::camera::{Camera, Crop};
use crate::mesh::MeshBuffers;
use crate::params::{RenderError, RenderParams};
use crate::shaders;
use crate::surface::{NoiseVolume, PlanarFrame};
use crate::timing::{Stamps, TimedPass};

pub(crate) const DIFFUSE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub(crate) const SPECULAR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub(crate) const DEPTH_MASK_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg16Float;
pub(crate) const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Ambient light: the room's sky (the 2021 system's 0.2), as the relief's tone match assumes.
const AMBIENT: f32 = glyptic_core::scene::SKY_LIGHT;
/// How much of the key light that passes through a thin part (the mesh's `transmit`) leaves
/// it towards the viewer: light lost at entering and leaving, and to the sides; marble's
/// share, the layered stones' scaled by their scattering.
const TRANSLUCENCY: f32 = 0.6;
/// Intensity of the white key light (raking: the flat ground gets sin 20 degrees of it).
const LIGHT_INTENSITY: f32 = glyptic_core::scene::KEY_LIGHT_INTENSITY;
/// Texture-space units per mm for the marble's veins (a few across a 44 x 56 mm cameo; the
/// 2021 shader used position / 500 on a base about 370 units wide). The noise volume's bake
/// uses it too.
pub(crate) const TEXTURE_SCALE: f32 = 1.0 / 75.0;
/// Shadow comparison: constant depth bias and the percentage-closer filter's radius, mm.
const SHADOW_BIAS_MM: f32 = 0.12;
const SHADOW_PCF_MM: f32 = 0.35;

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
    /// The baked noise: xyz centre of voxel (0, 0, 0) (mm), w 1 / voxel size (1/mm).
    pub volume: [f32; 4],
    /// xyz: 1 / the volume's voxel counts.
    pub volume_texel: [f32; 4],
    /// A layered stone's colours and polish ([`glyptic_core::stone::Layers::uniforms`]).
    pub layers: [[f32; 4]; 5],
    /// The compute form's view rays: the inverse of `view_proj`.
    pub inv_view_proj: [[f32; 4]; 4],
    /// The compute form: x the engraved band's first triangle, y-z the images' size (pixels),
    /// w the most triangles a pixel is shaded with.
    pub shade: [u32; 4],
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

impl SceneVariant {
    /// The scene shader's override constants for this variant (its compute form's too).
    pub fn constants(&self) -> [(&'static str, f64); 3] {
        [
            ("ENGRAVING", f64::from(u8::from(self.engraving))),
            ("LAMP", f64::from(u8::from(self.lamp))),
            ("BAKED_NOISE", f64::from(u8::from(self.baked_noise))),
        ]
    }
}

/// What the frame's steps decided about the surface and the draw.
pub(crate) struct Detail {
    pub planar: PlanarFrame,
    pub lamp: Option<LampAt>,
    /// The band the engraving's parallax search covers (mm inside the outline).
    pub band_mm: Option<[f32; 2]>,
    /// The scene pipelines without and with the engraving.
    pub plain: SceneVariant,
    pub engraved: SceneVariant,
    pub draw: Draw,
}

/// What a frame's scene pass draws into and with: its images, the mesh's buffers, the surface
/// maps' bind group (group 1) and the frame's decisions.
#[derive(Clone, Copy)]
pub(crate) struct SceneInput<'a> {
    pub targets: &'a SceneTargets,
    pub buffers: &'a MeshBuffers,
    pub surface: &'a wgpu::BindGroup,
    pub detail: &'a Detail,
}

/// The scene pass's pipelines by variant (the plain one built at start, the others on first
/// use), its uniform, and the layout and samplers of its surface maps; its compute form where
/// the device has one.
pub(crate) struct ScenePass {
    /// MSAA samples of an antialiased frame (4, or 1 where the device cannot resolve them).
    pub samples: u32,
    variants: Built<SceneVariant, wgpu::RenderPipeline>,
    /// The visibility image and its shading in a compute pass ([`super::scene_compute`]).
    pub compute: Option<SceneCompute>,
    module: wgpu::ShaderModule,
    pipeline_layout: wgpu::PipelineLayout,
    uniform: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    /// Group 1: the engraving's maps, the lamp's shadow cube, the baked noise.
    pub surface_layout: wgpu::BindGroupLayout,
    /// Mipmapped, clamped at the edges: the engraving's maps.
    pub linear_mipmap: wgpu::Sampler,
    /// Depth comparison (less-equal) for the shadow cube, filtered (2x2 PCF where supported).
    pub shadow_sampler: wgpu::Sampler,
}

impl ScenePass {
    /// `compute`: whether to build the pass's compute form (the device has compute shaders,
    /// storage images and the primitive index); `first_compute`: whether the plain pipeline
    /// built now is the compute form's (what a first frame on a GPU that has it will use).
    pub fn new(device: &wgpu::Device, samples: u32, compute: bool, first_compute: bool) -> Self {
        // The compute form's shading reads the uniform and the surface maps too.
        let stages = |s: wgpu::ShaderStages| {
            if compute {
                s | wgpu::ShaderStages::COMPUTE
            } else {
                s
            }
        };
        let seen_by = |e: wgpu::BindGroupLayoutEntry| wgpu::BindGroupLayoutEntry {
            visibility: stages(e.visibility),
            ..e
        };
        let module = common::module(device, "glyptic scene", shaders::SCENE.as_str());
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("glyptic frame uniform"),
            contents: bytemuck::bytes_of(&FrameUniform::zeroed()),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let scene_layout = common::layout(
            device,
            "glyptic scene layout",
            &[uniform_entry(
                0,
                stages(wgpu::ShaderStages::VERTEX_FRAGMENT),
            )],
        );
        let bind_group = common::bind_group(
            device,
            "glyptic scene bind group",
            &scene_layout,
            &[uniform.as_entire_binding()],
        );
        let fragment = wgpu::ShaderStages::FRAGMENT;
        let surface_layout = common::layout(
            device,
            "glyptic surface layout",
            &[
                texture_entry(0, true),
                texture_entry(1, true),
                common::sampler_entry(2, fragment),
                common::texture_of(
                    3,
                    wgpu::TextureSampleType::Depth,
                    wgpu::TextureViewDimension::Cube,
                ),
                wgpu::BindGroupLayoutEntry {
                    binding: 4,
                    visibility: fragment,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison),
                    count: None,
                },
                common::texture_of(
                    5,
                    wgpu::TextureSampleType::Float { filterable: true },
                    wgpu::TextureViewDimension::D3,
                ),
            ]
            .map(seen_by),
        );
        let linear_mipmap = common::linear_clamp(device, "glyptic linear mipmap", true);
        let shadow_sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("glyptic shadow"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            compare: Some(wgpu::CompareFunction::LessEqual),
            ..Default::default()
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("glyptic scene pipeline layout"),
            bind_group_layouts: &[Some(&scene_layout), Some(&surface_layout)],
            immediate_size: 0,
        });
        let compute = compute.then(|| SceneCompute::new(device, &scene_layout, &surface_layout));
        let mut pass = Self {
            samples,
            variants: Built::default(),
            compute,
            module,
            pipeline_layout,
            uniform,
            bind_group,
            surface_layout,
            linear_mipmap,
            shadow_sampler,
        };
        let plain = SceneVariant {
            engraving: false,
            lamp: false,
            samples,
            baked_noise: false,
        };
        match &mut pass.compute {
            Some(form) if first_compute => form.ensure(device, plain),
            _ => pass.ensure(device, plain),
        }
        pass
    }

    /// Builds the pipelines `detail`'s frame draws with, in the compute form (`compute_form`,
    /// where the pass has it) or the fragment form.
    pub fn ensure_for(&mut self, device: &wgpu::Device, detail: &Detail, compute_form: bool) {
        match &mut self.compute {
            Some(compute) if compute_form => compute.ensure(device, SceneCompute::variant(detail)),
            _ => {
                self.ensure(device, detail.plain);
                if detail.band_mm.is_some() {
                    self.ensure(device, detail.engraved);
                }
            }
        }
    }

    /// Builds the pipeline of `variant` if there is none yet.
    pub fn ensure(&mut self, device: &wgpu::Device, variant: SceneVariant) {
        let (module, layout) = (&self.module, &self.pipeline_layout);
        self.variants
            .ensure(variant, || pipeline(device, module, layout, variant));
    }

    fn pipeline(&self, variant: SceneVariant) -> Result<&wgpu::RenderPipeline, RenderError> {
        self.variants
            .get(variant)
            .ok_or_else(|| RenderError::Gpu(format!("no scene pipeline for {variant:?}")))
    }

    /// The frame's uniform: the camera onto the crop's images, the light, the stone, the
    /// engraving's band, the lamp and the baked noise's volume (`volume`, if there is one).
    pub fn write_uniform(
        &self,
        queue: &wgpu::Queue,
        params: &RenderParams,
        cam: &Camera,
        crop: &Crop,
        detail: &Detail,
        volume: Option<NoiseVolume>,
    ) {
        let v4 = |v: glam::Vec3, w: f32| v.extend(w).to_array();
        let planar = &detail.planar;
        let (w, h) = (params.width, params.height);
        let layers = params.material.layers();
        // Onto the crop's images.
        let view_proj = crop.clip_matrix(w, h) * cam.view_proj;
        let frame = FrameUniform {
            // Column-major, as WGSL expects.
            view_proj: view_proj.to_cols_array_2d(),
            eye: v4(cam.eye, 1.0),
            light_dir: v4(
                cam.light,
                LIGHT_INTENSITY * params.lamp.map_or(1.0, |l| l.key_light),
            ),
            cam_right: v4(cam.right, 0.0),
            cam_up: v4(cam.up, 0.0),
            cam_fwd: v4(cam.forward, 0.0),
            marble: [
                params.marble.vein_softness.clamp(0.0, 1.0),
                params.marble.vein_lightness.clamp(0.0, 1.0),
                TEXTURE_SCALE,
                AMBIENT,
            ],
            // z: how much of the light passing through thin parts shows (with the scattering
            // only: it is the same light, travelling further).
            depth: [
                cam.near,
                1.0 / (cam.far - cam.near).max(1e-6),
                params.sss.as_ref().map_or(0.0, |s| {
                    // The glow follows the scattering's strength (the kiosk's slider).
                    let share = s.strength[0] / crate::sss::SssParams::default().strength[0];
                    TRANSLUCENCY * share.clamp(0.0, 2.0) * layers.map_or(1.0, |l| l.scatter)
                }),
                0.0,
            ],
            material: [
                u32::from(layers.is_some()),
                u32::from(params.hair_layer && layers.is_some_and(|l| l.top.is_some())),
                0,
                0,
            ],
            planar: [
                planar.centre[0],
                planar.centre[1],
                planar.half[0],
                planar.half[1],
            ],
            engraving: match (&params.engraving, detail.band_mm) {
                (Some(e), Some([lo, hi])) => [1.0, e.depth_mm, lo, hi],
                _ => [0.0; 4],
            },
            lamp: detail.lamp.map_or([0.0; 4], |l| {
                let p = l.position;
                [p.x, p.y, p.z, l.lamp.intensity]
            }),
            shadow: detail.lamp.map_or([0.0; 4], |l| {
                let centre_mm = l.lamp.offset_mm.iter().map(|c| c * c).sum::<f32>().sqrt();
                [l.far, SHADOW_BIAS_MM, SHADOW_PCF_MM, centre_mm]
            }),
            // Without a volume (no mesh drawn yet) the placeholder's one zero voxel.
            volume: volume.map_or([0.0, 0.0, 0.0, 1.0], |v| {
                [v.origin[0], v.origin[1], v.origin[2], 1.0 / v.voxel_mm]
            }),
            volume_texel: volume.map_or([1.0; 4], |v| {
                [v.dims[0], v.dims[1], v.dims[2], 1].map(|d| 1.0 / d as f32)
            }),
            layers: layers.map_or([[0.0; 4]; 5], |l| l.uniforms()),
            inv_view_proj: view_proj.inverse().to_cols_array_2d(),
            // w: the most triangles a pixel is shaded with (its samples).
            shade: [detail.draw.band_start / 3, crop.width, crop.height, 4],
        };
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&frame));
    }

    /// Encodes the pass: everything but the engraved band with `detail.plain`, the band (if
    /// engraved) with `detail.engraved`; `surface` is group 1.
    pub fn encode(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        input: &SceneInput<'_>,
        stamps: &mut Stamps<'_>,
    ) -> Result<(), RenderError> {
        let SceneInput {
            targets,
            buffers,
            surface,
            detail,
        } = *input;
        if targets.visible.is_some() {
            let compute = self.compute.as_ref().ok_or_else(|| {
                RenderError::Gpu("scene images of the compute form without the form".into())
            })?;
            return compute.encode(device, encoder, input, &self.bind_group, stamps);
        }
        let plain = self.pipeline(detail.plain)?;
        let engraved = match detail.band_mm {
            Some(_) => Some(self.pipeline(detail.engraved)?),
            None => None,
        };
        let d = detail.draw;
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("glyptic scene pass"),
            color_attachments: &[
                Some(targets.diffuse.attachment()),
                Some(targets.specular.attachment()),
                Some(targets.depth_mask.attachment()),
            ],
            depth_stencil_attachment: Some(common::cleared_depth(
                &targets.depth,
                wgpu::StoreOp::Discard,
            )),
            timestamp_writes: stamps.writes(TimedPass::Scene),
            ..Default::default()
        });
        pass.set_pipeline(plain);
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.set_bind_group(1, surface, &[]);
        common::bind_mesh(&mut pass, buffers, &d, true);
        pass.draw_indexed(0..d.band_start, 0, 0..1);
        if let Some(engraved) = engraved
            && d.band_start < d.count
        {
            pass.set_pipeline(engraved);
            pass.draw_indexed(d.band_start..d.count, 0, 0..1);
        }
        Ok(())
    }
}

fn pipeline(
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
    common::mesh_pipeline(
        device,
        &common::MeshPipeline {
            label: "glyptic scene pipeline",
            layout,
            module,
            entries: ["vs_main", "fs_main"],
            constants: &variant.constants(),
            buffers: &[
                Some(common::vertices(&attributes)),
                // Tangent frames (surface::tangents), a buffer of their own: only frames with
                // the engraving compute them.
                Some(wgpu::VertexBufferLayout {
                    array_stride: 16,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &wgpu::vertex_attr_array![5 => Float32x4],
                }),
            ],
            depth: DEPTH_FORMAT,
            samples: variant.samples,
            targets: &[
                common::color_target(DIFFUSE_FORMAT),
                common::color_target(SPECULAR_FORMAT),
                common::color_target(DEPTH_MASK_FORMAT),
            ],
        },
    )
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

/// A scene-pass colour target: the single-sample texture later passes read, and, with MSAA, the
/// multisampled texture drawn into and resolved from.
pub(crate) struct ColorTarget {
    /// Single-sample view (keeps its texture alive).
    pub view: wgpu::TextureView,
    pub msaa: Option<wgpu::TextureView>,
}

/// Usage of a texture only drawn into (an MSAA image, the z-buffer).
const DRAWN_INTO: wgpu::TextureUsages = wgpu::TextureUsages::RENDER_ATTACHMENT;

impl ColorTarget {
    fn new(
        device: &wgpu::Device,
        label: &str,
        format: wgpu::TextureFormat,
        size: wgpu::Extent3d,
        samples: u32,
    ) -> Self {
        let view = common::pass_image(device, label, format, size, false);
        let msaa = (samples > 1)
            .then(|| common::image(device, label, format, size, (samples, DRAWN_INTO)));
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

/// The scene pass's images, the crop's size.
pub(crate) struct SceneTargets {
    /// Width and height (at most the frame's).
    pub size: [u32; 2],
    /// MSAA samples.
    pub samples: u32,
    pub diffuse: ColorTarget,
    pub specular: ColorTarget,
    pub depth_mask: ColorTarget,
    pub depth: wgpu::TextureView,
    /// The compute form's visibility image (`samples` a pixel); `None` in the fragment form.
    pub visible: Option<wgpu::TextureView>,
}

impl SceneTargets {
    /// Sizes must have been checked against the device limits by the caller. `compute`: the
    /// pass's compute form (a visibility image drawn, the three images written as storage).
    pub fn new(device: &wgpu::Device, size: [u32; 2], samples: u32, compute: bool) -> Self {
        let extent = wgpu::Extent3d {
            width: size[0],
            height: size[1],
            depth_or_array_layers: 1,
        };
        let target = |label, format| {
            if compute {
                ColorTarget {
                    view: common::pass_image(device, label, format, extent, true),
                    msaa: None,
                }
            } else {
                ColorTarget::new(device, label, format, extent, samples)
            }
        };
        let depth_mask_format = if compute {
            scene_compute::DEPTH_MASK_FORMAT
        } else {
            DEPTH_MASK_FORMAT
        };
        Self {
            size,
            samples,
            diffuse: target("glyptic diffuse", DIFFUSE_FORMAT),
            specular: target("glyptic specular", SPECULAR_FORMAT),
            depth_mask: target("glyptic depth+mask", depth_mask_format),
            visible: compute.then(|| {
                common::image(
                    device,
                    "glyptic visibility",
                    scene_compute::VISIBLE_FORMAT,
                    extent,
                    (samples, DRAWN_INTO | wgpu::TextureUsages::TEXTURE_BINDING),
                )
            }),
            depth: common::image(
                device,
                "glyptic z-buffer",
                DEPTH_FORMAT,
                extent,
                (samples, DRAWN_INTO),
            ),
        }
    }

    pub fn extent(&self) -> wgpu::Extent3d {
        wgpu::Extent3d {
            width: self.size[0],
            height: self.size[1],
            depth_or_array_layers: 1,
        }
    }
}
