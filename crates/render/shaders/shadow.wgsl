// Shadow pass: one face of the lamp's shadow cube. Writes each fragment's distance from the
// lamp over the far plane (linear, [0, 1]) as its depth, so the scene pass compares distances
// whatever the face (the cube lookup picks the face from the direction alone).
//
// Units are millimetres in object (= world) space, as in the scene pass.

struct Face {
    view_proj: mat4x4<f32>,
    // xyz: lamp position (mm); w: 1 / far plane (1/mm).
    lamp: vec4<f32>,
}

@group(0) @binding(0) var<uniform> face: Face;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
}

@vertex
fn vs_main(@location(0) position: vec3<f32>) -> VsOut {
    var out: VsOut;
    out.clip = face.view_proj * vec4<f32>(position, 1.0);
    out.world = position;
    return out;
}

@fragment
fn fs_main(in: VsOut) -> @builtin(frag_depth) f32 {
    return clamp(distance(in.world, face.lamp.xyz) * face.lamp.w, 0.0, 1.0);
}
