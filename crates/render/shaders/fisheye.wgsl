// requires: fullscreen.wgsl, style_common.wgsl
//
// Fish-eye: the pixel at offset d from the centre (in half the smaller side) shows the image at
// d * (1 + strength * |d|^power); black where that falls outside (crates/render/src/styles.rs `fisheye`).

@fragment
fn fs_main(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    let size = vec2<f32>(textureDimensions(src));
    let c = (size - 1.0) * 0.5;
    let half = max(min(size.x, size.y) * 0.5, 0.5);
    let d = (floor(pos.xy) - c) / half;
    let r = length(d);
    let k = 1.0 + style.p.x * pow(r, style.p.y);
    let s = c + d * k * half;
    if any(s < vec2<f32>(-0.5)) || any(s > size - 0.5) {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    return bilinear(s);
}
