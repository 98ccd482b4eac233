// requires: scene.wgsl
//
// The scene pass's compute form, its second step: each pixel of the visibility image
// (`scene_vis.wgsl`) shaded in a compute pass, into the same three images the fragment form
// writes (diffuse, specular, depth and mask; premultiplied by coverage). A pixel's triangles
// are shaded once each at the pixel's centre, as MSAA's fragment stage does (the varyings
// extrapolated where the centre lies outside), and weighted by the samples they cover, which
// is what the resolve of the fragment form's targets gives. The varyings are the triangle's
// plane seen along the pixel's view ray (perspective-correct, as the rasteriser interpolates),
// and their screen derivatives the plane at the next pixels.

// A vertex as the mesh buffer holds it (`glyptic_core::scene::Vertex`, 48 bytes).
struct StoredVertex {
    px: f32, py: f32, pz: f32,
    nx: f32, ny: f32, nz: f32,
    relief: f32,
    region: u32,
    hair: f32,
    occlusion: f32,
    key_light: f32,
    transmit: f32,
}

@group(2) @binding(0) var<storage, read> vertices: array<StoredVertex>;
// Tangent frames, one per vertex (written for frames with the engraving; zero otherwise).
@group(2) @binding(1) var<storage, read> tangents: array<vec4<f32>>;
@group(2) @binding(2) var<storage, read> indices: array<u32>;
@group(2) @binding(3) var out_diffuse: texture_storage_2d<rgba16float, write>;
@group(2) @binding(4) var out_specular: texture_storage_2d<rgba16float, write>;
@group(2) @binding(5) var out_depth_mask: texture_storage_2d<rgba16float, write>;
// The visibility image, multisampled (`cs_shade_msaa`) or not (`cs_shade`).
@group(2) @binding(6) var visible_msaa: texture_multisampled_2d<f32>;
@group(2) @binding(7) var visible: texture_2d<f32>;

fn position_of(v: StoredVertex) -> vec3<f32> {
    return vec3<f32>(v.px, v.py, v.pz);
}

// The point where the view ray through `pos` (pixels of the images) meets the plane through
// `p0` with normal `n`.
fn on_plane(pos: vec2<f32>, p0: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let size = vec2<f32>(frame.shade.yz);
    let ndc = vec2<f32>(pos.x / size.x * 2.0 - 1.0, 1.0 - pos.y / size.y * 2.0);
    let near = frame.inv_view_proj * vec4<f32>(ndc, 0.0, 1.0);
    let far = frame.inv_view_proj * vec4<f32>(ndc, 1.0, 1.0);
    let a = near.xyz / near.w;
    let d = far.xyz / far.w - a;
    let nd = dot(n, d);
    // A plane seen edge-on covers no pixel centre's ray; keep the division finite.
    let safe = select(nd, 1e-12, abs(nd) < 1e-12);
    return a + dot(n, p0 - a) / safe * d;
}

// The vertex as the fragment form's vertex stage receives it.
fn vertex_in(v: StoredVertex, tangent: vec4<f32>) -> VsIn {
    var in: VsIn;
    in.position = position_of(v);
    in.normal = vec3<f32>(v.nx, v.ny, v.nz);
    in.relief = v.relief;
    in.region = v.region;
    in.hair = v.hair;
    in.tangent = tangent;
    in.occlusion = v.occlusion;
    in.key_light = v.key_light;
    in.transmit = v.transmit;
    return in;
}

fn tangent_of(i: u32) -> vec4<f32> {
    if i < arrayLength(&tangents) {
        return tangents[i];
    }
    return vec4<f32>(0.0);
}

// Triangle `triangle`'s varyings at the pixel centre `pos`, as `vs_main` (`vertex_out`) and the
// rasteriser give them, shaded.
fn shade_triangle(triangle: u32, pos: vec2<f32>) -> FsOut {
    let i = vec3<u32>(indices[3u * triangle], indices[3u * triangle + 1u], indices[3u * triangle + 2u]);
    let v0 = vertices[i.x];
    let v1 = vertices[i.y];
    let v2 = vertices[i.z];
    let p0 = position_of(v0);
    let e1 = position_of(v1) - p0;
    let e2 = position_of(v2) - p0;
    let n = cross(e1, e2);
    let nn = dot(n, n);
    let p = on_plane(pos, p0, n);
    let p_dx = on_plane(pos + vec2<f32>(1.0, 0.0), p0, n) - p;
    let p_dy = on_plane(pos + vec2<f32>(0.0, 1.0), p0, n) - p;
    // Barycentric weights of p (outside [0, 1] where the centre lies off the triangle).
    var b = vec3<f32>(1.0, 0.0, 0.0);
    if nn > 0.0 {
        let b1 = dot(cross(p - p0, e2), n) / nn;
        let b2 = dot(cross(e1, p - p0), n) / nn;
        b = vec3<f32>(1.0 - b1 - b2, b1, b2);
    }
    let a = vertex_out(vertex_in(v0, tangent_of(i.x)));
    let c = vertex_out(vertex_in(v1, tangent_of(i.y)));
    let e = vertex_out(vertex_in(v2, tangent_of(i.z)));
    var s: VsOut;
    s.clip = vec4<f32>(0.0);
    s.world = p;
    s.normal = b.x * a.normal + b.y * c.normal + b.z * e.normal;
    s.relief = dot(b, vec3<f32>(a.relief, c.relief, e.relief));
    s.hair = dot(b, vec3<f32>(a.hair, c.hair, e.hair));
    s.gold = dot(b, vec3<f32>(a.gold, c.gold, e.gold));
    s.tangent = b.x * a.tangent + b.y * c.tangent + b.z * e.tangent;
    s.occlusion = dot(b, vec3<f32>(a.occlusion, c.occlusion, e.occlusion));
    s.key_light = dot(b, vec3<f32>(a.key_light, c.key_light, e.key_light));
    s.transmit = dot(b, vec3<f32>(a.transmit, c.transmit, e.transmit));
    return shade(s, p_dx, p_dy, triangle >= frame.shade.x);
}

// The pixel's result from the triangles its `n` samples see (`seen[k]`: triangle + 1, 0 none):
// each distinct triangle shaded once and weighted by its share of the samples. The shading is
// called from one place, in a loop whose count the compiler cannot bound (capped by the
// uniform's `shade.w`): called inside the loop over the samples, it may be unrolled four
// times, and a machine's first start compiled the pipeline some 175 ms longer (BENCHMARKS.md,
// issue #42); the image is the same to the bit.
fn resolve_pixel(id: vec2<u32>, samples: array<f32, 4>, n: u32) {
    var seen = samples;
    // The distinct triangles and their sample counts.
    var triangles = array<f32, 4>(0.0, 0.0, 0.0, 0.0);
    var counts = array<u32, 4>(0u, 0u, 0u, 0u);
    var m = 0u;
    for (var k = 0u; k < n; k = k + 1u) {
        let t = seen[k];
        if t <= 0.0 {
            continue;
        }
        var found = false;
        for (var j = 0u; j < m; j = j + 1u) {
            if triangles[j] == t {
                counts[j] = counts[j] + 1u;
                found = true;
            }
        }
        if !found {
            triangles[m] = t;
            counts[m] = 1u;
            m = m + 1u;
        }
    }
    let pos = vec2<f32>(id) + 0.5;
    var diffuse = vec4<f32>(0.0);
    var specular = vec4<f32>(0.0);
    var depth_mask = vec2<f32>(0.0);
    let shaded = min(m, frame.shade.w);
    for (var k = 0u; k < shaded; k = k + 1u) {
        let w = f32(counts[k]) / f32(n);
        let out = shade_triangle(u32(triangles[k]) - 1u, pos);
        diffuse += w * out.diffuse;
        specular += w * out.specular;
        depth_mask += w * out.depth_mask;
    }
    let texel = vec2<i32>(id);
    textureStore(out_diffuse, texel, diffuse);
    textureStore(out_specular, texel, specular);
    textureStore(out_depth_mask, texel, vec4<f32>(depth_mask, 0.0, 0.0));
}

@compute @workgroup_size(8, 8)
fn cs_shade_msaa(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.shade.y || id.y >= frame.shade.z {
        return;
    }
    let n = min(textureNumSamples(visible_msaa), 4u);
    var seen = array<f32, 4>(0.0, 0.0, 0.0, 0.0);
    for (var k = 0u; k < n; k = k + 1u) {
        seen[k] = textureLoad(visible_msaa, vec2<i32>(id.xy), i32(k)).r;
    }
    resolve_pixel(id.xy, seen, n);
}

@compute @workgroup_size(8, 8)
fn cs_shade(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.shade.y || id.y >= frame.shade.z {
        return;
    }
    let seen = array<f32, 4>(textureLoad(visible, vec2<i32>(id.xy), 0).r, 0.0, 0.0, 0.0);
    resolve_pixel(id.xy, seen, 1u);
}
