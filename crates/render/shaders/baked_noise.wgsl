// requires: noise.wgsl
//
// The gem's noise that varies slowly enough to be baked: the marble's cloudiness and the
// gold's ripple. Neither changes between frames, so both are computed once into a volume over
// the mesh (noise_volume.wgsl) and the scene pass reads them back with one trilinear fetch
// instead of five simplex noises per fragment. Positions in gem millimetres.
//
// The marble's veins are not baked: their warp moves thin lines, and a change of 0.002 in it
// (veins shifted by 0.03 mm) already takes the goldens past their FLIP tolerance, which no
// trilinear read of a half-float volume stays within (measured in BENCHMARKS.md).

// The marble's faint cloudiness (relative change of its grey, before the lightness control);
// `uv` in texture units (the marble's scale times mm). Waves 20 and 4.3 mm long.
fn marble_cloud(uv: vec3<f32>) -> f32 {
    return 0.018 * snoise3(uv * 3.75) + 0.008 * snoise3(uv * 17.25);
}

// Polished gold is never optically flat: a faint ripple of the normal, 6.7 mm waves, keeps
// large flat parts (the back) from reflecting one uniform tone.
fn gold_ripple(p: vec3<f32>) -> vec3<f32> {
    let q = p * 0.15;
    return vec3<f32>(snoise3(q), snoise3(q + vec3<f32>(17.0, 3.0, 5.0)), snoise3(q - vec3<f32>(7.0, 11.0, 2.0)));
}

// What the volume holds at `p`: r the marble's cloudiness, gba the gold's ripple. `scale`:
// the marble's texture scale (1/mm).
fn noise_baked(p: vec3<f32>, scale: f32) -> vec4<f32> {
    return vec4<f32>(marble_cloud(p * scale), gold_ripple(p));
}
