//! Checks on the draw data before anything reaches the GPU, the bounds the camera needs, and
//! the GPU buffers the mesh is uploaded into (grown only when a mesh does not fit).
//!
//! wgpu reports bad draws asynchronously and, by default, by panicking; a mesh from the gem
//! module (or from a user's file) is input, so everything it could get wrong is caught here and
//! returned as a [`RenderError`].

use crate::params::RenderError;
use glyptic_core::scene::{Mesh, Region, Vertex};

/// Axis-aligned box and bounding sphere of the vertices that triangles use (mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Bounds {
    pub min: [f32; 3],
    pub max: [f32; 3],
    /// The box centre: the orbit's pivot.
    pub center: [f32; 3],
    /// Largest distance of a vertex from `center`: the camera fits this sphere, so the mesh stays
    /// in frame at any yaw and pitch.
    pub radius: f32,
}

/// Largest region value a vertex may carry.
const MAX_REGION: u32 = Region::Gold as u32;

/// Validates `mesh` against the renderer's rules and the device's buffer limit and returns the
/// bounds of its vertices.
pub(crate) fn validate(mesh: &Mesh, max_buffer_bytes: u64) -> Result<Bounds, RenderError> {
    if mesh.vertices.is_empty() || mesh.indices.is_empty() {
        return Err(RenderError::EmptyMesh {
            vertices: mesh.vertices.len(),
            indices: mesh.indices.len(),
        });
    }
    if !mesh.indices.len().is_multiple_of(3) {
        return Err(RenderError::IndicesNotTriangles {
            count: mesh.indices.len(),
        });
    }
    let vertex_bytes = (mesh.vertices.len() as u64).saturating_mul(size_of::<Vertex>() as u64);
    let index_bytes = (mesh.indices.len() as u64).saturating_mul(size_of::<u32>() as u64);
    let largest = vertex_bytes.max(index_bytes);
    if largest > max_buffer_bytes || u32::try_from(mesh.indices.len()).is_err() {
        return Err(RenderError::MeshTooLarge {
            bytes: largest,
            max: max_buffer_bytes,
        });
    }
    let vertex_count = mesh.vertices.len();
    if let Some((position, &value)) = mesh
        .indices
        .iter()
        .enumerate()
        .find(|(_, v)| **v as usize >= vertex_count)
    {
        return Err(RenderError::IndexOutOfRange {
            position,
            value,
            vertex_count,
        });
    }

    let mut min = [f32::INFINITY; 3];
    let mut max = [f32::NEG_INFINITY; 3];
    for (index, v) in mesh.vertices.iter().enumerate() {
        let finite = v
            .position
            .iter()
            .chain(v.normal.iter())
            .all(|c| c.is_finite())
            && v.relief.is_finite()
            && v.hair.is_finite()
            && v.occlusion.is_finite()
            && v.key_light.is_finite();
        if !finite {
            return Err(RenderError::NonFiniteVertex { index });
        }
        if v.region > MAX_REGION {
            return Err(RenderError::InvalidRegion {
                index,
                value: v.region,
            });
        }
        for axis in 0..3 {
            min[axis] = min[axis].min(v.position[axis]);
            max[axis] = max[axis].max(v.position[axis]);
        }
    }
    let center = [0, 1, 2].map(|a| 0.5 * (min[a] + max[a]));
    let radius_sq = mesh
        .vertices
        .iter()
        .map(|v| {
            (0..3)
                .map(|a| (v.position[a] - center[a]).powi(2))
                .sum::<f32>()
        })
        .fold(0.0f32, f32::max);
    let radius = radius_sq.sqrt();
    // Finite coordinates can still overflow once squared (|x| > 1.8e19 mm).
    if !radius.is_finite() {
        return Err(RenderError::NonFiniteVertex { index: 0 });
    }
    Ok(Bounds {
        min,
        max,
        center,
        radius,
    })
}

/// Vertex and index buffers that keep their capacity between frames.
pub(crate) struct MeshBuffers {
    pub vertices: wgpu::Buffer,
    /// One tangent frame ([f32; 4]) per vertex.
    pub tangents: wgpu::Buffer,
    pub indices: wgpu::Buffer,
}

/// Bytes of the tangent frames of a mesh with `vertex_bytes` of vertices.
pub(crate) fn tangent_bytes(vertex_bytes: u64) -> u64 {
    vertex_bytes / size_of::<Vertex>() as u64 * 16
}

/// Smallest buffer allocated, so small meshes do not reallocate as they grow a little.
const MIN_MESH_BUFFER: u64 = 64 * 1024;

fn grown(needed: u64, max: u64) -> u64 {
    needed
        .max(MIN_MESH_BUFFER)
        .checked_next_power_of_two()
        .unwrap_or(needed)
        .min(max)
        .max(needed)
}

impl MeshBuffers {
    /// Buffers holding at least the given byte counts (both no larger than `max`); `storage`:
    /// also read as storage buffers (the scene pass's compute form).
    pub fn new(
        device: &wgpu::Device,
        vertex_bytes: u64,
        index_bytes: u64,
        max: u64,
        storage: bool,
    ) -> Self {
        let also = if storage {
            wgpu::BufferUsages::STORAGE
        } else {
            wgpu::BufferUsages::empty()
        };
        let buffer = |label, size, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: grown(size, max),
                usage: usage | also | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        Self {
            vertices: buffer("glyptic vertices", vertex_bytes, wgpu::BufferUsages::VERTEX),
            tangents: buffer(
                "glyptic tangents",
                tangent_bytes(vertex_bytes),
                wgpu::BufferUsages::VERTEX,
            ),
            indices: buffer("glyptic indices", index_bytes, wgpu::BufferUsages::INDEX),
        }
    }

    pub fn fits(&self, vertex_bytes: u64, index_bytes: u64) -> bool {
        self.vertices.size() >= vertex_bytes
            && self.tangents.size() >= tangent_bytes(vertex_bytes)
            && self.indices.size() >= index_bytes
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vertex(x: f32, y: f32, z: f32) -> Vertex {
        Vertex::open([x, y, z], [0.0, 0.0, 1.0], 0.0, Region::Ground)
    }

    fn triangle() -> Mesh {
        Mesh {
            vertices: vec![
                vertex(-1.0, -1.0, 0.0),
                vertex(1.0, -1.0, 0.0),
                vertex(0.0, 2.0, 1.0),
            ],
            indices: vec![0, 1, 2],
        }
    }

    #[test]
    fn bounds_of_a_triangle() {
        let b = validate(&triangle(), 1 << 20).unwrap();
        assert_eq!(b.min, [-1.0, -1.0, 0.0]);
        assert_eq!(b.max, [1.0, 2.0, 1.0]);
        assert_eq!(b.center, [0.0, 0.5, 0.5]);
        assert!((b.radius - (1.0f32 + 2.25 + 0.25).sqrt()).abs() < 1e-6);
    }

    #[test]
    fn rejects_bad_meshes() {
        assert!(matches!(
            validate(&Mesh::default(), 1 << 20),
            Err(RenderError::EmptyMesh { .. })
        ));
        let mut m = triangle();
        m.indices.push(0);
        assert!(matches!(
            validate(&m, 1 << 20),
            Err(RenderError::IndicesNotTriangles { .. })
        ));
        let mut m = triangle();
        m.indices[2] = 3;
        assert!(matches!(
            validate(&m, 1 << 20),
            Err(RenderError::IndexOutOfRange { value: 3, .. })
        ));
        let mut m = triangle();
        m.vertices[1].position[0] = f32::NAN;
        assert!(matches!(
            validate(&m, 1 << 20),
            Err(RenderError::NonFiniteVertex { index: 1 })
        ));
        let mut m = triangle();
        m.vertices[2].region = 9;
        assert!(matches!(
            validate(&m, 1 << 20),
            Err(RenderError::InvalidRegion { index: 2, value: 9 })
        ));
        assert!(matches!(
            validate(&triangle(), 16),
            Err(RenderError::MeshTooLarge { .. })
        ));
    }
}
