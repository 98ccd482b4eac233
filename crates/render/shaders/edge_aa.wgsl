// requires: fullscreen.wgsl
//
// Edge antialiasing for frames drawn with one sample a pixel (the kiosk's moving frames, or a
// device without MSAA): Lottes's FXAA in its console form. On the finished frame (display
// values): where the luma contrast round a pixel is high, blend along the edge's direction,
// estimated from the four diagonal neighbours; keep the wider blend only if it stays within
// the neighbourhood's luma range (else it crossed the edge). Nine reads a pixel. Colours are
// blended premultiplied by alpha and written straight, so a transparent frame's outline is
// smoothed in its alpha too (an opaque frame's alpha is 1 throughout).

@group(0) @binding(0) var src: texture_2d<f32>;
@group(0) @binding(1) var linear_clamp: sampler;

// Below this contrast (display luma), and below this share of the brightest neighbour, a pixel
// is left alone: flat areas and soft gradients are not blurred.
const EDGE_MIN: f32 = 0.0625;
const EDGE_SHARE: f32 = 0.25;
// The direction's length is floored at this share of the local luma (noise guard) and the
// blend spans at most this many pixels.
const REDUCE_MUL: f32 = 0.125;
const REDUCE_MIN: f32 = 0.0078125;
const SPAN_MAX: f32 = 8.0;

fn luma(c: vec3<f32>) -> f32 {
    return dot(c, vec3<f32>(0.299, 0.587, 0.114));
}

fn at(uv: vec2<f32>) -> vec4<f32> {
    let c = textureSampleLevel(src, linear_clamp, uv, 0.0);
    return vec4<f32>(c.rgb * c.a, c.a);
}

// Straight colour again.
fn straight(c: vec4<f32>) -> vec4<f32> {
    if c.a <= 0.0 {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(c.rgb / c.a, c.a);
}

@fragment
fn fs_main(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    let texel = 1.0 / vec2<f32>(textureDimensions(src));
    let uv = pos.xy * texel;
    let m = at(uv);
    let l_m = luma(m.rgb);
    let l_nw = luma(at(uv + vec2<f32>(-1.0, -1.0) * texel).rgb);
    let l_ne = luma(at(uv + vec2<f32>(1.0, -1.0) * texel).rgb);
    let l_sw = luma(at(uv + vec2<f32>(-1.0, 1.0) * texel).rgb);
    let l_se = luma(at(uv + vec2<f32>(1.0, 1.0) * texel).rgb);
    let l_min = min(l_m, min(min(l_nw, l_ne), min(l_sw, l_se)));
    let l_max = max(l_m, max(max(l_nw, l_ne), max(l_sw, l_se)));
    if l_max - l_min < max(EDGE_MIN, l_max * EDGE_SHARE) {
        return straight(m);
    }
    // Perpendicular to the luma gradient: along the edge.
    var dir = vec2<f32>(-((l_nw + l_ne) - (l_sw + l_se)), (l_nw + l_sw) - (l_ne + l_se));
    let reduce = max((l_nw + l_ne + l_sw + l_se) * 0.25 * REDUCE_MUL, REDUCE_MIN);
    let scale = 1.0 / (min(abs(dir.x), abs(dir.y)) + reduce);
    dir = clamp(dir * scale, vec2<f32>(-SPAN_MAX), vec2<f32>(SPAN_MAX)) * texel;
    let near = 0.5 * (at(uv + dir * (1.0 / 3.0 - 0.5)) + at(uv + dir * (2.0 / 3.0 - 0.5)));
    let wide = 0.5 * near + 0.25 * (at(uv - 0.5 * dir) + at(uv + 0.5 * dir));
    let l_wide = luma(wide.rgb);
    if l_wide < l_min || l_wide > l_max {
        return straight(near);
    }
    return straight(wide);
}
