//! The subsurface-scattering pass (when the frame asks for it): the scene pass's resolved
//! diffuse alone is blurred horizontally into `temp`, then vertically into `out` (both
//! Rgba16Float, coverage kept in alpha), with the kernel of [`crate::sss`], reading the scene's
//! depth and mask; the 2021 system found that blurring the highlights too made the stone look
//! hazy. Two full-screen draws with one pipeline, or the same blur as two compute dispatches
//! (8 x 8 pixels a workgroup) where the device has compute.

use super::common::{self, for_compute, texture_entry, uniform_entry};
use super::scene::SceneTargets;
use crate::camera::{Camera, FOV_Y_DEG};
use crate::params::{RenderError, RenderParams};
use crate::shaders;
use crate::sss::{Kernel, MAX_TAPS};
use crate::timing::{Stamps, TimedPass};

pub(crate) const SSS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// Uniforms of one direction; mirrors `Sss` in `sss.wgsl`: params, dir, then [`MAX_TAPS`]
/// taps (rgb weight, offset), as floats.
const SSS_UNIFORM_FLOATS: usize = 4 * (2 + MAX_TAPS);

/// The `Sss` uniform's contents for one direction.
fn uniform(
    kernel: &Kernel,
    radius_mm: f32,
    px_per_mm_at_1mm: f32,
    near: f32,
    range: f32,
    dir: [f32; 2],
) -> Vec<f32> {
    let mut u = vec![0.0f32; SSS_UNIFORM_FLOATS];
    u[..4].copy_from_slice(&[radius_mm, px_per_mm_at_1mm, near, range]);
    let taps = kernel.taps.len().min(MAX_TAPS);
    u[4..8].copy_from_slice(&[dir[0], dir[1], taps as f32, kernel.range]);
    for (slot, t) in u[8..].chunks_exact_mut(4).zip(&kernel.taps) {
        slot.copy_from_slice(&[t.weight[0], t.weight[1], t.weight[2], t.offset]);
    }
    u
}

/// The blur's pipeline (and its compute form where the device has one), the two directions'
/// uniforms and the sampler of its colour input.
pub(crate) struct SssPass {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    /// The same blur as a compute pass and its layout (the fragment pass's bindings and the
    /// storage image it writes), where the device has compute shaders.
    compute: Option<(wgpu::ComputePipeline, wgpu::BindGroupLayout)>,
    /// Horizontal and vertical.
    uniforms: [wgpu::Buffer; 2],
    sampler: wgpu::Sampler,
}

impl SssPass {
    pub fn new(device: &wgpu::Device, compute: bool) -> Self {
        let module = common::module(device, "glyptic sss", shaders::SSS);
        let fragment = wgpu::ShaderStages::FRAGMENT;
        let entries = [
            uniform_entry(0, fragment),
            texture_entry(1, true),
            texture_entry(2, false),
            common::sampler_entry(3, fragment),
        ];
        let layout = common::layout(device, "glyptic sss layout", &entries);
        let pipeline = common::fullscreen_pipeline(
            device,
            "glyptic sss pipeline",
            &module,
            &layout,
            SSS_FORMAT,
            &[],
        );
        let compute = compute.then(|| {
            let mut entries: Vec<_> = entries.into_iter().map(for_compute).collect();
            entries.push(common::storage_entry(
                4,
                SSS_FORMAT,
                wgpu::TextureViewDimension::D2,
            ));
            let layout = common::layout(device, "glyptic sss compute layout", &entries);
            let pipeline =
                common::compute_pipeline(device, "glyptic sss compute", &module, &layout, &[]);
            (pipeline, layout)
        });
        let bytes = (SSS_UNIFORM_FLOATS * 4) as u64;
        Self {
            pipeline,
            layout,
            compute,
            uniforms: [
                common::uniform_buffer(device, "glyptic sss horizontal", bytes),
                common::uniform_buffer(device, "glyptic sss vertical", bytes),
            ],
            sampler: common::linear_clamp(device, "glyptic linear clamp", false),
        }
    }

    /// Whether the blur has a compute form on this device.
    pub fn has_compute(&self) -> bool {
        self.compute.is_some()
    }

    /// The two directions' kernels for this frame; false (and nothing written) with the
    /// scattering off.
    pub fn write_uniforms(
        &self,
        queue: &wgpu::Queue,
        params: &RenderParams,
        cam: &Camera,
    ) -> Result<bool, RenderError> {
        let Some(p) = &params.sss else {
            return Ok(false);
        };
        let kernel = crate::sss::kernel(p)
            .map_err(|e| RenderError::InvalidParams(format!("subsurface scattering: {e}")))?;
        let px_per_mm = 0.5 * params.height as f32 / (0.5 * FOV_Y_DEG).to_radians().tan();
        for (buffer, dir) in self.uniforms.iter().zip([[1.0, 0.0], [0.0, 1.0]]) {
            let u = uniform(
                &kernel,
                p.width_mm,
                px_per_mm,
                cam.near,
                cam.far - cam.near,
                dir,
            );
            queue.write_buffer(buffer, 0, bytemuck::cast_slice(&u));
        }
        Ok(true)
    }

    /// Both directions into `targets`, as compute passes where `compute` asks for them and
    /// they were built.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        targets: &SssTargets,
        compute: bool,
        stamps: &mut Stamps<'_>,
    ) {
        if let (true, Some((pipeline, _)), Some(groups)) =
            (compute, &self.compute, &targets.compute_bind_groups)
        {
            for group in groups {
                common::dispatch_image(
                    encoder,
                    "glyptic sss compute pass",
                    pipeline,
                    group,
                    targets.size,
                    stamps.compute_writes(TimedPass::Sss),
                );
            }
            return;
        }
        let outputs = [&targets.temp, &targets.out];
        for (group, output) in targets.bind_groups.iter().zip(outputs) {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("glyptic sss pass"),
                color_attachments: &[common::overwrite(output, wgpu::Color::TRANSPARENT)],
                timestamp_writes: stamps.writes(TimedPass::Sss),
                ..Default::default()
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, group, &[]);
            pass.draw(0..3, 0..1);
        }
    }
}

/// The blur's images (the scene's crop size) and each direction's bind group.
pub(crate) struct SssTargets {
    size: [u32; 2],
    temp: wgpu::TextureView,
    /// The blurred diffuse, which the composite reads.
    pub out: wgpu::TextureView,
    /// Horizontal (diffuse -> temp) and vertical (temp -> out) inputs.
    bind_groups: [wgpu::BindGroup; 2],
    /// The same for the compute pass, each with its output image (where it is built).
    compute_bind_groups: Option<[wgpu::BindGroup; 2]>,
}

impl SssTargets {
    pub fn new(device: &wgpu::Device, pass: &SssPass, scene: &SceneTargets) -> Self {
        let size = scene.extent();
        // Written as storage images where the blur can run as a compute pass.
        let storage = pass.compute.is_some();
        let temp = common::pass_image(device, "glyptic sss temp", SSS_FORMAT, size, storage);
        let out = common::pass_image(device, "glyptic sss out", SSS_FORMAT, size, storage);
        // The blur's inputs; the compute form also binds the image it writes (4).
        let group = |label,
                     layout: &wgpu::BindGroupLayout,
                     uniform: &wgpu::Buffer,
                     colour: &wgpu::TextureView,
                     output: Option<&wgpu::TextureView>| {
            let mut resources = vec![
                uniform.as_entire_binding(),
                wgpu::BindingResource::TextureView(colour),
                wgpu::BindingResource::TextureView(&scene.depth_mask.view),
                wgpu::BindingResource::Sampler(&pass.sampler),
            ];
            resources.extend(output.map(wgpu::BindingResource::TextureView));
            common::bind_group(device, label, layout, &resources)
        };
        let [uh, uv] = &pass.uniforms;
        let diffuse = &scene.diffuse.view;
        let bind_groups = [
            group("glyptic sss horizontal", &pass.layout, uh, diffuse, None),
            group("glyptic sss vertical", &pass.layout, uv, &temp, None),
        ];
        let compute_bind_groups = pass.compute.as_ref().map(|(_, layout)| {
            [
                group(
                    "glyptic sss compute horizontal",
                    layout,
                    uh,
                    diffuse,
                    Some(&temp),
                ),
                group(
                    "glyptic sss compute vertical",
                    layout,
                    uv,
                    &temp,
                    Some(&out),
                ),
            ]
        });
        Self {
            size: scene.size,
            temp,
            out,
            bind_groups,
            compute_bind_groups,
        }
    }
}
