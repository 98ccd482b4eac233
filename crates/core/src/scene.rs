//! The draw data a cameo hands the renderer, and the scene's fixed key light.
//!
//! Units: millimetres, object space. The cameo lies in the XY plane facing +Z, +Y up, origin at
//! the centre of its base. Both the cameo (which bakes the key light's cast shadows into its
//! vertices) and the renderer (which lights with it) read the light from here, so the two
//! cannot disagree; neither depends on the other.

/// One vertex of the draw data, laid out for the GPU (44 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Vertex {
    /// Object-space position (mm).
    pub position: [f32; 3],
    /// Object-space normal (any length; zero means "use the facet normal").
    pub normal: [f32; 3],
    /// Height above the ground layer (mm); 0 on the ground. Drives the agate's layers.
    pub relief: f32,
    /// A [`Region`] as `u32`.
    pub region: u32,
    /// How much of the agate's brown hair layer lies here, 0..1 (clamped). Interpolated across
    /// triangles, so the layer's border runs smoothly between vertices instead of along them.
    pub hair: f32,
    /// Ambient light reaching this point, 0..1 (1: open; a groove's bottom or a wall's foot
    /// less): the relief's cavity term, applied to the ambient and fill light.
    pub occlusion: f32,
    /// How much of the key light reaches this point, 0..1 (cast shadows; see
    /// [`key_light_dir`]).
    pub key_light: f32,
}

/// What a vertex is made of.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Region {
    /// The flat field around the portrait (agate: the dark red layer).
    Ground = 0,
    /// The carved portrait (agate: the white layer).
    Relief = 1,
    /// Hair (agate: the brown top layer).
    Hair = 2,
    /// Bezel and back: gold in every material.
    Gold = 3,
}

impl From<Region> for u32 {
    fn from(region: Region) -> u32 {
        region as u32
    }
}

/// Indexed triangle list.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub vertices: Vec<Vertex>,
    /// Three indices per triangle, each below `vertices.len()`.
    pub indices: Vec<u32>,
}

impl Mesh {
    /// FNV-1a over every vertex and index word: equal for equal meshes, different (but for a
    /// 64-bit collision) for any change. Cheap next to a frame (about 0.4 ms for a cameo).
    pub fn fingerprint(&self) -> u64 {
        let words: &[u32] = bytemuck::cast_slice(&self.vertices);
        words
            .iter()
            .chain(&self.indices)
            .fold(0xcbf2_9ce4_8422_2325, |h, &w| {
                (h ^ u64::from(w)).wrapping_mul(0x0100_0000_01b3)
            })
    }
}

/// The key light's direction: fixed to the stone (it does not turn with the camera), from the
/// upper left, raking at [`KEY_LIGHT_ELEVATION_DEG`] above the stone's plane, the way cameos
/// are photographed: a high light fixed to the viewer flattens a relief, a raking one shows
/// every slope and casts short shadows.
pub const KEY_LIGHT_AZIMUTH_DEG: f32 = 145.0;
pub const KEY_LIGHT_ELEVATION_DEG: f32 = 20.0;

/// Unit vector towards the key light, object space (XY the stone's plane, +Z out of it).
pub fn key_light_dir() -> [f32; 3] {
    let (az, el) = (
        KEY_LIGHT_AZIMUTH_DEG.to_radians(),
        KEY_LIGHT_ELEVATION_DEG.to_radians(),
    );
    [az.cos() * el.cos(), az.sin() * el.cos(), el.sin()]
}
