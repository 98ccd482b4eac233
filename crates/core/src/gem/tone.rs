//! The photo's light and dark modelled into the face for the stone's own light, as a relief
//! carver renders a texture in very low relief (Donatello's *rilievo schiacciato*): where the
//! photo is lighter than its surroundings the surface turns a little towards the cameo's key
//! light, where darker a little away from it, so the stone under that light shows the photo's
//! fine pattern of light and dark (the eyes' shapes, the lids' folds, the lips, the lines and
//! the brows' weight) without a painted colour.
//!
//! Why: a face-recognition network, and a friend, know a face by that pattern. The carved
//! shape from 68 landmarks and the photo's broad shading is much alike between people; the
//! same gems with the photo's band-passed brightness laid over the face (a throwaway check,
//! BENCHMARKS.md, issue #37) were ranked to their own person for nearly every gem.
//!
//! The key light is fixed to the stone ([`crate::scene::key_light_dir`]), so the pattern holds
//! while the gem turns. The heights are carved after the bas-relief's compression, their
//! slopes kept (the compression flattens steep slopes most: the strongest light and dark). Heights come from a least-squares fit of their slope along the light's
//! direction to the wanted slope, smooth across it and held near zero by a ridge: a field whose
//! every change is small (a fraction of a millimetre over a few), not a picture pressed in.
//! Under it, the relief's own forms finer than the tone's band are taken off
//! ([`replace_fine_relief`]): the fitted face is much alike between people, and its fine forms
//! under the raking light (the nose's sides and shadow, the sockets) shade every gem alike.
//!
//! Units: the map's cells (x right, y down, as the photo); slopes in canonical mm per cell;
//! heights in canonical mm. Pure computation.

use nalgebra::Vector3;

use crate::fit::Pose;

/// The key light as the photo sees the face: its direction across the photo, and the photo's
/// scale there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToneLight {
    /// Unit direction in the photo (x right, y down) towards the light.
    pub toward: [f32; 2],
    /// Canonical millimetres per photo pixel at the face.
    pub mm_per_px: f32,
}

impl ToneLight {
    /// The light `light` (unit, the face model's frame: the frontal portrait's stone frame)
    /// seen by the photo under `pose` at model point `at` (mm). `None` when the light falls
    /// along the camera's axis (no direction across the photo) or the pose is degenerate.
    pub fn seen(pose: &Pose, at: [f32; 3], light: [f32; 3]) -> Option<Self> {
        let planar = (light[0].hypot(light[1])).max(0.0);
        if planar < 1e-3 {
            return None;
        }
        let step = 10.0; // mm along the light's direction in the stone's plane
        let a = Vector3::new(f64::from(at[0]), f64::from(at[1]), f64::from(at[2]));
        let d = Vector3::new(
            f64::from(step * light[0] / planar),
            f64::from(step * light[1] / planar),
            0.0,
        );
        let (p, q) = (pose.project(&a), pose.project(&(a + d)));
        let (dx, dy) = ((q.x - p.x) as f32, (q.y - p.y) as f32);
        let len = dx.hypot(dy);
        (len.is_finite() && len > 1e-3).then(|| ToneLight {
            toward: [dx / len, dy / len],
            mm_per_px: step / len,
        })
    }
}

impl ToneLight {
    /// The stone's key light ([`crate::scene::key_light_dir`]; the model's frame is a frontal
    /// portrait's stone frame) seen at the centre of `mesh` (its vertices' mean, model mm):
    /// [`Self::seen`]. `None` for an empty or broken mesh too.
    pub fn of_face(pose: &Pose, mesh: &[f32]) -> Option<Self> {
        let n = (mesh.len() / 3) as f32;
        if n < 1.0 {
            return None;
        }
        let mut at = [0f32; 3];
        for v in mesh.chunks_exact(3) {
            for k in 0..3 {
                at[k] += v[k] / n;
            }
        }
        if at.iter().any(|c| !c.is_finite()) {
            return None;
        }
        Self::seen(pose, at, crate::scene::key_light_dir())
    }
}

/// How the slopes are fitted: smoothness and ridge weights against the slope's own (1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToneSolve {
    /// Weight of the height's gradient (both directions) squared.
    pub smooth: f32,
    /// Weight of the height squared: how soon a run of dark or light stops adding up.
    pub ridge: f32,
    pub iterations: usize,
}

impl Default for ToneSolve {
    fn default() -> Self {
        ToneSolve {
            smooth: 0.1,
            ridge: 0.01,
            iterations: 80,
        }
    }
}

/// What the tone's heights are fitted to, on a `cols` x `rows` grid (row-major, one value per
/// cell each): the slope wanted along the light (mm per cell), how much each cell counts, and
/// the ridge that holds the heights at 0 (large off the face).
#[derive(Clone, Copy, Debug)]
pub struct SlopeField<'a> {
    pub slope: &'a [f32],
    pub weight: &'a [f32],
    pub hold: &'a [f32],
    pub cols: usize,
    pub rows: usize,
}

impl<'a> SlopeField<'a> {
    /// The maps on a `cols` x `rows` grid, in [`SlopeField`]'s order.
    pub fn new(
        slope: &'a [f32],
        weight: &'a [f32],
        hold: &'a [f32],
        cols: usize,
        rows: usize,
    ) -> Self {
        SlopeField {
            slope,
            weight,
            hold,
            cols,
            rows,
        }
    }

    /// Whether every map has one value per cell.
    fn fits(&self) -> bool {
        let n = self.cols * self.rows;
        self.slope.len() == n && self.weight.len() == n && self.hold.len() == n
    }
}

/// Heights (row-major, `cols` x `rows`) whose central-difference slope along `toward` comes
/// nearest `slope` where `weight` > 0, by conjugate gradients on the normal equations; `hold`
/// adds to the ridge per cell (large where the heights must stay 0: off the face).
///
/// Why the hold: a slope fixes heights along the light's direction only up to a constant per
/// line, and a uniform ridge picks the constant that makes each line's mean 0, a wake of the
/// opposite sign before and after every dark or light patch. Held at 0 off the face, each
/// line's heights start from the outline.
pub fn fit_slopes(field: SlopeField<'_>, toward: [f32; 2], solve: &ToneSolve) -> Vec<f32> {
    let SlopeField {
        slope,
        weight,
        hold,
        cols,
        rows,
    } = field;
    let n = cols * rows;
    if cols < 3 || rows < 3 || !field.fits() {
        return vec![0.0; n];
    }
    let [ux, uy] = toward;
    // D h at interior cells (0 on the border).
    let d = |h: &[f32], out: &mut [f32]| {
        out.fill(0.0);
        for r in 1..rows - 1 {
            for c in 1..cols - 1 {
                let i = r * cols + c;
                out[i] = 0.5 * (ux * (h[i + 1] - h[i - 1]) + uy * (h[i + cols] - h[i - cols]));
            }
        }
    };
    // D^T v.
    let dt = |v: &[f32], out: &mut [f32]| {
        out.fill(0.0);
        for r in 1..rows - 1 {
            for c in 1..cols - 1 {
                let i = r * cols + c;
                let (a, b) = (0.5 * ux * v[i], 0.5 * uy * v[i]);
                out[i + 1] += a;
                out[i - 1] -= a;
                out[i + cols] += b;
                out[i - cols] -= b;
            }
        }
    };
    // A h = D^T W D h + smooth * L h + ridge * h (L: the grid's Laplacian with free borders).
    let mut tmp = vec![0f32; n];
    let mut tmp2 = vec![0f32; n];
    let apply = |h: &[f32], out: &mut [f32]| {
        d(h, &mut tmp);
        for (t, w) in tmp.iter_mut().zip(weight) {
            *t *= w;
        }
        dt(&tmp, &mut tmp2);
        for r in 0..rows {
            for c in 0..cols {
                let i = r * cols + c;
                let mut lap = 0.0;
                if c > 0 {
                    lap += h[i] - h[i - 1];
                }
                if c + 1 < cols {
                    lap += h[i] - h[i + 1];
                }
                if r > 0 {
                    lap += h[i] - h[i - cols];
                }
                if r + 1 < rows {
                    lap += h[i] - h[i + cols];
                }
                out[i] = tmp2[i] + solve.smooth * lap + (solve.ridge + hold[i].max(0.0)) * h[i];
            }
        }
    };
    let ws: Vec<f32> = slope
        .iter()
        .zip(weight)
        .map(|(s, w)| if s.is_finite() { s * w } else { 0.0 })
        .collect();
    let mut b = vec![0f32; n];
    dt(&ws, &mut b);
    // Stops when the residual is 1e-4 of the right-hand side's.
    let h = crate::cg::conjugate_gradient(apply, &b, solve.iterations, 1e-4);
    if h.iter().all(|v| v.is_finite()) {
        h
    } else {
        vec![0.0; n]
    }
}

/// [`fit_slopes`] on a grid of half the resolution (each 2 x 2 cells averaged; the slopes per
/// coarse cell twice the fine ones, the ridge four times, so the same lengths in the face),
/// the heights interpolated back: a quarter of the unknowns, for a field the relief samples
/// more coarsely than the photo's map anyway (the Surrey face's relief has about 35 nodes to
/// the eyes' distance, the map 64).
pub fn fit_slopes_halved(field: SlopeField<'_>, toward: [f32; 2], solve: &ToneSolve) -> Vec<f32> {
    let (cols, rows) = (field.cols, field.rows);
    let n = cols * rows;
    if !field.fits() {
        return vec![0.0; n];
    }
    let (cc, cr) = (cols.div_ceil(2), rows.div_ceil(2));
    let halve = |v: &[f32], k: f32| -> Vec<f32> {
        let mut out = vec![0f32; cc * cr];
        for (j, o) in out.iter_mut().enumerate() {
            let (x, y) = (2 * (j % cc), 2 * (j / cc));
            let (mut sum, mut count) = (0f32, 0f32);
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                if x + dx < cols && y + dy < rows {
                    let f = v[(y + dy) * cols + x + dx];
                    if f.is_finite() {
                        sum += f;
                        count += 1.0;
                    }
                }
            }
            *o = if count > 0.0 { k * sum / count } else { 0.0 };
        }
        out
    };
    let coarse = ToneSolve {
        ridge: 4.0 * solve.ridge,
        ..*solve
    };
    let (slope, weight, hold) = (
        halve(field.slope, 2.0),
        halve(field.weight, 1.0),
        halve(field.hold, 1.0),
    );
    let field = SlopeField {
        slope: &slope,
        weight: &weight,
        hold: &hold,
        cols: cc,
        rows: cr,
    };
    let h = fit_slopes(field, toward, &coarse);
    // Fine cell c's centre lies at (c + 0.5) / 2 - 0.5 coarse cells.
    let at = |u: f32, v: f32| crate::photo_grid::bilinear_map(&h, cc, cr, u, v);
    (0..n)
        .map(|i| {
            let (c, r) = ((i % cols) as f32, (i / cols) as f32);
            at((c + 0.5) / 2.0 - 0.5, (r + 0.5) / 2.0 - 0.5)
        })
        .collect()
}

/// Takes `share` of the relief's own modelling finer than `sigma` (cells: a Gaussian's) off
/// `height` (row-major, `cols` x `rows`) where `weight` (0..1) says the tone is carved: its
/// high-pass, `height` less its blur. Why: the key light shades the fitted face's fine forms
/// alike on every gem, and casts their shadows alike; what the photo's light and dark (the
/// tone, added after) shows there is the person. The broader forms (the head's and the
/// face's volume, the nose's projection over its band) stay. Weight 0 or share 0: unchanged.
pub fn replace_fine_relief(
    height: &mut [f32],
    weight: &[f32],
    cols: usize,
    rows: usize,
    sigma: f32,
    share: f32,
) {
    let share = share.clamp(0.0, 1.0);
    if height.len() != cols * rows
        || weight.len() != height.len()
        || share <= 0.0
        || !(sigma.is_finite() && sigma > 0.0)
    {
        return;
    }
    let broad = super::blur::blur(height, cols, rows, sigma);
    for ((h, b), w) in height.iter_mut().zip(&broad).zip(weight) {
        *h -= share * w.clamp(0.0, 1.0) * (*h - b);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reliefs_fine_forms_are_taken_off_where_the_tone_is_carved_and_its_broad_ones_kept() {
        // A broad dome (sigma 30 cells) with a narrow ridge on it (sigma 2), as a nose on a
        // face; the tone carved over the left half only.
        let (cols, rows) = (120, 100);
        let dome =
            |c: f32, r: f32| 10.0 * (-((c - 60.0).powi(2) + (r - 50.0).powi(2)) / 1800.0).exp();
        let ridge = |c: f32| 3.0 * (-(c - 40.0).powi(2) / 8.0).exp();
        let ridge_right = |c: f32| 3.0 * (-(c - 80.0).powi(2) / 8.0).exp();
        let base: Vec<f32> = (0..cols * rows)
            .map(|i| {
                let (c, r) = ((i % cols) as f32, (i / cols) as f32);
                dome(c, r) + ridge(c) + ridge_right(c)
            })
            .collect();
        let weight: Vec<f32> = (0..cols * rows)
            .map(|i| if i % cols < 60 { 1.0 } else { 0.0 })
            .collect();
        let mut h = base.clone();
        replace_fine_relief(&mut h, &weight, cols, rows, 8.0, 1.0);
        let at = |v: &[f32], c: usize| v[50 * cols + c];
        // The ridge under the tone is (nearly) gone: what stands over its sides is under a
        // seventh of what did (what is left is the ridge's own broad part, its blur: about a
        // ninth).
        let before = at(&base, 40) - 0.5 * (at(&base, 32) + at(&base, 48));
        let after = at(&h, 40) - 0.5 * (at(&h, 32) + at(&h, 48));
        assert!(
            before > 2.5 && after.abs() < 0.15 * before,
            "ridge {before} -> {after}"
        );
        // The dome stays: its height at the tone's side within a tenth.
        let dome_at = dome(30.0, 50.0);
        assert!(
            (at(&h, 30) - dome_at).abs() < 0.1 * dome_at,
            "dome {} vs {dome_at}",
            at(&h, 30)
        );
        // Off the tone, nothing moved.
        assert!((60..cols).all(|c| at(&h, c) == at(&base, c)));
        // Share 0, a zero weight, or a broken size: unchanged.
        for (w, share) in [(&weight, 0.0), (&vec![0.0; cols * rows], 1.0)] {
            let mut k = base.clone();
            replace_fine_relief(&mut k, w, cols, rows, 8.0, share);
            assert_eq!(k, base);
        }
        let mut k = base.clone();
        replace_fine_relief(&mut k, &weight[1..], cols, rows, 8.0, 1.0);
        assert_eq!(k, base);
        // Half the share: about half the ridge.
        let mut half = base.clone();
        replace_fine_relief(&mut half, &weight, cols, rows, 8.0, 0.5);
        let mid = at(&half, 40) - 0.5 * (at(&half, 32) + at(&half, 48));
        assert!(
            (mid - 0.5 * (before + after)).abs() < 0.15 * before,
            "half share: {mid}"
        );
    }

    #[test]
    fn a_ramp_of_slopes_along_the_light_is_found_again() {
        // A bump: its slope along a diagonal light is asked for, the bump comes back.
        let (cols, rows) = (48, 40);
        let u = [-0.8f32, -0.6];
        let bump = |c: f32, r: f32| 2.0 * (-((c - 24.0).powi(2) + (r - 20.0).powi(2)) / 40.0).exp();
        let mut slope = vec![0f32; cols * rows];
        for r in 1..rows - 1 {
            for c in 1..cols - 1 {
                let (cf, rf) = (c as f32, r as f32);
                slope[r * cols + c] = 0.5
                    * (u[0] * (bump(cf + 1.0, rf) - bump(cf - 1.0, rf))
                        + u[1] * (bump(cf, rf + 1.0) - bump(cf, rf - 1.0)));
            }
        }
        // The slopes known on a box round the bump; the heights held at 0 outside it.
        let inside =
            |i: usize| (4..cols - 4).contains(&(i % cols)) && (4..rows - 4).contains(&(i / cols));
        let weight: Vec<f32> = (0..cols * rows)
            .map(|i| if inside(i) { 1.0 } else { 0.0 })
            .collect();
        let hold: Vec<f32> = weight.iter().map(|w| 1.0 - w).collect();
        let solve = ToneSolve {
            smooth: 0.001,
            ridge: 0.0001,
            iterations: 3000,
        };
        let field = SlopeField {
            slope: &slope,
            weight: &weight,
            hold: &hold,
            cols,
            rows,
        };
        let h = fit_slopes(field, u, &solve);
        // Solved on half the grid, the same bump within a tenth of its height.
        let halved = fit_slopes_halved(field, u, &solve);
        let worst = h
            .iter()
            .zip(&halved)
            .fold(0f32, |m, (a, b)| m.max((a - b).abs()));
        assert!(worst < 0.2, "halved against full: {worst}");
        // A uniform ridge instead leaves a wake along the light: the bump's peak falls short.
        let (uniform, none) = (vec![1.0; cols * rows], vec![0.0; cols * rows]);
        let wake = fit_slopes(
            SlopeField {
                weight: &uniform,
                hold: &none,
                ..field
            },
            u,
            &solve,
        );
        assert!(
            wake[20 * cols + 24] < 1.7,
            "peak without the hold {}",
            wake[20 * cols + 24]
        );
        let (mut err, mut norm) = (0f32, 0f32);
        for r in 0..rows {
            for c in 0..cols {
                let t = bump(c as f32, r as f32);
                err += (h[r * cols + c] - t).powi(2);
                norm += t * t;
            }
        }
        let peak = h[20 * cols + 24];
        let hmax = h.iter().fold(f32::MIN, |m, v| m.max(*v));
        let hmin = h.iter().fold(f32::MAX, |m, v| m.min(*v));
        assert!(
            (err / norm).sqrt() < 0.2,
            "relative error {} peak {peak} max {hmax} min {hmin}",
            (err / norm).sqrt()
        );
    }

    #[test]
    fn the_key_light_from_the_upper_left_is_seen_upper_left_in_a_frontal_photo() {
        use nalgebra::{Matrix3, Vector2};
        let pose = Pose {
            rotation: Matrix3::identity(),
            scale: 2.0,
            translation: Vector2::new(400.0, -400.0),
        };
        let light = ToneLight::seen(&pose, [0.0, 0.0, 0.0], crate::scene::key_light_dir())
            .expect("a light across the photo");
        let [x, y] = light.toward;
        assert!(x < -0.5 && y < -0.3, "towards {:?}", light.toward);
        assert!((light.mm_per_px - 0.5).abs() < 1e-4, "{}", light.mm_per_px);
        // Rolled a quarter turn, the light turns with the face.
        let rolled = Pose {
            rotation: Pose::rotation_from_yaw_pitch_roll_deg([0.0, 0.0, 90.0]),
            ..pose
        };
        let turned = ToneLight::seen(&rolled, [0.0; 3], crate::scene::key_light_dir())
            .expect("a light across the photo");
        let dot = turned.toward[0] * x + turned.toward[1] * y;
        assert!(
            dot.abs() < 1e-3,
            "{:?} against {:?}",
            turned.toward,
            light.toward
        );
        // A light along the camera's axis has no direction across the photo.
        assert_eq!(ToneLight::seen(&pose, [0.0; 3], [0.0, 0.0, 1.0]), None);
    }

    #[test]
    fn no_slope_or_a_broken_one_gives_a_flat_field() {
        let (w, z) = (vec![1f32; 100], vec![0f32; 100]);
        let mut s = vec![0.1f32; 100];
        let flat = |slope: &[f32], cols: usize, rows: usize| {
            let field = SlopeField {
                slope,
                weight: &w,
                hold: &z,
                cols,
                rows,
            };
            fit_slopes(field, [1.0, 0.0], &ToneSolve::default())
        };
        assert!(flat(&[0.0; 100], 10, 10).iter().all(|v| *v == 0.0));
        s[55] = f32::NAN;
        assert!(flat(&s, 10, 10).iter().all(|v| v.is_finite()));
        assert_eq!(flat(&s, 2, 50), vec![0.0; 100]);
    }
}
