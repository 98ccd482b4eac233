// requires: fullscreen.wgsl
//
// Separable subsurface scattering: one direction of the blur (the pass runs twice, horizontal
// then vertical), after Jimenez et al. 2015. It blurs the scene pass's diffuse light only; the
// composite adds the specular afterwards, so highlights stay sharp.
//
// Inputs (all the crop's size, premultiplied by coverage = diffuse.a):
//   colour_tex  diffuse radiance (linear), a = coverage
//   depth_tex   r = view depth normalised over [near, near + range], g = scattering mask
// Per pixel: the step between taps is the blur radius (mm) turned into pixels at that pixel's
// depth, times its mask; pixels without scattering material (gold, background) are copied.
// "Follow surface": a tap on another surface (depth differing by more than about the radius,
// or rising across a wall), on gold or on the background is replaced by the centre colour, so
// light does not leak across silhouettes, over the relief's cut outline or from the bezel into
// the stone.

const MAX_TAPS: u32 = 65u;
// The depth's rise over the stone (mm per mm) from which a tap counts as across a wall: the
// relief's compressed slopes stay under it nearly everywhere, its cut outline (near vertical)
// far over (2 already kept a faint halo of the agate's white on its dark ground).
const WALL_SLOPE: f32 = 1.0;

struct Sss {
    // x: blur radius (mm), y: pixels per mm at 1 mm depth (half the image height over
    // tan(fov_y / 2)), z: near depth (mm), w: depth range (mm).
    params: vec4<f32>,
    // xy: direction ((1, 0) or (0, 1)), z: number of taps, w: kernel range R (kernel units).
    dir: vec4<f32>,
    // rgb: weight, w: offset in kernel units; the centre tap first.
    kernel: array<vec4<f32>, MAX_TAPS>,
}

@group(0) @binding(0) var<uniform> sss: Sss;
@group(0) @binding(1) var colour_tex: texture_2d<f32>;
@group(0) @binding(2) var depth_tex: texture_2d<f32>;
@group(0) @binding(3) var linear_clamp: sampler;

// Depth (mm) and mask of a depth_tex texel, un-premultiplied by the texel's coverage.
fn depth_mask_at(texel: vec2<i32>) -> vec3<f32> {
    let coverage = textureLoad(colour_tex, texel, 0).a;
    let dm = textureLoad(depth_tex, texel, 0).rg;
    if coverage <= 0.0 {
        return vec3<f32>(0.0, 0.0, 0.0);
    }
    let depth = sss.params.z + sss.params.w * dm.r / coverage;
    return vec3<f32>(depth, clamp(dm.g / coverage, 0.0, 1.0), coverage);
}

// The blurred value of the pixel `texel` (centre `pos`, pixels).
fn sss_at(texel: vec2<i32>, pos: vec2<f32>) -> vec4<f32> {
    let centre = textureLoad(colour_tex, texel, 0);
    let here = depth_mask_at(texel);
    let mask = here.y;
    if mask <= 0.0 || here.x <= 0.0 || sss.params.x <= 0.0 {
        return centre;
    }
    let size = vec2<f32>(textureDimensions(colour_tex));
    let colour = centre.rgb / centre.a;
    // Pixels per kernel unit along the direction.
    let px_per_unit = sss.params.x / sss.dir.w * sss.params.y / here.x * mask;
    let step = sss.dir.xy * px_per_unit;
    var blurred = colour * sss.kernel[0].rgb;
    let taps = min(u32(sss.dir.z), MAX_TAPS);
    for (var i = 1u; i < taps; i = i + 1u) {
        let tap = sss.kernel[i];
        let p = pos + tap.w * step;
        let s = textureSampleLevel(colour_tex, linear_clamp, p / size, 0.0);
        var sample = colour;
        if s.a > 0.0 {
            let there = depth_mask_at(vec2<i32>(clamp(p, vec2<f32>(0.0), size - vec2<f32>(1.0))));
            let rise = abs(there.x - here.x);
            let other = clamp(rise / sss.params.x, 0.0, 1.0);
            // Across a wall: depth rising faster than a carved slope over the tap's own
            // offset (mm) is another face of the stone, whose light does not bleed over the
            // cut edge (the relief's outline stays crisp).
            let offset_mm = abs(tap.w) * sss.params.x / sss.dir.w * mask;
            let wall = smoothstep(WALL_SLOPE, 2.0 * WALL_SLOPE, rise / max(offset_mm, 1e-4));
            let away = max(max(other, wall), 1.0 - there.y * there.z);
            sample = mix(s.rgb / s.a, colour, away);
        }
        blurred += tap.rgb * sample;
    }
    return vec4<f32>(blurred * centre.a, centre.a);
}

@fragment
fn fs_main(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    return sss_at(vec2<i32>(pos.xy), pos.xy);
}

// The same blur as a compute pass (one invocation a pixel, 8 x 8 a workgroup), writing
// `sss_out_tex`: on GPUs whose graphics units are few (data-centre chips) a full-screen
// fragment pass runs far slower than the same work in a compute shader.
@group(0) @binding(4) var sss_out_tex: texture_storage_2d<rgba16float, write>;

@compute @workgroup_size(8, 8)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(colour_tex);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    // The pixel's centre, as the fragment stage's position gives it.
    textureStore(sss_out_tex, vec2<i32>(id.xy), sss_at(vec2<i32>(id.xy), vec2<f32>(id.xy) + 0.5));
}
