//! One frame, built in steps: the targets and buffers sized for it ([`Renderer::prepare`]),
//! the surface detail it asks for and the mesh upload ([`Renderer::upload_mesh`]), its
//! uniforms ([`Renderer::write_uniforms`]), then one function per pass, in the order the
//! crate's docs list them: [`shadow_pass`], [`scene_pass`], [`sss_passes`], [`composite_pass`],
//! [`style_passes`]. Units: millimetres on the stone, pixels on the targets.

use super::camera::{self, Camera, Crop, FOV_Y_DEG};
use super::gpu::{self, CompositeUniform, FrameUniform, MeshBuffers, Pipelines, Targets};
use super::{
    AMBIENT, COMPOSITE_PARAMS, EngravedMesh, LAMP_NEAR_MM, LIGHT_INTENSITY, Lamp, Mesh, Output,
    PassTimer, RenderError, RenderParams, Renderer, SHADOW_BIAS_MM, SHADOW_PCF_MM, TEXTURE_SCALE,
    TRANSLUCENCY, TimedPass, gpu_style_count, mesh, srgb_to_linear, surface,
};

/// What the frame's steps decided about the surface and the draw.
struct Detail {
    planar: surface::PlanarFrame,
    /// The lamp, its position (mm) and the shadow cube's far plane (mm).
    lamp: Option<(Lamp, glam::Vec3, f32)>,
    /// The band the engraving's parallax search covers (mm inside the outline).
    band_mm: Option<[f32; 2]>,
    /// The scene pipelines without and with the engraving.
    plain: gpu::SceneVariant,
    engraved: gpu::SceneVariant,
    draw: Draw,
}

/// Byte and index ranges of the uploaded mesh.
#[derive(Clone, Copy)]
struct Draw {
    vertex_bytes: u64,
    index_bytes: u64,
    tangent_bytes: u64,
    count: u32,
    /// The engraved band's triangles are drawn last, from this index.
    band_start: u32,
}

/// The timestamp queries of one frame (none for a window's frame).
struct Stamps<'a> {
    timer: Option<&'a PassTimer>,
    passes: Vec<TimedPass>,
}

impl<'a> Stamps<'a> {
    fn writes(&mut self, pass: TimedPass) -> Option<wgpu::RenderPassTimestampWrites<'a>> {
        self.timer.map(|t| t.writes(&mut self.passes, pass))
    }
    fn compute_writes(&mut self, pass: TimedPass) -> Option<wgpu::ComputePassTimestampWrites<'a>> {
        self.timer.map(|t| t.compute_writes(&mut self.passes, pass))
    }
}

/// What the passes read, borrowed from the renderer for one frame.
struct Frame<'a> {
    pipelines: &'a Pipelines,
    targets: &'a Targets,
    buffers: &'a MeshBuffers,
    surface: &'a gpu::SurfaceMaps,
    draw: Draw,
}

impl Renderer {
    /// MSAA samples of this frame's scene pass: the device's with antialiasing, else 1.
    fn frame_samples(&self, params: &RenderParams) -> u32 {
        if params.antialias {
            self.pipelines.samples
        } else {
            1
        }
    }

    /// Uploads the mesh and the frame's uniforms and encodes the passes, the composite (or
    /// the last style) into `output`. Timestamps only for an image (read back after).
    pub(super) fn encode_frame(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        mesh: &Mesh,
        bounds: &mesh::Bounds,
        params: &RenderParams,
        output: Output<'_>,
    ) -> Result<(), RenderError> {
        let format = match output {
            Output::Image => gpu::OUTPUT_FORMAT,
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
        let (gpu_styles, edge_aa) = self.prepare(mesh, params, output, format, mesh_box)?;
        let crop = match &self.targets {
            Some(t) => Crop::around(mesh_box, t.scene, params.width, params.height),
            None => return Err(RenderError::Gpu("frame resources missing".into())),
        };
        let detail = self.upload_mesh(mesh, bounds, params)?;
        let sss = self.write_uniforms(params, &cam, &crop, &detail)?;

        let (Some(targets), Some(buffers)) = (&self.targets, &self.mesh_buffers) else {
            return Err(RenderError::Gpu("frame resources missing".into()));
        };
        let frame = Frame {
            pipelines: &self.pipelines,
            targets,
            buffers,
            surface: &self.surface,
            draw: detail.draw,
        };
        let mut stamps = Stamps {
            timer: match output {
                Output::Image => self.timer.as_ref(),
                Output::View(..) => None,
            },
            passes: Vec::new(),
        };
        if let Some(bake) = &self.surface.pending_bake {
            volume_pass(encoder, &frame, bake)?;
        }
        if detail.lamp.is_some() {
            shadow_pass(encoder, &frame, &mut stamps);
        }
        let engraved = detail.band_mm.map(|_| detail.engraved);
        scene_pass(encoder, &frame, detail.plain, engraved, &mut stamps)?;
        if sss {
            match (
                &self.pipelines.sss_compute,
                &targets.sss_compute_bind_groups,
            ) {
                (Some((pipeline, _)), Some(groups)) if self.compute_passes => {
                    sss_compute_passes(encoder, targets, pipeline, groups, &mut stamps)
                }
                _ => sss_passes(encoder, &frame, &mut stamps),
            }
        }
        let final_view = match output {
            Output::Image => &targets.output_view,
            Output::View(view, _) => view,
        };
        let styles = &params.styles[..gpu_styles];
        let style_targets = self
            .style_targets
            .as_ref()
            .filter(|_| !styles.is_empty() || edge_aa);
        // With passes after it the composite writes the chain's first image.
        let composite_view = style_targets.map_or(final_view, |st| &st.views[0]);
        // Into the output image alone, it may run as a compute pass.
        let compute_composite = match (
            &output,
            style_targets,
            self.pipelines.composite_compute(params.transparent),
            &targets.composite_compute_bind_groups,
        ) {
            (Output::Image, None, Some(pipeline), Some(groups)) if self.compute_passes => {
                Some((pipeline, &groups[usize::from(sss)]))
            }
            _ => None,
        };
        if let Some((pipeline, group)) = compute_composite {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("glyptic composite compute pass"),
                timestamp_writes: stamps.compute_writes(TimedPass::Composite),
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, group, &[]);
            pass.dispatch_workgroups(targets.width.div_ceil(8), targets.height.div_ceil(8), 1);
        } else {
            composite_pass(
                encoder,
                &frame,
                format,
                composite_view,
                sss,
                params.transparent,
                &mut stamps,
            )?;
        }
        if let Some(st) = style_targets {
            let chain = Chain {
                styles,
                edge_aa,
                final_view,
                format,
            };
            style_passes(encoder, &frame, st, &chain, &mut stamps)?;
        }
        self.timed_passes = stamps.passes;
        // Recorded: the volume is baked when this frame runs.
        self.surface.pending_bake = None;
        Ok(())
    }

    /// Targets, mesh buffers and the chain's pipelines and uniforms sized for this frame;
    /// returns how many styles run on the GPU and whether the edge antialiasing runs (after
    /// them: on every frame drawn with one sample a pixel).
    fn prepare(
        &mut self,
        mesh: &Mesh,
        params: &RenderParams,
        output: Output<'_>,
        format: wgpu::TextureFormat,
        mesh_box: [u32; 4],
    ) -> Result<(usize, bool), RenderError> {
        let (w, h) = (params.width, params.height);
        self.pipelines
            .ensure_composite(&self.device, format, params.transparent);
        if self.compute_passes && matches!(output, Output::Image) {
            self.pipelines
                .ensure_composite_compute(&self.device, params.transparent);
        }
        let samples = self.frame_samples(params);
        let scene = Crop::size_for(mesh_box, w, h);
        // The scene images are kept while the mesh's box fits them and they are no more than
        // a step larger than it needs (a turning gem's box changes size every frame).
        let fits = |t: &Targets| {
            (0..2).all(|a| {
                let needed = mesh_box[a + 2] - mesh_box[a];
                t.scene[a] >= needed && t.scene[a] <= scene[a] + camera::CROP_STEP_PX
            })
        };
        let resized = self
            .targets
            .as_ref()
            .is_none_or(|t| t.width != w || t.height != h);
        if resized
            || self
                .targets
                .as_ref()
                .is_some_and(|t| t.samples != samples || !fits(t))
        {
            // Drop the old targets first so both sets are never alive at once; the style
            // chain's images have the frame's size and outlive a new crop or sample count.
            self.targets = None;
            if resized {
                self.style_targets = None;
            }
            self.targets = Some(Targets::new(
                &self.device,
                &self.pipelines,
                w,
                h,
                scene,
                samples,
            ));
        }
        let vb = std::mem::size_of_val(mesh.vertices.as_slice()) as u64;
        let ib = std::mem::size_of_val(mesh.indices.as_slice()) as u64;
        if self.mesh_buffers.as_ref().is_none_or(|b| !b.fits(vb, ib)) {
            self.mesh_buffers = None;
            self.mesh_buffers = Some(MeshBuffers::new(
                &self.device,
                vb,
                ib,
                self.limits.max_buffer_size,
            ));
        }
        // The styles the GPU does: those before the first done on the CPU.
        let gpu_styles = &params.styles[..gpu_style_count(&params.styles)];
        if matches!(output, Output::View(..)) && gpu_styles.len() < params.styles.len() {
            return Err(RenderError::InvalidParams(
                "dithering runs on the CPU after a readback: a window's frame takes toon, \
                 painterly, fisheye and chromatic only"
                    .into(),
            ));
        }
        if gpu_styles.len() > gpu::MAX_GPU_STYLES {
            return Err(RenderError::InvalidParams(format!(
                "{} GPU styles in a row; at most {}",
                gpu_styles.len(),
                gpu::MAX_GPU_STYLES
            )));
        }
        let edge_aa = samples == 1;
        if (!gpu_styles.is_empty() || edge_aa) && self.style_targets.is_none() {
            self.style_targets = Some(gpu::StyleTargets::new(&self.device, &self.pipelines, w, h));
        }
        if edge_aa {
            self.pipelines.ensure_edge_aa(&self.device, format);
        }
        for (i, &style) in gpu_styles.iter().enumerate() {
            let last = i + 1 == gpu_styles.len() && !edge_aa;
            let target_format = if last { format } else { gpu::STYLE_FORMAT };
            self.pipelines
                .ensure_style(&self.device, style, target_format);
            if let Some(u) = gpu::style_uniform(style, params.style_time_s) {
                self.queue.write_buffer(
                    &self.pipelines.style_uniforms[i],
                    0,
                    bytemuck::cast_slice(&u),
                );
            }
        }
        Ok((gpu_styles.len(), edge_aa))
    }

    /// Surface detail, made only when a frame asks for it (the engraving's maps, again only
    /// when the mesh's planar frame or the parameters change; the shadow cube and its
    /// uniforms), the scene pipelines, and the mesh's upload (band last when engraved).
    fn upload_mesh(
        &mut self,
        mesh: &Mesh,
        bounds: &mesh::Bounds,
        params: &RenderParams,
    ) -> Result<Detail, RenderError> {
        let planar = surface::PlanarFrame {
            centre: [bounds.center[0], bounds.center[1]],
            half: [
                (0.5 * (bounds.max[0] - bounds.min[0])).max(1e-3),
                (0.5 * (bounds.max[1] - bounds.min[1])).max(1e-3),
            ],
        };
        if let Some(e) = &params.engraving {
            let key = (planar, e.clone());
            if self.surface.engraving_key.as_ref() != Some(&key) {
                let maps = surface::engraving(&planar, e);
                self.surface
                    .set_engraving(&self.device, &self.queue, &self.pipelines, key, &maps);
            }
        }
        let lamp = params.lamp.map(|l| {
            let offset = glam::Vec3::from(l.offset_mm);
            let position = glam::Vec3::from(bounds.center) + offset;
            (l, position, offset.length() + 1.05 * bounds.radius + 1.0)
        });
        if let Some((_, position, far)) = lamp {
            self.surface.ensure_shadow(&self.device, &self.pipelines);
            for (face, buffer) in self.pipelines.shadow_uniforms.iter().enumerate() {
                let u = gpu::ShadowFaceUniform {
                    view_proj: camera::cube_face_view_proj(position, face, LAMP_NEAR_MM, far)
                        .to_cols_array_2d(),
                    lamp: [position.x, position.y, position.z, 1.0 / far],
                };
                self.queue.write_buffer(buffer, 0, bytemuck::bytes_of(&u));
            }
        }
        // The slowly varying noise, baked over the mesh once it has been drawn twice (again only
        // when a mesh leaves the volume).
        let baked_noise = self.noise_baking
            && self.surface.ensure_volume(
                &self.device,
                &mut self.pipelines,
                bounds.min,
                bounds.max,
                TEXTURE_SCALE,
            );
        // The band the engraving's parallax search covers (mm inside the outline): a groove's
        // width beyond it each side.
        let band_mm = params.engraving.as_ref().map(|e| {
            let margin = 0.5 * (e.inset_mm[1] - e.inset_mm[0]) / surface::BAND_UNITS;
            [e.inset_mm[0] - margin, e.inset_mm[1] + margin]
        });
        // The scene pipelines: without the engraving for everything but the band's triangles
        // (drawn last, from index `band_start`, with it).
        let plain = gpu::SceneVariant {
            engraving: false,
            lamp: params.lamp.is_some(),
            samples: self.frame_samples(params),
            baked_noise,
        };
        let engraved = gpu::SceneVariant {
            engraving: true,
            ..plain
        };
        self.pipelines.ensure_scene(&self.device, plain);
        if band_mm.is_some() {
            self.pipelines.ensure_scene(&self.device, engraved);
        }
        let Some(buffers) = &self.mesh_buffers else {
            return Err(RenderError::Gpu("frame resources missing".into()));
        };
        let vertex_bytes: &[u8] = bytemuck::cast_slice(&mesh.vertices);
        self.queue.write_buffer(&buffers.vertices, 0, vertex_bytes);
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
                self.queue
                    .write_buffer(&buffers.indices, 0, bytemuck::cast_slice(&c.indices));
                self.queue
                    .write_buffer(&buffers.tangents, 0, bytemuck::cast_slice(&c.tangents));
                c.band_start
            }
            None => {
                self.queue
                    .write_buffer(&buffers.indices, 0, bytemuck::cast_slice(&mesh.indices));
                mesh.indices.len()
            }
        };
        // validate() has checked that the count fits in u32.
        let count = u32::try_from(mesh.indices.len()).unwrap_or(0);
        let vb = vertex_bytes.len() as u64;
        Ok(Detail {
            planar,
            lamp,
            band_mm,
            plain,
            engraved,
            draw: Draw {
                vertex_bytes: vb,
                index_bytes: std::mem::size_of_val(mesh.indices.as_slice()) as u64,
                tangent_bytes: gpu::tangent_bytes(vb),
                count,
                band_start: u32::try_from(band_start).unwrap_or(count),
            },
        })
    }

    /// The frame, composite and SSS uniforms; returns whether the SSS passes run.
    fn write_uniforms(
        &mut self,
        params: &RenderParams,
        cam: &Camera,
        crop: &Crop,
        detail: &Detail,
    ) -> Result<bool, RenderError> {
        let v4 = |v: glam::Vec3, w: f32| v.extend(w).to_array();
        let planar = &detail.planar;
        let (w, h) = (params.width, params.height);
        let layers = params.material.layers();
        let frame = FrameUniform {
            // Column-major, as WGSL expects; onto the crop's images.
            view_proj: (crop.clip_matrix(w, h) * cam.view_proj).to_cols_array_2d(),
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
            lamp: detail
                .lamp
                .map_or([0.0; 4], |(l, p, _)| [p.x, p.y, p.z, l.intensity]),
            shadow: detail.lamp.map_or([0.0; 4], |(l, _, far)| {
                let centre_mm = l.offset_mm.iter().map(|c| c * c).sum::<f32>().sqrt();
                [far, SHADOW_BIAS_MM, SHADOW_PCF_MM, centre_mm]
            }),
            // Without a volume (no mesh drawn yet) the placeholder's one zero voxel.
            volume: self.surface.volume_box.map_or([0.0, 0.0, 0.0, 1.0], |v| {
                [v.origin[0], v.origin[1], v.origin[2], 1.0 / v.voxel_mm]
            }),
            volume_texel: self.surface.volume_box.map_or([1.0; 4], |v| {
                [v.dims[0], v.dims[1], v.dims[2], 1].map(|d| 1.0 / d as f32)
            }),
            layers: layers.map_or([[0.0; 4]; 5], |l| l.uniforms()),
        };
        self.queue
            .write_buffer(&self.pipelines.frame_uniform, 0, bytemuck::bytes_of(&frame));
        let composite = CompositeUniform {
            background: {
                let [r, g, b] = params.background.map(|c| srgb_to_linear(c.clamp(0.0, 1.0)));
                [r, g, b, 1.0]
            },
            params: COMPOSITE_PARAMS,
            crop: [crop.x, crop.y, crop.width, crop.height].map(|v| v as f32),
            size: [w as f32, h as f32, 0.0, 0.0],
        };
        self.queue.write_buffer(
            &self.pipelines.composite_uniform,
            0,
            bytemuck::bytes_of(&composite),
        );
        let Some(p) = &params.sss else {
            return Ok(false);
        };
        let kernel = crate::sss::kernel(p)
            .map_err(|e| RenderError::InvalidParams(format!("subsurface scattering: {e}")))?;
        let px_per_mm = 0.5 * params.height as f32 / (0.5 * FOV_Y_DEG).to_radians().tan();
        for (buffer, dir) in self
            .pipelines
            .sss_uniforms
            .iter()
            .zip([[1.0, 0.0], [0.0, 1.0]])
        {
            let u = gpu::sss_uniform(
                &kernel,
                p.width_mm,
                px_per_mm,
                cam.near,
                cam.far - cam.near,
                dir,
            );
            self.queue.write_buffer(buffer, 0, bytemuck::cast_slice(&u));
        }
        Ok(true)
    }
}

/// Pass 0: the mesh's distance from the lamp into the six faces of the shadow cube.
fn shadow_pass(encoder: &mut wgpu::CommandEncoder, frame: &Frame<'_>, stamps: &mut Stamps<'_>) {
    let Draw {
        vertex_bytes,
        index_bytes,
        count,
        ..
    } = frame.draw;
    for (face, view) in frame.surface.shadow_faces.iter().enumerate() {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("glyptic shadow pass"),
            color_attachments: &[],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: stamps.writes(TimedPass::Shadow),
            ..Default::default()
        });
        pass.set_pipeline(&frame.pipelines.shadow);
        pass.set_bind_group(0, &frame.pipelines.shadow_bind_groups[face], &[]);
        pass.set_vertex_buffer(0, frame.buffers.vertices.slice(..vertex_bytes));
        pass.set_index_buffer(
            frame.buffers.indices.slice(..index_bytes),
            wgpu::IndexFormat::Uint32,
        );
        pass.draw_indexed(0..count, 0, 0..1);
    }
}

/// Before the passes, once: the slowly varying noise baked into the volume over the mesh.
fn volume_pass(
    encoder: &mut wgpu::CommandEncoder,
    frame: &Frame<'_>,
    bake: &gpu::NoiseBake,
) -> Result<(), RenderError> {
    let pipeline = frame
        .pipelines
        .noise_bake_pipeline()
        .ok_or_else(|| RenderError::Gpu("no noise volume pipeline".into()))?;
    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some("glyptic noise volume"),
        // Not timed: lavapipe stamps a compute pass before its work is done (0.01-0.07 ms for
        // ~45 ms of work); bench_render times the bake by the frame's wall time instead.
        timestamp_writes: None,
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, &bake.bind_group, &[]);
    let [x, y, z] = bake.workgroups;
    pass.dispatch_workgroups(x, y, z);
    Ok(())
}

/// Pass 1: lit diffuse, specular and depth with the scattering mask; the engraved band's
/// triangles last, with the engraving pipeline.
fn scene_pass(
    encoder: &mut wgpu::CommandEncoder,
    frame: &Frame<'_>,
    plain: gpu::SceneVariant,
    engraved: Option<gpu::SceneVariant>,
    stamps: &mut Stamps<'_>,
) -> Result<(), RenderError> {
    let scene_pipeline = |variant| {
        frame
            .pipelines
            .scene(variant)
            .ok_or_else(|| RenderError::Gpu(format!("no scene pipeline for {variant:?}")))
    };
    let plain = scene_pipeline(plain)?;
    let engraved = engraved.map(scene_pipeline).transpose()?;
    let (targets, buffers, d) = (frame.targets, frame.buffers, frame.draw);
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("glyptic scene pass"),
        color_attachments: &[
            Some(targets.diffuse.attachment()),
            Some(targets.specular.attachment()),
            Some(targets.depth_mask.attachment()),
        ],
        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
            view: &targets.depth,
            depth_ops: Some(wgpu::Operations {
                load: wgpu::LoadOp::Clear(1.0),
                store: wgpu::StoreOp::Discard,
            }),
            stencil_ops: None,
        }),
        timestamp_writes: stamps.writes(TimedPass::Scene),
        ..Default::default()
    });
    pass.set_pipeline(plain);
    pass.set_bind_group(0, &frame.pipelines.scene_bind_group, &[]);
    pass.set_bind_group(1, &frame.surface.bind_group, &[]);
    pass.set_vertex_buffer(0, buffers.vertices.slice(..d.vertex_bytes));
    pass.set_vertex_buffer(1, buffers.tangents.slice(..d.tangent_bytes));
    pass.set_index_buffer(
        buffers.indices.slice(..d.index_bytes),
        wgpu::IndexFormat::Uint32,
    );
    pass.draw_indexed(0..d.band_start, 0, 0..1);
    if let Some(engraved) = engraved
        && d.band_start < d.count
    {
        pass.set_pipeline(engraved);
        pass.draw_indexed(d.band_start..d.count, 0, 0..1);
    }
    Ok(())
}

/// Pass 2: the resolved diffuse blurred horizontally, then vertically.
fn sss_passes(encoder: &mut wgpu::CommandEncoder, frame: &Frame<'_>, stamps: &mut Stamps<'_>) {
    let targets = frame.targets;
    let outputs = [&targets.sss_temp, &targets.sss_out];
    for (group, output) in targets.sss_bind_groups.iter().zip(outputs) {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("glyptic sss pass"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: output,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Store,
                },
            })],
            timestamp_writes: stamps.writes(TimedPass::Sss),
            ..Default::default()
        });
        pass.set_pipeline(&frame.pipelines.sss);
        pass.set_bind_group(0, group, &[]);
        pass.draw(0..3, 0..1);
    }
}

/// Pass 2 as compute passes (8 x 8 pixels a workgroup), writing the same images.
fn sss_compute_passes(
    encoder: &mut wgpu::CommandEncoder,
    targets: &Targets,
    pipeline: &wgpu::ComputePipeline,
    groups: &[wgpu::BindGroup; 2],
    stamps: &mut Stamps<'_>,
) {
    let [w, h] = targets.scene;
    for group in groups {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("glyptic sss compute pass"),
            timestamp_writes: stamps.compute_writes(TimedPass::Sss),
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, group, &[]);
        pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
    }
}

/// Pass 3: diffuse (blurred with `sss`) + specular over the backdrop into `view`.
fn composite_pass(
    encoder: &mut wgpu::CommandEncoder,
    frame: &Frame<'_>,
    format: wgpu::TextureFormat,
    view: &wgpu::TextureView,
    sss: bool,
    transparent: bool,
    stamps: &mut Stamps<'_>,
) -> Result<(), RenderError> {
    let composite = frame
        .pipelines
        .composite(format, transparent)
        .ok_or_else(|| RenderError::Gpu(format!("no composite pipeline for {format:?}")))?;
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("glyptic composite pass"),
        color_attachments: &[gpu::overwrite(view)],
        timestamp_writes: stamps.writes(TimedPass::Composite),
        ..Default::default()
    });
    pass.set_pipeline(composite);
    let group = if sss {
        &frame.targets.composite_sss_bind_group
    } else {
        &frame.targets.composite_bind_group
    };
    pass.set_bind_group(0, group, &[]);
    pass.draw(0..3, 0..1);
    Ok(())
}

/// The passes after the composite and where the last one writes.
struct Chain<'a> {
    styles: &'a [crate::styles::Style],
    edge_aa: bool,
    final_view: &'a wgpu::TextureView,
    format: wgpu::TextureFormat,
}

/// Pass 4: the GPU styles in order, then the edge antialiasing, ping-ponging between the
/// chain's images, the last into `final_view`.
fn style_passes(
    encoder: &mut wgpu::CommandEncoder,
    frame: &Frame<'_>,
    st: &gpu::StyleTargets,
    chain: &Chain<'_>,
    stamps: &mut Stamps<'_>,
) -> Result<(), RenderError> {
    let Chain {
        styles,
        edge_aa,
        final_view,
        format,
    } = *chain;
    for (i, &style) in styles.iter().enumerate() {
        let last = i + 1 == styles.len() && !edge_aa;
        let (view, target_format) = if last {
            (final_view, format)
        } else {
            (&st.views[(i + 1) % 2], gpu::STYLE_FORMAT)
        };
        let pipeline = frame.pipelines.style(style, target_format).ok_or_else(|| {
            RenderError::Gpu(format!("no {} pass for {target_format:?}", style.name()))
        })?;
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("glyptic style pass"),
            color_attachments: &[gpu::overwrite(view)],
            timestamp_writes: stamps.writes(TimedPass::Style(style)),
            ..Default::default()
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &st.bind_groups[i], &[]);
        pass.draw(0..3, 0..1);
    }
    if edge_aa {
        let pipeline = frame
            .pipelines
            .edge_aa(format)
            .ok_or_else(|| RenderError::Gpu(format!("no edge antialiasing for {format:?}")))?;
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("glyptic edge aa pass"),
            color_attachments: &[gpu::overwrite(final_view)],
            timestamp_writes: stamps.writes(TimedPass::EdgeAa),
            ..Default::default()
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &st.edge_aa_bind_groups[styles.len() % 2], &[]);
        pass.draw(0..3, 0..1);
    }
    Ok(())
}
