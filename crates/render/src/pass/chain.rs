//! The passes after the composite: the gallery styles that have a GPU pass (toon, fish-eye,
//! chromatic aberration, painterly), in order, then the edge antialiasing (FXAA) of frames
//! drawn with one sample a pixel, so a frame without MSAA (the kiosk's while the gem turns)
//! has no stair-stepped outline. They ping-pong between two images of the frame's size (the
//! composite writes the first), the last writing the frame's output. The serial styles
//! (dithering, and whatever follows it) run on the CPU after the readback.

use super::common::{self, Built, sampler_entry, texture_entry, uniform_entry};
use super::output::OUTPUT_FORMAT;
use crate::params::{MAX_GPU_STYLES, RenderError};
use crate::shaders;
use crate::styles::{
    ChromaticParams, FishEyeParams, PainterlyParams, Style, ToonParams, chromatic_offsets,
};
use crate::timing::{Stamps, TimedPass};

/// The ping-pong images of a chain (display values, like the output).
pub(crate) const STYLE_FORMAT: wgpu::TextureFormat = OUTPUT_FORMAT;

/// The format the composite writes: the chain's first image when passes follow it
/// (`chained`), else the frame's own `format`.
pub(crate) fn composite_format(chained: bool, format: wgpu::TextureFormat) -> wgpu::TextureFormat {
    if chained { STYLE_FORMAT } else { format }
}

/// How many of `styles`, from the first, have a GPU pass (those before the first serial one).
pub(crate) fn gpu_style_count(styles: &[Style]) -> usize {
    styles.iter().take_while(|s| !s.is_serial()).count()
}

/// A style pass's uniform (`Style` in style_common.wgsl), or `None` for a serial style (done
/// on the CPU: [`Style::is_serial`]).
fn style_uniform(style: Style, time_s: f32) -> Option<[f32; 8]> {
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

/// The styles' and the edge antialiasing's layouts and modules (made with the device) and
/// their pipelines by output format (built on first use), and one style uniform per place in
/// a chain.
pub(crate) struct ChainPasses {
    style_layout: wgpu::BindGroupLayout,
    style_modules: Vec<(Style, wgpu::ShaderModule)>,
    styles: Built<(Style, wgpu::TextureFormat), wgpu::RenderPipeline>,
    style_uniforms: Vec<wgpu::Buffer>,
    edge_aa_layout: wgpu::BindGroupLayout,
    edge_aa_module: wgpu::ShaderModule,
    edge_aa: Built<wgpu::TextureFormat, wgpu::RenderPipeline>,
    sampler: wgpu::Sampler,
}

impl ChainPasses {
    pub fn new(device: &wgpu::Device) -> Self {
        let edge_aa_layout = common::layout(
            device,
            "glyptic edge aa layout",
            &[
                texture_entry(0, true),
                sampler_entry(1, wgpu::ShaderStages::FRAGMENT),
            ],
        );
        let edge_aa_module = common::module(device, "glyptic edge aa", shaders::EDGE_AA);
        let style_layout = common::layout(
            device,
            "glyptic style layout",
            &[
                uniform_entry(0, wgpu::ShaderStages::FRAGMENT),
                texture_entry(1, false),
            ],
        );
        let style_modules = [
            (Style::Toon, shaders::TOON),
            (Style::FishEye, shaders::FISHEYE),
            (Style::Chromatic, shaders::CHROMATIC),
            (Style::Painterly, shaders::PAINTERLY),
        ]
        .into_iter()
        .map(|(style, source)| (style, common::module(device, style.name(), source)))
        .collect();
        let style_uniforms = (0..MAX_GPU_STYLES)
            .map(|_| common::uniform_buffer(device, "glyptic style uniform", 32))
            .collect();
        Self {
            style_layout,
            style_modules,
            styles: Built::default(),
            style_uniforms,
            edge_aa_layout,
            edge_aa_module,
            edge_aa: Built::default(),
            sampler: common::linear_clamp(device, "glyptic linear clamp", false),
        }
    }

    /// The pipelines and uniforms of a chain of `styles` (all with GPU passes), then the
    /// edge antialiasing if `edge_aa`, the last writing `format`.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        styles: &[Style],
        edge_aa: bool,
        format: wgpu::TextureFormat,
        time_s: f32,
    ) -> Result<(), RenderError> {
        if styles.len() > MAX_GPU_STYLES {
            return Err(RenderError::InvalidParams(format!(
                "{} GPU styles in a row; at most {MAX_GPU_STYLES}",
                styles.len(),
            )));
        }
        if edge_aa {
            let (module, layout) = (&self.edge_aa_module, &self.edge_aa_layout);
            self.edge_aa.ensure(format, || {
                common::fullscreen_pipeline(
                    device,
                    "glyptic edge aa pipeline",
                    module,
                    layout,
                    format,
                    &[],
                )
            });
        }
        for (i, &style) in styles.iter().enumerate() {
            let last = i + 1 == styles.len() && !edge_aa;
            let target_format = if last { format } else { STYLE_FORMAT };
            if let Some((_, module)) = self.style_modules.iter().find(|(s, _)| *s == style) {
                let layout = &self.style_layout;
                self.styles.ensure((style, target_format), || {
                    common::fullscreen_pipeline(
                        device,
                        style.name(),
                        module,
                        layout,
                        target_format,
                        &[],
                    )
                });
            }
            if let (Some(u), Some(buffer)) =
                (style_uniform(style, time_s), self.style_uniforms.get(i))
            {
                queue.write_buffer(buffer, 0, bytemuck::cast_slice(&u));
            }
        }
        Ok(())
    }

    /// The GPU styles in order, then the edge antialiasing, ping-ponging between the chain's
    /// images, the last into `chain.final_view`.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        targets: &ChainTargets,
        chain: &Chain<'_>,
        stamps: &mut Stamps<'_>,
    ) -> Result<(), RenderError> {
        let Chain {
            styles,
            edge_aa,
            final_view,
            format,
        } = *chain;
        // Each step: its pipeline, bind group, target and timestamp slot.
        let mut steps = Vec::with_capacity(styles.len() + 1);
        for (i, &style) in styles.iter().enumerate() {
            let last = i + 1 == styles.len() && !edge_aa;
            let (view, target_format) = if last {
                (final_view, format)
            } else {
                (&targets.views[(i + 1) % 2], STYLE_FORMAT)
            };
            let pipeline = self.styles.get((style, target_format)).ok_or_else(|| {
                RenderError::Gpu(format!("no {} pass for {target_format:?}", style.name()))
            })?;
            let group = targets
                .style_groups
                .get(i)
                .ok_or_else(|| RenderError::Gpu(format!("no bind group for style {i}")))?;
            steps.push((pipeline, group, view, TimedPass::Style(style)));
        }
        if edge_aa {
            let pipeline = self
                .edge_aa
                .get(format)
                .ok_or_else(|| RenderError::Gpu(format!("no edge antialiasing for {format:?}")))?;
            let group = &targets.edge_aa_groups[styles.len() % 2];
            steps.push((pipeline, group, final_view, TimedPass::EdgeAa));
        }
        for (pipeline, group, view, timed) in steps {
            let label = match timed {
                TimedPass::EdgeAa => "glyptic edge aa pass",
                _ => "glyptic style pass",
            };
            common::draw_fullscreen(encoder, label, pipeline, group, view, stamps.writes(timed));
        }
        Ok(())
    }
}

/// The passes after the composite and where the last one writes.
#[derive(Clone, Copy)]
pub(crate) struct Chain<'a> {
    pub styles: &'a [Style],
    pub edge_aa: bool,
    pub final_view: &'a wgpu::TextureView,
    pub format: wgpu::TextureFormat,
}

/// The two images a chain passes between (the composite writes the first; pass `i` reads
/// `views[i % 2]`), and each place's bind group (its uniform, its input).
pub(crate) struct ChainTargets {
    pub views: [wgpu::TextureView; 2],
    style_groups: Vec<wgpu::BindGroup>,
    /// The edge antialiasing pass reading `views[0]` or `views[1]` (it runs last).
    edge_aa_groups: [wgpu::BindGroup; 2],
}

impl ChainTargets {
    pub fn new(device: &wgpu::Device, passes: &ChainPasses, width: u32, height: u32) -> Self {
        let size = wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        };
        let views = [0, 1]
            .map(|_| common::pass_image(device, "glyptic style image", STYLE_FORMAT, size, false));
        let style_groups = passes
            .style_uniforms
            .iter()
            .enumerate()
            .map(|(i, uniform)| {
                common::bind_group(
                    device,
                    "glyptic style bind group",
                    &passes.style_layout,
                    &[
                        uniform.as_entire_binding(),
                        wgpu::BindingResource::TextureView(&views[i % 2]),
                    ],
                )
            })
            .collect();
        let edge_aa_groups = [0, 1].map(|i| {
            common::bind_group(
                device,
                "glyptic edge aa bind group",
                &passes.edge_aa_layout,
                &[
                    wgpu::BindingResource::TextureView(&views[i]),
                    wgpu::BindingResource::Sampler(&passes.sampler),
                ],
            )
        });
        Self {
            views,
            style_groups,
            edge_aa_groups,
        }
    }
}
