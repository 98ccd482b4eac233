// Procedural noise shared by the shaders that need it (prepended to them as text; this file is a
// valid module on its own).
//
// snoise3: 3D simplex noise after Stefan Gustavson and Ian McEwan's "webgl-noise" formulation
// (permutation polynomial modulo 289, gradients on an octahedron, radial falloff 0.5 - r^2,
// scale 105). Pure arithmetic, no tables or textures, so it is identical on every backend and
// every run. Output roughly in [-1, 1].
//
// turbulence3: Perlin's turbulence, the sum of |snoise3| over 5 octaves, each doubling the
// frequency and halving the amplitude (the 2021 marble's N(x, y, z)), each octave shifted.
// Range [0, ~1.9].

fn noise_mod289_3(x: vec3<f32>) -> vec3<f32> {
    return x - floor(x * (1.0 / 289.0)) * 289.0;
}

fn noise_mod289_4(x: vec4<f32>) -> vec4<f32> {
    return x - floor(x * (1.0 / 289.0)) * 289.0;
}

fn noise_permute4(x: vec4<f32>) -> vec4<f32> {
    return noise_mod289_4((x * 34.0 + 10.0) * x);
}

fn noise_taylor_inv_sqrt4(r: vec4<f32>) -> vec4<f32> {
    return 1.79284291400159 - 0.85373472095314 * r;
}

// The simplex grid's skew constants. Module constants rather than `let`s in snoise3: naga 30
// emits a constant `let` twice when it processes a pipeline's override constants, and then
// rejects its own output (ExpressionAlreadyInScope).
const NOISE_SKEW: vec2<f32> = vec2<f32>(1.0 / 6.0, 1.0 / 3.0);
// The gradients' 7x7 grid (same reason).
const NOISE_GRID: vec3<f32> = vec3<f32>(2.0 / 7.0, 0.5 / 7.0 - 1.0, 1.0 / 7.0);

fn snoise3(v: vec3<f32>) -> f32 {
    let c = NOISE_SKEW;

    // Skew into the simplex grid and find the simplex corner offsets.
    var i = floor(v + dot(v, vec3<f32>(c.y)));
    let x0 = v - i + dot(i, vec3<f32>(c.x));
    let g = step(x0.yzx, x0.xyz);
    let l = 1.0 - g;
    let i1 = min(g.xyz, l.zxy);
    let i2 = max(g.xyz, l.zxy);
    let x1 = x0 - i1 + vec3<f32>(c.x);
    let x2 = x0 - i2 + vec3<f32>(c.y);
    let x3 = x0 - vec3<f32>(0.5);

    // Hash the four corners.
    i = noise_mod289_3(i);
    let p = noise_permute4(
        noise_permute4(
            noise_permute4(i.z + vec4<f32>(0.0, i1.z, i2.z, 1.0)) + i.y + vec4<f32>(0.0, i1.y, i2.y, 1.0)
        ) + i.x + vec4<f32>(0.0, i1.x, i2.x, 1.0)
    );

    // Gradients: 7x7 points over a square, mapped onto an octahedron.
    let ns = NOISE_GRID;
    let j = p - 49.0 * floor(p * ns.z * ns.z);
    let gx = floor(j * ns.z);
    let gy = floor(j - 7.0 * gx);
    let x = gx * ns.x + vec4<f32>(ns.y);
    let y = gy * ns.x + vec4<f32>(ns.y);
    let h = 1.0 - abs(x) - abs(y);
    let b0 = vec4<f32>(x.xy, y.xy);
    let b1 = vec4<f32>(x.zw, y.zw);
    let s0 = floor(b0) * 2.0 + 1.0;
    let s1 = floor(b1) * 2.0 + 1.0;
    let sh = -step(h, vec4<f32>(0.0));
    let a0 = b0.xzyw + s0.xzyw * sh.xxyy;
    let a1 = b1.xzyw + s1.xzyw * sh.zzww;
    var g0 = vec3<f32>(a0.xy, h.x);
    var g1 = vec3<f32>(a0.zw, h.y);
    var g2 = vec3<f32>(a1.xy, h.z);
    var g3 = vec3<f32>(a1.zw, h.w);
    let norm = noise_taylor_inv_sqrt4(vec4<f32>(dot(g0, g0), dot(g1, g1), dot(g2, g2), dot(g3, g3)));
    g0 *= norm.x;
    g1 *= norm.y;
    g2 *= norm.z;
    g3 *= norm.w;

    // Mix the corner contributions.
    var m = max(0.5 - vec4<f32>(dot(x0, x0), dot(x1, x1), dot(x2, x2), dot(x3, x3)), vec4<f32>(0.0));
    m = m * m;
    return 105.0 * dot(m * m, vec4<f32>(dot(g0, x0), dot(g1, x1), dot(g2, x2), dot(g3, x3)));
}

fn turbulence3(p: vec3<f32>) -> f32 {
    return turbulence3_octaves(p, 5);
}

// The same over the first `octaves` octaves (fewer: coarser and cheaper).
fn turbulence3_octaves(p: vec3<f32>, octaves: i32) -> f32 {
    var sum = 0.0;
    var freq = 1.0;
    var amp = 1.0;
    for (var octave = 0; octave < octaves; octave++) {
        // Each octave is shifted by its own offset: unshifted, all octaves vanish together at
        // the origin and the pattern forms concentric rings around it.
        let shift = vec3<f32>(5.17, 1.31, 7.73) * f32(octave + 1);
        sum += amp * abs(snoise3(p * freq + shift));
        freq *= 2.0;
        amp *= 0.5;
    }
    return sum;
}
