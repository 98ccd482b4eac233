//! The cameo: a portrait relief on an oval stone in a gold setting ([`setting`]).
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
pub(crate) mod blur;
mod builder;
mod closure;
pub mod detail;
pub mod face;
pub mod gltf;
pub mod measure;
mod moles;
mod obj;
mod poisson;
mod refine;
pub mod relief;
pub mod setting;
mod shading;
pub mod silhouette;
pub mod solid;
pub mod template;
mod tessellate;
pub mod tone;
mod window;

use crate::scene::Mesh;
pub use basrelief::Compression;
pub use builder::{
    CameoBuilder, FACE_EXTENT_MM, MIN_FACE_TRIANGLES, TONE_SUBDIVISION, check_face_mesh,
};
pub use detail::{DetailParams, FaceDetail, PHOTO_MODELLING, TONE_MATCH};
pub use face::Placement;
pub use obj::{ObjError, mesh_to_obj, parse_obj, to_obj};
pub use setting::Setting;
pub use template::{HairCarving, HairStyle, View};

/// Why a cameo could not be built.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum GemError {
    #[error("the face mesh is empty or has no triangles")]
    EmptyFace,
    #[error("the face mesh has non-finite coordinates")]
    NonFinite,
    /// A mesh that is no face a relief could be carved from (issue #40: one triangle, or
    /// coordinates of 1e30, carved a faceless head).
    #[error("the face mesh {0}")]
    NotAFace(String),
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
    /// The gold round the stone.
    pub setting: Setting,
    /// A ring on the setting's top for hanging the cameo as a pendant.
    pub bail: bool,
}

impl CameoParams {
    /// A frontal portrait (the face looks out of the stone) on the default stone.
    pub fn frontal() -> Self {
        View::Frontal.cameo()
    }

    /// The setting in words, for reports: "plain bezel", "milgrain collet, bail".
    pub fn mount(&self) -> String {
        let setting = match self.setting {
            Setting::Plain => "plain bezel",
            Setting::Milgrain => "milgrain collet",
            Setting::Rope => "rope-twist frame",
        };
        if self.bail {
            format!("{setting}, bail")
        } else {
            setting.to_string()
        }
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
            setting: Setting::Plain,
            bail: false,
        }
    }
}

/// Depth of the gold back below the ground, gem mm.
const BACK_Z: f32 = -3.0;
/// The portrait stays inside this fraction of the oval (clear of the bezel's foot).
const PORTRAIT_OVAL: f32 = 0.93;
/// Gradient gain of the sculpted head and bust against the face's 1 (see
/// [`basrelief::compress`]).
const HEAD_EMPHASIS: f32 = 0.8;
/// How far light travels in the stone before it is spent (gem mm): what lets a thin part
/// glow. Marble's diffusion length from Jensen et al.'s measurement (about 8.5 mm for red)
/// at the quarter scale the scattering kernel uses for a 56 mm cameo, a little shorter.
const MEAN_FREE_MM: f32 = 1.5;
/// Relief below this height (gem mm) counts as ground.
const GROUND_EPS: f32 = 0.03;
/// The level of [`Relief::outline`] where the portrait's wall stands.
const OUTLINE_LEVEL: f32 = 0.5;
/// The share of the portrait's compressed heights below which the relief's scale is set
/// (the few highest nodes above it are clamped to the depth).
const DEPTH_QUANTILE: f32 = 0.998;

/// The finished relief in gem units, kept for tests, measurement and inspection.
#[derive(Clone, Debug)]
pub struct Relief {
    /// Height above the ground per grid node, gem mm (row-major, `cols` x `rows`): the
    /// portrait's [`Self::top`] inside its outline, 0 (the ground) outside.
    pub height: Vec<f32>,
    /// The portrait's top surface continued a little past its outline, gem mm (0 far off
    /// it): where the wall's top lies between two nodes, and the top's slope at the wall.
    pub top: Vec<f32>,
    /// The portrait's smoothed sub-cell coverage per node, 0..1: its [`OUTLINE_LEVEL`]
    /// contour is the relief's outline, where the wall stands.
    pub outline: Vec<f32>,
    /// How much of the agate's hair layer lies at each node, 0..1.
    pub hair: Vec<f32>,
    /// Ambient light reaching each node, 0..1 (1: open sky; the foot of a wall or a groove's
    /// bottom less).
    pub occlusion: Vec<f32>,
    /// How much of the key light ([`crate::scene::key_light_dir`]) reaches each node, 0..1:
    /// the relief's cast shadows (the key light is fixed to the stone, so they are computed
    /// once per cameo).
    pub key_light: Vec<f32>,
    /// How much of the key light reaches each shadowed node through the stone, 0..1 (thin
    /// parts glow; see [`crate::scene::Vertex::transmit`]).
    pub transmit: Vec<f32>,
    /// Nodes where the fitted face makes the surface.
    pub face: Vec<bool>,
    /// The portrait before compression, canonical mm (0 off the portrait).
    pub portrait: Vec<f32>,
    /// The face's own height (canonical mm, smoothed, eyes carved) where it covers a node;
    /// NaN elsewhere.
    pub face_height: Vec<f32>,
    /// Nodes where the stipple cut a pit ([`DetailParams::stipple_mm`]) or a dark was sunk
    /// into the key light's shadow ([`DetailParams::shadows`]); empty on a grid without the
    /// stipple: the grid is then [`TONE_SUBDIVISION`] times finer than the solve grid
    /// ([`CameoParams::cell`]), and the mesh keeps the finer cells only round what was cut.
    pub stippled: Vec<bool>,
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
    /// The compressed heights before scaling (canonical mm, 0 off the portrait), on the solve
    /// grid ([`CameoParams::cell`], coarser than this relief's where it is stippled): the warm
    /// start of the next relief when a face is tracked ([`CameoBuilder::build_after`]).
    pub relative: Vec<f32>,
}

impl Relief {
    /// The heights as a [`solid::HeightField`] (for the STL and height-map exports).
    pub fn height_field(&self) -> solid::HeightField<'_> {
        solid::HeightField {
            heights: &self.height,
            cols: self.cols,
            rows: self.rows,
            origin: self.origin,
            cell: self.cell,
        }
    }

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
pub const FACE_LENGTH_MM: f32 = 115.0;
pub const EYES_V: f32 = 30.0;
/// How far a crop stands over the skull, canonical mm.
const CROP_VOLUME: f32 = 4.0;
/// A stubble beard's thickness (mm, under [`template::STUBBLE_MM`]: stippled) and how far over
/// the jaw it is carved (0 chin alone .. 1 the whole jaw).
const STUBBLE_BEARD: f32 = 2.5;
const STUBBLE_JAW: f32 = 0.6;
/// Hair ending no further below the eyes than this (face lengths) is cut above the ears.
const SHORT_HAIR: f32 = 0.6 + 1e-3;

/// A person's hair as the template carves it, from what their photo shows: none for a bald
/// head; its volume from how far it stands above and beside the skull; where it ends from its
/// length (below the nape it falls behind the neck and over the shoulders); its locks from its
/// curl (straight hair in long locks, curls in short ones); its carving from its kind (curly
/// hair in snail curls, a crop stippled and close to the skull).
pub fn hair_style(person: &crate::person::Person) -> HairStyle {
    let smooth = template::smoothstep;
    // Facial hair: a beard as thick as it is full (3 mm of stubble-length beard on a chin
    // alone, 12 mm when it covers the whole jaw densely), a moustache a little thinner.
    // A beard found only by its stubble's texture is stubble-length (stippled) and, as
    // stubble grows, over the jaw as well as the chin (its extent is not measured: the lower
    // cheeks' detail told shaven from stubbled jaws no better than chance).
    let (beard, beard_jaw) = if person.stubble_only() {
        (STUBBLE_BEARD, STUBBLE_JAW)
    } else if person.has_beard() {
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
    let carving = match person.hair_kind() {
        crate::person::HairKind::Curly => template::HairCarving::Curls,
        crate::person::HairKind::Cropped => template::HairCarving::Stippled,
        _ => template::HairCarving::Locks,
    };
    let volume = (3.0 + 0.75 * FACE_LENGTH_MM * stand).clamp(3.0, 32.0);
    let style = HairStyle {
        bald: false,
        // A crop is a layer on the skull, whatever stood out of it in the photo (an ear).
        volume: if carving == template::HairCarving::Stippled {
            volume.min(CROP_VOLUME)
        } else {
            volume
        },
        carving,
        end: (EYES_V - h.length * FACE_LENGTH_MM).clamp(-290.0, -20.0),
        curl: (0.15 + 0.85 * h.curl).clamp(0.0, 1.0),
        // Hair that ends about the ears with nothing hanging beside the cheeks: cut above them.
        ears_shown: h.curtain < crate::person::CURTAIN && h.length <= SHORT_HAIR,
        outline: Some([FACE_LENGTH_MM * h.width, EYES_V + FACE_LENGTH_MM * h.height]),
        fall: (h.length > SHORT_HAIR).then(|| h.fall.map(|r| r.map(|x| FACE_LENGTH_MM * x))),
        ..facial
    };
    HairStyle {
        silhouette: Some(silhouette::Silhouette::from_mask(&h.mask, &style, h.crown)),
        ..style
    }
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

/// [`build_cameo`] with the photo's own detail carved into the face ([`FaceDetail`]).
pub fn build_cameo_detailed(
    positions: &[f32],
    triangles: &[[u32; 3]],
    p: &CameoParams,
    detail: Option<&FaceDetail>,
) -> Result<Mesh, GemError> {
    let builder = CameoBuilder::new(p)?;
    Ok(builder.mesh_of(&builder.relief_detailed(positions, triangles, &[], detail)?))
}

#[cfg(test)]
mod tests {
    use super::shading::light_visibility;
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
