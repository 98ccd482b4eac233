// requires: noise.wgsl
//
// Scene pass: draws the gem and writes, per pixel (all premultiplied by coverage, cleared to 0):
//   location 0  diffuse    rgb = diffuse radiance (linear), a = 1 (coverage after MSAA resolve)
//   location 1  specular   rgb = specular radiance (linear), a = 1
//   location 2  depth_mask r = linear view depth normalised to [0, 1] over frame.depth,
//                          g = subsurface-scattering strength (1 stone, 0 gold)
// Diffuse and specular are kept apart so a subsurface-scattering pass can blur the diffuse light
// alone and the composite pass adds the specular afterwards (the 2021 lesson: blurring the
// highlights made the stone look hazy).
//
// Units are millimetres in object (= world) space. Procedural textures are evaluated at the
// object-space position, so they run continuously across every part of the mesh. The 2021
// colours are display (sRGB) values and are decoded to linear albedo here.

struct Frame {
    view_proj: mat4x4<f32>,
    // xyz: camera position (mm).
    eye: vec4<f32>,
    // xyz: unit vector towards the light; w: light intensity.
    light_dir: vec4<f32>,
    // Camera basis (world space), used for the reflected environment.
    cam_right: vec4<f32>,
    cam_up: vec4<f32>,
    cam_fwd: vec4<f32>,
    // x: vein softness [0, 1], y: vein lightness [0, 1], z: texture scale (1/mm), w: ambient.
    marble: vec4<f32>,
    // x: near depth (mm), y: 1 / (far - near) (1/mm).
    depth: vec4<f32>,
    // x: material (0 marble, 1 agate).
    material: vec4<u32>,
}

@group(0) @binding(0) var<uniform> frame: Frame;

struct VsIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) relief: f32,
    @location(3) region: u32,
    @location(4) hair: f32,
}

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) relief: f32,
    // Region weights are interpolated (not flat) so that region borders run smoothly through
    // triangles instead of following their edges.
    @location(3) hair: f32,
    @location(4) gold: f32,
}

const REGION_GOLD: u32 = 3u;

@vertex
fn vs_main(in: VsIn) -> VsOut {
    var out: VsOut;
    out.clip = frame.view_proj * vec4<f32>(in.position, 1.0);
    out.world = in.position;
    out.normal = in.normal;
    out.relief = in.relief;
    out.hair = clamp(in.hair, 0.0, 1.0);
    out.gold = select(0.0, 1.0, in.region == REGION_GOLD);
    return out;
}

struct FsOut {
    @location(0) diffuse: vec4<f32>,
    @location(1) specular: vec4<f32>,
    @location(2) depth_mask: vec2<f32>,
}

fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    let lo = c / 12.92;
    let hi = pow((c + 0.055) / 1.055, vec3<f32>(2.4));
    return select(hi, lo, c <= vec3<f32>(0.04045));
}

// A studio environment for reflections, in the camera's frame so it turns with the view: a
// dim room (lighter above, dark below), a large soft box at the key light and a weaker fill
// strip to the right.
fn environment(r: vec3<f32>) -> vec3<f32> {
    let up = dot(r, frame.cam_up.xyz);
    let room = mix(0.03, 0.35, smoothstep(-0.5, 0.9, up));
    let key = 2.2 * pow(max(dot(r, frame.light_dir.xyz), 0.0), 10.0);
    let fill_dir = normalize(0.8 * frame.cam_right.xyz + 0.1 * frame.cam_up.xyz - 0.6 * frame.cam_fwd.xyz);
    let fill = 0.5 * pow(max(dot(r, fill_dir), 0.0), 6.0);
    return vec3<f32>(room + key + fill);
}

// The 2021 marble: value = 0.95 sin(3 uv.y^2 uv.z 30 + 8 turbulence(3 uv)), colormap
// [-1, 1] -> grey 0.2..0.95 through t^(1/8), t = (value + 1) / 2. That system's gem lay in its
// YZ plane (x was depth), ours lies in XY, so its uv.z is our uv.x: the first term then sweeps
// gently across the face as it did there, giving the veins a direction. Softness raises the floor
// of t before the power (the vein core loses its sharp crease and widens into a soft band);
// lightness lifts the darkest grey towards white. Softness 0 and lightness 0 give the 2021 look.
fn marble_albedo(p: vec3<f32>) -> vec3<f32> {
    let uv = p * frame.marble.z;
    let value = 0.95 * sin(3.0 * uv.y * uv.y * uv.x * 30.0 + 8.0 * turbulence3(3.0 * uv));
    let t = clamp((value + 1.0) * 0.5, 0.0, 1.0);
    let softness = clamp(frame.marble.x, 0.0, 1.0);
    let lightness = clamp(frame.marble.y, 0.0, 1.0);
    let floor_t = 0.25 * softness * softness;
    let shaped = pow((t + floor_t) / (1.0 + floor_t), 1.0 / 8.0);
    let darkest = mix(0.2, 0.95, lightness);
    let grey = mix(darkest, 0.95, shaped);
    // A faint warm cast: white statuary marble is never quite neutral.
    return srgb_to_linear(grey * vec3<f32>(1.0, 0.99, 0.965));
}

// The 2021 agate colours (display values).
const AGATE_RED: vec3<f32> = vec3<f32>(0.0745, 0.0196, 0.0196);
const AGATE_WHITE: vec3<f32> = vec3<f32>(0.6706, 0.6902, 0.6706);
const AGATE_BROWN: vec3<f32> = vec3<f32>(0.2863, 0.1137, 0.0078);
// Display-space gains applied before decoding to linear albedo. The 2021 system lit display
// values directly and its red ground came out a faint, saturated red; decoded as it is, that red
// would be black under linear lighting, and used as linear it turns a muddy maroon. Brightening
// in display space keeps each colour's hue.
const AGATE_RED_GAIN: f32 = 4.0;
const AGATE_WHITE_GAIN: f32 = 1.2;
const AGATE_BROWN_GAIN: f32 = 1.25;
// Height (mm) over which the white layer goes from transparent over the red to opaque.
const AGATE_FADE_MM: f32 = 0.9;

// Layered agate: a dark red ground, a grey-white layer carved into the relief (thin and
// red-tinted near the ground, opaque within AGATE_FADE_MM), and a brown top layer for the hair.
fn agate_albedo(p: vec3<f32>, relief: f32, hair: f32) -> vec3<f32> {
    let ground_noise = snoise3(p * vec3<f32>(0.09, 0.09, 0.3)) * 0.6 + snoise3(p * 0.35) * 0.4;
    let ground = srgb_to_linear(AGATE_RED * AGATE_RED_GAIN) * (0.85 + 0.3 * ground_noise);
    // The layer boundary is not a perfect plane in a real stone: wobble it a little.
    let wobble = 0.25 * snoise3(p * 0.7);
    let white_w = smoothstep(0.0, AGATE_FADE_MM, max(relief, 0.0) + wobble * min(relief, 1.0));
    let white = srgb_to_linear(AGATE_WHITE * AGATE_WHITE_GAIN) * (0.97 + 0.03 * snoise3(p * 0.5));
    var col = mix(ground, white, white_w);
    // Hair: the brown layer lies over the white, so a thin white edge shows where it starts.
    let strands = snoise3(p * vec3<f32>(0.5, 0.5, 1.6));
    let brown = srgb_to_linear(AGATE_BROWN * AGATE_BROWN_GAIN) * (0.75 + 0.4 * strands);
    // The per-vertex region border follows the triangles; a wide, noisy threshold turns it into
    // a soft, irregular layer edge instead of a saw-tooth.
    // (Noise amplitude below the smoothstep's margins: inside either region the weight stays
    // exactly 0 or 1.)
    let hair_edge = smoothstep(0.15, 0.85, hair + 0.12 * snoise3(p * 0.45));
    let hair_w = hair_edge * smoothstep(0.6, 1.8, relief);
    return mix(col, brown, hair_w);
}

// Gold's reflectance at normal incidence (linear).
const GOLD_F0: vec3<f32> = vec3<f32>(1.0, 0.71, 0.29);

@fragment
fn fs_main(in: VsOut) -> FsOut {
    let v = normalize(frame.eye.xyz - in.world);
    // The mesh normal, or the facet normal where the data gives none; flipped towards the
    // viewer, so the lighting does not depend on the triangles' winding.
    let facet = cross(dpdx(in.world), dpdy(in.world));
    var n = in.normal;
    if dot(n, n) < 1e-12 {
        n = facet;
    }
    n = normalize(n);
    if dot(n, v) < 0.0 {
        n = -n;
    }
    let l = frame.light_dir.xyz;
    let light = frame.light_dir.w;
    let ambient = frame.marble.w;
    let ndl = max(dot(n, l), 0.0);

    var diffuse: vec3<f32>;
    var specular = vec3<f32>(0.0);
    var sss = 1.0;
    if in.gold > 0.5 {
        // Polished gold: little diffuse, a coloured mirror of the studio plus a key highlight.
        // A hand-finished surface is never optically flat: a faint low-frequency ripple of the
        // normal keeps large flat parts (the back) from reflecting one uniform tone.
        let q = in.world * 0.15;
        let ripple = vec3<f32>(snoise3(q), snoise3(q + vec3<f32>(17.0, 3.0, 5.0)), snoise3(q - vec3<f32>(7.0, 11.0, 2.0)));
        n = normalize(n + 0.035 * ripple);
        let r = reflect(-v, n);
        diffuse = GOLD_F0 * 0.12 * (ambient + ndl * light);
        let ndv = max(dot(n, v), 0.0);
        let fresnel = GOLD_F0 + (1.0 - GOLD_F0) * pow(1.0 - ndv, 5.0);
        let h = normalize(l + v);
        let highlight = pow(max(dot(n, h), 0.0), 120.0) * 3.0 * light;
        specular = fresnel * (0.8 * environment(r) + highlight);
        sss = 0.0;
    } else if frame.material.x == 0u {
        diffuse = marble_albedo(in.world) * (ambient + ndl * light);
    } else {
        diffuse = agate_albedo(in.world, in.relief, in.hair) * (ambient + ndl * light);
        // Phong, exponent 500 (the 2021 agate), plus a faint Fresnel reflection of the studio
        // for the polish.
        let r = reflect(-v, n);
        let phong = pow(max(dot(r, l), 0.0), 500.0) * 0.9 * light;
        let ndv = max(dot(n, v), 0.0);
        let fresnel = 0.04 + 0.96 * pow(1.0 - ndv, 5.0);
        specular = vec3<f32>(phong) + 0.5 * fresnel * environment(r);
    }

    let view_depth = dot(in.world - frame.eye.xyz, frame.cam_fwd.xyz);
    let depth01 = clamp((view_depth - frame.depth.x) * frame.depth.y, 0.0, 1.0);

    var out: FsOut;
    out.diffuse = vec4<f32>(diffuse, 1.0);
    out.specular = vec4<f32>(specular, 1.0);
    out.depth_mask = vec2<f32>(depth01, sss);
    return out;
}
