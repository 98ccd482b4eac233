//! One frame, built in steps: the targets and buffers sized for it ([`Frames::prepare`]), the
//! surface detail it asks for and the mesh upload ([`Frames::upload_mesh`]), each pass's
//! uniforms, then each pass's encode step, in the order the crate's docs
//! list them ([`crate::pass`]). What frames reuse lives here, between them: the passes'
//! pipelines, the targets (made again only when the size or crop changes), the mesh buffers
//! (grown only when a mesh does not fit), the surface maps. Units: millimetres on the stone,
//! pixels on the targets.

use crate::camera::{self, Crop};
use crate::mesh::{self, MeshBuffers};
use crate::params::{RenderError, RenderParams};
use crate::pass::Passes;
use crate::pass::chain::{Chain, ChainTargets, composite_format, gpu_style_count};
use crate::pass::common::{Draw, LampAt};
use crate::pass::composite::CompositeTargets;
use crate::pass::maps::SurfaceMaps;
use crate::pass::output::{OUTPUT_FORMAT, OutputImage};
use crate::pass::scene::{Detail, SceneInput, SceneTargets, SceneVariant};
use crate::pass::scene_compute;
use crate::pass::sss::SssTargets;
use crate::surface;
use crate::timing::{PassTimer, Stamps, TimedPass};
use glyptic_core::scene::Mesh;

/// Where a frame's composite goes.
#[derive(Clone, Copy)]
pub(crate) enum Output<'a> {
    /// The renderer's own image, read back.
    Image,
    /// A caller's texture view (a window's surface), in a format without sRGB encoding.
    View(&'a wgpu::TextureView, wgpu::TextureFormat),
}

/// The device and what a frame may use of it.
pub(crate) struct Gpu<'a> {
    pub device: &'a wgpu::Device,
    pub queue: &'a wgpu::Queue,
    pub max_buffer_size: u64,
    /// Timestamps, for an image's frame only (read back after it; `None` for a view's).
    pub timer: Option<&'a PassTimer>,
    /// Whether the passes with a compute form run as compute passes.
    pub compute_passes: bool,
    /// Whether the scene pass runs in its compute form (where the device has it and the mesh
    /// suits it).
    pub compute_scene: bool,
    /// The device's largest storage-buffer binding (bytes): the compute form reads the mesh so.
    pub max_storage_binding: u64,
    /// Whether the slowly varying noise may be baked once a mesh is drawn a second time.
    pub noise_baking: bool,
}

/// The engraving's per-mesh data (triangles reordered band last, tangent frames), kept while
/// the mesh, its planar frame and the band stay the same: the kiosk redraws one gem for every
/// step of an orbit.
struct EngravedMesh {
    key: (u64, surface::PlanarFrame, [f32; 2]),
    indices: Vec<u32>,
    band_start: usize,
    tangents: Vec<[f32; 4]>,
}

/// Everything sized by the frame: the output and its readback at the frame's size, the scene
/// and SSS images at the crop's ([`crate::camera::Crop`]: the part of the frame the gem covers),
/// which the composite places in the frame.
pub(crate) struct Targets {
    pub width: u32,
    pub height: u32,
    scene: SceneTargets,
    sss: SssTargets,
    composite: CompositeTargets,
    pub output: OutputImage,
}

impl Targets {
    /// Sizes must have been checked against the device limits by the caller.
    fn new(
        device: &wgpu::Device,
        passes: &Passes,
        (width, height): (u32, u32),
        scene: [u32; 2],
        samples: u32,
        compute_scene: bool,
    ) -> Self {
        let scene = SceneTargets::new(device, scene, samples, compute_scene);
        let sss = SssTargets::new(device, &passes.sss, &scene);
        let output = OutputImage::new(device, width, height, passes.composite.has_compute());
        let composite =
            CompositeTargets::new(device, &passes.composite, &scene, &sss, &output.view);
        Self {
            width,
            height,
            scene,
            sss,
            composite,
            output,
        }
    }
}

/// What one frame after another reuses.
pub(crate) struct Frames {
    pub passes: Passes,
    targets: Option<Targets>,
    /// Images and bind groups of a chain after the composite, made on the first frame that
    /// has one.
    chain: Option<ChainTargets>,
    mesh_buffers: Option<MeshBuffers>,
    /// The engraving's maps, the shadow cube, the baked noise (placeholders until a frame
    /// needs them).
    surface: SurfaceMaps,
    engraved_mesh: Option<EngravedMesh>,
    /// The passes the last frame timed, in query-slot order.
    pub timed: Vec<TimedPass>,
}

impl Frames {
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, passes: Passes) -> Self {
        let surface = SurfaceMaps::new(device, queue, &passes.scene);
        Self {
            passes,
            targets: None,
            chain: None,
            mesh_buffers: None,
            surface,
            engraved_mesh: None,
            timed: Vec::new(),
        }
    }

    /// Drops what a GPU error may have spoiled (e.g. a failed allocation): everything is made
    /// afresh by the next frame.
    pub fn reset(&mut self, device: &wgpu::Device, queue: &wgpu::Queue) {
        self.targets = None;
        self.chain = None;
        self.mesh_buffers = None;
        self.surface = SurfaceMaps::new(device, queue, &self.passes.scene);
    }

    /// Drops the targets (a readback buffer left in a mapping state, say).
    pub fn drop_targets(&mut self) {
        self.targets = None;
    }

    /// The last frame's output image.
    pub fn output(&self) -> Option<&OutputImage> {
        self.targets.as_ref().map(|t| &t.output)
    }

    /// MSAA samples of this frame's scene pass: the device's with antialiasing, else 1.
    fn samples(&self, params: &RenderParams) -> u32 {
        if params.antialias {
            self.passes.scene.samples
        } else {
            1
        }
    }

    /// Uploads the mesh and the frame's uniforms and encodes the passes, the composite (or
    /// the last style) into `output`. Timestamps only for an image (read back after).
    pub fn encode(
        &mut self,
        gpu: &Gpu<'_>,
        encoder: &mut wgpu::CommandEncoder,
        mesh: &Mesh,
        bounds: &mesh::Bounds,
        params: &RenderParams,
        output: Output<'_>,
    ) -> Result<(), RenderError> {
        let format = match output {
            Output::Image => OUTPUT_FORMAT,
            Output::View(_, format) => format,
        };
        let cam = camera::orbit(
            bounds,
            params.yaw_deg,
            params.pitch_deg,
            params.zoom,
            params.width,
            params.height,
        );
        // Where the mesh lies in the frame: the scene and SSS passes draw only there.
        let mesh_box = camera::mesh_box(
            &cam.view_proj,
            mesh.vertices.iter().map(|v| v.position),
            params.width,
            params.height,
        );
        let (gpu_styles, edge_aa) = self.prepare(gpu, mesh, params, output, format, mesh_box)?;
        let crop = match &self.targets {
            Some(t) => Crop::around(mesh_box, t.scene.size, params.width, params.height),
            None => return Err(RenderError::Gpu("frame resources missing".into())),
        };
        let detail = self.upload_mesh(gpu, mesh, bounds, params)?;
        let passes = &self.passes;
        let volume = self.surface.volume_box;
        let queue = gpu.queue;
        passes
            .scene
            .write_uniform(queue, params, &cam, &crop, &detail, volume);
        passes.composite.write_uniform(queue, params, &crop);
        let sss = passes.sss.write_uniforms(queue, params, &cam)?;

        let (Some(targets), Some(buffers)) = (&self.targets, &self.mesh_buffers) else {
            return Err(RenderError::Gpu("frame resources missing".into()));
        };
        let image = matches!(output, Output::Image);
        let mut stamps = Stamps {
            timer: gpu.timer,
            passes: Vec::new(),
        };
        if let Some(bake) = &self.surface.pending_bake {
            passes.noise.encode(encoder, bake)?;
        }
        if detail.lamp.is_some() {
            let faces = &self.surface.shadow_faces;
            passes
                .shadow
                .encode(encoder, faces, buffers, detail.draw, &mut stamps);
        }
        let surface = &self.surface.bind_group;
        let input = SceneInput {
            targets: &targets.scene,
            buffers,
            surface,
            detail: &detail,
        };
        passes
            .scene
            .encode(gpu.device, encoder, &input, &mut stamps)?;
        if sss {
            passes
                .sss
                .encode(encoder, &targets.sss, gpu.compute_passes, &mut stamps);
        }
        let final_view = match output {
            Output::Image => &targets.output.view,
            Output::View(view, _) => view,
        };
        let styles = &params.styles[..gpu_styles];
        let chain = self
            .chain
            .as_ref()
            .filter(|_| !styles.is_empty() || edge_aa);
        // Into the output image alone, the composite may run as a compute pass.
        let composed = image
            && chain.is_none()
            && gpu.compute_passes
            && passes.composite.encode_compute(
                encoder,
                &targets.composite,
                [targets.width, targets.height],
                sss,
                params.transparent,
                &mut stamps,
            );
        if !composed {
            // With passes after it the composite writes the chain's first image.
            let view = chain.map_or(final_view, |c| &c.views[0]);
            passes.composite.encode(
                encoder,
                &targets.composite,
                composite_format(chain.is_some(), format),
                view,
                sss,
                params.transparent,
                &mut stamps,
            )?;
        }
        if let Some(chain_targets) = chain {
            let chain = Chain {
                styles,
                edge_aa,
                final_view,
                format,
            };
            passes
                .chain
                .encode(encoder, chain_targets, &chain, &mut stamps)?;
        }
        self.timed = stamps.passes;
        // Recorded: the volume is baked when this frame runs.
        self.surface.pending_bake = None;
        Ok(())
    }

    /// Targets, mesh buffers and the chain's pipelines and uniforms sized for this frame;
    /// returns how many styles run on the GPU and whether the edge antialiasing runs (after
    /// them: on every frame drawn with one sample a pixel).
    fn prepare(
        &mut self,
        gpu: &Gpu<'_>,
        mesh: &Mesh,
        params: &RenderParams,
        output: Output<'_>,
        format: wgpu::TextureFormat,
        mesh_box: [u32; 4],
    ) -> Result<(usize, bool), RenderError> {
        let device = gpu.device;
        let (w, h) = (params.width, params.height);
        let samples = self.samples(params);
        // The styles the GPU does: those before the first done on the CPU.
        let gpu_styles = &params.styles[..gpu_style_count(&params.styles)];
        if matches!(output, Output::View(..)) && gpu_styles.len() < params.styles.len() {
            return Err(RenderError::InvalidParams(
                "dithering runs on the CPU after a readback: a window's frame takes toon, \
                 painterly, fisheye and chromatic only"
                    .into(),
            ));
        }
        let edge_aa = samples == 1;
        let chained = !gpu_styles.is_empty() || edge_aa;
        let composite_format = composite_format(chained, format);
        self.passes
            .composite
            .ensure(device, composite_format, params.transparent);
        if gpu.compute_passes && matches!(output, Output::Image) {
            self.passes
                .composite
                .ensure_compute(device, params.transparent);
        }
        let vb = std::mem::size_of_val(mesh.vertices.as_slice()) as u64;
        let ib = std::mem::size_of_val(mesh.indices.as_slice()) as u64;
        let compute_scene = gpu.compute_scene
            && self.passes.scene.compute.is_some()
            && (mesh.indices.len() / 3) as u64 <= scene_compute::MAX_TRIANGLES
            && vb.max(ib) <= gpu.max_storage_binding;
        let scene = Crop::size_for(mesh_box, w, h);
        // The scene images are kept while the mesh's box fits them and they are no more than
        // a step larger than it needs (a turning gem's box changes size every frame).
        let fits = |t: &Targets| {
            (0..2).all(|a| {
                let needed = mesh_box[a + 2] - mesh_box[a];
                t.scene.size[a] >= needed && t.scene.size[a] <= scene[a] + camera::CROP_STEP_PX
            })
        };
        let resized = self
            .targets
            .as_ref()
            .is_none_or(|t| t.width != w || t.height != h);
        if resized
            || self.targets.as_ref().is_some_and(|t| {
                t.scene.samples != samples || t.scene.visible.is_some() != compute_scene || !fits(t)
            })
        {
            // Drop the old targets first so both sets are never alive at once; the chain's
            // images have the frame's size and outlive a new crop or sample count.
            self.targets = None;
            if resized {
                self.chain = None;
            }
            self.targets = Some(Targets::new(
                device,
                &self.passes,
                (w, h),
                scene,
                samples,
                compute_scene,
            ));
        }
        if self.mesh_buffers.as_ref().is_none_or(|b| !b.fits(vb, ib)) {
            self.mesh_buffers = None;
            // Readable by the compute form wherever the device has it.
            let storage = self.passes.scene.compute.is_some();
            self.mesh_buffers = Some(MeshBuffers::new(
                device,
                vb,
                ib,
                gpu.max_buffer_size,
                storage,
            ));
        }
        self.passes.chain.prepare(
            device,
            gpu.queue,
            gpu_styles,
            edge_aa,
            format,
            params.style_time_s,
        )?;
        if chained && self.chain.is_none() {
            self.chain = Some(ChainTargets::new(device, &self.passes.chain, w, h));
        }
        Ok((gpu_styles.len(), edge_aa))
    }

    /// Surface detail, made only when a frame asks for it (the engraving's maps, again only
    /// when the mesh's planar frame or the parameters change; the shadow cube and its
    /// uniforms), the scene pipelines, and the mesh's upload (band last when engraved).
    fn upload_mesh(
        &mut self,
        gpu: &Gpu<'_>,
        mesh: &Mesh,
        bounds: &mesh::Bounds,
        params: &RenderParams,
    ) -> Result<Detail, RenderError> {
        let (device, queue) = (gpu.device, gpu.queue);
        let planar = surface::PlanarFrame {
            centre: [bounds.center[0], bounds.center[1]],
            half: [
                (0.5 * (bounds.max[0] - bounds.min[0])).max(1e-3),
                (0.5 * (bounds.max[1] - bounds.min[1])).max(1e-3),
            ],
        };
        let scene = &self.passes.scene;
        if let Some(e) = &params.engraving {
            let key = (planar, e.clone());
            if self.surface.engraving_key.as_ref() != Some(&key) {
                let maps = surface::engraving(&planar, e);
                self.surface.set_engraving(device, queue, scene, key, &maps);
            }
        }
        let lamp = params.lamp.map(|l| LampAt::new(l, bounds));
        if let Some(lamp) = &lamp {
            self.surface.ensure_shadow(device, scene);
            self.passes.shadow.write_uniforms(queue, lamp);
        }
        // The slowly varying noise, baked over the mesh once it has been drawn twice (again
        // only when a mesh leaves the volume).
        let baked_noise = gpu.noise_baking
            && self.surface.ensure_volume(
                device,
                &mut self.passes.noise,
                &self.passes.scene,
                bounds.min,
                bounds.max,
            );
        // The band the engraving's parallax search covers (mm inside the outline): a groove's
        // width beyond it each side.
        let band_mm = params.engraving.as_ref().map(|e| {
            let margin = 0.5 * (e.inset_mm[1] - e.inset_mm[0]) / surface::BAND_UNITS;
            [e.inset_mm[0] - margin, e.inset_mm[1] + margin]
        });
        // The scene pipelines: without the engraving for everything but the band's triangles
        // (drawn last, from index `band_start`, with it).
        let plain = SceneVariant {
            engraving: false,
            lamp: params.lamp.is_some(),
            samples: self.samples(params),
            baked_noise,
        };
        let engraved = SceneVariant {
            engraving: true,
            ..plain
        };
        let Some(buffers) = &self.mesh_buffers else {
            return Err(RenderError::Gpu("frame resources missing".into()));
        };
        let vertex_bytes: &[u8] = bytemuck::cast_slice(&mesh.vertices);
        queue.write_buffer(&buffers.vertices, 0, vertex_bytes);
        let band_start = match band_mm {
            Some(band) => {
                let key = (mesh.fingerprint(), planar, band);
                if self.engraved_mesh.as_ref().is_none_or(|c| c.key != key) {
                    let (indices, band_start) =
                        surface::band_last(&mesh.vertices, &mesh.indices, &planar, band);
                    let tangents =
                        surface::tangents(&mesh.vertices, &mesh.indices, |p| planar.uv(p));
                    self.engraved_mesh = Some(EngravedMesh {
                        key,
                        indices,
                        band_start,
                        tangents,
                    });
                }
                let Some(c) = &self.engraved_mesh else {
                    return Err(RenderError::Gpu("engraving data missing".into()));
                };
                queue.write_buffer(&buffers.indices, 0, bytemuck::cast_slice(&c.indices));
                queue.write_buffer(&buffers.tangents, 0, bytemuck::cast_slice(&c.tangents));
                c.band_start
            }
            None => {
                queue.write_buffer(&buffers.indices, 0, bytemuck::cast_slice(&mesh.indices));
                mesh.indices.len()
            }
        };
        // validate() has checked that the count fits in u32.
        let count = u32::try_from(mesh.indices.len()).unwrap_or(0);
        let vb = vertex_bytes.len() as u64;
        let detail = Detail {
            planar,
            lamp,
            band_mm,
            plain,
            engraved,
            draw: Draw {
                vertex_bytes: vb,
                index_bytes: std::mem::size_of_val(mesh.indices.as_slice()) as u64,
                tangent_bytes: crate::mesh::tangent_bytes(vb),
                count,
                band_start: u32::try_from(band_start).unwrap_or(count),
            },
        };
        let compute_form = self
            .targets
            .as_ref()
            .is_some_and(|t| t.scene.visible.is_some());
        self.passes.scene.ensure_for(device, &detail, compute_form);
        Ok(detail)
    }
}
