//! [`CameoBuilder`]: the face-independent part of a cameo made once (the sculpted head, hair
//! and bust on the relief grid, the bezel and the back), then each face rasterised, merged,
//! compressed, shaded and meshed. Gem millimetres.
//!
//! Length: about 950 lines, most of it [`CameoBuilder::relief_detailed`], the face's steps in
//! order (rasterise, merge into the template, compress, carve the photo's detail, refine the
//! grid for its stipple, shade) over one grid and its masks; each step's own computation
//! lives in its module.

use crate::scene::Mesh;

use super::detail::FaceDetail;
use super::refine::Refine;
use super::setting::add_setting;
use super::shading::{
    SHADOW_SOFTNESS_MM, ShadowCut, carve_shadows, cavity, light_transmission, light_visibility,
    penumbra, smooth_121,
};
use super::tessellate::{add_relief_surface, plan_surface};
use super::window::Window;
use super::{
    CameoParams, DEPTH_QUANTILE, GemError, HEAD_EMPHASIS, MEAN_FREE_MM, OUTLINE_LEVEL,
    PORTRAIT_OVAL, Placement, Relief, View, basrelief, check_params, face, relief, template,
};

/// Builds cameos for one set of [`CameoParams`]: everything that does not depend on the face
/// (the sculpted head, hair and bust on the relief grid, the bezel and the back) is computed
/// once in [`CameoBuilder::new`]; each face then costs its rasterisation, the compression and
/// the mesh.
#[derive(Clone, Debug)]
pub struct CameoBuilder {
    params: CameoParams,
    cols: usize,
    rows: usize,
    /// Gem position of grid node (0, 0), gem mm.
    origin: [f32; 2],
    /// Canonical point at the gem's centre and canonical mm per gem mm.
    centre: [f32; 2],
    scale: f32,
    /// The template per node: height (canonical mm), hair weight and coverage (the share of
    /// the node's cell inside the portrait's outline; 0 outside the oval's margin).
    template: Template,
    /// The nodes the template covers (with any coverage), as a window.
    template_box: Option<Window>,
    /// Per node: inside the oval (the stone's top is made of cells with four such corners).
    inside: Vec<bool>,
    /// Per node: inside the portrait's share of the oval.
    allowed: Vec<bool>,
    /// Per node: the share of its cell inside the portrait's share of the oval (from the
    /// signed distance to that ellipse), so that where the portrait reaches it (a frontal
    /// bust's foot) its outline follows the ellipse, not the nodes' stair-steps.
    oval_cover: Vec<f32>,
    /// Bezel and back.
    base: Mesh,
}

impl CameoBuilder {
    pub fn new(p: &CameoParams) -> Result<Self, GemError> {
        check_params(p)?;
        let cols = (2.0 * p.half_width / p.cell).round() as usize + 1;
        let rows = (2.0 * p.half_height / p.cell).round() as usize + 1;
        let origin = [-p.half_width, -p.half_height];
        let (centre, scale) = template::framing(p.view);
        // The framing is for the default stone's height; a taller stone shows a larger head.
        let scale = scale * 28.0 / p.half_height;
        let node = |i: usize| {
            (
                origin[0] + (i % cols) as f32 * p.cell,
                origin[1] + (i / cols) as f32 * p.cell,
            )
        };
        let oval = |i: usize| {
            let (x, y) = node(i);
            ((x / p.half_width).powi(2) + (y / p.half_height).powi(2)).sqrt()
        };
        let inside = inside_oval(p, cols, rows, p.cell);
        let allowed: Vec<bool> = (0..cols * rows).map(|i| oval(i) <= PORTRAIT_OVAL).collect();
        let (a, b) = (p.half_width * PORTRAIT_OVAL, p.half_height * PORTRAIT_OVAL);
        let oval_cover = (0..cols * rows)
            .map(|i| {
                let (x, y) = node(i);
                let s = ((x / a).powi(2) + (y / b).powi(2)).sqrt();
                // First-order signed distance (mm, positive outside): the ellipse's level
                // over its gradient.
                let grad = ((x / (a * a)).powi(2) + (y / (b * b)).powi(2)).sqrt() / s.max(1e-6);
                let d = (s - 1.0) / grad.max(1e-6);
                (0.5 - d / p.cell).clamp(0.0, 1.0)
            })
            .collect();
        // Each node is the mean of 2 x 2 samples across its cell, so carved grooves and the
        // outline do not alias into stair-steps.
        // Nodes are independent: spread over the cores (the photo waits on this, issue #42).
        let sampled = crate::par::map(cols * rows, PAR_NODES, |i| {
            let mut s3 = [0f32; 3];
            if allowed[i] {
                let (x, y) = node(i);
                for (dx, dy) in [(-0.25, -0.25), (0.25, -0.25), (-0.25, 0.25), (0.25, 0.25)] {
                    let s = template::sample(
                        p.view,
                        &p.hair,
                        centre[0] + (x + dx * p.cell) * scale,
                        centre[1] + (y + dy * p.cell) * scale,
                    );
                    s3[0] += 0.25 * s.height;
                    s3[1] += 0.25 * s.hair;
                    s3[2] += 0.25 * f32::from(u8::from(s.covered));
                }
            }
            s3
        });
        let coarse: Vec<f32> = sampled.iter().map(|s| s[2]).collect();
        // Along the outline (partly covered nodes, or nodes beside one of another coverage)
        // the coverage again from the finer sub-samples the face's outline gets.
        let coverage = crate::par::map(cols * rows, PAR_NODES, |i| {
            let c = coarse[i];
            if !allowed[i] {
                return c;
            }
            let (x, y) = (i % cols, i / cols);
            let neighbours = [
                (x > 0).then(|| i - 1),
                (x + 1 < cols).then(|| i + 1),
                (y > 0).then(|| i - cols),
                (y + 1 < rows).then(|| i + cols),
            ];
            let edge = (c > 0.0 && c < 1.0) || neighbours.iter().flatten().any(|&j| coarse[j] != c);
            if !edge {
                return c;
            }
            let (gx, gy) = node(i);
            let covered = |k: usize| {
                let [ox, oy] = relief::coverage_offset(k);
                template::sample(
                    p.view,
                    &p.hair,
                    centre[0] + (gx + ox * p.cell) * scale,
                    centre[1] + (gy + oy * p.cell) * scale,
                )
                .covered
            };
            // Every fourth sample first (a lattice of 16 of its own): where they all agree
            // the cell is taken as whole or empty, and only the cells the outline crosses
            // cost all 64 (the template is a few times dearer than the face to sample).
            let n = relief::COVERAGE_SAMPLES;
            let first = (0..n).step_by(4).filter(|&k| covered(k)).count();
            if first == 0 || first == n / 4 {
                first as f32 / (n / 4) as f32
            } else {
                let rest = (0..n).filter(|k| k % 4 != 0 && covered(*k)).count();
                (first + rest) as f32 / n as f32
            }
        });
        let template = Template {
            height: sampled.iter().map(|s| s[0]).collect(),
            hair: sampled.iter().map(|s| s[1]).collect(),
            coverage,
        };
        let mut base = Mesh::default();
        add_setting(&mut base, p);
        let template_box = Window::of(cols, rows, |i| {
            template.coverage[i] > 0.0 || template.height[i] > 0.0
        });
        Ok(Self {
            params: p.clone(),
            cols,
            rows,
            origin,
            centre,
            scale,
            template,
            template_box,
            inside,
            allowed,
            oval_cover,
            base,
        })
    }

    pub fn params(&self) -> &CameoParams {
        &self.params
    }

    /// The relief height field (gem mm) for a face mesh in model mm.
    pub fn relief(&self, positions: &[f32], triangles: &[[u32; 3]]) -> Result<Relief, GemError> {
        self.relief_from(positions, triangles, &[])
    }

    /// [`Self::relief`], its compression's solve started from `warm` (a previous relief's
    /// [`Relief::relative`], or empty).
    pub fn relief_from(
        &self,
        positions: &[f32],
        triangles: &[[u32; 3]],
        warm: &[f32],
    ) -> Result<Relief, GemError> {
        self.relief_detailed(positions, triangles, warm, None)
    }

    /// [`Self::relief_from`] with the photo's own detail carved into the face
    /// ([`FaceDetail`]: brows, irises, the mouth's line, folds), when given for this mesh's
    /// vertices.
    pub fn relief_detailed(
        &self,
        positions: &[f32],
        triangles: &[[u32; 3]],
        warm: &[f32],
        detail: Option<&FaceDetail>,
    ) -> Result<Relief, GemError> {
        if positions.len() < 9 || triangles.is_empty() {
            return Err(GemError::EmptyFace);
        }
        if positions.iter().any(|v| !v.is_finite()) {
            return Err(GemError::NonFinite);
        }
        check_face_mesh(positions, triangles)?;
        let p = &self.params;
        let (cols, rows, cell) = (self.cols, self.rows, p.cell);
        let n = cols * rows;
        let view = p.view;
        let placement = face::place(positions, view);
        // The beard and moustache stand on the face (placed by the face's own shape: a full
        // beard does not make a smaller face).
        let bearded = face::facial_hair(positions, triangles, &p.hair);
        let surface = bearded.as_ref().map_or(positions, |f| &f.positions[..]);
        // Face vertices -> grid coordinates and canonical height.
        let points: Vec<Option<[f32; 3]>> = surface
            .chunks_exact(3)
            .map(|v| {
                let c = placement.to_canonical(view, [v[0], v[1], v[2]]);
                let [x, y] = self.grid_position([c[0], c[1]]);
                let g = [x, y, c[2]];
                g.iter().all(|c| c.is_finite()).then_some(g)
            })
            .collect();
        // The facial hair's thickness per node (empty without any).
        let (raw, fuzz) = match &bearded {
            Some(f) => relief::rasterise_attribute(&points, triangles, &f.thickness, cols, rows),
            None => (
                relief::rasterise(&points, triangles, cols, rows),
                Vec::new(),
            ),
        };
        let face: Vec<bool> = (0..n)
            .map(|i| raw[i].is_finite() && self.allowed[i])
            .collect();
        let detail = detail.filter(|d| d.seen().len() == points.len());
        let photo = detail.map(|d| photo_detail(d, &points, triangles, &face, cols, rows));
        let face_box = Window::of(cols, rows, |i| face[i]).map(|w| w.grow(2, cols, rows));
        let face_cover = relief::coverage(&points, triangles, &raw, cols, rows);
        // Smooth the face within its footprint (1-2-1 each way, about 0.7 cells: the Surrey
        // mesh's facets, 3-5 mm triangles, are not features, and the detail boost would carve
        // them).
        let mut smooth = vec![0f32; n];
        let mut den = vec![0f32; n];
        if let Some(w) = face_box {
            let values = w.crop(&raw, cols, |v| if v.is_finite() { v.max(0.0) } else { 0.0 });
            let weights = w.crop(&raw, cols, |v| f32::from(u8::from(v.is_finite())));
            let (num, d) = (
                smooth_121(&values, w.width(), w.height()),
                smooth_121(&weights, w.width(), w.height()),
            );
            let ratio: Vec<f32> = num
                .iter()
                .zip(&d)
                .map(|(v, d)| if *d > 1e-6 { v / d } else { 0.0 })
                .collect();
            w.paste(&ratio, &mut smooth, cols);
            w.paste(&d, &mut den, cols);
        }
        let eyes = face::eyes(positions, view, &placement);
        let canonical = |i: usize| self.canonical((i % cols) as f32, (i / cols) as f32);
        // Nothing of the template stands in front of the face's profile line: in every row the
        // face reaches, the template starts behind the face's front-most node.
        let front: Vec<usize> = (0..rows)
            .map(|y| {
                if view == View::Profile {
                    (0..cols).find(|&x| face[y * cols + x]).unwrap_or(0)
                } else {
                    0
                }
            })
            .collect();
        let breadth = placement.breadth;
        let (head, head_box) = self.template_for(&placement);
        // Everything the portrait can reach, a little grown: outside it the relief is ground.
        let Some(portrait_box) = [face_box, head_box]
            .into_iter()
            .flatten()
            .reduce(|a, b| a.union(b))
            .map(|w| w.grow(2, cols, rows))
        else {
            return Err(GemError::EmptyFace);
        };
        let mut portrait = vec![0f32; n];
        let mut mask = vec![false; n];
        let mut hair = vec![0f32; n];
        // The share of each node's cell inside the portrait's outline (sub-cell precise), and
        // how much of a node the face makes.
        let mut cover = vec![0f32; n];
        let mut face_share = vec![0f32; n];
        let mut face_height = vec![f32::NAN; n];
        // How much of the photo's light and dark (`FaceDetail::tone_at`, carved after the
        // compression) each node takes: none under a beard, the face's share of its cell.
        let mut tone_weight = vec![0f32; n];
        for i in portrait_box.indices(cols) {
            // (Behind the front-most node, not on it: what the face leaves uncovered of that
            // node's cell is the ground before the profile, and the head's share there raised
            // the edge node 5-8 canonical mm over the next one in, which the compression kept
            // as a groove just inside the forehead's wall.)
            let (x, front) = (i % cols, front[i / cols]);
            let head_ok = self.allowed[i] && x >= front && !(face[i] && x == front);
            cover[i] = if self.allowed[i] {
                face_cover[i].max(if head_ok { head.coverage[i] } else { 0.0 })
            } else {
                0.0
            };
            let head_here = head.coverage[i] >= 0.5 && head_ok;
            let head_height = head.height[i] * breadth;
            // Where the face's border crosses a node's cell, face and head share it by the
            // face's coverage (no stair-steps along the jaw or the hairline).
            let share = if head_here && den[i] > 1e-6 && self.allowed[i] {
                face_cover[i]
            } else if face[i] {
                1.0
            } else {
                0.0
            };
            if share > 0.0 {
                let [u, v] = canonical(i);
                let mut carved: f32 = eyes.iter().map(|e| e.carve(u, v)).sum();
                if p.hair.glasses {
                    carved += face::glasses(&eyes, view, u, v);
                }
                // Facial hair carved as the hair is cut (`template::beard_texture`), as deep as
                // it is thick (up to 4 mm).
                let thick = fuzz.get(i).copied().unwrap_or(0.0);
                // The photo's detail, except under a beard (carved as locks instead).
                if let Some(ph) = &photo {
                    let bare = 1.0 - template::smoothstep(0.5, 2.0, thick);
                    carved += ph.detail[i] * bare;
                    tone_weight[i] = ph.seen[i] * bare * share;
                }
                let locks = if thick > 0.05 {
                    (thick / 4.0).min(1.0) * template::beard_texture(&p.hair, u, v)
                } else {
                    0.0
                };
                // A fringe over the forehead (frontal, where the photo's hair reaches it).
                let fringe = if view == View::Frontal {
                    template::fringe(&p.hair, u, v)
                } else {
                    0.0
                };
                let f = (smooth[i] + carved + locks + fringe).max(0.0);
                if face[i] {
                    face_height[i] = f;
                }
                portrait[i] = share * f + (1.0 - share) * head_height;
                let on_face = template::smoothstep(0.5, 2.0, thick.max(fringe));
                hair[i] = (1.0 - share) * head.hair[i] + share * on_face;
                mask[i] = true;
            } else if head_here {
                portrait[i] = head_height;
                hair[i] = head.hair[i];
                mask[i] = true;
            }
            face_share[i] = share;
        }
        // A beard hangs below the face's lower edge (under the chin and the jaw): in each
        // column, below the lowest bearded node of the face, half again its thickness more
        // beard, thinning and curling under, over whatever the template has there.
        if !fuzz.is_empty() {
            let canonical_cell = cell * self.scale;
            for x in portrait_box.x0..=portrait_box.x1 {
                let Some(r0) = (portrait_box.y0..=portrait_box.y1)
                    .find(|&y| face[y * cols + x] && fuzz[y * cols + x] > 0.5)
                else {
                    continue;
                };
                let top = r0 * cols + x;
                let thick = fuzz[top];
                let reach = ((1.5 * thick / canonical_cell).round() as usize).min(r0);
                for k in 1..=reach {
                    let i = (r0 - k) * cols + x;
                    if face[i] || !self.allowed[i] || r0 - k < portrait_box.y0 {
                        break;
                    }
                    let s = k as f32 / (reach + 1) as f32;
                    let [u, v] = canonical(i);
                    let locks = (thick / 4.0).min(1.0) * template::beard_texture(&p.hair, u, v);
                    let below = if mask[i] { portrait[i] } else { 0.0 };
                    let hanging = portrait[top] * (1.0 - 0.6 * s * s) + (1.0 - s) * locks;
                    if hanging > below {
                        portrait[i] = hanging;
                        mask[i] = true;
                        cover[i] = cover[i].max(1.0 - template::smoothstep(0.75, 1.0, s));
                        hair[i] = hair[i].max(1.0 - s);
                    }
                }
            }
        }
        // The face keeps its compressed gradients; the sculpted head and bust are carved a
        // little lower, so the face gets more of the stone's depth.
        let emphasis: Vec<f32> = face_share
            .iter()
            .map(|&s| HEAD_EMPHASIS + (1.0 - HEAD_EMPHASIS) * s)
            .collect();
        let warm = if warm.len() == n { warm } else { &[] };
        let (relative, solve) = basrelief::compress(
            &portrait,
            &mask,
            &emphasis,
            warm,
            cols,
            rows,
            cell * self.scale,
            &p.compression,
        )?;
        // Scale: the highest compressed heights reach the depth above the wall.
        let mut sorted: Vec<f32> = portrait_box
            .indices(cols)
            .filter(|&i| mask[i])
            .map(|i| relative[i])
            .collect();
        let top = if sorted.is_empty() {
            1.0
        } else {
            let k = ((sorted.len() - 1) as f32 * DEPTH_QUANTILE) as usize;
            *sorted.select_nth_unstable_by(k, f32::total_cmp).1
        };
        let gain = (p.relief_depth - p.wall) / top.max(1e-6);
        // The outline: the portrait's sub-cell coverage smoothed once (1-2-1 each way), its
        // 0.5 contour a line that follows the silhouette, not the grid's stair-steps (more
        // smoothing would fill the profile's narrow notches, such as the parting of the lips).
        // Inside it the stone stands at `top`, the wall's height over the compressed relief;
        // outside it is ground: a step, which the mesh cuts along the contour itself as a
        // near-vertical wall (see `tessellate`), as a cutter leaves it.
        for i in portrait_box.indices(cols) {
            cover[i] = cover[i].min(self.oval_cover[i]);
        }
        let mut outline = vec![0f32; n];
        portrait_box.paste(
            &smooth_121(
                &portrait_box.crop(&cover, cols, |c| c),
                portrait_box.width(),
                portrait_box.height(),
            ),
            &mut outline,
            cols,
        );
        // The top continues the relief's slope past its last node to the contour (linearly,
        // two cells), so it rolls into the wall without a crease; where the relief falls
        // steeply to its edge the wall is lower, never under `MIN_WALL_SHARE` of its height.
        // (Unclamped: the compression leaves its edge a little below zero, and a clamp there
        // would crease the top.)
        let scaled: Vec<f32> = relative.iter().map(|r| r * gain).collect();
        let mut continued = extrapolate(&scaled, &mask, &outline, cols, rows, 2);
        // The photo's light and dark goes into the stone after the compression, its slopes as
        // the photo asked for them (canonical mm over canonical mm = gem mm over gem mm): the
        // compression would flatten its steepest slopes most, the ones that draw the
        // strongest light and dark. Its stipple's pits are a few tenths of a millimetre
        // across: from here on the grid is `TONE_SUBDIVISION` times finer (the relief's
        // solve, the head and the outline stay on the coarse one, bilinearly refined).
        let tone_detail = detail.filter(|d| {
            view == View::Frontal
                && !d.tone_map().is_empty()
                && tone_weight.iter().any(|w| *w > 0.0)
        });
        // The relief's own fine light and dark, alike on every gem, gives way to the photo's
        // where the tone is carved (`DetailParams::photo_modelling`); on the solve grid, so a
        // stippled relief and a smooth one share it.
        if let Some((share, band_mm)) = tone_detail.and_then(|d| d.replaces()) {
            let sigma = band_mm / (cell * self.scale);
            super::tone::replace_fine_relief(
                &mut continued,
                &tone_weight,
                cols,
                rows,
                sigma,
                share,
            );
        }
        let k = match tone_detail {
            Some(d) if d.stippled() && fine_nodes(p, TONE_SUBDIVISION) <= MAX_FINE_NODES => {
                TONE_SUBDIVISION
            }
            _ => 1,
        };
        // (Every field refined is 0 off the portrait's window.)
        let grid = Refine::new(cols, rows, k, portrait_box);
        let (cols, rows, n, cell) = (grid.cols, grid.rows, grid.cols * grid.rows, cell / k as f32);
        let mut continued = grid.up(&continued);
        // Where the stipple cut a pit (the mesh keeps the finer grid's cells there only).
        let mut stippled = Vec::new();
        // How much of each node the photo's strongest darks sink into the key light's shadow.
        let mut carve = Vec::new();
        // The tone's weight and the photo point of each node of the finer grid: the tone, the
        // stipple, the cut and the tone's match all read them.
        let photo_nodes = tone_detail.zip(photo.as_ref()).map(|(d, ph)| {
            (
                d,
                grid.up(&tone_weight),
                grid.up_points(&ph.point, &ph.seen),
            )
        });
        if let Some((d, weight, point)) = &photo_nodes {
            if k > 1 {
                stippled = vec![false; n];
            }
            for (i, c) in continued.iter_mut().enumerate() {
                if weight[i] > 0.0 {
                    let [x, y] = point[i];
                    let pit = weight[i] * d.stipple_at(x, y);
                    *c += (weight[i] * d.tone_at(x, y) + pit) / self.scale;
                    if let Some(s) = stippled.get_mut(i) {
                        *s = pit < -STIPPLE_EPS;
                    }
                }
            }
            if d.shadowed() {
                carve = (0..n)
                    .map(|i| {
                        let [x, y] = point[i];
                        weight[i] * d.shadow_at(x, y)
                    })
                    .collect();
            }
        }
        let outline = grid.up(&outline);
        let face_share = grid.up(&face_share);
        let portrait_box = grid.window(portrait_box);
        let mut top = vec![0f32; n];
        let mut height = vec![0f32; n];
        for i in portrait_box.indices(cols) {
            top[i] = (p.wall + continued[i]).clamp(MIN_WALL_SHARE * p.wall, p.relief_depth);
            if outline[i] >= OUTLINE_LEVEL {
                height[i] = top[i];
            }
        }
        // Shadows fall away from the light, at most the depth over the light's slope.
        let light = crate::scene::key_light_dir();
        let reach = (p.relief_depth / light[2].max(0.05) / cell).ceil() as usize + 2;
        let shadow_box = portrait_box.grow_towards(
            if light[0] < 0.0 {
                (0, reach)
            } else {
                (reach, 0)
            },
            if light[1] < 0.0 {
                (0, reach)
            } else {
                (reach, 0)
            },
            cols,
            rows,
        );
        // The darks sunk under the shadow's line, as far into its penumbra as they are dark
        // (on the portrait's top only); the mesh keeps the finer cells there, as round the
        // pits. (In the shadows' box: the ground towards the light, beyond it, casts no
        // horizon above the cut's floor.) The cut's sweep gives the carved relief's shadows.
        let mut box_height = shadow_box.crop(&height, cols, |h| h);
        let (bw, bh) = (shadow_box.width(), shadow_box.height());
        let sharp = if carve.is_empty() {
            light_visibility(&box_height, bw, bh, cell, light)
        } else {
            let shade: Vec<f32> = shadow_box
                .indices(cols)
                .map(|i| {
                    if outline[i] >= OUTLINE_LEVEL {
                        carve[i]
                    } else {
                        0.0
                    }
                })
                .collect();
            let sharp = carve_shadows(
                &mut box_height,
                &shade,
                bw,
                bh,
                cell,
                light,
                ShadowCut {
                    penumbra: SHADOW_SOFTNESS_MM,
                    max_drop: MAX_SHADOW_DROP * p.relief_depth,
                    floor: MIN_WALL_SHARE * p.wall,
                },
            );
            for (i, c) in shadow_box.indices(cols).zip(&box_height) {
                if *c < height[i] {
                    if let Some(s) = stippled.get_mut(i) {
                        *s |= *c < height[i] - SHADOW_EPS;
                    }
                    height[i] = *c;
                    top[i] = *c;
                }
            }
            sharp
        };
        // The carved light and dark matched to the photo's as the stone's light shows it
        // (`DetailParams::tone_match`): the tone, the pits and the cut add up with the
        // relief's own forms, and the raking light shows each its own way.
        let mut sharp = sharp;
        let matched = photo_nodes
            .as_ref()
            .and_then(|(d, weight, point)| d.tone_match().map(|m| (d, weight, point, m)));
        if let Some((d, weight, point, (gain, iod))) = matched {
            let target: Vec<f32> = (0..n)
                .map(|i| {
                    if weight[i] > 0.0 && outline[i] >= OUTLINE_LEVEL {
                        let [x, y] = point[i];
                        d.bright_at(x, y)
                    } else {
                        f32::NAN
                    }
                })
                .collect();
            let matched = super::closure::close(
                &mut height,
                &mut top,
                &target,
                weight,
                super::closure::Grid { cols, rows, cell },
                light,
                portrait_box,
                &super::closure::Closure::for_face(gain, iod / (cell * self.scale)),
            );
            if matched.changed {
                let box_height = shadow_box.crop(&height, cols, |h| h);
                sharp = light_visibility(&box_height, bw, bh, cell, light);
            }
        }
        let occlusion = cavity(&height, cols, rows, cell);
        let mut key_light = vec![1f32; n];
        shadow_box.paste(&penumbra(&sharp, bw, bh), &mut key_light, cols);
        // The light through the stone on the solve grid, then refined: each node marches a
        // ray of many cells, a refined grid's 8 times the work, for a soft glow that the
        // face (where the stipple is) does not take.
        let (coarse_cols, coarse_rows) = grid.coarse;
        let coarse_box = grid.coarse_window(shadow_box);
        let (cw, ch) = (coarse_box.width(), coarse_box.height());
        let coarse_height = coarse_box.crop(&grid.down(&height), coarse_cols, |h| h);
        let coarse_shadow = coarse_box.crop(&grid.down(&key_light), coarse_cols, |v| 1.0 - v);
        let mut transmit = vec![0f32; coarse_cols * coarse_rows];
        coarse_box.paste(
            &light_transmission(
                &coarse_height,
                cw,
                ch,
                cell * k as f32,
                light,
                &coarse_shadow,
                MEAN_FREE_MM,
            ),
            &mut transmit,
            coarse_cols,
        );
        let mut transmit = grid.up(&transmit);
        // Not through the face: its shadows model it (the sockets under the brows, the
        // nose's side), and lightening them made the gems less like their people to a
        // recognition network that was not tuned on (BENCHMARKS.md, "The glow").
        for (t, share) in transmit.iter_mut().zip(&face_share) {
            *t *= 1.0 - share.clamp(0.0, 1.0);
        }
        let face_f: Vec<f32> = face.iter().map(|&f| f32::from(u8::from(f))).collect();
        let face = grid
            .up(&face_f)
            .iter()
            .map(|&f| f >= 0.5)
            .collect::<Vec<bool>>();
        let known: Vec<bool> = face_height.iter().map(|h| h.is_finite()).collect();
        let face_height = grid
            .up_where(&face_height, &known)
            .iter()
            .zip(&face)
            .map(|(h, &f)| h.filter(|_| f).unwrap_or(f32::NAN))
            .collect();
        Ok(Relief {
            height,
            top,
            outline,
            hair: grid.up(&hair),
            occlusion,
            key_light,
            transmit,
            face,
            portrait: grid.up(&portrait),
            face_height,
            stippled,
            cols,
            rows,
            origin: self.origin,
            cell,
            placement,
            view,
            centre: self.centre,
            canonical_per_gem: self.scale,
            solve,
            relative,
        })
    }

    /// The canonical point at grid position (col, row) (fractional nodes).
    fn canonical(&self, col: f32, row: f32) -> [f32; 2] {
        let cell = self.params.cell;
        [
            self.centre[0] + (self.origin[0] + col * cell) * self.scale,
            self.centre[1] + (self.origin[1] + row * cell) * self.scale,
        ]
    }

    /// The grid position (fractional nodes) of canonical point `c`.
    fn grid_position(&self, c: [f32; 2]) -> [f32; 2] {
        let cell = self.params.cell;
        [
            ((c[0] - self.centre[0]) / self.scale - self.origin[0]) / cell,
            ((c[1] - self.centre[1]) / self.scale - self.origin[1]) / cell,
        ]
    }

    /// The template stretched to the face's proportions ([`Placement::head_stretch`] about
    /// its pivot), resampled bilinearly from the one computed in [`CameoBuilder::new`], and
    /// the window it covers.
    fn template_for(
        &self,
        placement: &Placement,
    ) -> (std::borrow::Cow<'_, Template>, Option<Window>) {
        let st = placement.head_stretch;
        if (st[0] - 1.0).abs() < 1e-4 && (st[1] - 1.0).abs() < 1e-4 {
            return (
                std::borrow::Cow::Borrowed(&self.template),
                self.template_box,
            );
        }
        let Some(tb) = self.template_box else {
            return (std::borrow::Cow::Borrowed(&self.template), None);
        };
        let (cols, rows) = (self.cols, self.rows);
        let pivot = placement.head_pivot;
        let (to_canonical, to_grid) = (
            |col: f32, row: f32| self.canonical(col, row),
            |c: [f32; 2]| self.grid_position(c),
        );
        // The stretched template's window: its box's corners moved, grown by a node.
        let corners = [
            (tb.x0, tb.y0),
            (tb.x1, tb.y0),
            (tb.x0, tb.y1),
            (tb.x1, tb.y1),
        ]
        .map(|(x, y)| {
            let c = to_canonical(x as f32, y as f32);
            to_grid([
                pivot[0] + (c[0] - pivot[0]) * st[0],
                pivot[1] + (c[1] - pivot[1]) * st[1],
            ])
        });
        let lo = |k: usize| corners.iter().map(|c| c[k]).fold(f32::INFINITY, f32::min);
        let hi = |k: usize| {
            corners
                .iter()
                .map(|c| c[k])
                .fold(f32::NEG_INFINITY, f32::max)
        };
        let clamp = |v: f32, max: usize| (v.max(0.0) as usize).min(max - 1);
        let window = Window {
            x0: clamp(lo(0).floor() - 1.0, cols),
            y0: clamp(lo(1).floor() - 1.0, rows),
            x1: clamp(hi(0).ceil() + 1.0, cols),
            y1: clamp(hi(1).ceil() + 1.0, rows),
        };
        let t = &self.template;
        let mut out = Template {
            height: vec![0.0; cols * rows],
            hair: vec![0.0; cols * rows],
            coverage: vec![0.0; cols * rows],
        };
        for i in window.indices(cols) {
            // Node -> canonical -> the unstretched template's point -> its grid position.
            let c = to_canonical((i % cols) as f32, (i / cols) as f32);
            let [fx, fy] = to_grid([
                pivot[0] + (c[0] - pivot[0]) / st[0],
                pivot[1] + (c[1] - pivot[1]) / st[1],
            ]);
            if !(fx >= 0.0 && fy >= 0.0 && fx < (cols - 1) as f32 && fy < (rows - 1) as f32) {
                continue;
            }
            let (x0, y0) = (fx as usize, fy as usize);
            let (tx, ty) = (fx - x0 as f32, fy - y0 as f32);
            let j = y0 * cols + x0;
            let lerp = |f: &[f32]| {
                let top = f[j] + (f[j + 1] - f[j]) * tx;
                let bottom = f[j + cols] + (f[j + cols + 1] - f[j + cols]) * tx;
                top + (bottom - top) * ty
            };
            out.height[i] = lerp(&t.height);
            out.hair[i] = lerp(&t.hair);
            out.coverage[i] = lerp(&t.coverage);
        }
        (std::borrow::Cow::Owned(out), Some(window))
    }

    /// The whole cameo mesh for a face mesh in model mm (`[x0, y0, z0, ...]`).
    pub fn build(&self, positions: &[f32], triangles: &[[u32; 3]]) -> Result<Mesh, GemError> {
        Ok(self.mesh_of(&self.relief(positions, triangles)?))
    }

    /// [`Self::build`] for the next face of a sequence (a tracked visitor): the relief's solve
    /// starts from the previous one's result kept in `warm` (empty at first), which it then
    /// replaces, with the visitor's `detail` (read from one of their frames) carved when
    /// given. The gem equals [`Self::build`]'s within the solver's tolerance.
    pub fn build_after(
        &self,
        positions: &[f32],
        triangles: &[[u32; 3]],
        warm: &mut Vec<f32>,
        detail: Option<&FaceDetail>,
    ) -> Result<Mesh, GemError> {
        let relief = self.relief_detailed(positions, triangles, warm, detail)?;
        let mesh = self.mesh_of(&relief);
        *warm = relief.relative;
        Ok(mesh)
    }

    /// The cameo mesh of a relief: the stone's top as planned, the bezel and the back.
    pub fn mesh_of(&self, relief: &Relief) -> Mesh {
        let mut mesh = Mesh::default();
        let k = (self.params.cell / relief.cell).round().max(1.0) as usize;
        let fine;
        let inside = if relief.cols == self.cols && relief.rows == self.rows {
            &self.inside
        } else {
            fine = inside_oval(&self.params, relief.cols, relief.rows, relief.cell);
            &fine
        };
        let plan = plan_surface(relief, inside, k);
        add_relief_surface(&mut mesh, relief, &plan);
        let first = mesh.vertices.len() as u32;
        mesh.vertices.extend_from_slice(&self.base.vertices);
        mesh.indices
            .extend(self.base.indices.iter().map(|&i| i + first));
        mesh
    }
}

/// The sculpted head on the relief grid (see [`CameoBuilder`]).
#[derive(Clone, Debug)]
struct Template {
    height: Vec<f32>,
    hair: Vec<f32>,
    coverage: Vec<f32>,
}

/// The wall's least height where the relief falls steeply to its outline, a share of
/// [`CameoParams::wall`].
const MIN_WALL_SHARE: f32 = 0.5;

/// Grid nodes a thread takes at least when the template is sampled on several cores (a
/// node's samples cost a few microseconds; a thread's start some tens).
const PAR_NODES: usize = 2048;

/// `values` where `known`, continued `rings` nodes past it wherever `reach` is positive, to
/// first order: each new node the mean of its known 4-neighbours' values carried on by their
/// gradients (central differences where both sides are known, else one-sided), so a rounded
/// edge keeps its slope into the wall instead of creasing.
fn extrapolate(
    values: &[f32],
    known: &[bool],
    reach: &[f32],
    cols: usize,
    rows: usize,
    rings: usize,
) -> Vec<f32> {
    let mut out: Vec<f32> = values
        .iter()
        .zip(known)
        .map(|(&v, &k)| if k { v } else { 0.0 })
        .collect();
    let mut have = known.to_vec();
    let at = |i: usize, dc: isize, dr: isize| {
        let (x, y) = ((i % cols) as isize + dc, (i / cols) as isize + dr);
        (x >= 0 && y >= 0 && (x as usize) < cols && (y as usize) < rows)
            .then(|| y as usize * cols + x as usize)
    };
    for _ in 0..rings {
        // The known field's slope per node along one axis, in values per node.
        let slope = |out: &[f32], have: &[bool], i: usize, dc: isize, dr: isize| {
            let fwd = at(i, dc, dr).filter(|&j| have[j]);
            let back = at(i, -dc, -dr).filter(|&j| have[j]);
            match (fwd, back) {
                (Some(f), Some(b)) => 0.5 * (out[f] - out[b]),
                (Some(f), None) => out[f] - out[i],
                (None, Some(b)) => out[i] - out[b],
                (None, None) => 0.0,
            }
        };
        let mut next = Vec::new();
        for i in (0..cols * rows).filter(|&i| !have[i] && reach[i] > 0.0) {
            let (mut sum, mut count) = (0.0, 0);
            for (dc, dr) in [(1isize, 0isize), (-1, 0), (0, 1), (0, -1)] {
                let Some(n) = at(i, dc, dr).filter(|&j| have[j]) else {
                    continue;
                };
                // From n back to i along this axis: minus the slope along (dc, dr).
                let g = if dc != 0 {
                    slope(&out, &have, n, 1, 0) * dc as f32
                } else {
                    slope(&out, &have, n, 0, 1) * dr as f32
                };
                sum += out[n] - g;
                count += 1;
            }
            if count > 0 {
                next.push((i, sum / count as f32));
            }
        }
        for &(i, v) in &next {
            out[i] = v;
            have[i] = true;
        }
    }
    out
}

/// The photo per face node: its detail's height (canonical mm), and the photo point the node
/// shows (pixels), from its vertices' photo positions interpolated over the face, with how
/// squarely the photo sees it there (0..1; 0 off the face, or where the photo sees it
/// edge-on): the tone is read at that point after the compression, on the finer grid.
struct PhotoNodes {
    detail: Vec<f32>,
    point: Vec<[f32; 2]>,
    seen: Vec<f32>,
}

fn photo_detail(
    detail: &FaceDetail,
    points: &[Option<[f32; 3]>],
    triangles: &[[u32; 3]],
    face: &[bool],
    cols: usize,
    rows: usize,
) -> PhotoNodes {
    let seen = detail.seen();
    let channel = |f: fn(&[f32; 3]) -> f32| -> Vec<f32> {
        let a: Vec<f32> = seen.iter().map(f).collect();
        relief::rasterise_attribute(points, triangles, &a, cols, rows).1
    };
    let w = channel(|s| s[2]);
    let x = channel(|s| s[0] * s[2]);
    let y = channel(|s| s[1] * s[2]);
    let mut out = PhotoNodes {
        detail: vec![0.0; cols * rows],
        point: vec![[0.0; 2]; cols * rows],
        seen: vec![0.0; cols * rows],
    };
    for i in (0..cols * rows).filter(|&i| face[i] && w[i] > 0.05) {
        let (px, py) = (x[i] / w[i], y[i] / w[i]);
        let seen = template::smoothstep(0.2, 0.8, w[i]);
        out.detail[i] = seen * detail.at(px, py);
        out.point[i] = [px, py];
        out.seen[i] = seen;
    }
    out
}

/// The relief's cells per solve-grid cell where the photo's light and dark is carved (a
/// frontal portrait with a photo): its stipple's pits are 0.3 mm apart on the default stone,
/// 1.5 cells of 0.2 mm, which carve as a rough speckle; at 0.1 mm they carve round (the
/// recognition networks' measure: BENCHMARKS.md, issue #37).
pub const TONE_SUBDIVISION: usize = 2;
/// A pit shallower than this (canonical mm) leaves its cells to the solve grid's mesh.
const STIPPLE_EPS: f32 = 0.01;
/// A node lowered by more than this (gem mm) into the key light's shadow counts as cut there.
const SHADOW_EPS: f32 = 1e-4;
/// The deepest the photo's darks are sunk into the key light's shadow, a share of the
/// relief's depth (1.5 mm of the default 5): a fold's groove, not a hole (on Biden's photo,
/// 99 % of the sunk nodes go less than 1.2 mm).
const MAX_SHADOW_DROP: f32 = 0.3;
/// The most nodes a refined grid may have (a stone with a fine cell stays on its own grid).
const MAX_FINE_NODES: f32 = 4.0e6;

/// The nodes of the stone's grid `k` times finer.
fn fine_nodes(p: &CameoParams, k: usize) -> f32 {
    let cell = p.cell / k as f32;
    (2.0 * p.half_width / cell + 1.0) * (2.0 * p.half_height / cell + 1.0)
}

/// Per node of a `cols` x `rows` grid of `cell` mm over the stone: inside its oval.
fn inside_oval(p: &CameoParams, cols: usize, rows: usize, cell: f32) -> Vec<bool> {
    (0..cols * rows)
        .map(|i| {
            let x = -p.half_width + (i % cols) as f32 * cell;
            let y = -p.half_height + (i / cols) as f32 * cell;
            (x / p.half_width).powi(2) + (y / p.half_height).powi(2) <= 1.0
        })
        .collect()
}

/// The fewest triangles a face mesh may have: a relief is carved from its surface, and a
/// coarse face has a few hundred (the Surrey mesh 6736).
pub const MIN_FACE_TRIANGLES: usize = 100;
/// A face mesh's extent, model millimetres: a head is about 150-250 mm across; anything from
/// a tenth of that to ten times it is taken (a scan in centimetres would be 15-25 "mm").
pub const FACE_EXTENT_MM: std::ops::RangeInclusive<f32> = 10.0..=2500.0;

/// Refuses a mesh no relief can be carved from: too few triangles, a size far from a
/// head's (1e30 coordinates placed to the gem's scale carved nothing), or flat (a picture
/// of a face, not a surface). A face mesh in other units or of another topology passes:
/// the builder places it by its box.
pub fn check_face_mesh(positions: &[f32], triangles: &[[u32; 3]]) -> Result<(), GemError> {
    if triangles.len() < MIN_FACE_TRIANGLES {
        return Err(GemError::NotAFace(format!(
            "has {} triangles: too few to carve a face from (at least {MIN_FACE_TRIANGLES}; \
             the Surrey mesh of `glyptic photo --obj` has 6736)",
            triangles.len()
        )));
    }
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for v in positions.chunks_exact(3) {
        for k in 0..3 {
            lo[k] = lo[k].min(v[k]);
            hi[k] = hi[k].max(v[k]);
        }
    }
    let extent: Vec<f32> = (0..3).map(|k| hi[k] - lo[k]).collect();
    let largest = extent.iter().fold(0f32, |a, &b| a.max(b));
    let far = lo.iter().chain(&hi).fold(0f32, |a, &b| a.max(b.abs()));
    if !largest.is_finite()
        || !FACE_EXTENT_MM.contains(&largest)
        || far > 100.0 * FACE_EXTENT_MM.end()
    {
        return Err(GemError::NotAFace(format!(
            "spans {largest:.3e} model millimetres, {far:.3e} from the origin: a face in \
             model millimetres spans {}..={} mm near the origin",
            FACE_EXTENT_MM.start(),
            FACE_EXTENT_MM.end()
        )));
    }
    let smallest = extent.iter().fold(f32::INFINITY, |a, &b| a.min(b));
    if smallest < 0.05 * largest {
        return Err(GemError::NotAFace(format!(
            "is flat ({smallest:.1} mm deep against {largest:.1} mm across): a relief needs \
             the face's depth"
        )));
    }
    Ok(())
}
