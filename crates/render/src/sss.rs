//! Separable subsurface scattering: the blur kernel, and a CPU reference of the blur.
//!
//! After Jimenez et al., "Separable Subsurface Scattering" (CGF 2015): light that enters a
//! translucent stone leaves it a little further on, which a screen-space pass imitates by blurring
//! the lit *diffuse* image with a diffusion profile, once horizontally and once vertically. The
//! kernel is computed here at run time for any odd number of taps:
//!
//! * offsets `o_i = -R + i * 2R / (N - 1)`, remapped to `sign(o) R (|o| / R)^2` so taps crowd
//!   near the centre, where the profile changes fastest (R = 3 above 20 taps, else 2);
//! * the weight of a tap is the profile at its offset times the tap's footprint (half the
//!   distance to each neighbour), normalised per RGB channel;
//! * `strength` (per channel) blends the kernel with "no blur": the centre weight moves towards
//!   1 and the others shrink, so the weights still sum to 1;
//! * the centre tap is stored first (the shader reads the pixel itself once, then the others).
//!
//! Units: offsets are in kernel units (`-R..=R`); the renderer maps `R` to the blur radius in
//! millimetres ([`SssParams::width_mm`]) and that to pixels through the camera. Colours are
//! linear light. Pure computation: no GPU, no I/O.

/// Largest tap count (Blender's EEVEE goes to 65; beyond that the pass costs more than it shows).
pub const MAX_TAPS: usize = 65;

/// Which diffusion profile shapes the kernel (also the command line's `--sss-profile`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Profile {
    /// Jimenez's sum of five Gaussians (variances 0.0484 .. 7.41), each channel's radius scaled
    /// by its falloff: the reference demo's profile.
    Gaussians,
    /// Christensen-Burley normalised diffusion, as the radial density of scattered light
    /// `(e^(-r/d) + e^(-r/3d)) / 4d` (finite at r = 0), with `d = BURLEY_D * falloff` per channel.
    Burley,
    /// Measured marble: the diffuse reflectance Rd(r) of Jensen et al.'s dipole ("A Practical
    /// Model for Subsurface Light Transport", SIGGRAPH 2001) with their measured scattering of
    /// marble ([`MARBLE`]), in millimetres on the stone (r / falloff per channel). Its core
    /// is about half a millimetre wide; red light creeps several millimetres.
    #[default]
    Marble,
}

impl Profile {
    /// The per-channel radius scale this profile is used at ([`SssParams::falloff`]): the
    /// reference demo's red-furthest radii for the analytic profiles; the measured marble has
    /// its own per channel, used at [`MARBLE_SCALE`].
    pub fn falloff(self) -> [f32; 3] {
        match self {
            Profile::Marble => [MARBLE_SCALE; 3],
            Profile::Gaussians | Profile::Burley => [1.0, 0.37, 0.3],
        }
    }
}

/// Measured optical properties of one stone, per RGB channel (Jensen et al. 2001, table 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scattering {
    /// Reduced scattering coefficient, 1/mm.
    pub sigma_s: [f32; 3],
    /// Absorption coefficient, 1/mm.
    pub sigma_a: [f32; 3],
    /// Relative index of refraction.
    pub eta: f32,
}

/// Marble, as Jensen et al. measured it.
pub const MARBLE: Scattering = Scattering {
    sigma_s: [2.19, 2.62, 3.00],
    sigma_a: [0.0021, 0.0041, 0.0071],
    eta: 1.5,
};

impl Scattering {
    /// The dipole's diffuse reflectance Rd(r) (per mm^2) at distance `r` (mm) for channel `c`.
    pub fn dipole(&self, c: usize, r: f32) -> f32 {
        let (ss, sa) = (self.sigma_s[c], self.sigma_a[c]);
        let st = ss + sa;
        let albedo = ss / st;
        let sigma_tr = (3.0 * sa * st).sqrt();
        let eta = self.eta;
        let fdr = -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta;
        let a = (1.0 + fdr) / (1.0 - fdr);
        let zr = 1.0 / st;
        let zv = zr * (1.0 + 4.0 * a / 3.0);
        let term = |z: f32| {
            let d = (r * r + z * z).sqrt();
            z * (sigma_tr * d + 1.0) * (-sigma_tr * d).exp() / (d * d * d)
        };
        albedo / (4.0 * std::f32::consts::PI) * (term(zr) + term(zv))
    }

    /// The distance (mm) within which `share` of the light re-emerges for channel `c` (the
    /// integral of Rd over the disc of that radius over the total).
    pub fn radius(&self, c: usize, share: f32) -> f32 {
        let (dr, max) = (0.01f32, 200.0f32);
        let mut total = 0f64;
        let mut ring = Vec::new();
        let mut r = 0.5 * dr;
        while r < max {
            let e = f64::from(2.0 * std::f32::consts::PI * r * self.dipole(c, r) * dr);
            total += e;
            ring.push((r, total));
            r += dr;
        }
        ring.iter()
            .find(|(_, acc)| *acc >= f64::from(share) * total)
            .map_or(max, |(r, _)| *r)
    }
}

/// Burley's shape parameter `d` (kernel units) at falloff 1: puts most of the profile's weight
/// inside the kernel's range, as the Gaussian sum does.
pub const BURLEY_D: f32 = 0.5;

/// The kernel's controls.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SssParams {
    /// Taps per direction: odd, 3 ..= [`MAX_TAPS`].
    pub taps: usize,
    /// How much each channel scatters, 0 (none) ..= 1 (the full profile).
    pub strength: [f32; 3],
    /// Radius scale of the profile per channel, > 0 (red scatters furthest in stone and skin).
    pub falloff: [f32; 3],
    /// Blur radius on the surface, mm: the kernel's last tap lands this far away.
    pub width_mm: f32,
    pub profile: Profile,
}

/// The distance scale the measured marble profile is used at (its `falloff`): a quarter of
/// Jensen et al.'s, as for a finer-grained statuary marble. At their scale half of the red
/// light re-emerges 1.5 mm away and 90 % within 7.5 mm, which on a 56 mm cameo dissolves a
/// 1.4 mm eye and the lips; at a quarter the stone still glows and light still creeps into
/// the shadows, warm, while the carving stays legible.
pub const MARBLE_SCALE: f32 = 0.25;
/// The default blur radius: where 90 % of the (scaled) marble's red light has re-emerged
/// ([`Scattering::radius`] x [`MARBLE_SCALE`]), rounded.
pub const DEFAULT_WIDTH_MM: f32 = 1.9;
/// The default overall strength (red's; see [`SssParams::strength_rgb`]).
pub const DEFAULT_STRENGTH: f32 = 0.5;

impl Default for SssParams {
    /// Measured marble scattering ([`Profile::Marble`] at [`MARBLE_SCALE`]), 21 taps (as the
    /// 2021 system shipped) over a [`DEFAULT_WIDTH_MM`] radius, strength [`DEFAULT_STRENGTH`].
    fn default() -> Self {
        SssParams {
            taps: 21,
            strength: SssParams::strength_rgb(DEFAULT_STRENGTH),
            falloff: Profile::Marble.falloff(),
            width_mm: DEFAULT_WIDTH_MM,
            profile: Profile::Marble,
        }
    }
}

/// Why a kernel could not be made.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SssError {
    #[error("{0} taps: the tap count must be odd and 3..={MAX_TAPS}")]
    Taps(usize),
    #[error("{what} is {value}: {problem}")]
    Value {
        what: &'static str,
        value: f32,
        problem: &'static str,
    },
}

/// One tap: `weight` per RGB channel and `offset` in kernel units (the centre tap first).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tap {
    pub weight: [f32; 3],
    pub offset: f32,
}

/// A blur kernel; weights sum to 1 per channel.
#[derive(Clone, Debug, PartialEq)]
pub struct Kernel {
    pub taps: Vec<Tap>,
    /// The largest |offset| (R), which the renderer maps to `width_mm`.
    pub range: f32,
}

/// The reference demo's strengths relative to red's: one "strength" control keeps this balance.
pub const CHANNEL_BALANCE: [f32; 3] = [1.0, 0.41 / 0.48, 0.28 / 0.48];

impl SssParams {
    /// Per-channel strengths for one overall strength `s` (red's), in [`CHANNEL_BALANCE`];
    /// 0.48 gives the reference demo's. Not clamped: [`SssParams::validate`] rejects `s` > 1.
    pub fn strength_rgb(s: f32) -> [f32; 3] {
        CHANNEL_BALANCE.map(|b| s * b)
    }

    /// A tap count the kernel can have: odd (a centre tap and as many on each side) and
    /// 3 ..= [`MAX_TAPS`] (the renderer's kernel buffer).
    pub fn check_taps(taps: usize) -> Result<usize, SssError> {
        if taps.is_multiple_of(2) || !(3..=MAX_TAPS).contains(&taps) {
            return Err(SssError::Taps(taps));
        }
        Ok(taps)
    }

    /// Checks every field, naming the first bad one.
    pub fn validate(&self) -> Result<(), SssError> {
        Self::check_taps(self.taps)?;
        let bad = |what, value, problem| {
            Err(SssError::Value {
                what,
                value,
                problem,
            })
        };
        for (c, &s) in self.strength.iter().enumerate() {
            if !(0.0..=1.0).contains(&s) {
                return bad(STRENGTH_NAMES[c], s, "must be 0..=1");
            }
        }
        for (c, &f) in self.falloff.iter().enumerate() {
            if !(f.is_finite() && f > 0.0) {
                return bad(FALLOFF_NAMES[c], f, "must be finite and above 0");
            }
        }
        if !(self.width_mm.is_finite() && self.width_mm >= 0.0) {
            return bad("width_mm", self.width_mm, "must be finite and 0 or more");
        }
        Ok(())
    }
}

const STRENGTH_NAMES: [&str; 3] = ["strength (red)", "strength (green)", "strength (blue)"];
const FALLOFF_NAMES: [&str; 3] = ["falloff (red)", "falloff (green)", "falloff (blue)"];

/// The Gaussian sum's (variance, weight) pairs, from the reference demo.
const GAUSSIANS: [(f32, f32); 5] = [
    (0.0484, 0.100),
    (0.187, 0.118),
    (0.567, 0.113),
    (1.99, 0.358),
    (7.41, 0.078),
];

/// The profile at offset `r` (kernel units; `mm_per_unit` converts) for each channel.
fn profile(p: &SssParams, r: f32, mm_per_unit: f32) -> [f32; 3] {
    std::array::from_fn(|c| {
        let falloff = p.falloff[c];
        match p.profile {
            Profile::Marble => MARBLE.dipole(c, r.abs() * mm_per_unit / falloff),
            Profile::Gaussians => {
                // The demo divides by (0.001 + falloff) so a zero falloff cannot divide by 0.
                let rr = r / (0.001 + falloff);
                GAUSSIANS
                    .iter()
                    .map(|&(variance, weight)| {
                        weight * (-(rr * rr) / (2.0 * variance)).exp()
                            / (2.0 * std::f32::consts::PI * variance)
                    })
                    .sum()
            }
            Profile::Burley => {
                let d = BURLEY_D * falloff;
                let r = r.abs();
                ((-r / d).exp() + (-r / (3.0 * d)).exp()) / (4.0 * d)
            }
        }
    })
}

/// The kernel for `params` (see the module doc for the construction).
pub fn kernel(params: &SssParams) -> Result<Kernel, SssError> {
    params.validate()?;
    let n = params.taps;
    let range = if n > 20 { 3.0f32 } else { 2.0 };
    let step = 2.0 * range / (n - 1) as f32;
    let offsets: Vec<f32> = (0..n)
        .map(|i| {
            let o = -range + i as f32 * step;
            o.signum() * range * (o / range).powi(2)
        })
        .collect();
    let mut taps: Vec<Tap> = (0..n)
        .map(|i| {
            let left = if i > 0 {
                offsets[i] - offsets[i - 1]
            } else {
                0.0
            };
            let right = if i + 1 < n {
                offsets[i + 1] - offsets[i]
            } else {
                0.0
            };
            let area = 0.5 * (left + right);
            Tap {
                weight: profile(params, offsets[i], params.width_mm.max(1e-3) / range)
                    .map(|v| v * area),
                offset: offsets[i],
            }
        })
        .collect();
    for c in 0..3 {
        let sum: f32 = taps.iter().map(|t| t.weight[c]).sum();
        // Every profile is positive everywhere, so the sum is too; the guard only protects
        // against an underflow to 0 with absurd falloffs.
        if sum > 0.0 {
            taps.iter_mut().for_each(|t| t.weight[c] /= sum);
        }
    }
    // Centre tap first, the others in order.
    let centre = taps.remove(n / 2);
    taps.insert(0, centre);
    taps[0].offset = 0.0;
    for c in 0..3 {
        let s = params.strength[c];
        taps[0].weight[c] = 1.0 - s + s * taps[0].weight[c];
        taps[1..].iter_mut().for_each(|t| t.weight[c] *= s);
    }
    Ok(Kernel { taps, range })
}

impl Kernel {
    /// Per-channel sums of the weights (1 up to rounding).
    pub fn sums(&self) -> [f32; 3] {
        std::array::from_fn(|c| self.taps.iter().map(|t| t.weight[c]).sum())
    }

    /// The kernel as text: one line per tap, `offset  r g b`, centre first (`glyptic kernel`).
    pub fn to_text(&self) -> String {
        let mut out = String::new();
        for t in &self.taps {
            out.push_str(&format!(
                "{:+.6}  {:.6} {:.6} {:.6}\n",
                t.offset, t.weight[0], t.weight[1], t.weight[2]
            ));
        }
        out
    }
}

/// CPU reference of one blur direction over a linear RGB image (`width` x `height`, row-major),
/// for tests and benchmarks: each pixel gathers the kernel's taps `px_per_unit` pixels apart per
/// kernel unit along `dir` ((1, 0) or (0, 1)), reading bilinearly, clamped at the borders. No
/// depth or mask (the GPU pass adds those).
pub fn blur_reference(
    image: &[[f32; 3]],
    width: usize,
    height: usize,
    kernel: &Kernel,
    px_per_unit: f32,
    dir: [f32; 2],
) -> Vec<[f32; 3]> {
    let at = |x: i64, y: i64| {
        let x = x.clamp(0, width as i64 - 1) as usize;
        let y = y.clamp(0, height as i64 - 1) as usize;
        image[y * width + x]
    };
    let bilinear = |x: f32, y: f32| crate::bilinear::bilinear(at, x, y);
    let mut out = vec![[0.0f32; 3]; width * height];
    for y in 0..height {
        for x in 0..width {
            let mut sum = [0.0f32; 3];
            for t in &kernel.taps {
                let s = bilinear(
                    x as f32 + t.offset * px_per_unit * dir[0],
                    y as f32 + t.offset * px_per_unit * dir[1],
                );
                for k in 0..3 {
                    sum[k] += t.weight[k] * s[k];
                }
            }
            out[y * width + x] = sum;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_sum_to_one_for_every_odd_size_and_profile() {
        for profile in [Profile::Gaussians, Profile::Burley, Profile::Marble] {
            for taps in (3..=MAX_TAPS).step_by(2) {
                let k = kernel(&SssParams {
                    taps,
                    profile,
                    ..SssParams::default()
                })
                .unwrap();
                assert_eq!(k.taps.len(), taps);
                for s in k.sums() {
                    assert!((s - 1.0).abs() < 1e-5, "{profile:?} {taps}: {s}");
                }
                // Centre first, then offsets rising through the range, symmetric.
                assert_eq!(k.taps[0].offset, 0.0);
                let rest: Vec<f32> = k.taps[1..].iter().map(|t| t.offset).collect();
                assert!(rest.windows(2).all(|w| w[0] < w[1]), "{rest:?}");
                assert!(
                    (rest[0] + k.range).abs() < 1e-5 && (rest[taps - 2] - k.range).abs() < 1e-5
                );
                for i in 0..(taps - 1) / 2 {
                    let (a, b) = (&k.taps[1 + i], &k.taps[taps - 1 - i]);
                    assert!((a.offset + b.offset).abs() < 1e-5);
                    for c in 0..3 {
                        assert!((a.weight[c] - b.weight[c]).abs() < 1e-6);
                    }
                }
                // Weights fall off away from the centre.
                let half = &k.taps[1..=(taps - 1) / 2];
                for c in 0..3 {
                    assert!(k.taps[0].weight[c] >= half.last().unwrap().weight[c]);
                }
            }
        }
    }

    #[test]
    fn strength_blends_with_no_blur() {
        let none = kernel(&SssParams {
            strength: [0.0; 3],
            ..SssParams::default()
        })
        .unwrap();
        assert_eq!(none.taps[0].weight, [1.0; 3]);
        assert!(none.taps[1..].iter().all(|t| t.weight == [0.0; 3]));
        let full = kernel(&SssParams {
            strength: [1.0; 3],
            ..SssParams::default()
        })
        .unwrap();
        let half = kernel(&SssParams {
            strength: [0.5; 3],
            ..SssParams::default()
        })
        .unwrap();
        for c in 0..3 {
            let expect = 0.5 + 0.5 * full.taps[0].weight[c];
            assert!((half.taps[0].weight[c] - expect).abs() < 1e-6);
        }
        // Red spreads further than blue: less weight left at the centre.
        assert!(full.taps[0].weight[0] < full.taps[0].weight[2]);
    }

    /// Jensen et al.'s dipole for their marble: the profile falls monotonically, red light
    /// travels furthest, most light re-emerges within a few millimetres, and the default width
    /// is where 90 % of red has at the scale it is used at.
    #[test]
    fn measured_marble_scatters_as_published() {
        for c in 0..3 {
            let mut last = f32::INFINITY;
            for i in 0..200 {
                let v = MARBLE.dipole(c, i as f32 * 0.05);
                assert!(v.is_finite() && v > 0.0 && v <= last, "channel {c} at {i}");
                last = v;
            }
        }
        let r90: Vec<f32> = (0..3).map(|c| MARBLE.radius(c, 0.9)).collect();
        let r50: Vec<f32> = (0..3).map(|c| MARBLE.radius(c, 0.5)).collect();
        println!("marble: half the light within {r50:.2?} mm, 90 % within {r90:.2?} mm");
        assert!(r90[0] > r90[1] && r90[1] > r90[2], "{r90:?}");
        assert!(r50[0] < 2.0 && r50[0] > 0.3, "{r50:?}");
        assert!(
            (r90[0] * MARBLE_SCALE - DEFAULT_WIDTH_MM).abs() < 0.1,
            "{r90:?}"
        );
        // The diffuse albedo (Rd integrated) is high: marble is white.
        let (mut total, dr) = (0f64, 0.005f32);
        let mut r = 0.5 * dr;
        while r < 100.0 {
            total += f64::from(2.0 * std::f32::consts::PI * r * MARBLE.dipole(0, r) * dr);
            r += dr;
        }
        println!("marble red diffuse albedo {total:.3}");
        assert!(total > 0.7 && total < 1.0, "{total}");
    }

    #[test]
    fn bad_parameters_are_named() {
        let p = SssParams::default();
        for taps in [0, 1, 2, 20, 67, 1001] {
            assert_eq!(kernel(&SssParams { taps, ..p }), Err(SssError::Taps(taps)));
        }
        let e = kernel(&SssParams {
            strength: [0.5, f32::NAN, 0.5],
            ..p
        })
        .unwrap_err();
        assert!(e.to_string().contains("strength (green)"), "{e}");
        assert!(
            kernel(&SssParams {
                falloff: [1.0, 0.0, 1.0],
                ..p
            })
            .is_err()
        );
        assert!(
            kernel(&SssParams {
                width_mm: f32::INFINITY,
                ..p
            })
            .is_err()
        );
        assert!(
            kernel(&SssParams {
                width_mm: -1.0,
                ..p
            })
            .is_err()
        );
    }

    #[test]
    fn flat_colour_stays_flat_and_an_edge_spreads() {
        let (w, h) = (40, 30);
        let flat = vec![[0.8, 0.5, 0.2]; w * h];
        for taps in [7, 21, 65] {
            let k = kernel(&SssParams {
                taps,
                strength: [1.0; 3],
                ..SssParams::default()
            })
            .unwrap();
            let once = blur_reference(&flat, w, h, &k, 2.5, [1.0, 0.0]);
            let twice = blur_reference(&once, w, h, &k, 2.5, [0.0, 1.0]);
            for (p, q) in twice.iter().zip(&flat) {
                for c in 0..3 {
                    assert!((p[c] - q[c]).abs() <= 0.01 * q[c], "{taps}: {p:?} vs {q:?}");
                }
            }
        }
        // A vertical edge: light spreads into the dark side, red furthest.
        let edge: Vec<[f32; 3]> = (0..w * h)
            .map(|i| if i % w < w / 2 { [1.0; 3] } else { [0.0; 3] })
            .collect();
        let k = kernel(&SssParams {
            strength: [1.0; 3],
            ..SssParams::default()
        })
        .unwrap();
        let out = blur_reference(&edge, w, h, &k, 2.0, [1.0, 0.0]);
        let p = out[10 * w + w / 2 + 1];
        assert!(p[0] > p[1] && p[1] > 0.0 && p[2] > 0.0, "{p:?}");
        // Energy is kept away from the borders.
        let row: f32 = (0..w).map(|x| out[10 * w + x][0]).sum();
        assert!((row - (w / 2) as f32).abs() < 0.05, "{row}");
    }
}
