// Shared by the gallery style passes: their uniform, their input (the previous pass's
// Rgba8Unorm image, display values) and a bilinear read with clamped edges that matches the
// CPU references in crates/render/src/styles.rs (pixel centres at whole numbers).

struct Style {
    // Per style: toon (levels, edge low, edge high, threshold); fish-eye (strength, power);
    // chromatic (red offset x, y, green offset x, y); painterly (radii, jitter).
    p: vec4<f32>,
    // Chromatic: blue offset x, y. Painterly: 1 / difference, seed high, layers, seed low.
    q: vec4<f32>,
}

@group(0) @binding(0) var<uniform> style: Style;
@group(0) @binding(1) var src: texture_2d<f32>;

fn texel(x: i32, y: i32) -> vec4<f32> {
    let size = vec2<i32>(textureDimensions(src));
    return textureLoad(src, clamp(vec2<i32>(x, y), vec2<i32>(0), size - 1), 0);
}

fn bilinear(p: vec2<f32>) -> vec4<f32> {
    let f = floor(p);
    let t = p - f;
    let i = vec2<i32>(f);
    let top = mix(texel(i.x, i.y), texel(i.x + 1, i.y), t.x);
    let bottom = mix(texel(i.x, i.y + 1), texel(i.x + 1, i.y + 1), t.x);
    return mix(top, bottom, t.y);
}
