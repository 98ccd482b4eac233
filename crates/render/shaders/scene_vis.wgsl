// The scene pass's compute form, its first step: the visibility image. Each sample keeps which
// triangle it sees (its index in the draw, plus one; 0 where nothing is drawn), as a float
// (exact up to 2^24 triangles; R32Float is multisampled on every WebGPU device, R32Uint is
// not). `scene_shade.wgsl` then shades each pixel's triangles in a compute pass: on GPUs with
// few graphics units (data-centre chips) the fragment stage and the multisampled targets, not
// the shading, were two thirds of the scene pass (BENCHMARKS.md, issue #42).
enable primitive_index;

// The head of `Frame` in scene.wgsl (the same uniform buffer).
struct VisFrame {
    view_proj: mat4x4<f32>,
}

@group(0) @binding(0) var<uniform> frame: VisFrame;

@vertex
fn vs_vis(@location(0) position: vec3<f32>) -> @builtin(position) vec4<f32> {
    return frame.view_proj * vec4<f32>(position, 1.0);
}

@fragment
fn fs_vis(@builtin(primitive_index) triangle: u32) -> @location(0) f32 {
    return f32(triangle + 1u);
}
