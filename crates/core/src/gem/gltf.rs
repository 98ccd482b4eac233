//! The cameo as binary glTF 2.0 (GLB), for a 3D viewer, a web page or a scene in Blender: the
//! render mesh (the geometry `--gem-obj` writes) with its normals, split into primitives by
//! what it is made of, each with a metallic-roughness material that matches the renderer's.
//!
//! Units and axes: glTF's are metres, +Y up, right-handed, with an asset's front facing +Z. The
//! gem's frame is the same one (the stone in the XY plane, +Y up, +Z out of the stone towards
//! the viewer: see [`crate::scene`]), so the axes stay as they are and the positions are only
//! scaled from millimetres to metres. A viewer therefore opens the cameo upright, facing it.
//!
//! Primitives: `ground` (the flat field round the portrait), `portrait` (the relief, its hair
//! and its wall: every triangle with a vertex above the ground) and `gold` (bezel and back).
//! What the renderer computes per pixel is kept where glTF can say it: the stones' colours,
//! gold's reflectance, and how sharp each highlight is (as roughness); agate's layers, whose
//! colour follows the relief's height and the hair (the white thinning to show the red along
//! every edge, the brown hair layer), travel as vertex colours (`COLOR_0`). Left out: the
//! marble's veins and the stones' fine noise (procedural, no texture), the subsurface
//! scattering, the baked cavity and cast shadows (a viewer lights the model itself), and the
//! engraved border (a parallax map).
//!
//! Pure: bytes in memory, no files.
//!
//! Length: 449 lines of code, then its unit tests (253 lines), kept beside what they test.

use serde_json::{Value, json};

use crate::scene::{Mesh, Region};
use crate::stone::{Material, linear, srgb_to_linear};

/// Metres per gem millimetre.
const METRES_PER_MM: f32 = 0.001;

/// The stone as the renderer draws it: the [`Material`] (the one table of stones,
/// [`crate::stone`]) and, for a layered stone, whether the hair is cut from its top layer
/// (`false`: white like the face).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stone {
    pub material: Material,
    pub hair_layer: bool,
}

/// What goes into the file besides the mesh.
#[derive(Clone, Debug)]
pub struct GltfOptions<'a> {
    pub stone: Stone,
    /// `asset.generator`, e.g. "glyptic 0.1.0".
    pub generator: &'a str,
    /// Where the cameo came from (a photo's path, "the mean face"), kept in `asset.extras`.
    pub source: &'a str,
}

/// Why a GLB could not be made.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum GltfError {
    #[error("the cameo mesh has no triangles")]
    Empty,
    #[error("the cameo mesh's triangle list is not a multiple of three indices")]
    Ragged,
    #[error("index {index} names no vertex (the mesh has {count})")]
    BadIndex { index: u32, count: usize },
    #[error("vertex {0} has a NaN or infinite position")]
    NonFinite(usize),
    #[error("the GLB would be {0} bytes, more than its 32-bit lengths can say")]
    TooLarge(usize),
}

/// A glTF metallic-roughness material (factors only, linear colour).
#[derive(Clone, Debug, PartialEq)]
pub struct Pbr {
    pub name: String,
    pub base_colour: [f32; 4],
    pub metallic: f32,
    pub roughness: f32,
}

/// glTF roughness for a Blinn-Phong exponent: the exponent's microfacet width is
/// `alpha = sqrt(2 / (n + 2))` (Walter et al. 2007, the usual Beckmann/GGX match), and glTF's
/// roughness is `sqrt(alpha)`. A Phong (r.l) exponent is about a quarter of the Blinn one.
pub fn roughness_for_blinn(exponent: f32) -> f32 {
    (2.0 / (exponent + 2.0)).sqrt().sqrt()
}

/// The materials of a stone: ground, portrait, gold. Marble's ground and portrait are one
/// stone; a layered stone's ground is its ground layer and its portrait takes its colours per
/// vertex (so its base colour is white).
pub fn materials(stone: Stone) -> [Pbr; 3] {
    use crate::stone::{GOLD_BLINN, GOLD_F0, MARBLE_BLINN, MARBLE_GREY, MARBLE_TINT};
    let gold = Pbr {
        name: "gold".into(),
        base_colour: [GOLD_F0[0], GOLD_F0[1], GOLD_F0[2], 1.0],
        metallic: 1.0,
        roughness: roughness_for_blinn(GOLD_BLINN),
    };
    match stone.material.layers() {
        None => {
            let c = MARBLE_TINT.map(|t| srgb_to_linear(MARBLE_GREY * t));
            let marble = Pbr {
                name: "marble".into(),
                base_colour: [c[0], c[1], c[2], 1.0],
                metallic: 0.0,
                roughness: roughness_for_blinn(MARBLE_BLINN),
            };
            [marble.clone(), marble, gold]
        }
        Some(layers) => {
            let roughness = roughness_for_blinn(4.0 * layers.phong);
            let ground = linear(layers.ground);
            [
                Pbr {
                    name: format!("{} ground (its ground layer)", layers.name),
                    base_colour: [ground[0], ground[1], ground[2], 1.0],
                    metallic: 0.0,
                    roughness,
                },
                Pbr {
                    name: format!("{} portrait (layers in the vertex colours)", layers.name),
                    base_colour: [1.0; 4],
                    metallic: 0.0,
                    roughness,
                },
                gold,
            ]
        }
    }
}

/// One primitive's own vertices (remapped from the mesh's) and triangles.
struct Part {
    name: &'static str,
    /// Mesh vertex of each of this part's vertices.
    vertices: Vec<u32>,
    indices: Vec<u32>,
}

impl Part {
    fn new(name: &'static str) -> Part {
        Part {
            name,
            vertices: Vec::new(),
            indices: Vec::new(),
        }
    }
}

/// The binary buffer being filled, with its views and accessors.
#[derive(Default)]
struct Bin {
    bytes: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Bin {
    /// Appends `data` as a buffer view (4-byte aligned) with one accessor; returns its index.
    fn push(&mut self, data: &[u8], target: u32, mut accessor: Value) -> usize {
        let offset = self.bytes.len();
        self.bytes.extend_from_slice(data);
        self.bytes.resize(self.bytes.len().next_multiple_of(4), 0);
        self.views.push(json!({
            "buffer": 0,
            "byteOffset": offset,
            "byteLength": data.len(),
            "target": target,
        }));
        accessor["bufferView"] = json!(self.views.len() - 1);
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    fn vec3(&mut self, values: &[[f32; 3]], min_max: bool) -> usize {
        let data: Vec<u8> = values
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let mut accessor = json!({
            "componentType": 5126,
            "count": values.len(),
            "type": "VEC3",
        });
        if min_max {
            let mut lo = [f32::INFINITY; 3];
            let mut hi = [f32::NEG_INFINITY; 3];
            for v in values {
                for k in 0..3 {
                    lo[k] = lo[k].min(v[k]);
                    hi[k] = hi[k].max(v[k]);
                }
            }
            // Exactly the stored floats (f32 widened to f64 is exact): the validator compares.
            accessor["min"] = json!(lo.map(f64::from));
            accessor["max"] = json!(hi.map(f64::from));
        }
        self.push(&data, ARRAY_BUFFER, accessor)
    }

    /// Indices as u16 where they fit (65535 is the restart value, never an index), else u32.
    fn indices(&mut self, indices: &[u32], vertex_count: usize) -> usize {
        let (data, component): (Vec<u8>, u32) = if vertex_count <= usize::from(u16::MAX) {
            (
                indices
                    .iter()
                    .flat_map(|&i| (i as u16).to_le_bytes())
                    .collect(),
                5123,
            )
        } else {
            (indices.iter().flat_map(|i| i.to_le_bytes()).collect(), 5125)
        };
        let accessor = json!({
            "componentType": component,
            "count": indices.len(),
            "type": "SCALAR",
        });
        self.push(&data, ELEMENT_ARRAY_BUFFER, accessor)
    }
}

const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

/// Unit normals per mesh vertex: the mesh's own, or where it has none (zero length: "use the
/// facet normal" for the renderer) the area-weighted normal of the triangles around it; +Z if
/// those are degenerate too. glTF requires unit normals.
fn unit_normals(mesh: &Mesh) -> Vec<[f32; 3]> {
    let usable = |n: [f32; 3]| {
        let l = crate::vec3::length(n);
        (l.is_finite() && l > 1e-12).then(|| n.map(|c| c / l))
    };
    let mut normals: Vec<Option<[f32; 3]>> =
        mesh.vertices.iter().map(|v| usable(v.normal)).collect();
    if normals.iter().any(Option::is_none) {
        let mut sums = vec![[0.0f32; 3]; mesh.vertices.len()];
        for t in mesh.indices.chunks_exact(3) {
            let [a, b, c] = [0, 1, 2].map(|k| mesh.vertices[t[k] as usize].position);
            let n = crate::vec3::triangle_normal(a, b, c);
            for &i in t {
                for k in 0..3 {
                    sums[i as usize][k] += n[k];
                }
            }
        }
        for (n, sum) in normals.iter_mut().zip(sums) {
            if n.is_none() {
                *n = Some(usable(sum).unwrap_or([0.0, 0.0, 1.0]));
            }
        }
    }
    normals.into_iter().flatten().collect()
}

/// The cameo mesh (gem millimetres) as a GLB: one scene, one node, one mesh of up to three
/// primitives (ground, portrait, gold; an empty one left out), positions in metres.
pub fn to_glb(mesh: &Mesh, options: &GltfOptions) -> Result<Vec<u8>, GltfError> {
    if !mesh.indices.len().is_multiple_of(3) {
        return Err(GltfError::Ragged);
    }
    if mesh.indices.is_empty() {
        return Err(GltfError::Empty);
    }
    let count = mesh.vertices.len();
    if let Some(&index) = mesh.indices.iter().find(|&&i| i as usize >= count) {
        return Err(GltfError::BadIndex { index, count });
    }
    if let Some(i) = mesh
        .vertices
        .iter()
        .position(|v| v.position.iter().any(|c| !c.is_finite()))
    {
        return Err(GltfError::NonFinite(i));
    }

    // Triangles to parts: gold if all three corners are gold (the bezel shares no vertex with
    // the stone), ground if all three lie on the ground, else the portrait (its wall included).
    let (ground, portrait, gold) = (0usize, 1usize, 2usize);
    let mut parts = [
        Part::new("ground"),
        Part::new("portrait"),
        Part::new("gold"),
    ];
    let mut slot = vec![[u32::MAX; 3]; count];
    for t in mesh.indices.chunks_exact(3) {
        let regions = [0, 1, 2].map(|k| mesh.vertices[t[k] as usize].region);
        let part = if regions.iter().all(|&r| r == Region::Gold as u32) {
            gold
        } else if regions.iter().all(|&r| r == Region::Ground as u32) {
            ground
        } else {
            portrait
        };
        let p = &mut parts[part];
        for &i in t {
            let s = &mut slot[i as usize][part];
            if *s == u32::MAX {
                *s = p.vertices.len() as u32;
                p.vertices.push(i);
            }
            p.indices.push(*s);
        }
    }

    let normals = unit_normals(mesh);
    let pbr = materials(options.stone);
    // Marble's ground and portrait share one material.
    let material_of = |part: usize| match (options.stone.material, part) {
        (Material::Marble, 1) => 0,
        _ => part,
    };
    let mut bin = Bin::default();
    let mut primitives = Vec::new();
    let mut used_materials: Vec<usize> = Vec::new();
    for (k, part) in parts.iter().enumerate() {
        if part.indices.is_empty() {
            continue;
        }
        let positions: Vec<[f32; 3]> = part
            .vertices
            .iter()
            .map(|&i| {
                mesh.vertices[i as usize]
                    .position
                    .map(|c| c * METRES_PER_MM)
            })
            .collect();
        let part_normals: Vec<[f32; 3]> =
            part.vertices.iter().map(|&i| normals[i as usize]).collect();
        let mut attributes = serde_json::Map::new();
        attributes.insert("POSITION".into(), json!(bin.vec3(&positions, true)));
        attributes.insert("NORMAL".into(), json!(bin.vec3(&part_normals, false)));
        if let (Some(layers), 1) = (options.stone.material.layers(), k) {
            let hair_layer = options.stone.hair_layer;
            let colours: Vec<[f32; 3]> = part
                .vertices
                .iter()
                .map(|&i| {
                    let v = &mesh.vertices[i as usize];
                    layers.colour(v.relief, v.hair, hair_layer)
                })
                .collect();
            attributes.insert("COLOR_0".into(), json!(bin.vec3(&colours, false)));
        }
        let indices = bin.indices(&part.indices, part.vertices.len());
        let material = material_of(k);
        let slot = match used_materials.iter().position(|&m| m == material) {
            Some(s) => s,
            None => {
                used_materials.push(material);
                used_materials.len() - 1
            }
        };
        primitives.push(json!({
            "attributes": attributes,
            "indices": indices,
            "material": slot,
            "mode": 4,
            "extras": { "part": part.name },
        }));
    }
    let materials: Vec<Value> = used_materials
        .iter()
        .map(|&m| {
            let p = &pbr[m];
            json!({
                "name": p.name,
                "pbrMetallicRoughness": {
                    "baseColorFactor": p.base_colour.map(tidy),
                    "metallicFactor": tidy(p.metallic),
                    "roughnessFactor": tidy(p.roughness),
                },
                // The renderer draws both sides (it turns the normal to the viewer).
                "doubleSided": true,
            })
        })
        .collect();

    let document = json!({
        "asset": {
            "version": "2.0",
            "generator": options.generator,
            "extras": {
                "source": options.source,
                "note": "a carved cameo; 1 unit = 1 m (gem millimetres / 1000); the stone faces +Z, +Y up",
            },
        },
        "scene": 0,
        "scenes": [{ "name": "cameo", "nodes": [0] }],
        "nodes": [{ "name": "cameo", "mesh": 0 }],
        "meshes": [{ "name": "cameo", "primitives": primitives }],
        "materials": materials,
        "accessors": bin.accessors,
        "bufferViews": bin.views,
        "buffers": [{ "byteLength": bin.bytes.len() }],
    });
    glb(&document, &bin.bytes)
}

/// A material factor with six decimals: the file stays readable and nothing visible changes.
fn tidy(x: f32) -> f64 {
    (f64::from(x) * 1e6).round() / 1e6
}

/// The GLB container: a 12-byte header, the JSON chunk (padded with spaces) and the binary
/// chunk (padded with zeros), each chunk's length a multiple of 4.
fn glb(document: &Value, bin: &[u8]) -> Result<Vec<u8>, GltfError> {
    let mut text = document.to_string().into_bytes();
    text.resize(text.len().next_multiple_of(4), b' ');
    let bin_len = bin.len().next_multiple_of(4);
    let total = 12 + 8 + text.len() + 8 + bin_len;
    let length = u32::try_from(total).map_err(|_| GltfError::TooLarge(total))?;
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&length.to_le_bytes());
    // Both chunk lengths are below `total`, which fits.
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&text);
    out.extend_from_slice(&(bin_len as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(bin);
    out.resize(total, 0);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Vertex;

    fn vertex(position: [f32; 3], normal: [f32; 3], region: Region, relief: f32) -> Vertex {
        Vertex::open(position, normal, relief, region)
    }

    /// A toy cameo: a ground square, a raised square (one normal missing) with a hair corner
    /// and a wall triangle sharing ground vertices, and a gold quad; 70,000 extra ground
    /// vertices on request, to need 32-bit indices.
    fn toy(extra: usize) -> Mesh {
        let mut vertices = vec![
            vertex([-10.0, -10.0, 0.0], [0.0, 0.0, 1.0], Region::Ground, 0.0),
            vertex([10.0, -10.0, 0.0], [0.0, 0.0, 2.0], Region::Ground, 0.0),
            vertex([10.0, 10.0, 0.0], [0.0, 0.0, 1.0], Region::Ground, 0.0),
            vertex([-10.0, 10.0, 0.0], [0.0, 0.0, 1.0], Region::Ground, 0.0),
            vertex([-2.0, -2.0, 3.0], [0.0, 0.0, 0.0], Region::Relief, 3.0),
            vertex([2.0, -2.0, 3.0], [0.0, 0.3, 1.0], Region::Relief, 3.0),
            vertex([2.0, 2.0, 4.5], [0.0, 0.0, 1.0], Region::Hair, 4.5),
            vertex([-2.0, 2.0, 3.0], [0.0, 0.0, 1.0], Region::Relief, 3.0),
            vertex([-23.0, -29.0, -3.0], [0.0, 0.0, -1.0], Region::Gold, 0.0),
            vertex([23.0, -29.0, -3.0], [0.0, 0.0, -1.0], Region::Gold, 0.0),
            vertex([23.0, 29.0, -3.0], [0.0, 0.0, -1.0], Region::Gold, 0.0),
            vertex([-23.0, 29.0, -3.0], [0.0, 0.0, -1.0], Region::Gold, 0.0),
        ];
        let mut indices = vec![
            0, 1, 2, 0, 2, 3, // ground
            4, 5, 6, 4, 6, 7, // top of the relief
            0, 1, 5, // a wall from the ground up
            8, 10, 9, 8, 11, 10, // the gold back, facing -Z
        ];
        for k in 0..extra {
            let base = vertices.len() as u32;
            let x = -9.0 + 18.0 * (k as f32 / extra as f32);
            for (dx, dy) in [(0.0, 0.0), (0.0001, 0.0), (0.0, 0.0001)] {
                vertices.push(vertex(
                    [x + dx, dy, 0.0],
                    [0.0, 0.0, 1.0],
                    Region::Ground,
                    0.0,
                ));
            }
            if k % 3 == 0 {
                indices.extend_from_slice(&[base, base + 1, base + 2]);
            }
        }
        Mesh { vertices, indices }
    }

    /// The GLB's JSON and binary chunk, the container's lengths checked on the way.
    fn open(glb: &[u8]) -> (Value, &[u8]) {
        assert_eq!(&glb[0..4], b"glTF");
        let word = |at: usize| u32::from_le_bytes(glb[at..at + 4].try_into().unwrap()) as usize;
        assert_eq!(word(4), 2, "version");
        assert_eq!(word(8), glb.len(), "total length");
        let json_len = word(12);
        assert_eq!(&glb[16..20], b"JSON");
        assert_eq!(json_len % 4, 0);
        let doc: Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
        let at = 20 + json_len;
        let bin_len = word(at);
        assert_eq!(&glb[at + 4..at + 8], b"BIN\0");
        assert_eq!(bin_len % 4, 0);
        assert_eq!(at + 8 + bin_len, glb.len());
        (doc, &glb[at + 8..])
    }

    /// An accessor's values as f64 (floats, u16 or u32), checked against its view.
    fn read(doc: &Value, bin: &[u8], accessor: usize) -> Vec<f64> {
        let a = &doc["accessors"][accessor];
        let view = &doc["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
        let offset = view["byteOffset"].as_u64().unwrap() as usize;
        let length = view["byteLength"].as_u64().unwrap() as usize;
        assert_eq!(offset % 4, 0, "view offset aligned");
        assert!(offset + length <= bin.len());
        let count = a["count"].as_u64().unwrap() as usize;
        let width = match a["type"].as_str().unwrap() {
            "VEC3" => 3,
            "SCALAR" => 1,
            t => panic!("type {t}"),
        };
        let bytes = &bin[offset..offset + length];
        let values: Vec<f64> = match a["componentType"].as_u64().unwrap() {
            5126 => bytes
                .chunks_exact(4)
                .map(|b| f64::from(f32::from_le_bytes(b.try_into().unwrap())))
                .collect(),
            5123 => bytes
                .chunks_exact(2)
                .map(|b| f64::from(u16::from_le_bytes(b.try_into().unwrap())))
                .collect(),
            5125 => bytes
                .chunks_exact(4)
                .map(|b| f64::from(u32::from_le_bytes(b.try_into().unwrap())))
                .collect(),
            c => panic!("component type {c}"),
        };
        assert_eq!(values.len(), count * width, "accessor {accessor}");
        values
    }

    const MARBLE: Stone = Stone {
        material: Material::Marble,
        hair_layer: true,
    };
    const AGATE_HAIR: Stone = Stone {
        material: Material::Agate,
        hair_layer: true,
    };

    fn options(stone: Stone) -> GltfOptions<'static> {
        GltfOptions {
            stone,
            generator: "glyptic test",
            source: "a toy",
        }
    }

    #[test]
    fn a_glb_holds_the_cameo_in_metres_by_material() {
        let mesh = toy(0);
        for stone in [MARBLE, AGATE_HAIR] {
            let glb = to_glb(&mesh, &options(stone)).unwrap();
            let (doc, bin) = open(&glb);
            assert_eq!(doc["asset"]["version"], "2.0");
            assert_eq!(doc["asset"]["generator"], "glyptic test");
            assert_eq!(doc["scenes"][0]["nodes"], json!([0]));
            assert_eq!(doc["nodes"][0]["mesh"], 0);
            assert_eq!(
                doc["buffers"][0]["byteLength"].as_u64(),
                Some(bin.len() as u64)
            );
            let prims = doc["meshes"][0]["primitives"].as_array().unwrap();
            let names: Vec<&str> = prims
                .iter()
                .map(|p| p["extras"]["part"].as_str().unwrap())
                .collect();
            assert_eq!(names, ["ground", "portrait", "gold"]);
            let materials = doc["materials"].as_array().unwrap();
            assert_eq!(materials.len(), if stone == MARBLE { 2 } else { 3 });
            let mut triangles = 0;
            for (k, (p, expect)) in prims.iter().zip([(4, 2), (6, 3), (4, 2)]).enumerate() {
                let pos = p["attributes"]["POSITION"].as_u64().unwrap() as usize;
                let positions = read(&doc, bin, pos);
                assert_eq!(positions.len() / 3, expect.0, "{p}");
                // min and max are exactly the positions' own (as f32: serde_json's default
                // parser may miss a float's last bit, the validator's does not).
                let single = |v: &Value| v.as_f64().map(|x| x as f32);
                for a in 0..3 {
                    let axis = positions.iter().skip(a).step_by(3);
                    let lo = axis.clone().cloned().fold(f64::INFINITY, f64::min) as f32;
                    let hi = axis.cloned().fold(f64::NEG_INFINITY, f64::max) as f32;
                    assert_eq!(single(&doc["accessors"][pos]["min"][a]), Some(lo));
                    assert_eq!(single(&doc["accessors"][pos]["max"][a]), Some(hi));
                }
                // Metres: the stone is a few centimetres.
                assert!(positions.iter().all(|c| c.abs() <= 0.03), "{positions:?}");
                let normal = p["attributes"]["NORMAL"].as_u64().unwrap() as usize;
                for n in read(&doc, bin, normal).chunks_exact(3) {
                    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                    assert!((len - 1.0).abs() < 1e-6, "normal {n:?}");
                }
                let idx = p["indices"].as_u64().unwrap() as usize;
                assert_eq!(doc["accessors"][idx]["componentType"], 5123);
                let indices = read(&doc, bin, idx);
                assert_eq!(indices.len(), 3 * expect.1);
                assert!(indices.iter().all(|&i| i < expect.0 as f64));
                triangles += indices.len() / 3;
                // Agate's portrait takes its layers per vertex.
                let has_colour = p["attributes"].get("COLOR_0").is_some();
                assert_eq!(has_colour, stone != MARBLE && k == 1);
                let m = &materials[p["material"].as_u64().unwrap() as usize];
                let metallic = m["pbrMetallicRoughness"]["metallicFactor"]
                    .as_f64()
                    .unwrap();
                assert_eq!(metallic, if k == 2 { 1.0 } else { 0.0 }, "{m}");
            }
            assert_eq!(triangles, mesh.indices.len() / 3);
        }
    }

    #[test]
    fn agate_colours_follow_the_layers() {
        let agate = |relief, hair, layer| crate::stone::AGATE.colour(relief, hair, layer);
        let red = agate(0.0, 0.0, true);
        let thin = agate(0.2, 0.0, true);
        let white = agate(4.0, 0.0, true);
        let hair = agate(4.0, 1.0, true);
        let no_layer = agate(4.0, 1.0, false);
        assert!(red[0] > 2.0 * red[2], "red ground {red:?}");
        assert!(white[1] > 0.5 && white[2] > 0.5, "white layer {white:?}");
        // A thin white layer lets the red through (less white than the full layer).
        assert!(thin[1] > red[1] && thin[1] < white[1], "{thin:?}");
        assert!(hair[2] < 0.05 && hair[0] > hair[2], "brown hair {hair:?}");
        assert_eq!(no_layer, white);
    }

    #[test]
    fn highlights_become_roughness() {
        // A sharper highlight is a smoother surface; agate's is the sharpest.
        let [marble, _, gold] = materials(MARBLE);
        let [_, agate, _] = materials(AGATE_HAIR);
        assert!(agate.roughness < gold.roughness && gold.roughness < marble.roughness);
        assert!((0.1..0.5).contains(&marble.roughness), "{marble:?}");
        assert_eq!(gold.metallic, 1.0);
        assert_eq!(gold.base_colour, [1.0, 0.71, 0.29, 1.0]);
    }

    #[test]
    fn large_parts_take_32_bit_indices() {
        let mesh = toy(70_000);
        let glb = to_glb(&mesh, &options(MARBLE)).unwrap();
        let (doc, bin) = open(&glb);
        let ground = &doc["meshes"][0]["primitives"][0];
        let idx = ground["indices"].as_u64().unwrap() as usize;
        assert_eq!(doc["accessors"][idx]["componentType"], 5125);
        let count =
            doc["accessors"][ground["attributes"]["POSITION"].as_u64().unwrap() as usize]["count"]
                .as_f64()
                .unwrap();
        assert!(count > 65535.0);
        assert!(read(&doc, bin, idx).iter().all(|&i| i < count));
    }

    #[test]
    fn broken_meshes_are_refused() {
        let o = options(MARBLE);
        assert_eq!(to_glb(&Mesh::default(), &o), Err(GltfError::Empty));
        let mut mesh = toy(0);
        mesh.indices.push(0);
        assert_eq!(to_glb(&mesh, &o), Err(GltfError::Ragged));
        let mut mesh = toy(0);
        mesh.indices.extend_from_slice(&[0, 1, 99]);
        assert_eq!(
            to_glb(&mesh, &o),
            Err(GltfError::BadIndex {
                index: 99,
                count: 12
            })
        );
        let mut mesh = toy(0);
        mesh.vertices[3].position[1] = f32::NAN;
        assert_eq!(to_glb(&mesh, &o), Err(GltfError::NonFinite(3)));
    }
}
