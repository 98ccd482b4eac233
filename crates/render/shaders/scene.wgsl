// requires: stones.wgsl, baked_noise.wgsl
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
    // x: near depth (mm), y: 1 / (far - near) (1/mm), z: the translucency (0 without the
    // scattering).
    depth: vec4<f32>,
    // x: material (0 marble, 1 a layered stone), y: the hair cut from its top layer (1 on).
    material: vec4<u32>,
    // The engraving's planar frame: centre x, y and half extents x, y (mm) of the mesh's box.
    planar: vec4<f32>,
    // x: engraving on (1), y: groove depth (mm), z-w: the band's insets with a margin (mm).
    engraving: vec4<f32>,
    // xyz: lamp position (mm), w: its intensity at the gem's centre (0: no lamp).
    lamp: vec4<f32>,
    // x: shadow far plane (mm), y: depth bias (mm), z: PCF radius (mm), w: lamp-centre distance.
    shadow: vec4<f32>,
    // The baked noise's volume: xyz centre of voxel (0, 0, 0) (mm), w 1 / voxel size (1/mm);
    // and xyz 1 / its voxel counts.
    volume: vec4<f32>,
    volume_texel: vec4<f32>,
    // A layered stone (glyptic-core's `Layers::uniforms`): ground rgb + mottling, white rgb +
    // veil thickness (mm), top rgb + bands, veil tint rgb + grain, polish (Phong exponent,
    // highlight, reflection, scattering share).
    layers: array<vec4<f32>, 5>,
    // The pass's compute form (`scene_shade.wgsl`): the inverse of `view_proj` (a pixel's
    // view ray), and x the engraved band's first triangle, yz the images' size (pixels), w the
    // most triangles a pixel is shaded with.
    inv_view_proj: mat4x4<f32>,
    shade: vec4<u32>,
}

@group(0) @binding(0) var<uniform> frame: Frame;

// Which surface effects this pipeline has compiled in (gpu.rs `SceneVariant`): on a CPU
// rasteriser even an untaken branch costs, so the plain pipeline leaves them out.
override ENGRAVING: bool = false;
override LAMP: bool = false;
// Whether the slowly varying noise comes from the baked volume (group 1, binding 5) or is
// computed here: the renderer bakes it only for a mesh drawn twice, so a single frame (a
// photo) does not pay for a bake it cannot amortise.
override BAKED_NOISE: bool = false;

// Group 1, surface detail: the engraving's height (r: 1 the ground, 0 a groove's bottom) and
// tangent-space normal maps over the planar frame, the lamp's shadow cube (distance to the
// lamp over the far plane), and the slowly varying noise baked over the mesh (`noise_baked`,
// read with the engraving's clamped linear sampler).
@group(1) @binding(0) var engraving_height: texture_2d<f32>;
@group(1) @binding(1) var engraving_normal: texture_2d<f32>;
@group(1) @binding(2) var engraving_sampler: sampler;
@group(1) @binding(3) var shadow_cube: texture_depth_cube;
@group(1) @binding(4) var shadow_sampler: sampler_comparison;
@group(1) @binding(5) var noise_volume: texture_3d<f32>;

struct VsIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) relief: f32,
    @location(3) region: u32,
    @location(4) hair: f32,
    // Tangent along +u (planar frame) and handedness; w = 0: no usable frame here.
    @location(5) tangent: vec4<f32>,
    // Ambient light reaching the point (the relief's cavity term), 0..1.
    @location(6) occlusion: f32,
    // How much of the key light reaches the point (the relief's cast shadows), 0..1.
    @location(7) key_light: f32,
    // How much of it reaches the point through the stone where the relief shadows it, 0..1.
    @location(8) transmit: f32,
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
    @location(5) tangent: vec4<f32>,
    @location(6) occlusion: f32,
    @location(7) key_light: f32,
    @location(8) transmit: f32,
}

const REGION_GOLD: u32 = 3u;
// The colour of light that has travelled a millimetre or two through the stone.
const GLOW_TINT: vec3<f32> = vec3<f32>(1.0, 0.82, 0.66);

@vertex
fn vs_main(in: VsIn) -> VsOut {
    return vertex_out(in);
}

// A vertex's varyings (the compute form interpolates the same).
fn vertex_out(in: VsIn) -> VsOut {
    var out: VsOut;
    out.clip = frame.view_proj * vec4<f32>(in.position, 1.0);
    out.world = in.position;
    out.normal = in.normal;
    out.relief = in.relief;
    out.hair = clamp(in.hair, 0.0, 1.0);
    out.gold = select(0.0, 1.0, in.region == REGION_GOLD);
    out.tangent = in.tangent;
    out.occlusion = clamp(in.occlusion, 0.0, 1.0);
    out.key_light = clamp(in.key_light, 0.0, 1.0);
    out.transmit = clamp(in.transmit, 0.0, 1.0);
    return out;
}

struct FsOut {
    @location(0) diffuse: vec4<f32>,
    @location(1) specular: vec4<f32>,
    @location(2) depth_mask: vec2<f32>,
}

// The baked noise at `p` (mm): trilinear between voxel centres, clamped at the box.
fn baked_noise(p: vec3<f32>) -> vec4<f32> {
    let t = ((p - frame.volume.xyz) * frame.volume.w + 0.5) * frame.volume_texel.xyz;
    return textureSampleLevel(noise_volume, engraving_sampler, t, 0.0);
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

// Statuary marble: a warm white body with a faint cloud, and soft grey veins that run roughly
// one way, about 17 mm apart, wandering without closing into rings. A vein is a thin core in
// a feathered halo (its edge roughened by fine noise, as veins bleed into the stone), fades
// in and out along its length, and sends shorter, fainter branches off at an angle. Their
// contrast stays well below the relief's own shading under the raking key light, so the
// carving, not the stone, is what the eye reads. `frame.marble.x` (softness, 0..1) widens the
// veins; `frame.marble.y` (lightness, 0..1) fades them and the cloud (1: a plain white stone).
fn marble_albedo(p: vec3<f32>) -> vec3<f32> {
    let softness = clamp(frame.marble.x, 0.0, 1.0);
    let lightness = clamp(frame.marble.y, 0.0, 1.0);
    // Texture space: frame.marble.z per mm (1/75: a few veins across a 44 x 56 mm stone).
    let uv = p * frame.marble.z;
    let dir = normalize(vec3<f32>(0.82, -0.5, 0.28));
    // Three octaves: the veins' course; the fine noise below roughens their edges.
    let warp = 1.1 * turbulence3_octaves(uv * 2.625, 3);
    // Distance to the nearest vein's middle, in spacings (1 is about 17 mm), its edge
    // roughened at about 1.5 mm.
    let rough = snoise3(uv * 50.0 + vec3<f32>(3.1, 7.9, 1.3));
    let w1 = dot(uv, dir) * 4.5 + warp;
    let d1 = abs(fract(w1 + 0.5) - 0.5) * (1.0 + 0.35 * rough);
    let core = mix(0.012, 0.03, softness);
    let halo = mix(0.05, 0.12, softness);
    let c1 = d1 / core;
    let h1 = d1 / halo;
    let v1 = 0.6 * exp(-c1 * c1) + 0.4 * exp(-h1 * h1);
    // Veins thin out and stop, and branches come and go: one slow noise sets both.
    let course = snoise3(uv * 3.0 + vec3<f32>(11.0, 5.0, 2.0));
    let along = smoothstep(-0.45, 0.35, course);
    let w2 = dot(uv, normalize(vec3<f32>(0.3, 0.9, 0.3))) * 9.0 + 1.3 * warp + 0.5;
    let d2 = abs(fract(w2 + 0.5) - 0.5) * (1.0 + 0.35 * rough);
    let h2 = d2 / (0.8 * halo);
    let v2 = exp(-h2 * h2) * smoothstep(0.05, 0.55, course);
    let vein = (1.0 - lightness) * (0.11 * v1 * along + 0.045 * v2);
    var cloud_noise: f32;
    if BAKED_NOISE {
        cloud_noise = baked_noise(p).r;
    } else {
        cloud_noise = marble_cloud(uv);
    }
    let cloud = (1.0 - lightness) * cloud_noise;
    let grey = MARBLE_GREY * (1.0 - vein) * (1.0 + cloud);
    // The veins are a cool grey in the warm body.
    let cool = vec3<f32>(1.0 - 0.25 * vein, 1.0, 1.0 + 0.3 * vein);
    return srgb_to_linear(grey * MARBLE_TINT * cool);
}

// A layered stone (agate, shell, jasperware; their values come from glyptic-core's `stone`
// module through `frame.layers`): a ground layer, a white layer carved into the relief whose
// opacity grows with its thickness (the relief's height above the ground), so the ground shows
// through wherever the cutter left the white thin (every edge of the relief, the wall's foot,
// a lock's tip), tinted there by the veil; shell's growth bands across the ground; the hair
// cut from the top layer where the stone has one.
fn layered_albedo(p: vec3<f32>, relief: f32, hair: f32) -> vec3<f32> {
    let mottle = frame.layers[0].w;
    let veil_mm = frame.layers[1].w;
    let bands = frame.layers[2].w;
    let grain = frame.layers[3].w;
    let ground_noise = snoise3(p * vec3<f32>(0.09, 0.09, 0.3)) * 0.6 + snoise3(p * 0.35) * 0.4;
    var ground = frame.layers[0].rgb * (1.0 - 0.5 * mottle + mottle * ground_noise);
    if bands > 0.0 {
        // A shell's growth lines: gently curved bands about 2.6 mm apart, fading in and out.
        let fade = 0.5 + 0.5 * snoise3(p * vec3<f32>(0.05, 0.2, 0.2) + vec3<f32>(7.0));
        ground *= 1.0 + bands * fade * sin(2.4 * p.y + 0.35 * p.x + 2.0 * snoise3(p * 0.06));
    }
    // The layer boundary is not a perfect plane in a real stone: wobble it a little.
    let wobble = 0.12 * snoise3(p * 0.7);
    let thickness = max(relief + wobble * min(relief, 1.0), 0.0);
    let white_w = 1.0 - exp(-thickness / veil_mm);
    let white = frame.layers[1].rgb * (1.0 - grain + grain * snoise3(p * 0.5));
    var col = mix(ground, white, white_w) + 4.0 * white_w * (1.0 - white_w) * frame.layers[3].rgb;
    if frame.material.y == 0u {
        return col;
    }
    // Hair: the top layer lies over the white, so a thin white edge shows where it starts.
    let strands = snoise3(p * vec3<f32>(0.5, 0.5, 1.6));
    let top = frame.layers[2].rgb * (0.75 + 0.4 * strands);
    // The per-vertex region border follows the triangles; a wide, noisy threshold turns it into
    // a soft, irregular layer edge instead of a saw-tooth.
    // (Noise amplitude below the smoothstep's margins: inside either region the weight stays
    // exactly 0 or 1.)
    let hair_edge = smoothstep(0.15, 0.85, hair + 0.12 * snoise3(p * 0.45));
    let hair_w = hair_edge * smoothstep(0.6, 1.8, relief);
    return mix(col, top, hair_w);
}

// Distance inside the planar frame's ellipse (the gem's outline), mm, to first order: as
// `engraving_heights` in surface.rs measures the band.
fn inset_mm(p: vec3<f32>) -> f32 {
    let ab = frame.planar.zw;
    let q = (p.xy - frame.planar.xy) / ab;
    let rho = length(q);
    let grad = length(q / ab) / max(rho, 1e-6);
    return (1.0 - rho) / max(grad, 1e-6);
}

fn engraving_depth(uv: vec2<f32>, dx: vec2<f32>, dy: vec2<f32>) -> f32 {
    return 1.0 - textureSampleGrad(engraving_height, engraving_sampler, uv, dx, dy).r;
}

// Parallax occlusion mapping (the seed's: step along the view ray through depth layers until
// it passes under the height map, then interpolate between the last two steps). `view_ts` is
// the unit direction to the eye in the tangent frame (x along +u, y along +v); the result is
// the texture coordinate the eye sees.
fn parallax(uv: vec2<f32>, view_ts: vec3<f32>, dx: vec2<f32>, dy: vec2<f32>) -> vec2<f32> {
    let layers = mix(32.0, 8.0, abs(view_ts.z));
    let layer_depth = 1.0 / layers;
    // The whole groove depth's shift, mm along the tangent frame, as texture coordinates.
    let shift_mm = view_ts.xy / max(view_ts.z, 0.05) * frame.engraving.y;
    let delta = shift_mm / (2.0 * frame.planar.zw) / layers;
    var cur_uv = uv;
    var cur_layer = 0.0;
    var cur_depth = engraving_depth(cur_uv, dx, dy);
    for (var i = 0; i < 32; i = i + 1) {
        if cur_layer >= cur_depth {
            break;
        }
        cur_uv = cur_uv - delta;
        cur_depth = engraving_depth(cur_uv, dx, dy);
        cur_layer = cur_layer + layer_depth;
    }
    let prev_uv = cur_uv + delta;
    let after = cur_depth - cur_layer;
    let before = engraving_depth(prev_uv, dx, dy) - cur_layer + layer_depth;
    let weight = after / min(after - before, -1e-6);
    return mix(cur_uv, prev_uv, clamp(weight, 0.0, 1.0));
}

// How much of the lamp reaches `p` (0 in shadow, 1 lit): the shadow cube compared at nine
// points across the direction (percentage-closer filtering), with a bias that grows at grazing
// angles (`ndl`, the lamp's cosine there).
fn lamp_visibility(p: vec3<f32>, ndl: f32) -> f32 {
    let to_p = p - frame.lamp.xyz;
    let dist = length(to_p);
    let dir = to_p / max(dist, 1e-6);
    let bias = frame.shadow.y * (1.0 + 3.0 * (1.0 - ndl));
    let reference = (dist - bias) / frame.shadow.x;
    let helper = select(vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(1.0, 0.0, 0.0), abs(dir.y) > 0.9);
    let s = normalize(cross(dir, helper));
    let t = cross(dir, s);
    var lit = textureSampleCompareLevel(shadow_cube, shadow_sampler, to_p, reference);
    for (var k = 0; k < 8; k = k + 1) {
        let a = f32(k) * 0.7853982;
        let o = (s * cos(a) + t * sin(a)) * frame.shadow.z;
        lit = lit + textureSampleCompareLevel(shadow_cube, shadow_sampler, to_p + o, reference);
    }
    return lit / 9.0;
}

// The fill light's strength (from the camera's side): FILL_LIGHT, from glyptic_core::scene
// (stones.wgsl).

@fragment
fn fs_main(in: VsOut) -> FsOut {
    // The screen derivatives, taken here in uniform control flow; the pipeline with the
    // engraving draws the band's triangles alone.
    return shade(in, dpdx(in.world), dpdy(in.world), true);
}

// The light leaving the surface point `in` (its varyings at a pixel's centre), whose position
// changes by `world_dx`, `world_dy` (mm) to the next pixel right and down; `band`: whether it
// lies on the engraved band's triangles.
fn shade(in: VsOut, world_dx: vec3<f32>, world_dy: vec3<f32>, band: bool) -> FsOut {
    // With MSAA a pixel on a triangle's edge is shaded once, at its centre, which may lie
    // outside the triangle: the varyings are extrapolated there, past the vertices' range.
    // A negative occlusion or key light made the light negative, and the pixel black once
    // resolved (isolated dead pixels, issue #40); so each weight is held to its range here.
    let relief = max(in.relief, 0.0);
    let hair = clamp(in.hair, 0.0, 1.0);
    let gold = clamp(in.gold, 0.0, 1.0);
    let in_occlusion = clamp(in.occlusion, 0.0, 1.0);
    let key_light = clamp(in.key_light, 0.0, 1.0);
    let transmit = clamp(in.transmit, 0.0, 1.0);
    let v = normalize(frame.eye.xyz - in.world);
    // The mesh normal, or the facet normal where the data gives none; flipped towards the
    // viewer, so the lighting does not depend on the triangles' winding.
    let facet = cross(world_dx, world_dy);
    var n = in.normal;
    if dot(n, n) < 1e-12 {
        n = facet;
    }
    n = normalize(n);
    var flipped = false;
    if dot(n, v) < 0.0 {
        n = -n;
        flipped = true;
    }
    // The planar texture coordinates and their screen derivatives (for the mip level of the
    // engraving's maps).
    let uv_scale = vec2<f32>(0.5, -0.5) / frame.planar.zw;
    let uv = (in.world.xy - frame.planar.xy) * uv_scale + vec2<f32>(0.5);
    let uv_dx = world_dx.xy * uv_scale;
    let uv_dy = world_dy.xy * uv_scale;

    // The engraved border: on the stone's ground only (the portrait cuts through it), where the
    // vertex has a tangent frame, and within the band (elsewhere the map is flat anyway).
    var p = in.world;
    var occlusion = 1.0;
    let ground_w = 1.0 - smoothstep(0.02, 0.08, relief);
    let inset = inset_mm(in.world);
    if ENGRAVING && band && frame.engraving.x > 0.5 && gold < 0.5 && ground_w > 0.0 && !flipped
        && abs(in.tangent.w) > 0.5 && inset > frame.engraving.z && inset < frame.engraving.w {
        let t_raw = in.tangent.xyz - n * dot(n, in.tangent.xyz);
        if dot(t_raw, t_raw) > 1e-8 {
            let t = normalize(t_raw);
            let b = cross(n, t) * sign(in.tangent.w);
            let view_ts = vec3<f32>(dot(v, t), dot(v, b), dot(v, n));
            let seen = parallax(uv, view_ts, uv_dx, uv_dy);
            let depth = engraving_depth(seen, uv_dx, uv_dy);
            let nm = textureSampleGrad(engraving_normal, engraving_sampler, seen, uv_dx, uv_dy).xyz * 2.0 - 1.0;
            let mapped = normalize(t * nm.x + b * nm.y + n * nm.z);
            n = normalize(mix(n, mapped, ground_w));
            // The point seen, for the procedural stone: moved along the ground and down into
            // the groove.
            let shift_mm = (seen - uv) * 2.0 * frame.planar.zw;
            p = in.world + ground_w * (t * shift_mm.x + b * shift_mm.y - n * depth * frame.engraving.y);
            // Grooves hold shadow: the ambient and diffuse light reaching a groove's bottom.
            occlusion = 1.0 - ground_w * 0.45 * depth;
        }
    }

    let l = frame.light_dir.xyz;
    // Sky light from the room in front of the stone, and a soft fill from the camera's side so
    // slopes turned from the key never go black; both dimmed in hollows and at the foot of
    // walls (the relief's cavity term).
    let cavity = in_occlusion * occlusion;
    let ambient = frame.marble.w * cavity * (0.55 + 0.45 * max(n.z, 0.0))
        + FILL_LIGHT * cavity * max(dot(n, v), 0.0);
    let ndl = max(dot(n, l), 0.0);
    // The key light (fixed to the stone, raking; the relief's cast shadows come with the
    // vertices), and the lamp where it has one (falling off with the square of the distance,
    // 1 at the gem's centre, and shadowed).
    var light = frame.light_dir.w * occlusion * key_light;
    var lamp = 0.0;
    var lamp_l = vec3<f32>(0.0, 0.0, 1.0);
    if LAMP && frame.lamp.w > 0.0 {
        let to_lamp = frame.lamp.xyz - in.world;
        let dist = length(to_lamp);
        lamp_l = to_lamp / max(dist, 1e-6);
        let cos_l = max(dot(n, lamp_l), 0.0);
        let falloff = pow(frame.shadow.w / max(dist, 1e-3), 2.0);
        if cos_l > 0.0 {
            lamp = frame.lamp.w * falloff * occlusion * lamp_visibility(in.world, cos_l);
        }
    }
    let ndl_lamp = max(dot(n, lamp_l), 0.0);
    let lit = ambient + ndl * light + ndl_lamp * lamp;
    // The key light that came through a thin part (an ear's rim, a lock) leaves it on every
    // side, whatever the normal, warmer than it came in (red travels furthest in stone).
    let glow = frame.depth.z * frame.light_dir.w * transmit * GLOW_TINT;

    var diffuse: vec3<f32>;
    var specular = vec3<f32>(0.0);
    var sss = 1.0;
    if gold > 0.5 {
        // Polished gold: little diffuse, a coloured mirror of the studio plus a key highlight,
        // its normal rippled faintly (`gold_ripple`, baked).
        var ripple: vec3<f32>;
        if BAKED_NOISE {
            ripple = baked_noise(in.world).gba;
        } else {
            ripple = gold_ripple(in.world);
        }
        n = normalize(n + 0.035 * ripple);
        let r = reflect(-v, n);
        diffuse = GOLD_F0 * 0.12 * (ambient + max(dot(n, l), 0.0) * light + max(dot(n, lamp_l), 0.0) * lamp);
        let ndv = max(dot(n, v), 0.0);
        let fresnel = GOLD_F0 + (1.0 - GOLD_F0) * pow(1.0 - ndv, 5.0);
        let h = normalize(l + v);
        let h_lamp = normalize(lamp_l + v);
        let highlight = (pow(max(dot(n, h), 0.0), GOLD_BLINN) * light
            + pow(max(dot(n, h_lamp), 0.0), GOLD_BLINN) * lamp) * 3.0;
        specular = fresnel * (0.8 * environment(r) * in_occlusion + highlight);
        sss = 0.0;
    } else if frame.material.x == 0u {
        diffuse = marble_albedo(p) * (lit + glow);
        // Polished marble: a faint, sharp highlight and a weak Fresnel reflection of the
        // studio (kept out of the scattering pass, so they stay sharp).
        let h = normalize(l + v);
        let ndv = max(dot(n, v), 0.0);
        let fresnel = 0.04 + 0.96 * pow(1.0 - ndv, 5.0);
        specular = vec3<f32>(0.12 * pow(max(dot(n, h), 0.0), MARBLE_BLINN) * light)
            + 0.35 * fresnel * environment(reflect(-v, n));
    } else {
        diffuse = layered_albedo(p, relief, hair) * (lit + glow);
        // Phong with the stone's exponent (agate's 500, as in 2021), plus a Fresnel reflection
        // of the studio for the polish, and the stone's share of the scattering.
        let polish = frame.layers[4];
        let r = reflect(-v, n);
        let phong = (pow(max(dot(r, l), 0.0), polish.x) * light
            + pow(max(dot(r, lamp_l), 0.0), polish.x) * lamp) * polish.y;
        let ndv = max(dot(n, v), 0.0);
        let fresnel = 0.04 + 0.96 * pow(1.0 - ndv, 5.0);
        specular = vec3<f32>(phong) + polish.z * fresnel * environment(r);
        sss = polish.w;
    }

    let view_depth = dot(in.world - frame.eye.xyz, frame.cam_fwd.xyz);
    let depth01 = clamp((view_depth - frame.depth.x) * frame.depth.y, 0.0, 1.0);

    var out: FsOut;
    out.diffuse = vec4<f32>(diffuse, 1.0);
    out.specular = vec4<f32>(specular, 1.0);
    out.depth_mask = vec2<f32>(depth01, sss);
    return out;
}
