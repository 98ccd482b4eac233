//! The composite pass: diffuse (blurred by the SSS pass or not) + specular over the backdrop
//! (a gentle top-light gradient and vignette round the background colour), the highlight's
//! shoulder, sRGB encoding, into the frame's output (Rgba8Unorm: the shader encodes) or a
//! window's view. The scene's images cover only the crop, which it places in the frame; the
//! backdrop round it is painted without reading them. Into the output image alone it may run
//! as a compute pass (8 x 8 pixels a workgroup).

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use super::common::{self, Built, for_compute, texture_entry, uniform_entry};
use super::output::OUTPUT_FORMAT;
use super::scene::SceneTargets;
use super::sss::SssTargets;
use crate::camera::Crop;
use crate::params::{RenderError, RenderParams};
use crate::shaders;
use crate::timing::{Stamps, TimedPass};

/// Exposure, vignette strength, vertical gradient strength, dither (8-bit steps).
const COMPOSITE_PARAMS: [f32; 4] = [1.0, 0.45, 0.35, 1.0];

/// Uniforms of the composite pass; mirrors `Composite` in `composite.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct CompositeUniform {
    background: [f32; 4],
    params: [f32; 4],
    /// The scene images' place in the frame: x, y of their top left, their width, height (px).
    crop: [f32; 4],
    /// The frame's width, height (px); zw unused.
    size: [f32; 4],
}

/// sRGB transfer function, decoding (display value -> linear light).
fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The composite's pipelines by output format and backdrop (the image's built at start, a
/// window's on first use), its compute form where the device has compute, and its uniform.
pub(crate) struct CompositePass {
    /// By (format, transparent).
    pipelines: Built<(wgpu::TextureFormat, bool), wgpu::RenderPipeline>,
    module: wgpu::ShaderModule,
    layout: wgpu::BindGroupLayout,
    uniform: wgpu::Buffer,
    /// The compute form's layout, made with the device (the output image is made a storage
    /// image for it), and its pipelines by transparency, built on first use.
    compute_layout: Option<wgpu::BindGroupLayout>,
    compute: Built<bool, wgpu::ComputePipeline>,
}

impl CompositePass {
    pub fn new(device: &wgpu::Device, compute: bool) -> Self {
        let module = common::module(device, "glyptic composite", shaders::COMPOSITE);
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("glyptic composite uniform"),
            contents: bytemuck::bytes_of(&CompositeUniform::zeroed()),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let entries = [
            uniform_entry(0, wgpu::ShaderStages::FRAGMENT),
            texture_entry(1, false),
            texture_entry(2, false),
        ];
        let layout = common::layout(device, "glyptic composite layout", &entries);
        let compute_layout = compute.then(|| {
            let mut entries: Vec<_> = entries.into_iter().map(for_compute).collect();
            entries.push(common::storage_entry(
                3,
                OUTPUT_FORMAT,
                wgpu::TextureViewDimension::D2,
            ));
            common::layout(device, "glyptic composite compute layout", &entries)
        });
        let mut pass = Self {
            pipelines: Built::default(),
            module,
            layout,
            uniform,
            compute_layout,
            compute: Built::default(),
        };
        pass.ensure(device, OUTPUT_FORMAT, false);
        pass
    }

    /// Whether the output image must be a storage image (the compute form exists).
    pub fn has_compute(&self) -> bool {
        self.compute_layout.is_some()
    }

    /// Builds the pipeline for `format`, with the backdrop or without (`transparent`: the
    /// shader's `TRANSPARENT`), if there is none yet.
    pub fn ensure(
        &mut self,
        device: &wgpu::Device,
        format: wgpu::TextureFormat,
        transparent: bool,
    ) {
        let (module, layout) = (&self.module, &self.layout);
        self.pipelines.ensure((format, transparent), || {
            common::fullscreen_pipeline(
                device,
                "glyptic composite pipeline",
                module,
                layout,
                format,
                &[("TRANSPARENT", f64::from(u8::from(transparent)))],
            )
        });
    }

    /// Builds the compute form (`transparent` or not) if there is none yet and the device has
    /// compute.
    pub fn ensure_compute(&mut self, device: &wgpu::Device, transparent: bool) {
        let (Some(layout), module) = (&self.compute_layout, &self.module) else {
            return;
        };
        self.compute.ensure(transparent, || {
            common::compute_pipeline(
                device,
                "glyptic composite compute",
                module,
                layout,
                &[("TRANSPARENT", f64::from(u8::from(transparent)))],
            )
        });
    }

    /// The compute form for this frame's backdrop, if built.
    pub fn compute(&self, transparent: bool) -> Option<&wgpu::ComputePipeline> {
        self.compute.get(transparent)
    }

    /// The backdrop and where the scene's crop lies in the frame.
    pub fn write_uniform(&self, queue: &wgpu::Queue, params: &RenderParams, crop: &Crop) {
        let composite = CompositeUniform {
            background: {
                let [r, g, b] = params.background.map(|c| srgb_to_linear(c.clamp(0.0, 1.0)));
                [r, g, b, 1.0]
            },
            params: COMPOSITE_PARAMS,
            crop: [crop.x, crop.y, crop.width, crop.height].map(|v| v as f32),
            size: [params.width as f32, params.height as f32, 0.0, 0.0],
        };
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&composite));
    }

    /// The fragment form into `view` (of `format`), reading the blurred diffuse with `sss`.
    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        targets: &CompositeTargets,
        format: wgpu::TextureFormat,
        view: &wgpu::TextureView,
        sss: bool,
        transparent: bool,
        stamps: &mut Stamps<'_>,
    ) -> Result<(), RenderError> {
        let pipeline = self
            .pipelines
            .get((format, transparent))
            .ok_or_else(|| RenderError::Gpu(format!("no composite pipeline for {format:?}")))?;
        let group = &targets.bind_groups[usize::from(sss)];
        common::draw_fullscreen(
            encoder,
            "glyptic composite pass",
            pipeline,
            group,
            view,
            stamps.writes(TimedPass::Composite),
        );
        Ok(())
    }

    /// The compute form into the output image (`size` pixels), if it and its bind groups were
    /// built; false where the fragment form must run instead.
    pub fn encode_compute(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        targets: &CompositeTargets,
        size: [u32; 2],
        sss: bool,
        transparent: bool,
        stamps: &mut Stamps<'_>,
    ) -> bool {
        let (Some(pipeline), Some(groups)) =
            (self.compute(transparent), &targets.compute_bind_groups)
        else {
            return false;
        };
        common::dispatch_image(
            encoder,
            "glyptic composite compute pass",
            pipeline,
            &groups[usize::from(sss)],
            size,
            stamps.compute_writes(TimedPass::Composite),
        );
        true
    }
}

/// The composite's inputs: the scene's diffuse (SSS off) or the blurred one (SSS on), each with
/// the specular; the compute form's also bind the output image they write.
pub(crate) struct CompositeTargets {
    /// SSS off, on.
    bind_groups: [wgpu::BindGroup; 2],
    compute_bind_groups: Option<[wgpu::BindGroup; 2]>,
}

impl CompositeTargets {
    pub fn new(
        device: &wgpu::Device,
        pass: &CompositePass,
        scene: &SceneTargets,
        sss: &SssTargets,
        output: &wgpu::TextureView,
    ) -> Self {
        let group = |label,
                     layout: &wgpu::BindGroupLayout,
                     diffuse: &wgpu::TextureView,
                     output: Option<&wgpu::TextureView>| {
            let mut resources = vec![
                pass.uniform.as_entire_binding(),
                wgpu::BindingResource::TextureView(diffuse),
                wgpu::BindingResource::TextureView(&scene.specular.view),
            ];
            resources.extend(output.map(wgpu::BindingResource::TextureView));
            common::bind_group(device, label, layout, &resources)
        };
        let (diffuse, blurred) = (&scene.diffuse.view, &sss.out);
        Self {
            bind_groups: [
                group("glyptic composite bind group", &pass.layout, diffuse, None),
                group("glyptic composite (sss)", &pass.layout, blurred, None),
            ],
            compute_bind_groups: pass.compute_layout.as_ref().map(|layout| {
                [
                    group("glyptic composite compute", layout, diffuse, Some(output)),
                    group(
                        "glyptic composite compute (sss)",
                        layout,
                        blurred,
                        Some(output),
                    ),
                ]
            }),
        }
    }
}
