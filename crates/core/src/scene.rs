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

    /// A coarser copy for frames that must be quick (the kiosk's gem while it turns): vertex
    /// clustering (Rossignac and Borrel) on a grid of `cell_mm` cubes. Vertices in one cube,
    /// of one region and facing the same way (the dominant axis of their normal, so the bezel's
    /// and the walls' creases stay sharp) become their mean; triangles left with fewer than
    /// three distinct corners go. No holes are opened: every remaining triangle keeps its
    /// neighbours' shared corners. A cell that is not finite and positive returns the mesh.
    pub fn clustered(&self, cell_mm: f32) -> Mesh {
        if !(cell_mm.is_finite() && cell_mm > 0.0) {
            return self.clone();
        }
        let facing = |n: [f32; 3]| {
            let a = n.map(f32::abs);
            let axis = if a[0] >= a[1] && a[0] >= a[2] {
                0
            } else if a[1] >= a[2] {
                1
            } else {
                2
            };
            (axis, n[axis] >= 0.0)
        };
        let mut clusters: std::collections::HashMap<_, u32> =
            std::collections::HashMap::with_capacity(self.vertices.len() / 2);
        let mut sums: Vec<(Vertex, f32)> = Vec::new();
        let map: Vec<u32> = self
            .vertices
            .iter()
            .map(|v| {
                let cell = v.position.map(|c| (c / cell_mm).floor() as i64);
                let key = (cell, v.region, facing(v.normal));
                let at = *clusters.entry(key).or_insert_with(|| {
                    sums.push((
                        Vertex {
                            position: [0.0; 3],
                            normal: [0.0; 3],
                            relief: 0.0,
                            hair: 0.0,
                            occlusion: 0.0,
                            key_light: 0.0,
                            ..*v
                        },
                        0.0,
                    ));
                    (sums.len() - 1) as u32
                });
                let (sum, n) = &mut sums[at as usize];
                for k in 0..3 {
                    sum.position[k] += v.position[k];
                    sum.normal[k] += v.normal[k];
                }
                sum.relief += v.relief;
                sum.hair += v.hair;
                sum.occlusion += v.occlusion;
                sum.key_light += v.key_light;
                *n += 1.0;
                at
            })
            .collect();
        let vertices = sums
            .into_iter()
            .map(|(v, n)| Vertex {
                position: v.position.map(|c| c / n),
                relief: v.relief / n,
                hair: v.hair / n,
                occlusion: v.occlusion / n,
                key_light: v.key_light / n,
                ..v
            })
            .collect();
        let indices = self
            .indices
            .chunks_exact(3)
            .filter_map(|t| {
                let [a, b, c] = [t[0], t[1], t[2]].map(|i| map.get(i as usize).copied());
                match (a, b, c) {
                    (Some(a), Some(b), Some(c)) if a != b && b != c && a != c => Some([a, b, c]),
                    _ => None,
                }
            })
            .flatten()
            .collect();
        Mesh { vertices, indices }
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

#[cfg(test)]
mod tests {
    use super::*;

    fn vertex(position: [f32; 3], normal: [f32; 3], region: Region) -> Vertex {
        Vertex {
            position,
            normal,
            relief: position[2],
            region: region as u32,
            hair: 0.0,
            occlusion: 1.0,
            key_light: 1.0,
        }
    }

    /// A fine grid of a flat plate collapses to the clusters' grid; a crease (two faces of
    /// different facing in the same cell) and another region stay apart; no index dangles.
    #[test]
    fn clustering_merges_within_cells_and_keeps_creases_and_regions() {
        let n = 20;
        let mut m = Mesh::default();
        for y in 0..=n {
            for x in 0..=n {
                let p = [x as f32 * 0.1, y as f32 * 0.1, 0.0];
                m.vertices.push(vertex(p, [0.0, 0.0, 1.0], Region::Ground));
            }
        }
        for y in 0..n {
            for x in 0..n {
                let i = (y * (n + 1) + x) as u32;
                let w = (n + 1) as u32;
                m.indices.extend([i, i + 1, i + w, i + 1, i + w + 1, i + w]);
            }
        }
        let c = m.clustered(0.5);
        assert!(c.vertices.len() <= 25, "{} clusters", c.vertices.len());
        assert!(c.indices.len() < m.indices.len() / 8, "{}", c.indices.len());
        assert!(c.indices.iter().all(|&i| (i as usize) < c.vertices.len()));
        // Every cluster's mean lies inside the plate and keeps the attributes' mean.
        assert!(
            c.vertices
                .iter()
                .all(|v| v.position[0] >= 0.0 && v.position[0] <= 2.0)
        );
        assert!(c.vertices.iter().all(|v| (v.occlusion - 1.0).abs() < 1e-6));
        // A wall vertex (facing +x) and a gold vertex in a cell with ground ones stay apart.
        let mut m2 = m.clone();
        m2.vertices
            .push(vertex([0.05, 0.05, 0.0], [1.0, 0.0, 0.0], Region::Ground));
        m2.vertices
            .push(vertex([0.05, 0.05, 0.0], [0.0, 0.0, 1.0], Region::Gold));
        let c2 = m2.clustered(0.5);
        assert_eq!(c2.vertices.len(), c.vertices.len() + 2);
        // A cell of 0 or NaN leaves the mesh as it is.
        assert_eq!(m.clustered(0.0).indices, m.indices);
        assert_eq!(m.clustered(f32::NAN).vertices.len(), m.vertices.len());
    }
}
