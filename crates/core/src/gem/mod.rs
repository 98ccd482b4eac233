//! The cameo: a portrait relief on an oval stone, a gold bezel around it and a gold back.
//!
//! Units: gem millimetres. The cameo lies in the XY plane facing +Z, centred on the origin;
//! the ground (the stone's top where nothing is carved) is at z = 0 and the relief rises above
//! it. The portrait (a profile facing left, or a frontal head) is one height field:
//!
//! 1. the fitted face is placed into the sculpted head's frame by its own landmarks
//!    ([`face::place`]), rasterised onto the grid and its eyes carved ([`face::Eye`]); inside
//!    its footprint the face *is* the surface (the face leads);
//! 2. everywhere else the sculpted head, hair, ear and draped bust of [`template`] (computed
//!    once per [`CameoBuilder`]);
//! 3. the whole portrait is compressed in the gradient domain ([`basrelief`]): bulk and
//!    silhouettes are flattened, features kept, so that eye, lids, nostril, lips, ear and locks
//!    stay crisp at a stone's depth;
//! 4. scaled to [`CameoParams::relief_depth`] and lifted by [`CameoParams::wall`], so the
//!    outline is a steep wall, as a cutter leaves it, not a ramp;
//! 5. a cavity term per node ([`Relief::occlusion`]: how much of the sky the surrounding relief
//!    hides), which the renderer uses as ambient occlusion.
//!
//! Everything here is pure computation: no files, no GPU.

pub mod basrelief;
pub mod face;
pub mod measure;
pub mod relief;
pub mod template;

use std::fmt::Write as _;

use crate::scene::{Mesh, Region, Vertex};
pub use basrelief::Compression;
pub use face::Placement;
pub use template::{HairStyle, View};

/// Why a cameo could not be built.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum GemError {
    #[error("the face mesh is empty or has no triangles")]
    EmptyFace,
    #[error("the face mesh has non-finite coordinates")]
    NonFinite,
    #[error("invalid cameo parameter: {0}")]
    BadParams(String),
    #[error(transparent)]
    Relief(#[from] basrelief::ReliefError),
}

/// Shape of the cameo.
#[derive(Clone, Debug, PartialEq)]
pub struct CameoParams {
    /// Semi-axes of the stone oval, gem mm.
    pub half_width: f32,
    pub half_height: f32,
    /// Grid spacing of the relief, gem mm.
    pub cell: f32,
    /// Highest point of the relief above the ground, gem mm.
    pub relief_depth: f32,
    /// Height of the steep wall along the portrait's outline, gem mm (part of the depth).
    pub wall: f32,
    /// Profile or frontal portrait.
    pub view: View,
    /// How the portrait's heights are compressed to the stone's depth.
    pub compression: Compression,
    /// The hair: the classical default, or a person's ([`hair_style`]).
    pub hair: HairStyle,
}

impl CameoParams {
    /// A frontal portrait (the face looks out of the stone) on the default stone.
    pub fn frontal() -> Self {
        View::Frontal.cameo()
    }
}

impl View {
    /// The default stone with the portrait cut this way.
    pub fn cameo(self) -> CameoParams {
        CameoParams {
            view: self,
            ..CameoParams::default()
        }
    }
}

impl Default for CameoParams {
    /// A profile portrait facing left, the classic cameo: 44 x 56 mm, relief up to 5 mm
    /// (catalogued stones are 3.5-8 mm thick in all) with a 0.8 mm wall.
    fn default() -> Self {
        CameoParams {
            half_width: 22.0,
            half_height: 28.0,
            cell: 0.2,
            relief_depth: 5.0,
            wall: 0.8,
            view: View::Profile,
            compression: Compression::default(),
            hair: HairStyle::default(),
        }
    }
}

/// Bezel cross-section: (offset along the oval's outward normal, height), gem mm, from the
/// inner foot over the crown to the outer foot.
const BEZEL_PROFILE: [[f32; 2]; 7] = [
    [-0.7, -0.3],
    [-0.7, 0.9],
    [-0.3, 1.6],
    [0.4, 1.9],
    [1.2, 1.55],
    [1.6, 0.6],
    [1.6, -3.0],
];
/// Segments around the oval for the bezel and the back.
const RING_SEGMENTS: usize = 360;
/// Depth of the gold back below the ground, gem mm.
const BACK_Z: f32 = -3.0;
/// The portrait stays inside this fraction of the oval (clear of the bezel's foot).
const PORTRAIT_OVAL: f32 = 0.93;
/// Gradient gain of the sculpted head and bust against the face's 1 (see
/// [`basrelief::compress`]).
const HEAD_EMPHASIS: f32 = 0.8;
/// Relief below this height (gem mm) counts as ground.
const GROUND_EPS: f32 = 0.03;
/// The share of the portrait's compressed heights below which the relief's scale is set
/// (the few highest nodes above it are clamped to the depth).
const DEPTH_QUANTILE: f32 = 0.998;

/// The finished relief in gem units, kept for tests, measurement and inspection.
#[derive(Clone, Debug)]
pub struct Relief {
    /// Height above the ground per grid node, gem mm (row-major, `cols` x `rows`).
    pub height: Vec<f32>,
    /// How much of the agate's hair layer lies at each node, 0..1.
    pub hair: Vec<f32>,
    /// Ambient light reaching each node, 0..1 (1: open sky; the foot of a wall or a groove's
    /// bottom less).
    pub occlusion: Vec<f32>,
    /// How much of the key light ([`crate::scene::key_light_dir`]) reaches each node, 0..1:
    /// the relief's cast shadows (the key light is fixed to the stone, so they are computed
    /// once per cameo).
    pub key_light: Vec<f32>,
    /// Nodes where the fitted face makes the surface.
    pub face: Vec<bool>,
    /// The portrait before compression, canonical mm (0 off the portrait).
    pub portrait: Vec<f32>,
    /// The face's own height (canonical mm, smoothed, eyes carved) where it covers a node;
    /// NaN elsewhere.
    pub face_height: Vec<f32>,
    pub cols: usize,
    pub rows: usize,
    /// Gem position of node (0, 0) and the spacing, gem mm.
    pub origin: [f32; 2],
    pub cell: f32,
    /// How the face was placed, and the canonical frame's point at the gem's centre and its
    /// millimetres per gem millimetre (see [`Relief::model_to_gem`]).
    pub placement: Placement,
    pub view: View,
    pub centre: [f32; 2],
    pub canonical_per_gem: f32,
    /// How the Poisson solve of the compression went.
    pub solve: basrelief::SolveReport,
    /// The compressed heights before scaling (canonical mm, 0 off the portrait): the warm
    /// start of the next relief when a face is tracked ([`CameoBuilder::build_after`]).
    pub relative: Vec<f32>,
}

impl Relief {
    /// Height at a grid node.
    pub fn at(&self, col: usize, row: usize) -> f32 {
        self.height[row * self.cols + col]
    }

    /// Where a model point (mm, the face mesh's frame) lands on the stone: gem x, y and its
    /// height in canonical mm (before compression).
    pub fn model_to_gem(&self, p: [f32; 3]) -> [f32; 3] {
        let c = self.placement.to_canonical(self.view, p);
        [
            (c[0] - self.centre[0]) / self.canonical_per_gem,
            (c[1] - self.centre[1]) / self.canonical_per_gem,
            c[2],
        ]
    }
}

fn check_params(p: &CameoParams) -> Result<(), GemError> {
    let pos = [p.half_width, p.half_height, p.cell, p.relief_depth, p.wall];
    if pos.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
        return Err(GemError::BadParams(
            "sizes and depths must be positive".into(),
        ));
    }
    if p.wall >= p.relief_depth {
        return Err(GemError::BadParams(format!(
            "the wall ({} mm) must be lower than the relief depth ({} mm)",
            p.wall, p.relief_depth
        )));
    }
    let nodes = (2.0 * p.half_width / p.cell + 1.0) * (2.0 * p.half_height / p.cell + 1.0);
    if nodes > 4.0e6 {
        return Err(GemError::BadParams(format!(
            "{nodes:.0} grid nodes: the cell is too small"
        )));
    }
    p.compression.validate()?;
    Ok(())
}

/// The canonical face's length from the eyes' level to the chin, and the eyes' level
/// (canonical v), model mm: the unit [`crate::person`] measures hair in.
const FACE_LENGTH_MM: f32 = 115.0;
const EYES_V: f32 = 30.0;

/// A person's hair as the template carves it, from what their photo shows: none for a bald
/// head; its volume from how far it stands above and beside the skull; where it ends from its
/// length (below the nape it falls behind the neck and over the shoulders); its locks from its
/// curl (straight hair in long locks, curls in short ones).
pub fn hair_style(person: &crate::person::Person) -> HairStyle {
    let smooth = template::smoothstep;
    // Facial hair: a beard as thick as it is full (3 mm of stubble-length beard on a chin
    // alone, 12 mm when it covers the whole jaw densely), a moustache a little thinner.
    let (beard, beard_jaw) = if person.has_beard() {
        (
            3.0 + 9.0 * smooth(0.6, 0.95, person.beard_jaw),
            smooth(0.4, 0.8, person.beard_jaw),
        )
    } else {
        (0.0, 0.0)
    };
    let moustache = if person.has_moustache() {
        2.0 + 0.2 * beard
    } else {
        0.0
    };
    let facial = HairStyle {
        beard,
        beard_jaw,
        moustache,
        glasses: person.has_glasses(),
        ..HairStyle::default()
    };
    let Some(h) = person.hair else {
        return HairStyle {
            bald: true,
            ..facial
        };
    };
    let stand = h.top.max(0.7 * h.sides);
    HairStyle {
        bald: false,
        volume: (3.0 + 0.75 * FACE_LENGTH_MM * stand).clamp(3.0, 32.0),
        end: (EYES_V - h.length * FACE_LENGTH_MM).clamp(-290.0, -20.0),
        curl: (0.15 + 0.85 * h.curl).clamp(0.0, 1.0),
        ..facial
    }
}

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
        let inside = (0..cols * rows).map(|i| oval(i) <= 1.0).collect();
        let allowed: Vec<bool> = (0..cols * rows).map(|i| oval(i) <= PORTRAIT_OVAL).collect();
        // Each node is the mean of 2 x 2 samples across its cell, so carved grooves and the
        // outline do not alias into stair-steps.
        let mut template = Template {
            height: vec![0.0; cols * rows],
            hair: vec![0.0; cols * rows],
            coverage: vec![0.0; cols * rows],
        };
        for i in (0..cols * rows).filter(|&i| allowed[i]) {
            let (x, y) = node(i);
            for (dx, dy) in [(-0.25, -0.25), (0.25, -0.25), (-0.25, 0.25), (0.25, 0.25)] {
                let s = template::sample(
                    p.view,
                    &p.hair,
                    centre[0] + (x + dx * p.cell) * scale,
                    centre[1] + (y + dy * p.cell) * scale,
                );
                template.height[i] += 0.25 * s.height;
                template.hair[i] += 0.25 * s.hair;
                template.coverage[i] += 0.25 * f32::from(u8::from(s.covered));
            }
        }
        // Along the outline (partly covered nodes, or nodes beside one of another coverage)
        // the coverage again from the finer sub-samples the face's outline gets.
        let coarse = template.coverage.clone();
        let n_sub = relief::COVERAGE_SAMPLES;
        for i in (0..cols * rows).filter(|&i| allowed[i]) {
            let (x, y) = (i % cols, i / cols);
            let c = coarse[i];
            let neighbours = [
                (x > 0).then(|| i - 1),
                (x + 1 < cols).then(|| i + 1),
                (y > 0).then(|| i - cols),
                (y + 1 < rows).then(|| i + cols),
            ];
            let edge = (c > 0.0 && c < 1.0) || neighbours.iter().flatten().any(|&j| coarse[j] != c);
            if !edge {
                continue;
            }
            let (gx, gy) = node(i);
            let mut inside = 0;
            for sy in 0..n_sub {
                for sx in 0..n_sub {
                    let o = |k: usize| ((k as f32 + 0.5) / n_sub as f32 - 0.5) * p.cell;
                    let s = template::sample(
                        p.view,
                        &p.hair,
                        centre[0] + (gx + o(sx)) * scale,
                        centre[1] + (gy + o(sy)) * scale,
                    );
                    inside += usize::from(s.covered);
                }
            }
            template.coverage[i] = inside as f32 / (n_sub * n_sub) as f32;
        }
        let mut base = Mesh::default();
        add_bezel_and_back(&mut base, p);
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
        if positions.len() < 9 || triangles.is_empty() {
            return Err(GemError::EmptyFace);
        }
        if positions.iter().any(|v| !v.is_finite()) {
            return Err(GemError::NonFinite);
        }
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
        for i in portrait_box.indices(cols) {
            let head_ok = self.allowed[i] && i % cols >= front[i / cols];
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
                // Facial hair carved in locks, as deep as it is thick (up to 4 mm).
                let thick = fuzz.get(i).copied().unwrap_or(0.0);
                let locks = if thick > 0.05 {
                    (thick / 4.0).min(1.0) * template::beard_locks(u, v, p.hair.curl)
                } else {
                    0.0
                };
                let f = (smooth[i] + carved + locks).max(0.0);
                if face[i] {
                    face_height[i] = f;
                }
                portrait[i] = share * f + (1.0 - share) * head_height;
                hair[i] =
                    (1.0 - share) * head.hair[i] + share * template::smoothstep(0.5, 2.0, thick);
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
                    let locks = (thick / 4.0).min(1.0) * template::beard_locks(u, v, p.hair.curl);
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
        // The wall: the outline's sub-cell coverage smoothed once (1-2-1 each way), a steep
        // bevel about two cells wide that follows the silhouette, not the grid's stair-steps
        // (more smoothing would fill the profile's narrow notches, such as the parting of the
        // lips).
        let mut edge = vec![0f32; n];
        portrait_box.paste(
            &smooth_121(
                &portrait_box.crop(&cover, cols, |c| c),
                portrait_box.width(),
                portrait_box.height(),
            ),
            &mut edge,
            cols,
        );
        let mut height = vec![0f32; n];
        for i in portrait_box.indices(cols) {
            let lift = p.wall * template::smoothstep(0.0, 1.0, edge[i]);
            let h = lift + relative[i].max(0.0) * gain;
            height[i] = if h < GROUND_EPS {
                0.0
            } else {
                h.min(p.relief_depth)
            };
        }
        let occlusion = cavity(&height, cols, rows, cell);
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
        let mut key_light = vec![1f32; n];
        shadow_box.paste(
            &light_visibility(
                &shadow_box.crop(&height, cols, |h| h),
                shadow_box.width(),
                shadow_box.height(),
                cell,
                light,
            ),
            &mut key_light,
            cols,
        );
        Ok(Relief {
            height,
            hair,
            occlusion,
            key_light,
            face,
            portrait,
            face_height,
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
        Ok(self.mesh(&self.relief(positions, triangles)?))
    }

    /// [`Self::build`] for the next face of a sequence (a tracked visitor): the relief's solve
    /// starts from the previous one's result kept in `warm` (empty at first), which it then
    /// replaces. The gem equals [`Self::build`]'s within the solver's tolerance.
    pub fn build_after(
        &self,
        positions: &[f32],
        triangles: &[[u32; 3]],
        warm: &mut Vec<f32>,
    ) -> Result<Mesh, GemError> {
        let relief = self.relief_from(positions, triangles, warm)?;
        let mesh = self.mesh(&relief);
        *warm = relief.relative;
        Ok(mesh)
    }

    /// The cameo mesh of a relief: the stone's top as planned, the bezel and the back.
    fn mesh(&self, relief: &Relief) -> Mesh {
        let mut mesh = Mesh::default();
        let plan = plan_surface(relief, &self.inside);
        add_relief_surface(&mut mesh, relief, &plan);
        let first = mesh.vertices.len() as u32;
        mesh.vertices.extend_from_slice(&self.base.vertices);
        mesh.indices
            .extend(self.base.indices.iter().map(|&i| i + first));
        mesh
    }
}

/// A rectangle of grid nodes (inclusive bounds): the relief's work is done only where the
/// portrait can reach.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Window {
    x0: usize,
    y0: usize,
    x1: usize,
    y1: usize,
}

impl Window {
    /// The nodes where `pred` holds, or `None`.
    fn of(cols: usize, rows: usize, pred: impl Fn(usize) -> bool) -> Option<Self> {
        let (mut x0, mut y0, mut x1, mut y1) = (cols, rows, 0, 0);
        for i in (0..cols * rows).filter(|&i| pred(i)) {
            let (x, y) = (i % cols, i / cols);
            (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
        }
        (x0 <= x1).then_some(Window { x0, y0, x1, y1 })
    }

    fn grow(self, m: usize, cols: usize, rows: usize) -> Self {
        self.grow_towards((m, m), (m, m), cols, rows)
    }

    /// Grown by (before, after) nodes along x and along y, within the grid.
    fn grow_towards(self, x: (usize, usize), y: (usize, usize), cols: usize, rows: usize) -> Self {
        Window {
            x0: self.x0.saturating_sub(x.0),
            y0: self.y0.saturating_sub(y.0),
            x1: (self.x1 + x.1).min(cols - 1),
            y1: (self.y1 + y.1).min(rows - 1),
        }
    }

    fn union(self, o: Self) -> Self {
        Window {
            x0: self.x0.min(o.x0),
            y0: self.y0.min(o.y0),
            x1: self.x1.max(o.x1),
            y1: self.y1.max(o.y1),
        }
    }

    fn width(&self) -> usize {
        self.x1 - self.x0 + 1
    }

    fn height(&self) -> usize {
        self.y1 - self.y0 + 1
    }

    /// Row-major node indices of the grid (`cols` wide) inside the window.
    fn indices(self, cols: usize) -> impl Iterator<Item = usize> {
        (self.y0..=self.y1).flat_map(move |y| (self.x0..=self.x1).map(move |x| y * cols + x))
    }

    /// The window's part of a grid field, each value mapped.
    fn crop(&self, field: &[f32], cols: usize, f: impl Fn(f32) -> f32) -> Vec<f32> {
        self.indices(cols).map(|i| f(field[i])).collect()
    }

    /// Writes a window-sized field into the grid field.
    fn paste(&self, part: &[f32], field: &mut [f32], cols: usize) {
        for (k, i) in self.indices(cols).enumerate() {
            field[i] = part[k];
        }
    }
}

/// The sculpted head on the relief grid (see [`CameoBuilder`]).
#[derive(Clone, Debug)]
struct Template {
    height: Vec<f32>,
    hair: Vec<f32>,
    coverage: Vec<f32>,
}

/// Radii (gem mm) and weights of the cavity term: how far the relief around a node stands
/// above it, at two scales (a groove's width, a wall's foot).
const CAVITY_SCALES: [(f32, f32); 2] = [(0.35, 0.9), (1.2, 0.45)];

/// Ambient light reaching each node, 0..1: one minus the weighted amount by which the blurred
/// relief stands above the node (a groove, the foot of a wall, the hollow of an ear), at two
/// scales. Ridges and open ground get 1.
fn cavity(height: &[f32], cols: usize, rows: usize, cell: f32) -> Vec<f32> {
    let mut occ = vec![1f32; height.len()];
    // Only the relief's bounding box, grown by the widest blur's reach, can be occluded (the
    // blur of the zero ground beyond it is zero either way).
    let Some(window) = Window::of(cols, rows, |i| height[i] > 0.0) else {
        return occ;
    };
    let window = window.grow(
        3 * (CAVITY_SCALES[1].0 / cell).ceil() as usize + 2,
        cols,
        rows,
    );
    let (w, h) = (window.width(), window.height());
    let crop = window.crop(height, cols, |h| h);
    let mut local = vec![1f32; w * h];
    for (radius, weight) in CAVITY_SCALES {
        let blurred = basrelief::blur(&crop, w, h, radius / cell);
        for ((o, b), h) in local.iter_mut().zip(&blurred).zip(&crop) {
            *o = (*o - weight * (b - h).max(0.0)).clamp(0.25, 1.0);
        }
    }
    window.paste(&local, &mut occ, cols);
    occ
}

/// One pass of 1-2-1 smoothing in each direction (edges clamped).
fn smooth_121(values: &[f32], cols: usize, rows: usize) -> Vec<f32> {
    let mut tmp = vec![0f32; values.len()];
    for y in 0..rows {
        for x in 0..cols {
            let at = |xx: usize| values[y * cols + xx];
            tmp[y * cols + x] =
                0.25 * at(x.saturating_sub(1)) + 0.5 * at(x) + 0.25 * at((x + 1).min(cols - 1));
        }
    }
    let mut out = vec![0f32; values.len()];
    for y in 0..rows {
        for x in 0..cols {
            let at = |yy: usize| tmp[yy * cols + x];
            out[y * cols + x] =
                0.25 * at(y.saturating_sub(1)) + 0.5 * at(y) + 0.25 * at((y + 1).min(rows - 1));
        }
    }
    out
}

/// Softness of the cast shadows' edge, gem mm of height.
const SHADOW_SOFTNESS_MM: f32 = 0.15;

/// How much of a directional light (unit vector `light` towards it) reaches each node of a
/// height field (gem mm, `cell` apart): one sweep from the light's side keeps, per node, the
/// highest horizon S = max over the nodes towards the light of (their height - distance x
/// the light's slope), from the previous node's S (interpolated between two nodes of the
/// previous line); a node is lit where it stands above S, fading out over
/// [`SHADOW_SOFTNESS_MM`] below it.
fn light_visibility(
    height: &[f32],
    cols: usize,
    rows: usize,
    cell: f32,
    light: [f32; 3],
) -> Vec<f32> {
    let n = cols * rows;
    let plane = light[0].hypot(light[1]);
    if plane < 1e-6 || light[2] <= 0.0 {
        return vec![if light[2] > 0.0 { 1.0 } else { 0.0 }; n];
    }
    let (dx, dy) = (light[0] / plane, light[1] / plane);
    let slope = light[2] / plane;
    // Step one line along the major axis towards the light; the minor axis moves by a fraction.
    let x_major = dx.abs() >= dy.abs();
    let (lines, len) = if x_major { (cols, rows) } else { (rows, cols) };
    let (major, minor) = if x_major { (dx, dy) } else { (dy, dx) };
    let shift = minor / major.abs();
    let step = cell * (1.0 + shift * shift).sqrt();
    let drop = step * slope;
    let idx = |line: usize, k: usize| {
        if x_major {
            k * cols + line
        } else {
            line * cols + k
        }
    };
    let mut horizon = vec![f32::NEG_INFINITY; n];
    let mut vis = vec![1f32; n];
    // Lines nearest the light first.
    let order: Vec<usize> = if major < 0.0 {
        (0..lines).collect()
    } else {
        (0..lines).rev().collect()
    };
    for w in 1..order.len() {
        let (prev, line) = (order[w - 1], order[w]);
        for k in 0..len {
            // The point one step towards the light, between two nodes of the previous line.
            let pos = k as f32 + shift;
            if pos < 0.0 || pos > (len - 1) as f32 {
                continue;
            }
            let k0 = pos.floor() as usize;
            let k1 = (k0 + 1).min(len - 1);
            let t = pos - k0 as f32;
            let sample = |f: &[f32]| {
                let (a, b) = (f[idx(prev, k0)], f[idx(prev, k1)]);
                if a.is_finite() && b.is_finite() {
                    a + (b - a) * t
                } else {
                    a.max(b)
                }
            };
            let s = sample(height).max(sample(&horizon)) - drop;
            let i = idx(line, k);
            horizon[i] = s;
            vis[i] = template::smoothstep(-SHADOW_SOFTNESS_MM, 0.0, height[i] - s);
        }
    }
    vis
}

/// Builds the relief height field (gem mm) from a face mesh in model mm (one-off: see
/// [`CameoBuilder`] to rebuild for many faces).
pub fn build_relief(
    positions: &[f32],
    triangles: &[[u32; 3]],
    p: &CameoParams,
) -> Result<Relief, GemError> {
    CameoBuilder::new(p)?.relief(positions, triangles)
}

/// Builds the whole cameo mesh from a face mesh in model mm (`[x0, y0, z0, ...]`; one-off: see
/// [`CameoBuilder`]).
pub fn build_cameo(
    positions: &[f32],
    triangles: &[[u32; 3]],
    p: &CameoParams,
) -> Result<Mesh, GemError> {
    CameoBuilder::new(p)?.build(positions, triangles)
}

/// Largest square of grid cells the stone's top is simplified to, how far (gem mm) a
/// simplified square's grid heights may stray from the bilinear patch of its corners, and how
/// far their slopes may (shading follows the interpolated normals, which show a fan's pattern
/// long before its heights do).
const MAX_BLOCK: usize = 8;
const FLAT_TOLERANCE_MM: f32 = 0.004;
const SLOPE_TOLERANCE: f32 = 0.004;
/// How far the hair layer's weight may stray from the corners' bilinear patch in a merged square.
const HAIR_TOLERANCE: f32 = 0.02;

/// One square element of the stone's top: `size` x `size` cells from node (`x`, `y`).
#[derive(Clone, Copy, Debug)]
struct Element {
    x: usize,
    y: usize,
    size: usize,
}

/// The stone's top before triangulation: per node its material region and slope, and the
/// quadtree's elements.
#[derive(Clone, Debug, Default)]
struct SurfacePlan {
    region: Vec<Region>,
    slope: Vec<[f32; 2]>,
    elements: Vec<Element>,
}

/// The stone's top, with detail only where the surface needs it: the grid's cells are merged
/// (quadtree fashion, up to [`MAX_BLOCK`] cells a side) wherever the heights stay within
/// [`FLAT_TOLERANCE_MM`] of a plane and the material does not change, so the flat ground and
/// smooth slopes take a few triangles and the face keeps every cell. Cells need all four
/// corners inside the oval; the bezel's inner foot covers the stepped outline.
fn plan_surface(relief: &Relief, inside: &[bool]) -> SurfacePlan {
    let (cols, rows, cell) = (relief.cols, relief.rows, relief.cell);
    let mut region = vec![Region::Ground; cols * rows];
    let mut slope = vec![[0.0; 2]; cols * rows];
    for row in 0..rows {
        for col in 0..cols {
            let i = row * cols + col;
            region[i] = if relief.height[i] < GROUND_EPS {
                Region::Ground
            } else if relief.hair[i] > 0.5 {
                Region::Hair
            } else {
                Region::Relief
            };
            // Central differences, one-sided at the grid's edge.
            let (left, right) = (col.saturating_sub(1), (col + 1).min(cols - 1));
            let (up, down) = (row.saturating_sub(1), (row + 1).min(rows - 1));
            slope[i] = [
                (relief.height[row * cols + right] - relief.height[row * cols + left])
                    / (cell * (right - left) as f32),
                (relief.height[down * cols + col] - relief.height[up * cols + col])
                    / (cell * (down - up) as f32),
            ];
        }
    }
    let (blocks_x, blocks_y) = (
        (cols - 1).div_ceil(MAX_BLOCK),
        (rows - 1).div_ceil(MAX_BLOCK),
    );
    // Summed-area table of nodes that are not bare ground (inside, height, slope and hair 0):
    // a square without any is merged without looking at its nodes (most of the field).
    let sat_w = cols + 1;
    let mut busy = vec![0u32; sat_w * (rows + 1)];
    for y in 0..rows {
        let mut run = 0;
        for x in 0..cols {
            let i = y * cols + x;
            let bare = inside[i]
                && relief.height[i] == 0.0
                && slope[i] == [0.0, 0.0]
                && relief.hair[i] == 0.0;
            run += u32::from(!bare);
            busy[(y + 1) * sat_w + x + 1] = busy[y * sat_w + x + 1] + run;
        }
    }
    let busy_in = |e: Element| {
        let (x0, y0) = (e.x, e.y);
        let (x1, y1) = (x0 + e.size + 1, y0 + e.size + 1);
        busy[y1 * sat_w + x1] + busy[y0 * sat_w + x0]
            - busy[y0 * sat_w + x1]
            - busy[y1 * sat_w + x0]
    };
    // A square may be one element if every node is inside, of one region, and near the
    // bilinear patch of its corners in height, slope and hair weight.
    let mergeable = |e: Element| {
        if busy_in(e) == 0 {
            return true;
        }
        let at = |dx: usize, dy: usize| (e.y + dy) * cols + e.x + dx;
        let c = [at(0, 0), at(e.size, 0), at(0, e.size), at(e.size, e.size)];
        let bilinear = |v: [f32; 4], u: f32, w: f32| {
            (v[0] * (1.0 - u) + v[1] * u) * (1.0 - w) + (v[2] * (1.0 - u) + v[3] * u) * w
        };
        let heights = c.map(|i| relief.height[i]);
        let sx = c.map(|i| slope[i][0]);
        let sy = c.map(|i| slope[i][1]);
        let hair = c.map(|i| relief.hair[i]);
        let first = region[c[0]];
        let scale = 1.0 / e.size as f32;
        let node_ok = |dx: usize, dy: usize| {
            let i = at(dx, dy);
            let (u, w) = (dx as f32 * scale, dy as f32 * scale);
            inside[i]
                && region[i] == first
                && (relief.height[i] - bilinear(heights, u, w)).abs() <= FLAT_TOLERANCE_MM
                && (slope[i][0] - bilinear(sx, u, w)).abs() <= SLOPE_TOLERANCE
                && (slope[i][1] - bilinear(sy, u, w)).abs() <= SLOPE_TOLERANCE
                && (relief.hair[i] - bilinear(hair, u, w)).abs() <= HAIR_TOLERANCE
        };
        // The centre and the edges' midpoints stray first on a curved surface: try them first.
        let h = e.size / 2;
        [(h, h), (h, 0), (0, h), (e.size, h), (h, e.size)]
            .iter()
            .all(|&(dx, dy)| node_ok(dx, dy))
            && (0..=e.size).all(|dy| (0..=e.size).all(|dx| node_ok(dx, dy)))
    };
    let split = |root: Element, elements: &mut Vec<Element>| {
        let mut stack = vec![root];
        while let Some(e) = stack.pop() {
            if e.x >= cols - 1 || e.y >= rows - 1 {
                continue;
            }
            let fits = e.x + e.size < cols && e.y + e.size < rows;
            if e.size == 1 {
                let corners = [(0, 0), (1, 0), (0, 1), (1, 1)];
                if corners
                    .iter()
                    .all(|&(dx, dy)| inside[(e.y + dy) * cols + e.x + dx])
                {
                    elements.push(e);
                }
            } else if fits && mergeable(e) {
                elements.push(e);
            } else {
                let h = e.size / 2;
                for (dx, dy) in [(0, 0), (h, 0), (0, h), (h, h)] {
                    stack.push(Element {
                        x: e.x + dx,
                        y: e.y + dy,
                        size: h,
                    });
                }
            }
        }
    };
    let mut elements = Vec::with_capacity(cols * rows / 16);
    // Last block first (the order of a stack of all blocks).
    for b in (0..blocks_x * blocks_y).rev() {
        let (bx, by) = (b % blocks_x, b / blocks_x);
        split(
            Element {
                x: bx * MAX_BLOCK,
                y: by * MAX_BLOCK,
                size: MAX_BLOCK,
            },
            &mut elements,
        );
    }
    SurfacePlan {
        region,
        slope,
        elements,
    }
}

/// Adds the stone's top as planned: a merged square is a fan around its centre node through
/// every node on its border that a neighbour uses as a corner, so the surface stays watertight
/// (no T-junctions).
fn add_relief_surface(mesh: &mut Mesh, relief: &Relief, plan: &SurfacePlan) {
    let (cols, rows, cell) = (relief.cols, relief.rows, relief.cell);
    let (elements, region, slope) = (&plan.elements, &plan.region, &plan.slope);
    let node_xy = |col: usize, row: usize| {
        (
            relief.origin[0] + col as f32 * cell,
            relief.origin[1] + row as f32 * cell,
        )
    };
    // Nodes in use: every element's corners, and merged squares' centres.
    let mut corner = vec![false; cols * rows];
    let mut used = vec![false; cols * rows];
    for e in elements {
        for (dx, dy) in [(0, 0), (e.size, 0), (0, e.size), (e.size, e.size)] {
            corner[(e.y + dy) * cols + e.x + dx] = true;
            used[(e.y + dy) * cols + e.x + dx] = true;
        }
        if e.size > 1 {
            used[(e.y + e.size / 2) * cols + e.x + e.size / 2] = true;
        }
    }

    let mut index = vec![u32::MAX; cols * rows];
    let count = used.iter().filter(|u| **u).count();
    mesh.vertices.reserve(count);
    for (i, (x, y)) in (0..rows)
        .flat_map(|row| (0..cols).map(move |col| (row * cols + col, col, row)))
        .filter(|&(i, _, _)| used[i])
        .map(|(i, col, row)| (i, node_xy(col, row)))
    {
        let h = relief.height[i];
        let [dzdx, dzdy] = slope[i];
        let inv_len = 1.0 / (dzdx * dzdx + dzdy * dzdy + 1.0).sqrt();
        index[i] = mesh.vertices.len() as u32;
        mesh.vertices.push(Vertex {
            position: [x, y, h],
            normal: [-dzdx * inv_len, -dzdy * inv_len, inv_len],
            relief: h,
            region: region[i] as u32,
            hair: relief.hair[i].clamp(0.0, 1.0),
            occlusion: relief.occlusion[i],
            key_light: relief.key_light[i],
        });
    }

    // Counter-clockwise seen from +Z (y up), like the bezel's.
    let mut border = Vec::with_capacity(4 * MAX_BLOCK);
    for e in elements {
        let at = |dx: usize, dy: usize| (e.y + dy) * cols + e.x + dx;
        if e.size == 1 {
            let [a, b, c, d] = [at(0, 0), at(1, 0), at(1, 1), at(0, 1)].map(|i| index[i]);
            mesh.indices.extend_from_slice(&[a, b, c, a, c, d]);
            continue;
        }
        let n = e.size;
        border.clear();
        border.extend((0..n).map(|k| at(k, 0)));
        border.extend((0..n).map(|k| at(n, k)));
        border.extend((0..n).map(|k| at(n - k, n)));
        border.extend((0..n).map(|k| at(0, n - k)));
        border.retain(|&i| corner[i]);
        let centre = index[at(n / 2, n / 2)];
        for k in 0..border.len() {
            let (a, b) = (border[k], border[(k + 1) % border.len()]);
            mesh.indices
                .extend_from_slice(&[centre, index[a], index[b]]);
        }
    }
}

/// The gold bezel swept around the oval (flat across each profile segment, smooth along the
/// oval) and the gold back.
fn add_bezel_and_back(mesh: &mut Mesh, p: &CameoParams) {
    let (a, b) = (p.half_width, p.half_height);
    let frame = |i: usize| {
        let t = i as f32 / RING_SEGMENTS as f32 * std::f32::consts::TAU;
        let (s, c) = t.sin_cos();
        let n = [b * c, a * s];
        let l = (n[0] * n[0] + n[1] * n[1]).sqrt();
        ([a * c, b * s], [n[0] / l, n[1] / l])
    };
    let gold = |position: [f32; 3], normal: [f32; 3]| Vertex {
        position,
        normal,
        relief: 0.0,
        region: Region::Gold as u32,
        hair: 0.0,
        occlusion: 1.0,
        key_light: 1.0,
    };
    for seg in BEZEL_PROFILE.windows(2) {
        let ([d0, z0], [d1, z1]) = (seg[0], seg[1]);
        let (td, tz) = (d1 - d0, z1 - z0);
        let l = (td * td + tz * tz).sqrt();
        let (nd, nz) = (-tz / l, td / l);
        let base = mesh.vertices.len() as u32;
        for i in 0..=RING_SEGMENTS {
            let (e, n) = frame(i % RING_SEGMENTS);
            let normal = [n[0] * nd, n[1] * nd, nz];
            for (d, z) in [(d0, z0), (d1, z1)] {
                mesh.vertices
                    .push(gold([e[0] + n[0] * d, e[1] + n[1] * d, z], normal));
            }
        }
        for i in 0..RING_SEGMENTS as u32 {
            let (p0, p1) = (base + 2 * i, base + 2 * i + 1);
            let (q0, q1) = (p0 + 2, p1 + 2);
            // Counter-clockwise seen from the side the normal points to.
            mesh.indices.extend_from_slice(&[p0, q0, q1, p0, q1, p1]);
        }
    }
    let outer = BEZEL_PROFILE[BEZEL_PROFILE.len() - 1][0];
    let centre = mesh.vertices.len() as u32;
    mesh.vertices
        .push(gold([0.0, 0.0, BACK_Z], [0.0, 0.0, -1.0]));
    for i in 0..RING_SEGMENTS {
        let (e, n) = frame(i);
        mesh.vertices.push(gold(
            [e[0] + n[0] * outer, e[1] + n[1] * outer, BACK_Z],
            [0.0, 0.0, -1.0],
        ));
    }
    for i in 0..RING_SEGMENTS as u32 {
        let next = (i + 1) % RING_SEGMENTS as u32;
        mesh.indices
            .extend_from_slice(&[centre, centre + 1 + next, centre + 1 + i]);
    }
}

/// Why an OBJ face mesh could not be read.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ObjError {
    #[error("line {line}: {problem}")]
    Line { line: usize, problem: String },
}

/// Reads the positions and faces of Wavefront OBJ text (`v x y z`, `f a b c ...` with any of
/// the `a/t/n` forms and negative indices; polygons as fans; everything else ignored),
/// keeping the vertices in the file's order: a Surrey face keeps its vertex numbers, which
/// place it in the portrait (a general loader renumbers them by first use).
pub fn parse_obj(text: &str) -> Result<(Vec<f32>, Vec<[u32; 3]>), ObjError> {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let bad = |problem: String| ObjError::Line {
            line: k + 1,
            problem,
        };
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let xyz: Vec<f32> = words
                    .take(3)
                    .map(|w| {
                        w.parse::<f32>()
                            .map_err(|_| bad(format!("bad coordinate {w:?}")))
                    })
                    .collect::<Result<_, _>>()?;
                if xyz.len() != 3 {
                    return Err(bad("a vertex needs three coordinates".into()));
                }
                positions.extend_from_slice(&xyz);
            }
            Some("f") => {
                let count = positions.len() / 3;
                let ids: Vec<u32> = words
                    .map(|w| {
                        let first = w.split('/').next().unwrap_or("");
                        let i: i64 = first
                            .parse()
                            .map_err(|_| bad(format!("bad vertex reference {w:?}")))?;
                        let index = if i < 0 { count as i64 + i } else { i - 1 };
                        if index < 0 || index >= count as i64 {
                            return Err(bad(format!("vertex {i} does not exist ({count} so far)")));
                        }
                        Ok(index as u32)
                    })
                    .collect::<Result<_, _>>()?;
                if ids.len() < 3 {
                    return Err(bad("a face needs three vertices".into()));
                }
                for j in 1..ids.len() - 1 {
                    triangles.push([ids[0], ids[j], ids[j + 1]]);
                }
            }
            _ => {}
        }
    }
    Ok((positions, triangles))
}

/// Wavefront OBJ text of a triangle mesh (positions `[x0, y0, z0, ...]`, 0-based triangles).
pub fn to_obj(positions: &[f32], triangles: &[[u32; 3]], comment: &str) -> String {
    let mut s = String::with_capacity(positions.len() * 12 + triangles.len() * 20);
    for line in comment.lines() {
        let _ = writeln!(s, "# {line}");
    }
    for v in positions.chunks_exact(3) {
        let _ = writeln!(s, "v {:.4} {:.4} {:.4}", v[0], v[1], v[2]);
    }
    for t in triangles {
        let _ = writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    s
}

/// OBJ text of a render mesh (positions, normals, triangles).
pub fn mesh_to_obj(mesh: &Mesh, comment: &str) -> String {
    let mut s = String::with_capacity(mesh.vertices.len() * 60 + mesh.indices.len() * 8);
    for line in comment.lines() {
        let _ = writeln!(s, "# {line}");
    }
    for v in &mesh.vertices {
        let _ = writeln!(
            s,
            "v {:.4} {:.4} {:.4}",
            v.position[0], v.position[1], v.position[2]
        );
    }
    for v in &mesh.vertices {
        let _ = writeln!(
            s,
            "vn {:.4} {:.4} {:.4}",
            v.normal[0], v.normal[1], v.normal[2]
        );
    }
    for t in mesh.indices.chunks_exact(3) {
        let _ = writeln!(
            s,
            "f {0}//{0} {1}//{1} {2}//{2}",
            t[0] + 1,
            t[1] + 1,
            t[2] + 1
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn obj_faces_keep_the_file_order() {
        let text = "# c\nv 0 0 0\nv 1 0 0\nvn 0 0 1\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1/1 3/2/1 4//1\nf -4 -3 -2 -1\n";
        let (p, t) = parse_obj(text).unwrap();
        assert_eq!(p, vec![0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.]);
        assert_eq!(t, vec![[0, 1, 2], [0, 2, 3], [0, 1, 2], [0, 2, 3]]);
        for (bad, line) in [
            ("v 1 2\n", 1),
            ("v 0 0 0\nf 1 2 3\n", 2),
            ("v 0 0 0\nf 1 x 1\n", 2),
            ("v 0 0 0\nf 1 1\n", 2),
            ("v a 0 0\n", 1),
        ] {
            match parse_obj(bad) {
                Err(ObjError::Line { line: l, .. }) => assert_eq!(l, line, "{bad:?}"),
                other => panic!("{bad:?}: {other:?}"),
            }
        }
    }

    #[test]
    fn light_sweep_shadows_behind_a_wall_and_not_in_front() {
        // A wall 1 mm high across the middle; light from the left at 20 degrees.
        let (cols, rows, cell) = (80, 5, 0.1);
        let height: Vec<f32> = (0..cols * rows)
            .map(|i| {
                if (28..32).contains(&(i % cols)) {
                    1.0
                } else {
                    0.0
                }
            })
            .collect();
        let el = 20f32.to_radians();
        let vis = light_visibility(&height, cols, rows, cell, [-el.cos(), 0.0, el.sin()]);
        let row = 2 * cols;
        // In front of the wall (lit side) and on it: lit.
        assert!(
            vis[row + 10] > 0.99 && vis[row + 30] > 0.99,
            "{:?}",
            &vis[row..row + cols]
        );
        // Behind it the shadow is 1 / tan(20) = 2.75 mm long: about 27 cells from the wall's
        // back (cell 31).
        assert!(
            vis[row + 35] < 0.01 && vis[row + 50] < 0.01,
            "{:?}",
            &vis[row..row + cols]
        );
        let lit_again = (32..cols).find(|&x| vis[row + x] > 0.5).unwrap();
        assert!(
            (57..=61).contains(&lit_again),
            "{lit_again}: {:?}",
            &vis[row..row + cols]
        );
        // Light from straight above: nothing shadowed.
        let top = light_visibility(&height, cols, rows, cell, [0.0, 0.0, 1.0]);
        assert!(top.iter().all(|v| *v == 1.0));
    }
}
