// requires: fullscreen.wgsl
//
// Composite pass: diffuse + specular (both linear, premultiplied by coverage) over a soft studio
// backdrop, a gentle highlight shoulder, sRGB encoding and a 1/255 ordered dither (so the dark
// backdrop gradient does not band in 8 bits). The output target is Rgba8Unorm and this shader
// encodes; a subsurface-scattering pass slots in by binding its blurred diffuse at binding 1.
//
// Everything is read with textureLoad (no sampler), one texel per output pixel. The inputs cover
// only the crop (the part of the frame the gem is in, placed by `crop`); outside it there is
// nothing but backdrop.

struct Composite {
    // rgb: backdrop colour (linear) at the centre; a: unused.
    background: vec4<f32>,
    // x: exposure, y: vignette strength, z: vertical gradient strength, w: dither amplitude
    // (in 8-bit steps).
    params: vec4<f32>,
    // xy: the inputs' top left in the frame, zw: their size (pixels).
    crop: vec4<f32>,
    // xy: the frame's size (pixels).
    size: vec4<f32>,
}

@group(0) @binding(0) var<uniform> comp: Composite;

// No backdrop: the output's alpha is the gem's coverage and its colour unpremultiplied. A
// pipeline constant, not a uniform: with a runtime branch here the kiosk's memory grew on
// llvmpipe (20 % over a 24 s soak; flat as a constant).
override TRANSPARENT: bool = false;
@group(0) @binding(1) var diffuse_tex: texture_2d<f32>;
@group(0) @binding(2) var specular_tex: texture_2d<f32>;

fn linear_to_srgb(c: vec3<f32>) -> vec3<f32> {
    let lo = c * 12.92;
    let hi = 1.055 * pow(c, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(hi, lo, c <= vec3<f32>(0.0031308));
}

// Identity below the knee, then an exponential shoulder that reaches 1 asymptotically with
// matching slope: mid-tones stay exactly as lit, only highlights above the knee are compressed.
fn shoulder(x: vec3<f32>) -> vec3<f32> {
    let knee = 0.8;
    let span = 1.0 - knee;
    let over = max(x - vec3<f32>(knee), vec3<f32>(0.0));
    let compressed = vec3<f32>(knee) + span * (vec3<f32>(1.0) - exp(-over / span));
    return select(x, compressed, x > vec3<f32>(knee));
}

// Interleaved gradient noise (Jimenez 2014): a fixed pattern, so output is deterministic.
fn dither(p: vec2<f32>) -> f32 {
    return fract(52.9829189 * fract(dot(p, vec2<f32>(0.06711056, 0.00583715)))) - 0.5;
}

// The output pixel whose centre is `pos` (frame pixels).
fn composite_at(pos: vec2<f32>) -> vec4<f32> {
    let size = comp.size.xy;
    let local = pos - comp.crop.xy;
    var diffuse = vec4<f32>(0.0);
    var specular = vec4<f32>(0.0);
    if all(local >= vec2<f32>(0.0)) && all(local < comp.crop.zw) {
        let texel = vec2<i32>(local);
        diffuse = textureLoad(diffuse_tex, texel, 0);
        specular = textureLoad(specular_tex, texel, 0);
    }
    let coverage = clamp(diffuse.a, 0.0, 1.0);

    // Backdrop: lighter towards the top, darker towards the corners, as under a gallery spot.
    let uv = pos / size;
    let aspect = size.x / max(size.y, 1.0);
    let gradient = 1.0 + comp.params.z * (0.5 - uv.y);
    let centred = (uv - vec2<f32>(0.5, 0.45)) * vec2<f32>(aspect, 1.0);
    let vignette = 1.0 - comp.params.y * smoothstep(0.25, 0.95, length(centred));
    let backdrop = comp.background.rgb * gradient * vignette;

    if TRANSPARENT {
        if coverage <= 0.0 {
            return vec4<f32>(0.0);
        }
        let own = (diffuse.rgb + specular.rgb) * comp.params.x / coverage;
        let straight = linear_to_srgb(shoulder(max(own, vec3<f32>(0.0))));
        return vec4<f32>(clamp(straight, vec3<f32>(0.0), vec3<f32>(1.0)), coverage);
    }
    let radiance = (diffuse.rgb + specular.rgb) * comp.params.x + (1.0 - coverage) * backdrop;
    let encoded = linear_to_srgb(shoulder(max(radiance, vec3<f32>(0.0))));
    let noisy = encoded + vec3<f32>(dither(pos) * comp.params.w / 255.0);
    return vec4<f32>(clamp(noisy, vec3<f32>(0.0), vec3<f32>(1.0)), 1.0);
}

@fragment
fn fs_main(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    return composite_at(pos.xy);
}

// The same as a compute pass (8 x 8 pixels a workgroup) writing the output image: on GPUs with
// few graphics units a full-screen fragment pass is many times slower than this.
@group(0) @binding(3) var out_tex: texture_storage_2d<rgba8unorm, write>;

@compute @workgroup_size(8, 8)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<u32>(comp.size.xy);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    textureStore(out_tex, vec2<i32>(id.xy), composite_at(vec2<f32>(id.xy) + 0.5));
}
