// requires: fullscreen.wgsl, style_common.wgsl
//
// Toon: the luminance quantised to `levels` greys, black where the smoothed Sobel gradient
// magnitude passes the threshold (crates/render/src/styles.rs `toon`).

fn luma(x: i32, y: i32) -> f32 {
    return dot(texel(x, y).rgb, vec3<f32>(0.2126, 0.7152, 0.0722));
}

@fragment
fn fs_main(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    let x = i32(pos.x);
    let y = i32(pos.y);
    let gx = luma(x + 1, y - 1) + 2.0 * luma(x + 1, y) + luma(x + 1, y + 1)
        - luma(x - 1, y - 1) - 2.0 * luma(x - 1, y) - luma(x - 1, y + 1);
    let gy = luma(x - 1, y + 1) + 2.0 * luma(x, y + 1) + luma(x + 1, y + 1)
        - luma(x - 1, y - 1) - 2.0 * luma(x, y - 1) - luma(x + 1, y - 1);
    let edge = smoothstep(style.p.y, style.p.z, sqrt(gx * gx + gy * gy));
    let a = texel(x, y).a;
    if edge > style.p.w {
        return vec4<f32>(0.0, 0.0, 0.0, a);
    }
    let levels = max(style.p.x, 2.0);
    let step = min(floor(luma(x, y) * levels), levels - 1.0);
    let grey = step / (levels - 1.0);
    return vec4<f32>(grey, grey, grey, a);
}
