//! Per-pass GPU times from timestamp queries, where the device has them: each pass of a frame
//! writes a begin and an end stamp into its slot, the frame resolves them after its passes,
//! and the renderer reads them once it has waited for the frame.

use crate::params::MAX_GPU_STYLES;
use crate::styles::Style;

/// GPU time of each pass of the last frame, from timestamp queries (where the device has them).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PassTimes {
    /// The scene pass; in its compute form, the visibility image's draw and the shading.
    pub scene_ms: f64,
    /// Of `scene_ms`, the compute form's shading; `None` in the fragment form.
    pub scene_shade_ms: Option<f64>,
    /// Both blur directions; `None` with SSS off.
    pub sss_ms: Option<f64>,
    pub composite_ms: f64,
    /// The lamp's six shadow-cube faces; `None` without a lamp.
    pub shadow_ms: Option<f64>,
    /// Each style of the chain, in order: its pass's GPU time, or for those done on the CPU
    /// after the readback (from the first serial one on) their wall time.
    pub styles_ms: Vec<(Style, f64)>,
    /// The edge antialiasing pass (frames drawn with one sample a pixel).
    pub edge_aa_ms: Option<f64>,
}

/// Where a renderer's start went (wall time, ms): the API's instance, the adapter's choice
/// (the driver's load included), the device, the pipelines built up front, the surface maps and timer.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct InitTimes {
    /// The graphics API's instance (the Vulkan loader and its drivers' manifests).
    pub instance_ms: f64,
    pub adapter_ms: f64,
    pub device_ms: f64,
    pub pipelines_ms: f64,
    pub rest_ms: f64,
    /// [`crate::Renderer::warm_up`]'s frame, where the caller asked for one.
    pub warm_up_ms: f64,
}

impl std::fmt::Display for InitTimes {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "instance {:.0} ms, adapter {:.0} ms, device {:.0} ms, pipelines {:.0} ms, maps {:.0} ms",
            self.instance_ms, self.adapter_ms, self.device_ms, self.pipelines_ms, self.rest_ms
        )?;
        if self.warm_up_ms > 0.0 {
            write!(f, ", warm-up frame {:.0} ms", self.warm_up_ms)?;
        }
        Ok(())
    }
}

/// A pass with timestamp queries, in the order the frame ran them (its query slots).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum TimedPass {
    Shadow,
    Scene,
    SceneShade,
    Sss,
    Composite,
    Style(Style),
    EdgeAa,
}

/// Timestamp queries around each pass: scene, the SSS passes, composite, the GPU styles.
pub(crate) struct PassTimer {
    queries: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    /// Nanoseconds per timestamp tick.
    period_ns: f64,
}

/// The most passes a frame times: six shadow faces, scene (two in its compute form), two SSS,
/// composite, the edge antialiasing and the GPU styles.
const TIMED_PASSES: u32 = 12 + MAX_GPU_STYLES as u32;

impl PassTimer {
    pub(crate) fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Self {
        let count = 2 * TIMED_PASSES;
        let bytes = u64::from(count) * 8;
        Self {
            queries: device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("glyptic pass times"),
                ty: wgpu::QueryType::Timestamp,
                count,
            }),
            resolve: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("glyptic pass times resolve"),
                size: bytes,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            readback: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("glyptic pass times read"),
                size: bytes,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            period_ns: f64::from(queue.get_timestamp_period()),
        }
    }

    /// The timestamp writes of the next pass, recorded in `passes` (its slot is its place
    /// there: the queries are resolved as one run from 0, so none may be skipped).
    pub(crate) fn writes(
        &self,
        passes: &mut Vec<TimedPass>,
        pass: TimedPass,
    ) -> wgpu::RenderPassTimestampWrites<'_> {
        let index = Self::slot(passes, pass);
        wgpu::RenderPassTimestampWrites {
            query_set: &self.queries,
            beginning_of_pass_write_index: Some(2 * index),
            end_of_pass_write_index: Some(2 * index + 1),
        }
    }

    /// The next pass's slot, recorded in `passes`.
    fn slot(passes: &mut Vec<TimedPass>, pass: TimedPass) -> u32 {
        passes.push(pass);
        passes.len() as u32 - 1
    }

    /// As [`PassTimer::writes`], for a compute pass.
    pub(crate) fn compute_writes(
        &self,
        passes: &mut Vec<TimedPass>,
        pass: TimedPass,
    ) -> wgpu::ComputePassTimestampWrites<'_> {
        let index = Self::slot(passes, pass);
        wgpu::ComputePassTimestampWrites {
            query_set: &self.queries,
            beginning_of_pass_write_index: Some(2 * index),
            end_of_pass_write_index: Some(2 * index + 1),
        }
    }
}

impl PassTimer {
    /// Encodes the resolve of the `passes` a frame timed and their copy into the mappable
    /// buffer. Only what was written is resolved: unwritten queries are an error on some
    /// backends.
    pub(crate) fn resolve(&self, encoder: &mut wgpu::CommandEncoder, passes: usize) {
        let n = 2 * passes as u32;
        encoder.resolve_query_set(&self.queries, 0..n, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.readback, 0, u64::from(n) * 8);
    }

    /// Reads the timestamps of the frame just waited for, which timed `passes` in this order.
    pub(crate) fn read(&self, device: &wgpu::Device, passes: &[TimedPass]) -> Option<PassTimes> {
        let slice = self.readback.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        device.poll(wgpu::PollType::wait_indefinitely()).ok()?;
        let mapped = matches!(rx.try_recv(), Ok(Ok(())));
        let ticks: Option<Vec<u64>> = mapped
            .then(|| {
                slice.get_mapped_range().ok().map(|view| {
                    view.chunks_exact(8)
                        .map(|b| u64::from_le_bytes(b.try_into().unwrap_or([0; 8])))
                        .collect()
                })
            })
            .flatten();
        self.readback.unmap();
        let ticks = ticks?;
        let mut times = PassTimes::default();
        for (slot, pass) in passes.iter().enumerate() {
            let (a, b) = (*ticks.get(2 * slot)?, *ticks.get(2 * slot + 1)?);
            let ms = b.saturating_sub(a) as f64 * self.period_ns / 1e6;
            match *pass {
                TimedPass::Shadow => *times.shadow_ms.get_or_insert(0.0) += ms,
                TimedPass::Scene => times.scene_ms += ms,
                TimedPass::SceneShade => {
                    times.scene_ms += ms;
                    *times.scene_shade_ms.get_or_insert(0.0) += ms;
                }
                TimedPass::Sss => *times.sss_ms.get_or_insert(0.0) += ms,
                TimedPass::Composite => times.composite_ms += ms,
                TimedPass::Style(style) => times.styles_ms.push((style, ms)),
                TimedPass::EdgeAa => *times.edge_aa_ms.get_or_insert(0.0) += ms,
            }
        }
        Some(times)
    }
}

/// The timestamp queries of one frame (none for a window's frame): each pass asks for its
/// writes, which take the next slot.
pub(crate) struct Stamps<'a> {
    pub timer: Option<&'a PassTimer>,
    pub passes: Vec<TimedPass>,
}

impl<'a> Stamps<'a> {
    pub fn writes(&mut self, pass: TimedPass) -> Option<wgpu::RenderPassTimestampWrites<'a>> {
        self.timer.map(|t| t.writes(&mut self.passes, pass))
    }

    pub fn compute_writes(
        &mut self,
        pass: TimedPass,
    ) -> Option<wgpu::ComputePassTimestampWrites<'a>> {
        self.timer.map(|t| t.compute_writes(&mut self.passes, pass))
    }
}
