//! What the relief bakes for the renderer: the cavity term (ambient occlusion from the relief
//! around a node) and the key light's visibility (cast shadows), per grid node. Gem mm.

use super::window::Window;
use super::{basrelief, template};

/// Radii (gem mm) and weights of the cavity term: how far the relief around a node stands
/// above it, at two scales (a groove's width, a wall's foot).
const CAVITY_SCALES: [(f32, f32); 2] = [(0.35, 0.9), (1.2, 0.45)];

/// Ambient light reaching each node, 0..1: one minus the weighted amount by which the blurred
/// relief stands above the node (a groove, the foot of a wall, the hollow of an ear), at two
/// scales. Ridges and open ground get 1.
pub(super) fn cavity(height: &[f32], cols: usize, rows: usize, cell: f32) -> Vec<f32> {
    let mut occ = vec![1f32; height.len()];
    // Only the relief's bounding box, grown by the widest blur's reach, can be occluded (the
    // blur of the zero ground beyond it is zero either way).
    let Some(window) = Window::of(cols, rows, |i| height[i] > 0.0) else {
        return occ;
    };
    let window = window.grow(
        3 * (CAVITY_SCALES[1].0 / cell).ceil() as usize + 2,
        cols,
        rows,
    );
    let (w, h) = (window.width(), window.height());
    let crop = window.crop(height, cols, |h| h);
    let mut local = vec![1f32; w * h];
    for (radius, weight) in CAVITY_SCALES {
        let blurred = basrelief::blur(&crop, w, h, radius / cell);
        for ((o, b), h) in local.iter_mut().zip(&blurred).zip(&crop) {
            *o = (*o - weight * (b - h).max(0.0)).clamp(0.25, 1.0);
        }
    }
    window.paste(&local, &mut occ, cols);
    occ
}

/// One pass of 1-2-1 smoothing in each direction (edges clamped).
pub(super) fn smooth_121(values: &[f32], cols: usize, rows: usize) -> Vec<f32> {
    pass_121(&pass_121(values, cols, rows, true), cols, rows, false)
}

/// One 1-2-1 pass along the rows (`along_x`) or the columns, the edge's node standing in for
/// its missing neighbour.
fn pass_121(values: &[f32], cols: usize, rows: usize, along_x: bool) -> Vec<f32> {
    let mut out = vec![0f32; values.len()];
    for y in 0..rows {
        for x in 0..cols {
            let (i, len, step) = if along_x {
                (x, cols, 1)
            } else {
                (y, rows, cols)
            };
            let k = y * cols + x;
            let before = if i > 0 { k - step } else { k };
            let after = if i + 1 < len { k + step } else { k };
            out[k] = 0.25 * values[before] + 0.5 * values[k] + 0.25 * values[after];
        }
    }
    out
}

/// Softness of the cast shadows' edge, gem mm of height.
pub(super) const SHADOW_SOFTNESS_MM: f32 = 0.15;

/// A penumbra for [`light_visibility`]'s result: smoothed twice 1-2-1 each way (about a cell
/// and a half, 0.3 mm), as a lamp of some size casts it. The sweep's edge is decided node by
/// node, and the renderer interpolates it linearly across the grid's triangles: a sharp edge
/// running slantwise across the grid shows every cell as a stair-step at large output sizes
/// (seen at 1536x1920 along the hair's shadow on the face).
pub(super) fn penumbra(visibility: &[f32], cols: usize, rows: usize) -> Vec<f32> {
    smooth_121(&smooth_121(visibility, cols, rows), cols, rows)
}

/// How much of a directional light (unit vector `light` towards it) reaches each node of a
/// height field (gem mm, `cell` apart): one sweep from the light's side keeps, per node, the
/// highest horizon S = max over the nodes towards the light of (their height - distance x
/// the light's slope), from the previous node's S (interpolated between two nodes of the
/// previous line); a node is lit where it stands above S, fading out over
/// [`SHADOW_SOFTNESS_MM`] below it.
pub(super) fn light_visibility(
    height: &[f32],
    cols: usize,
    rows: usize,
    cell: f32,
    light: [f32; 3],
) -> Vec<f32> {
    let mut h = height.to_vec();
    sweep(&mut h, cols, rows, cell, light, |_, _| {})
}

/// How [`carve_shadows`] cuts, gem mm.
#[derive(Clone, Copy, Debug)]
pub(super) struct ShadowCut {
    /// The depth below the horizon over which a shadow's edge fades ([`SHADOW_SOFTNESS_MM`]).
    pub penumbra: f32,
    /// The deepest a node is sunk; one that would need more (a dark facing the light on the
    /// relief's top, the horizon far below it) is left as it is.
    pub max_drop: f32,
    /// No node is sunk below this height (the wall's foot stays whole).
    pub floor: f32,
}

/// Sinks each node with a `shade` (0..1) into the shadow the relief casts from the light:
/// in one sweep from the light's side, a node standing above the horizon less `shade` times
/// the penumbra is lowered to it. So the node lies in the shadow of the relief towards the
/// light (the nodes sunk before it included), as dark as its shade asks within the
/// penumbra: a dark cut as a carver cuts it for a known light, a drop on the side towards
/// the light and a floor under the shadow's line, with no lit rise inside it. Nodes already
/// below stay as they are, and those the cut's limits keep out of reach. Returns
/// [`light_visibility`] of the carved heights (the same sweep's).
pub(super) fn carve_shadows(
    height: &mut [f32],
    shade: &[f32],
    cols: usize,
    rows: usize,
    cell: f32,
    light: [f32; 3],
    cut: ShadowCut,
) -> Vec<f32> {
    if shade.len() != height.len() {
        return light_visibility(height, cols, rows, cell, light);
    }
    sweep(height, cols, rows, cell, light, |i, (h, s)| {
        let k = shade[i].clamp(0.0, 1.0);
        let to = s - cut.penumbra * k;
        if k > 0.0 && to.is_finite() && to < *h && *h - to <= cut.max_drop && to >= cut.floor {
            *h = to;
        }
    })
}

/// The sweep of [`light_visibility`]: per node, the horizon S from the previous line; `at`
/// may change the node's height (given its index, its height and S) before its visibility is
/// decided and before the next line looks back at it.
fn sweep(
    height: &mut [f32],
    cols: usize,
    rows: usize,
    cell: f32,
    light: [f32; 3],
    mut at: impl FnMut(usize, (&mut f32, f32)),
) -> Vec<f32> {
    let n = cols * rows;
    let plane = light[0].hypot(light[1]);
    if plane < 1e-6 || light[2] <= 0.0 {
        return vec![if light[2] > 0.0 { 1.0 } else { 0.0 }; n];
    }
    let (dx, dy) = (light[0] / plane, light[1] / plane);
    let slope = light[2] / plane;
    // Step one line along the major axis towards the light; the minor axis moves by a fraction.
    let x_major = dx.abs() >= dy.abs();
    let (lines, len) = if x_major { (cols, rows) } else { (rows, cols) };
    let (major, minor) = if x_major { (dx, dy) } else { (dy, dx) };
    let shift = minor / major.abs();
    let step = cell * (1.0 + shift * shift).sqrt();
    let drop = step * slope;
    let idx = |line: usize, k: usize| {
        if x_major {
            k * cols + line
        } else {
            line * cols + k
        }
    };
    let mut horizon = vec![f32::NEG_INFINITY; n];
    let mut vis = vec![1f32; n];
    // Lines nearest the light first.
    let order: Vec<usize> = if major < 0.0 {
        (0..lines).collect()
    } else {
        (0..lines).rev().collect()
    };
    for w in 1..order.len() {
        let (prev, line) = (order[w - 1], order[w]);
        for k in 0..len {
            // The point one step towards the light, between two nodes of the previous line.
            let pos = k as f32 + shift;
            if pos < 0.0 || pos > (len - 1) as f32 {
                continue;
            }
            let k0 = pos.floor() as usize;
            let k1 = (k0 + 1).min(len - 1);
            let t = pos - k0 as f32;
            let sample = |f: &[f32]| {
                let (a, b) = (f[idx(prev, k0)], f[idx(prev, k1)]);
                if a.is_finite() && b.is_finite() {
                    a + (b - a) * t
                } else {
                    a.max(b)
                }
            };
            let s = sample(height).max(sample(&horizon)) - drop;
            let i = idx(line, k);
            at(i, (&mut height[i], s));
            horizon[i] = s;
            vis[i] = template::smoothstep(-SHADOW_SOFTNESS_MM, 0.0, height[i] - s);
        }
    }
    vis
}

/// How much of a directional light (unit vector `light` towards it) reaches each shadowed
/// node through the stone (gem mm heights, `cell` apart): along the ray from the node
/// towards the light, the length L that runs below the height field (inside the stone) lets
/// `exp(-L / mean_free_mm)` through; weighted by how much the node is shadowed (`shadow`:
/// 1 - [`light_visibility`]), so a lit node gets none (its light arrives directly), and the
/// ground (height 0) none. A thin
/// part (an ear's rim, a lock, the nose's tip seen against the light) lets much through, the
/// head's bulk almost nothing.
pub(super) fn light_transmission(
    height: &[f32],
    cols: usize,
    rows: usize,
    cell: f32,
    light: [f32; 3],
    shadow: &[f32],
    mean_free_mm: f32,
) -> Vec<f32> {
    let n = cols * rows;
    let plane = light[0].hypot(light[1]);
    let top = height.iter().copied().fold(0f32, f32::max);
    if plane < 1e-6 || light[2] <= 0.0 || top <= 0.0 || mean_free_mm <= 0.0 {
        return vec![0.0; n];
    }
    let (dx, dy) = (light[0] / plane, light[1] / plane);
    let slope = light[2] / plane;
    // Steps of a cell along the ground (bilinear between nodes); each is this long along the
    // ray.
    let step = cell;
    let along_ray = step * (1.0 + slope * slope).sqrt();
    let sample = |x: f32, y: f32| -> Option<f32> {
        if x < 0.0 || y < 0.0 || x > (cols - 1) as f32 || y > (rows - 1) as f32 {
            return None;
        }
        Some(crate::photo_grid::bilinear_map(height, cols, rows, x, y))
    };
    // Each node marches its own ray: spread over the cores.
    crate::par::map(n, 2048, |i| {
        let (dark, h0) = (shadow[i].clamp(0.0, 1.0), height[i]);
        // The relief only: the ground's shadows stay as they are (light through a part
        // reaches the ground behind it spread thin, and marching every shadowed ground node
        // costs more than the rest of the shading together).
        if dark < 0.01 || h0 <= 0.0 {
            return 0.0;
        }
        let (x, y) = ((i % cols) as f32, (i / cols) as f32);
        // March until the ray rises above the highest relief, or until what could still come
        // through is too little to show (under 2 %: a grey level or two).
        let steps = ((top - h0).max(0.0) / slope / step).ceil() as usize + 1;
        let enough = mean_free_mm * (dark / 0.02).ln().max(0.0);
        let mut inside = 0f32;
        for k in 1..=steps {
            if inside > enough {
                break;
            }
            let t = k as f32 * step;
            let Some(surface) = sample(x + dx * t / cell, y + dy * t / cell) else {
                break;
            };
            if surface > h0 + t * slope {
                inside += along_ray;
            }
        }
        dark * (-inside / mean_free_mm).exp()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2 mm step whose edge runs slantwise across the grid (the hair's side over the face),
    /// lit by the key light from its high side: the shadow's far edge runs slantwise too.
    fn slanted_step() -> (Vec<f32>, usize, usize) {
        let (cols, rows) = (120, 120);
        let height = (0..cols * rows)
            .map(|i| {
                let (x, y) = ((i % cols) as f32, (i / cols) as f32);
                // High on the light's side (upper left: -x, +y), the edge at 70 degrees.
                if x - 0.36 * y < 20.0 { 2.0 } else { 0.0 }
            })
            .collect();
        (height, cols, rows)
    }

    /// The largest change of the light between neighbours (along rows and columns) on the
    /// low side of the step.
    fn largest_jump(vis: &[f32], cols: usize, rows: usize) -> f32 {
        let mut worst = 0f32;
        for y in 0..rows - 1 {
            for x in 0..cols - 1 {
                if (x as f32) - 0.36 * (y as f32) < 24.0 {
                    continue;
                }
                let v = vis[y * cols + x];
                worst = worst
                    .max((vis[y * cols + x + 1] - v).abs())
                    .max((vis[(y + 1) * cols + x] - v).abs());
            }
        }
        worst
    }

    #[test]
    fn the_shadow_edge_is_a_penumbra_not_a_stair() {
        let (height, cols, rows) = slanted_step();
        let (cell, light) = (0.2, crate::scene::key_light_dir());
        let sharp = light_visibility(&height, cols, rows, cell, light);
        let soft = penumbra(&sharp, cols, rows);
        let (hard, smooth) = (
            largest_jump(&sharp, cols, rows),
            largest_jump(&soft, cols, rows),
        );
        println!("largest jump between neighbours: sharp {hard:.3}, penumbra {smooth:.3}");
        // A shadow falls (some nodes dark) and light stays (some lit), in both.
        for v in [&sharp, &soft] {
            assert!(v.iter().any(|&l| l < 0.05) && v.iter().any(|&l| l > 0.95));
            assert!(v.iter().all(|l| (0.0..=1.0).contains(l)));
        }
        // Node by node the edge jumps by most of the light between neighbours; the penumbra
        // spreads it over several cells.
        assert!(hard > 0.5, "sharp edge's jump {hard}");
        assert!(
            smooth < 0.5 * hard,
            "penumbra's jump {smooth} against {hard}"
        );
    }

    /// A dark band across a 2 mm plateau lit from the left at 20 degrees: sunk, its nodes lie
    /// in the plateau's shadow, as dark as their shade within the penumbra; the light's side
    /// of the band drops, the rest of it follows the shadow's line (no lit rise inside), the
    /// plateau around it stays as it was, and the cut's limits hold.
    #[test]
    fn a_dark_band_is_sunk_into_the_shadow_and_no_further() {
        let (cols, rows, cell) = (200, 3, 0.1);
        let height: Vec<f32> = (0..cols * rows)
            .map(|i| {
                let x = (i % cols) as f32 * cell;
                if (1.0..19.0).contains(&x) { 2.0 } else { 0.0 }
            })
            .collect();
        // The band from 8 to 10 mm: full shade, and half shade from 12 to 13 mm.
        let shade: Vec<f32> = (0..cols * rows)
            .map(|i| {
                let x = (i % cols) as f32 * cell;
                if (8.0..10.0).contains(&x) {
                    1.0
                } else if (12.0..13.0).contains(&x) {
                    0.5
                } else {
                    0.0
                }
            })
            .collect();
        let el = 20f32.to_radians();
        let light = [-el.cos(), 0.0, el.sin()];
        let cut = ShadowCut {
            penumbra: SHADOW_SOFTNESS_MM,
            max_drop: 1.5,
            floor: 1.0,
        };
        let mut carved = height.clone();
        let vis = carve_shadows(&mut carved, &shade, cols, rows, cell, light, cut);
        assert_eq!(vis, light_visibility(&carved, cols, rows, cell, light));
        let node = |x_mm: f32| cols + (x_mm / cell).round() as usize;
        for x in [8.0, 8.5, 9.0, 9.9] {
            assert!(vis[node(x)] < 0.01, "{x} mm: light {}", vis[node(x)]);
        }
        // Half shade: half way into the penumbra (a smoothstep's 0.5).
        let half = vis[node(12.5)];
        assert!((0.3..0.7).contains(&half), "half shade's light {half}");
        // Unshaded nodes keep their height; nothing is raised.
        for i in 0..cols * rows {
            assert!(carved[i] <= height[i]);
            if shade[i] == 0.0 {
                assert_eq!(carved[i], height[i]);
            }
        }
        // The band's floor under the shadow's line falls at the light's slope from its edge.
        let drop = |x: f32| height[node(x)] - carved[node(x)];
        let slope = el.tan();
        assert!((drop(9.9) - drop(8.0) - 1.9 * slope).abs() < 0.05);
        // A longer band would go past the floor: the node where it would is left standing,
        // and the band's shadow starts again behind it (a sawtooth of cuts).
        let long: Vec<f32> = (0..cols * rows)
            .map(|i| {
                let x = (i % cols) as f32 * cell;
                if (4.0..15.0).contains(&x) { 1.0 } else { 0.0 }
            })
            .collect();
        let mut deep = height.clone();
        carve_shadows(&mut deep, &long, cols, rows, cell, light, cut);
        let deepest = (0..cols * rows).fold(0f32, |m, i| m.max(height[i] - deep[i]));
        assert!(
            deepest <= 1.0 + 1e-4,
            "deepest {deepest} (the floor at 1 mm)"
        );
        let standing = (40..150)
            .filter(|&x| deep[cols + x] == height[cols + x])
            .count();
        assert!(standing >= 1, "the whole band sunk");
        assert!(deep[node(14.5)] < height[node(14.5)]);
    }

    /// On a 1 mm plateau of relief, a thin fin and a thick block, each 2 mm higher, lit from
    /// the left at 20 degrees: just behind the fin light comes through, behind the block
    /// hardly any; in front of either (lit directly) and on the bare ground none is added.
    #[test]
    fn thin_parts_let_light_through_and_thick_ones_do_not() {
        let (cols, rows, cell) = (240, 3, 0.1);
        // The plateau from x = 1 mm to 20 mm; the fin 0.4 mm thick at x = 2.0-2.4 mm; the
        // block 6 mm thick at x = 10-16 mm.
        let height: Vec<f32> = (0..cols * rows)
            .map(|i| {
                let x = (i % cols) as f32 * cell;
                if (2.0..2.4).contains(&x) || (10.0..16.0).contains(&x) {
                    3.0
                } else if (1.0..20.0).contains(&x) {
                    1.0
                } else {
                    0.0
                }
            })
            .collect();
        let el = 20f32.to_radians();
        let light = [-el.cos(), 0.0, el.sin()];
        let vis = light_visibility(&height, cols, rows, cell, light);
        let shadow: Vec<f32> = vis.iter().map(|v| 1.0 - v).collect();
        let through = light_transmission(&height, cols, rows, cell, light, &shadow, 1.5);
        let row = cols;
        let node = |x_mm: f32| row + (x_mm / cell).round() as usize;
        // 1 mm behind each, on the plateau, in full shadow.
        let (fin, block) = (node(3.4), node(17.0));
        assert!(vis[fin] < 0.01 && vis[block] < 0.01);
        assert!(through[fin] > 0.5, "behind the fin {}", through[fin]);
        // Through 4.8 mm of the block's stone: exp(-4.8 / 1.5) = 0.04.
        assert!(through[block] < 0.06, "behind the block {}", through[block]);
        assert!(through[fin] > 10.0 * through[block]);
        assert_eq!(through[node(1.5)], 0.0, "in front of the fin (lit)");
        // The bare ground in the plateau's shadow: none.
        assert!(vis[node(21.0)] < 0.01);
        assert_eq!(through[node(21.0)], 0.0);
        assert!(through.iter().all(|t| (0.0..=1.0).contains(t)));
    }
}
