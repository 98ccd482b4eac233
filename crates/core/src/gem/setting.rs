//! The gold setting round the stone: a bezel (plain, a milgrain collet or with a rope-twist
//! frame), the back, and a bail for a pendant.
//!
//! Units: gem millimetres, the stone's frame (the oval in the XY plane centred on the origin,
//! the ground at z = 0, +Z towards the viewer). A setting's profile is given as (offset along
//! the oval's outward normal, height); the beads and the rope are tubes swept along an offset
//! oval with a cross-section that changes along it (a bead's circle, two twisted wires). Their
//! normals are the surfaces' own (analytic for the beads, from the swept grid for the rope),
//! so the gold's highlights run over each bead and along each wire as on a real mount.
//!
//! Sizes follow jewellers' practice for a 40-60 mm cameo: milgrain beads 0.8 mm across on a
//! 1.35 mm collet, a rope of two 0.84 mm wires with a 2.2 mm lay, a bail ring 7 mm across.

use std::f32::consts::TAU;

use super::{BACK_Z, CameoParams};
use crate::scene::{Mesh, Region, Vertex};
use crate::vec3::{cross, sub, unit};

/// How the stone is held: one type for the cameo, the kiosk's TOML (`setting = "milgrain"`)
/// and the command line (`--setting`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Setting {
    /// A polished bezel with a rounded crown.
    #[default]
    Plain,
    /// A collet whose rim is a row of small beads (as a milgrain wheel rolls them).
    Milgrain,
    /// The plain bezel framed by a rope of two twisted wires.
    Rope,
}

/// The plain bezel's cross-section: (offset along the oval's outward normal, height), from
/// the inner foot over the crown to the outer foot.
const BEZEL_PROFILE: [[f32; 2]; 7] = [
    [-0.7, -0.3],
    [-0.7, 0.9],
    [-0.3, 1.6],
    [0.4, 1.9],
    [1.2, 1.55],
    [1.6, 0.6],
    [1.6, -3.0],
];
/// The milgrain collet: a lower, flat-topped wall that the beads crown.
const COLLET_PROFILE: [[f32; 2]; 7] = [
    [-0.7, -0.3],
    [-0.7, 0.9],
    [-0.4, 1.3],
    [0.8, 1.35],
    [1.25, 1.15],
    [1.6, 0.5],
    [1.6, -3.0],
];
/// Milgrain beads: radius, and where their centres run (offset, height).
const BEAD_RADIUS: f32 = 0.4;
const BEAD_PATH: [f32; 2] = [0.2, 1.35];
/// The rope: each wire's radius, how far the wires' axes stand from the rope's, its lay
/// (the length of one full twist) and where its axis runs (offset, height), touching the
/// bezel's outer wall.
const WIRE_RADIUS: f32 = 0.42;
const WIRE_OFFSET: f32 = 0.24;
const ROPE_LAY: f32 = 2.2;
const ROPE_PATH: [f32; 2] = [1.6 + WIRE_OFFSET + WIRE_RADIUS, 0.35];
/// The bail: a ring standing on the setting's top, its radius (to the wire's axis), the
/// wire's radius, how deep it sinks into the setting and the height of its plane.
const BAIL_RADIUS: f32 = 3.2;
const BAIL_WIRE: f32 = 0.8;
const BAIL_OVERLAP: f32 = 0.9;
const BAIL_Z: f32 = -0.6;
/// Segments around the oval for the bezel and the back.
const RING_SEGMENTS: usize = 360;
/// Samples per bead along the oval and round each bead; per lay along the rope and round it.
const BEAD_ALONG: usize = 6;
const BEAD_AROUND: usize = 12;
const ROPE_ALONG: usize = 12;
const ROPE_AROUND: usize = 16;

impl Setting {
    /// The bezel's cross-section.
    fn profile(self) -> &'static [[f32; 2]] {
        match self {
            Setting::Plain | Setting::Rope => &BEZEL_PROFILE,
            Setting::Milgrain => &COLLET_PROFILE,
        }
    }

    /// How far the setting reaches beyond the oval (gem mm), the bail aside.
    pub fn reach(self) -> f32 {
        match self {
            Setting::Plain | Setting::Milgrain => BEZEL_PROFILE[BEZEL_PROFILE.len() - 1][0],
            Setting::Rope => ROPE_PATH[0] + WIRE_OFFSET + WIRE_RADIUS,
        }
    }
}

/// The setting of `p`: bezel, its beads or rope, the back and the bail.
pub(super) fn add_setting(mesh: &mut Mesh, p: &CameoParams) {
    let (a, b) = (p.half_width, p.half_height);
    add_bezel(mesh, a, b, p.setting.profile());
    add_back(
        mesh,
        a,
        b,
        p.setting.profile()[p.setting.profile().len() - 1][0],
    );
    match p.setting {
        Setting::Plain => {}
        Setting::Milgrain => add_milgrain(mesh, &Path::oval(a, b, BEAD_PATH)),
        Setting::Rope => add_rope(mesh, &Path::oval(a, b, ROPE_PATH)),
    }
    if p.bail {
        add_bail(mesh, b + p.setting.reach());
    }
}

fn gold(position: [f32; 3], normal: [f32; 3], occlusion: f32) -> Vertex {
    Vertex {
        position,
        normal,
        relief: 0.0,
        region: Region::Gold as u32,
        hair: 0.0,
        occlusion,
        key_light: 1.0,
        transmit: 0.0,
    }
}

/// Point and outward unit normal of the oval at parameter `t` (radians).
fn oval_frame(a: f32, b: f32, t: f32) -> ([f32; 2], [f32; 2]) {
    let (s, c) = t.sin_cos();
    let n = [b * c, a * s];
    let l = (n[0] * n[0] + n[1] * n[1]).sqrt();
    ([a * c, b * s], [n[0] / l, n[1] / l])
}

/// The bezel swept round the oval (flat across each profile segment, smooth along the oval).
fn add_bezel(mesh: &mut Mesh, a: f32, b: f32, profile: &[[f32; 2]]) {
    for seg in profile.windows(2) {
        let ([d0, z0], [d1, z1]) = (seg[0], seg[1]);
        let (td, tz) = (d1 - d0, z1 - z0);
        let l = (td * td + tz * tz).sqrt();
        let (nd, nz) = (-tz / l, td / l);
        let base = mesh.vertices.len() as u32;
        for i in 0..=RING_SEGMENTS {
            let t = (i % RING_SEGMENTS) as f32 / RING_SEGMENTS as f32 * TAU;
            let (e, n) = oval_frame(a, b, t);
            let normal = [n[0] * nd, n[1] * nd, nz];
            for (d, z) in [(d0, z0), (d1, z1)] {
                mesh.vertices
                    .push(gold([e[0] + n[0] * d, e[1] + n[1] * d, z], normal, 1.0));
            }
        }
        for i in 0..RING_SEGMENTS as u32 {
            let (p0, p1) = (base + 2 * i, base + 2 * i + 1);
            let (q0, q1) = (p0 + 2, p1 + 2);
            // Counter-clockwise seen from the side the normal points to.
            mesh.indices.extend_from_slice(&[p0, q1, q0, p0, p1, q1]);
        }
    }
}

/// The flat gold back, out to `outer` beyond the oval.
fn add_back(mesh: &mut Mesh, a: f32, b: f32, outer: f32) {
    let centre = mesh.vertices.len() as u32;
    mesh.vertices
        .push(gold([0.0, 0.0, BACK_Z], [0.0, 0.0, -1.0], 1.0));
    for i in 0..RING_SEGMENTS {
        let t = i as f32 / RING_SEGMENTS as f32 * TAU;
        let (e, n) = oval_frame(a, b, t);
        mesh.vertices.push(gold(
            [e[0] + n[0] * outer, e[1] + n[1] * outer, BACK_Z],
            [0.0, 0.0, -1.0],
            1.0,
        ));
    }
    for i in 0..RING_SEGMENTS as u32 {
        let next = (i + 1) % RING_SEGMENTS as u32;
        mesh.indices
            .extend_from_slice(&[centre, centre + 1 + next, centre + 1 + i]);
    }
}

/// A closed curve in a plane parallel to the stone, walked by arc length: an oval offset along
/// its outward normal (a circle when the semi-axes agree).
pub(super) struct Path {
    /// (oval parameter, arc length to it) at fine steps, the last closing the loop.
    table: Vec<(f32, f32)>,
    a: f32,
    b: f32,
    offset: f32,
    centre: [f32; 3],
    /// The curve's length, gem mm.
    pub length: f32,
}

/// A point of a [`Path`]: where it is, its outward normal in the plane and its tangent (the
/// direction of walking; with +Z they make a right-handed frame: normal x tangent = +Z).
#[derive(Clone, Copy, Debug)]
pub(super) struct PathPoint {
    pub at: [f32; 3],
    pub normal: [f32; 3],
    pub tangent: [f32; 3],
}

impl Path {
    /// The stone's oval (semi-axes `a`, `b`) offset by `place[0]` at height `place[1]`.
    pub(super) fn oval(a: f32, b: f32, place: [f32; 2]) -> Path {
        Path::new(a, b, place[0], [0.0, 0.0, place[1]])
    }

    fn new(a: f32, b: f32, offset: f32, centre: [f32; 3]) -> Path {
        const STEPS: usize = 4096;
        let point = |t: f32| {
            let (e, n) = oval_frame(a, b, t);
            [e[0] + n[0] * offset, e[1] + n[1] * offset]
        };
        let mut table = Vec::with_capacity(STEPS + 1);
        let mut length = 0.0;
        let mut last = point(0.0);
        table.push((0.0, 0.0));
        for i in 1..=STEPS {
            let t = i as f32 / STEPS as f32 * TAU;
            let q = point(t);
            length += ((q[0] - last[0]).powi(2) + (q[1] - last[1]).powi(2)).sqrt();
            table.push((t, length));
            last = q;
        }
        Path {
            table,
            a,
            b,
            offset,
            centre,
            length,
        }
    }

    /// The point `s` millimetres along (wrapping round).
    pub(super) fn at(&self, s: f32) -> PathPoint {
        let s = s.rem_euclid(self.length);
        let k = self
            .table
            .partition_point(|&(_, l)| l < s)
            .clamp(1, self.table.len() - 1);
        let ((t0, l0), (t1, l1)) = (self.table[k - 1], self.table[k]);
        let t = t0 + (t1 - t0) * ((s - l0) / (l1 - l0).max(1e-9));
        let (e, n) = oval_frame(self.a, self.b, t);
        PathPoint {
            at: [
                self.centre[0] + e[0] + n[0] * self.offset,
                self.centre[1] + e[1] + n[1] * self.offset,
                self.centre[2],
            ],
            normal: [n[0], n[1], 0.0],
            tangent: [-n[1], n[0], 0.0],
        }
    }
}

/// One vertex of a swept tube: its offset from the path in the path's frame (along the
/// normal, along +Z, along the tangent), its unit normal in the same frame (None: take it from
/// the swept grid) and its ambient light.
struct Section {
    offset: [f32; 3],
    normal: Option<[f32; 3]>,
    occlusion: f32,
}

fn local_to_world(p: &PathPoint, v: [f32; 3]) -> [f32; 3] {
    std::array::from_fn(|k| p.normal[k] * v[0] + [0.0, 0.0, 1.0][k] * v[1] + p.tangent[k] * v[2])
}

/// A tube swept along `path` through `stations` (mm along it, ascending; `closed`: the last
/// joins the first) at `around` angles (from the outward normal towards +Z), whose
/// cross-section `section(row, s, angle)` gives. Triangles wind counter-clockwise seen from
/// outside.
fn sweep(
    mesh: &mut Mesh,
    path: &Path,
    stations: &[f32],
    closed: bool,
    around: usize,
    section: impl Fn(usize, f32, f32) -> Section,
) {
    let base = mesh.vertices.len();
    let along = stations.len();
    let mut missing = Vec::new();
    for (i, &s) in stations.iter().enumerate() {
        let frame = path.at(s);
        for j in 0..around {
            let angle = j as f32 / around as f32 * TAU;
            let c = section(i, s, angle);
            let off = local_to_world(&frame, c.offset);
            let position = std::array::from_fn(|k| frame.at[k] + off[k]);
            let normal = match c.normal {
                Some(n) => local_to_world(&frame, n),
                None => {
                    missing.push(base + i * around + j);
                    [0.0; 3]
                }
            };
            mesh.vertices.push(gold(position, normal, c.occlusion));
        }
    }
    let index = |i: usize, j: usize| base + (i % along) * around + (j % around);
    // Grid normals: the cross product of the surface's differences along and around
    // (one-sided at an open tube's ends).
    for &v in &missing {
        let (i, j) = ((v - base) / around, (v - base) % around);
        let p = |i: usize, j: usize| mesh.vertices[index(i, j)].position;
        let (next, prev) = if closed {
            (i + 1, i + along - 1)
        } else {
            ((i + 1).min(along - 1), i.saturating_sub(1))
        };
        let d_along = sub(p(next, j), p(prev, j));
        let d_around = sub(p(i, j + 1), p(i, j + around - 1));
        mesh.vertices[v].normal = unit(cross(d_along, d_around));
    }
    let rows = if closed { along } else { along - 1 };
    for i in 0..rows {
        for j in 0..around {
            let (p00, p10) = (index(i, j), index(i + 1, j));
            let (p11, p01) = (index(i + 1, j + 1), index(i, j + 1));
            mesh.indices
                .extend([p00, p10, p11, p00, p11, p01].iter().map(|&k| k as u32));
        }
    }
}

/// `n` evenly spaced stations round a closed path of `length`.
fn stations(length: f32, n: usize) -> Vec<f32> {
    (0..n).map(|i| i as f32 / n as f32 * length).collect()
}

/// A whole number of equal pieces of about `want` mm along `length`.
fn pieces(length: f32, want: f32) -> usize {
    ((length / want).round() as usize).max(3)
}

/// The milgrain: touching beads along the collet's top, each a sphere (its rows meet at the
/// poles, where neighbours touch; the cleft between two beads gets little ambient light).
fn add_milgrain(mesh: &mut Mesh, path: &Path) {
    let beads = pieces(path.length, 2.0 * BEAD_RADIUS);
    let pitch = path.length / beads as f32;
    let r = pitch / 2.0;
    for k in 0..beads {
        // Rows from one pole (u = -r from the bead's centre) to the other.
        let rows: Vec<f32> = (0..=BEAD_ALONG)
            .map(|m| (k as f32 + m as f32 / BEAD_ALONG as f32) * pitch)
            .collect();
        sweep(mesh, path, &rows, false, BEAD_AROUND, |m, _, angle| {
            let u = (m as f32 / BEAD_ALONG as f32 - 0.5) * 2.0 * r;
            let rho = (r * r - u * u).max(0.0).sqrt();
            let (sa, ca) = angle.sin_cos();
            // The along-offset stays 0: the row's station already sits u from the centre.
            Section {
                offset: [rho * ca, rho * sa, 0.0],
                normal: Some([rho * ca / r, rho * sa / r, u / r]),
                occlusion: 0.45 + 0.55 * rho / r,
            }
        });
    }
}

/// The rope: two wires twisted round each other; the tube's cross-section at each station is
/// the outline of the two wires' circles, turned by the lay.
fn add_rope(mesh: &mut Mesh, path: &Path) {
    let lays = pieces(path.length, ROPE_LAY);
    let lay = path.length / lays as f32;
    let (r, h) = (WIRE_RADIUS, WIRE_OFFSET);
    let least = (r * r - h * h).sqrt();
    let rows = stations(path.length, lays * ROPE_ALONG);
    sweep(mesh, path, &rows, true, ROPE_AROUND, |_, s, angle| {
        let phase = s / lay * TAU;
        // The farther of the two wires' circles along this direction (both hold the axis).
        let rho = (0..2)
            .map(|k| {
                let c = phase + k as f32 * std::f32::consts::PI;
                let along = h * (angle - c).cos();
                along + (r * r - h * h + along * along).sqrt()
            })
            .fold(0.0f32, f32::max);
        let (sa, ca) = angle.sin_cos();
        Section {
            offset: [rho * ca, rho * sa, 0.0],
            normal: None,
            // The groove between the wires (rho near its least, sqrt(r^2 - h^2)) gets less.
            occlusion: 0.55 + 0.45 * ((rho - least) / (r + h - least)).clamp(0.0, 1.0),
        }
    });
}

/// The bail: a ring in a plane parallel to the stone, standing on the setting's top edge
/// (`top`: how far up the setting reaches), sunk into it so it reads as soldered on.
fn add_bail(mesh: &mut Mesh, top: f32) {
    let centre = [0.0, top + BAIL_RADIUS - BAIL_OVERLAP, BAIL_Z];
    let path = Path::new(BAIL_RADIUS, BAIL_RADIUS, 0.0, centre);
    sweep(
        mesh,
        &path,
        &stations(path.length, 72),
        true,
        16,
        |_, _, angle| {
            let (sa, ca) = angle.sin_cos();
            Section {
                offset: [BAIL_WIRE * ca, BAIL_WIRE * sa, 0.0],
                normal: Some([ca, sa, 0.0]),
                occlusion: 1.0,
            }
        },
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vec3::dot;

    fn setting(setting: Setting, bail: bool) -> Mesh {
        let mut mesh = Mesh::default();
        add_setting(
            &mut mesh,
            &CameoParams {
                setting,
                bail,
                ..CameoParams::default()
            },
        );
        mesh
    }

    /// Each triangle's winding agrees with its corners' normals (counter-clockwise seen from
    /// where they point), and every normal is a unit vector.
    fn assert_outward(mesh: &Mesh, what: &str) {
        let mut checked = 0;
        for t in mesh.indices.chunks(3) {
            let [a, b, c] = [0, 1, 2].map(|k| mesh.vertices[t[k] as usize]);
            let face = cross(sub(b.position, a.position), sub(c.position, a.position));
            let area = dot(face, face).sqrt();
            if area < 1e-6 {
                continue; // a bead's pole
            }
            let n = [0, 1, 2].map(|k| a.normal[k] + b.normal[k] + c.normal[k]);
            assert!(
                dot(face, n) > 0.0,
                "{what}: a triangle winds against its normals at {:?}",
                a.position
            );
            checked += 1;
        }
        assert!(checked > 1000, "{what}: {checked} triangles");
        for v in &mesh.vertices {
            assert!(v.position.iter().all(|x| x.is_finite()));
            let l = dot(v.normal, v.normal).sqrt();
            assert!((l - 1.0).abs() < 1e-3, "{what}: normal of length {l}");
        }
    }

    #[test]
    fn every_setting_faces_outwards() {
        for s in [Setting::Plain, Setting::Milgrain, Setting::Rope] {
            for bail in [false, true] {
                assert_outward(&setting(s, bail), &format!("{s:?}, bail {bail}"));
            }
        }
    }

    #[test]
    fn milgrain_is_a_row_of_touching_beads_on_the_collet() {
        let plain = setting(Setting::Milgrain, false);
        let path = Path::oval(22.0, 28.0, BEAD_PATH);
        let beads = pieces(path.length, 2.0 * BEAD_RADIUS);
        // About 0.8 mm apart round a 160 mm rim.
        assert!((180..230).contains(&beads), "{beads} beads");
        let top = plain
            .vertices
            .iter()
            .map(|v| v.position[2])
            .fold(f32::MIN, f32::max);
        let collet = COLLET_PROFILE.iter().map(|p| p[1]).fold(f32::MIN, f32::max);
        // The beads crown the collet by their radius.
        assert!(
            (top - (BEAD_PATH[1] + BEAD_RADIUS)).abs() < 0.02,
            "top {top}"
        );
        assert!(top > collet + 0.3);
        // Between two beads the rim dips to the collet (the beads read one by one).
        let cleft = path.at(path.length / beads as f32 * 7.0);
        let nearest = plain
            .vertices
            .iter()
            .filter(|v| (v.position[0] - cleft.at[0]).hypot(v.position[1] - cleft.at[1]) < 0.05)
            .map(|v| v.position[2])
            .fold(f32::MIN, f32::max);
        assert!(nearest < BEAD_PATH[1] + 0.05, "cleft at {nearest}");
    }

    #[test]
    fn the_rope_twists_two_wires_round_its_axis() {
        let path = Path::oval(22.0, 28.0, ROPE_PATH);
        let mut mesh = Mesh::default();
        add_rope(&mut mesh, &path);
        // Sample one station's ring: its radius from the axis swings between the groove's
        // sqrt(r^2 - h^2) and the wires' crowns r + h as the angle goes round.
        let rope: Vec<_> = mesh.vertices.iter().collect();
        let lays = pieces(path.length, ROPE_LAY);
        assert_eq!(rope.len(), lays * ROPE_ALONG * ROPE_AROUND);
        let ring = &rope[..ROPE_AROUND];
        let axis = path.at(0.0).at;
        let radii: Vec<f32> = ring
            .iter()
            .map(|v| dot(sub(v.position, axis), sub(v.position, axis)).sqrt())
            .collect();
        let (lo, hi) = radii
            .iter()
            .fold((f32::MAX, f32::MIN), |(l, h), &r| (l.min(r), h.max(r)));
        let least = (WIRE_RADIUS.powi(2) - WIRE_OFFSET.powi(2)).sqrt();
        assert!(
            (hi - (WIRE_RADIUS + WIRE_OFFSET)).abs() < 0.01,
            "crown {hi}"
        );
        assert!(lo < least + 0.05, "groove {lo}");
        // The normals point away from the axis.
        for v in ring {
            assert!(dot(v.normal, sub(v.position, axis)) > 0.0);
        }
        // The whole rope stays within the setting's reach.
        let reach = Setting::Rope.reach();
        for v in &rope {
            let (x, y) = (v.position[0], v.position[1]);
            assert!((x / (22.0 + reach)).powi(2) + (y / (28.0 + reach)).powi(2) < 1.01);
        }
    }

    #[test]
    fn the_bail_stands_on_the_top_and_only_with_it() {
        let top = |m: &Mesh| {
            m.vertices
                .iter()
                .map(|v| v.position[1])
                .fold(f32::MIN, f32::max)
        };
        for s in [Setting::Plain, Setting::Milgrain, Setting::Rope] {
            let (without, with) = (setting(s, false), setting(s, true));
            assert!(top(&without) <= 28.0 + s.reach() + 0.01, "{s:?}");
            let ring_top = 28.0 + s.reach() + 2.0 * BAIL_RADIUS + BAIL_WIRE - BAIL_OVERLAP;
            assert!(
                (top(&with) - ring_top).abs() < 0.05,
                "{s:?}: {}",
                top(&with)
            );
        }
    }
}
