// requires: baked_noise.wgsl
//
// Bakes the gem's slowly varying noise (`noise_baked`) into a 3D texture over the mesh, one
// invocation per voxel; the scene pass reads it back trilinearly. Run once per process (again
// only when a mesh leaves the baked box).

struct Volume {
    // xyz: centre of voxel (0, 0, 0), gem mm; w: voxel size, mm.
    origin: vec4<f32>,
    // x: the marble's texture scale (1/mm).
    params: vec4<f32>,
}

@group(0) @binding(0) var<uniform> volume: Volume;
@group(0) @binding(1) var baked: texture_storage_3d<rgba16float, write>;

@compute @workgroup_size(4, 4, 4)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id >= textureDimensions(baked)) {
        return;
    }
    let p = volume.origin.xyz + vec3<f32>(id) * volume.origin.w;
    textureStore(baked, id, noise_baked(p, volume.params.x));
}
