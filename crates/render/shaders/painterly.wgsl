// requires: fullscreen.wgsl, style_common.wgsl
//
// Painterly (crates/render/src/styles.rs `painterly`): layers of brush dabs on jittered grids, coarse first;
// a dab is the colour under its centre, smaller where the colour changes within a brush
// radius. The CPU paints the dabs in order and a pixel ends as the last dab over it; every dab
// reads the original picture, so this pass gathers the same answer: it visits the cells whose
// dab could reach the pixel from the last painted backwards and stops at the first that covers
// it. The arithmetic follows the CPU's to the bit where it can (the hash, multiplications for
// divisions, rounding half up).
//
// Uniform: p = radii of layers 0..2 (pixels), jitter (fraction of a step); q = 1 / colour
// difference, seed's high 16 bits, layer count (1..=3), seed's low 16 bits.

fn hash32(v: u32) -> u32 {
    var x = v;
    x = x ^ (x >> 16u);
    x = x * 0x7feb352du;
    x = x ^ (x >> 15u);
    x = x * 0x846ca68bu;
    return x ^ (x >> 16u);
}

fn unit(bits: u32) -> f32 {
    return f32(bits & 0xffffu) * (1.0 / 65535.0) - 0.5;
}

// A pixel's bytes as the CPU's u32::from_le_bytes([r, g, b, a]).
fn pixel_bits(x: u32, y: u32) -> u32 {
    let b = vec4<u32>(floor(texel(i32(x), i32(y)) * 255.0 + 0.5));
    return b.x | (b.y << 8u) | (b.z << 16u) | (b.w << 24u);
}

// The colour at the pixel nearest (x, y), rounding half up, edges clamped.
fn colour(x: f32, y: f32) -> vec3<f32> {
    return texel(i32(floor(x + 0.5)), i32(floor(y + 0.5))).rgb;
}

fn difference(a: vec3<f32>, b: vec3<f32>) -> f32 {
    let d = abs(a - b);
    return (d.x + d.y + d.z) * (1.0 / 3.0);
}

@fragment
fn fs_main(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    let size = vec2<u32>(textureDimensions(src));
    // The painting's seed: from the base and sixteen pixels of the picture (painting_seed).
    var seed = (u32(style.q.y) << 16u) | u32(style.q.w);
    for (var k = 0u; k < 16u; k = k + 1u) {
        seed = hash32(seed ^ pixel_bits((k * 7919u) % size.x, (k * 104729u) % size.y));
    }
    let x = floor(pos.x);
    let y = floor(pos.y);
    let own = texel(i32(x), i32(y));
    let jitter = style.p.w;
    let radii = vec3<f32>(style.p.x, style.p.y, style.p.z);
    for (var layer = i32(style.q.z) - 1; layer >= 0; layer = layer - 1) {
        let radius = radii[layer];
        let step = max(radius, 1.0);
        let cells = vec2<i32>(ceil(vec2<f32>(size) / step));
        // Cells whose jittered centre can lie within a step (the largest brush) of the pixel.
        let lo = max(vec2<i32>(ceil(vec2<f32>(x, y) / step - 1.5 - 0.5 * jitter)), vec2<i32>(0));
        let hi = min(vec2<i32>(floor(vec2<f32>(x, y) / step + 0.5 + 0.5 * jitter)), cells - 1);
        for (var gy = hi.y; gy >= lo.y; gy = gy - 1) {
            for (var gx = hi.x; gx >= lo.x; gx = gx - 1) {
                let r = hash32(hash32(hash32(seed ^ u32(layer)) ^ u32(gy)) ^ u32(gx));
                let cx = (f32(gx) + 0.5 + jitter * unit(r)) * step;
                let cy = (f32(gy) + 0.5 + jitter * unit(r >> 16u)) * step;
                let dx = x - cx;
                let dy = y - cy;
                let d2 = dx * dx + dy * dy;
                // No brush is larger than its radius.
                if d2 > radius * radius {
                    continue;
                }
                let c = colour(cx, cy);
                var change = difference(colour(cx + radius, cy), c);
                change = max(change, difference(colour(cx - radius, cy), c));
                change = max(change, difference(colour(cx, cy + radius), c));
                change = max(change, difference(colour(cx, cy - radius), c));
                let brush = radius * (1.0 - 0.6 * min(change * style.q.x, 1.0));
                if d2 <= brush * brush {
                    return vec4<f32>(c, own.a);
                }
            }
        }
    }
    return own;
}
