// requires: fullscreen.wgsl, style_common.wgsl
//
// Chromatic aberration: each colour channel read at its own offset (pixels), which the CPU
// turns with time (crates/render/src/styles.rs `chromatic_offsets`).

@fragment
fn fs_main(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    let p = floor(pos.xy);
    let r = bilinear(p + style.p.xy).r;
    let g = bilinear(p + style.p.zw).g;
    let b = bilinear(p + style.q.xy).b;
    return vec4<f32>(r, g, b, texel(i32(p.x), i32(p.y)).a);
}
