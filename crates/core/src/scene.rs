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
    /// How much of the key light reaches this point through the stone, 0..1, where the
    /// relief shadows it: a thin part (an ear's rim, a lock's tip) lets light through and
    /// glows; a thick one does not. The renderer adds it with the scattering.
    pub transmit: f32,
}

impl Vertex {
    /// A vertex of `region` in the open: all the key light and ambient light reach it, none
    /// shines through, and the agate's hair layer lies on the hair alone. The draw data of
    /// simple meshes (a glTF's, the tests').
    pub fn open(position: [f32; 3], normal: [f32; 3], relief: f32, region: Region) -> Vertex {
        Vertex {
            position,
            normal,
            relief,
            region: region as u32,
            hair: if region == Region::Hair { 1.0 } else { 0.0 },
            occlusion: 1.0,
            key_light: 1.0,
            transmit: 0.0,
        }
    }
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

    /// A coarser copy of at most about `max_triangles` triangles for frames that must be quick
    /// (the kiosk's gem while it turns): meshoptimizer's quadric edge collapse (Garland and
    /// Heckbert), which spends the triangles where the surface bends, weighing the normals and
    /// the shading attributes besides the positions and keeping the regions' borders (gold and
    /// stone, hair and face) where they are. The vertices kept are copied unchanged. A mesh
    /// already that small, or one whose indices do not all name a vertex, returns itself.
    pub fn simplified(&self, max_triangles: usize) -> Mesh {
        let count = self.vertices.len();
        if self.indices.len() / 3 <= max_triangles
            || self.indices.iter().any(|&i| i as usize >= count)
        {
            return self.clone();
        }
        let bytes: &[u8] = bytemuck::cast_slice(&self.vertices);
        let Ok(adapter) = meshopt::VertexDataAdapter::new(bytes, std::mem::size_of::<Vertex>(), 0)
        else {
            return self.clone();
        };
        // Attributes per vertex, weighed against the position error (relative to the mesh's
        // extent): the unit normal, the region, the hair layer, occlusion and key light.
        const ATTRIBUTES: usize = 7;
        let weights = [0.5, 0.5, 0.5, 4.0, 1.0, 0.5, 0.5];
        let attributes: Vec<f32> = self
            .vertices
            .iter()
            .flat_map(|v| {
                let n = v.normal;
                let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt().max(1e-12);
                [
                    n[0] / len,
                    n[1] / len,
                    n[2] / len,
                    v.region as f32,
                    v.hair,
                    v.occlusion,
                    v.key_light,
                ]
            })
            .collect();
        // Vertices on a region's border do not move (the gold bezel meets the stone on a line),
        // nor do the gold's: the bezel is a few thousand triangles whose round profile carries
        // its highlights.
        let gold = Region::Gold as u32;
        let mut lock: Vec<bool> = self.vertices.iter().map(|v| v.region == gold).collect();
        // Nor do the vertices that bound the mesh: its box and bounding sphere stay the same,
        // and with them the camera that frames it (a moving frame must not jump).
        let mut lo = [(f32::INFINITY, 0); 3];
        let mut hi = [(f32::NEG_INFINITY, 0); 3];
        for (i, v) in self.vertices.iter().enumerate() {
            for a in 0..3 {
                if v.position[a] < lo[a].0 {
                    lo[a] = (v.position[a], i);
                }
                if v.position[a] > hi[a].0 {
                    hi[a] = (v.position[a], i);
                }
            }
        }
        let centre: [f32; 3] = std::array::from_fn(|a| 0.5 * (lo[a].0 + hi[a].0));
        let far = self
            .vertices
            .iter()
            .enumerate()
            .fold((0.0f32, 0), |best, (i, v)| {
                let d: f32 = (0..3).map(|a| (v.position[a] - centre[a]).powi(2)).sum();
                if d > best.0 { (d, i) } else { best }
            });
        for i in lo.iter().chain(&hi).map(|e| e.1).chain([far.1]) {
            lock[i] = true;
        }
        for t in self.indices.chunks_exact(3) {
            let r = [0, 1, 2].map(|k| self.vertices[t[k] as usize].region);
            if r[0] != r[1] || r[1] != r[2] {
                for k in 0..3 {
                    lock[t[k] as usize] = true;
                }
            }
        }
        let indices = meshopt::simplify_with_attributes_and_locks(
            &self.indices,
            &adapter,
            &attributes,
            &weights,
            ATTRIBUTES * std::mem::size_of::<f32>(),
            &lock,
            3 * max_triangles,
            1.0,
            meshopt::SimplifyOptions::None,
            None,
        );
        // Keep only the vertices still used, in their first use's order.
        let mut remap = vec![u32::MAX; count];
        let mut vertices = Vec::new();
        let indices = indices
            .into_iter()
            .map(|i| {
                let slot = &mut remap[i as usize];
                if *slot == u32::MAX {
                    *slot = vertices.len() as u32;
                    vertices.push(self.vertices[i as usize]);
                }
                *slot
            })
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

/// The room's lights as the renderer draws them (unitless, white): the sky from in front of
/// the stone (times 0.55 + 0.45 of the normal's share towards the viewer, and the relief's
/// cavity term), a weak fill from the camera's side (times the normal towards the viewer and
/// the cavity), and the key light's intensity (the flat ground gets sin 20 degrees of it). The
/// relief's tone is matched to the photo's under these ([`crate::gem::detail`]'s tone match),
/// so the renderer takes them from here (the 2021 system's ambient was 0.2).
pub const SKY_LIGHT: f32 = 0.2;
pub const FILL_LIGHT: f32 = 0.2;
pub const KEY_LIGHT_INTENSITY: f32 = 1.25;

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
        Vertex::open(position, normal, position[2], region)
    }

    /// A grid of `n` x `n` cells over [0, 2] mm square, heights from `z`.
    fn grid(n: usize, z: impl Fn(f32, f32) -> f32, region: impl Fn(f32, f32) -> Region) -> Mesh {
        let mut m = Mesh::default();
        let step = 2.0 / n as f32;
        for y in 0..=n {
            for x in 0..=n {
                let (px, py) = (x as f32 * step, y as f32 * step);
                let p = [px, py, z(px, py)];
                m.vertices.push(vertex(p, [0.0, 0.0, 1.0], region(px, py)));
            }
        }
        let w = (n + 1) as u32;
        for y in 0..n as u32 {
            for x in 0..n as u32 {
                let i = y * w + x;
                m.indices.extend([i, i + 1, i + w, i + 1, i + w + 1, i + w]);
            }
        }
        m
    }

    fn bounds(m: &Mesh) -> [[f32; 3]; 2] {
        let mut b = [[f32::INFINITY; 3], [f32::NEG_INFINITY; 3]];
        for i in &m.indices {
            let p = m.vertices[*i as usize].position;
            for a in 0..3 {
                b[0][a] = b[0][a].min(p[a]);
                b[1][a] = b[1][a].max(p[a]);
            }
        }
        b
    }

    /// The triangles go where the surface bends: a flat plate collapses to a handful, a bump
    /// keeps its share; the gold and the mesh's bounds are untouched; no index dangles.
    #[test]
    fn simplifying_spends_the_triangles_on_the_relief_and_keeps_gold_and_bounds() {
        let bump = |x: f32, y: f32| {
            let r2 = (x - 1.5).powi(2) + (y - 1.0).powi(2);
            if x > 1.0 {
                0.3 * (-r2 / 0.05).exp()
            } else {
                0.0
            }
        };
        let rim = |_x: f32, y: f32| {
            if y > 1.9 {
                Region::Gold
            } else {
                Region::Ground
            }
        };
        let m = grid(60, bump, rim);
        let total = m.indices.len() / 3;
        let target = total / 8;
        let s = m.simplified(target);
        let kept = s.indices.len() / 3;
        assert!(
            kept <= target + target / 10,
            "{kept} of {total}, asked {target}"
        );
        assert!(s.indices.iter().all(|&i| (i as usize) < s.vertices.len()));
        // Every vertex kept is one of the mesh's, unchanged.
        assert!(
            s.vertices
                .iter()
                .all(|v| m.vertices.iter().any(|w| w.position == v.position))
        );
        let gold = |m: &Mesh| {
            m.indices
                .chunks_exact(3)
                .filter(|t| {
                    t.iter()
                        .all(|&i| m.vertices[i as usize].region == Region::Gold as u32)
                })
                .count()
        };
        assert_eq!(gold(&s), gold(&m));
        assert_eq!(bounds(&s), bounds(&m));
        // The bump's half holds most of the stone's triangles that are left.
        let centroid_x = |t: &[u32]| {
            t.iter()
                .map(|&i| s.vertices[i as usize].position[0])
                .sum::<f32>()
                / 3.0
        };
        let stone: Vec<&[u32]> = s
            .indices
            .chunks_exact(3)
            .filter(|t| {
                t.iter()
                    .any(|&i| s.vertices[i as usize].region != Region::Gold as u32)
            })
            .collect();
        let on_bump = stone.iter().filter(|t| centroid_x(t) > 1.0).count();
        assert!(
            on_bump * 10 >= stone.len() * 7,
            "{on_bump} of {} on the bump",
            stone.len()
        );
        // Small enough already, or an index past the vertices: the mesh as it is.
        assert_eq!(m.simplified(total).indices, m.indices);
        let mut broken = m.clone();
        broken.indices[0] = broken.vertices.len() as u32;
        assert_eq!(broken.simplified(10).indices, broken.indices);
    }
}
