//! The identity steered towards the photo by a face-recognition network: analysis by
//! synthesis (Blanz & Vetter 1999) with a recognition embedding as the comparison, as
//! Deep3DFaceRecon's identity loss does, but without gradients through the network.
//!
//! The landmark fit pins pose and proportions, not who someone is (68 points of one photo
//! fit many faces alike). So the fitted face is drawn grey on the CPU the way the photo shows
//! it (the fit's camera, the photo's light estimated on the fitted face, aligned as the
//! network aligns the photo), a recognition network embeds each drawing, and the 63 identity
//! coefficients (the first [`SearchOptions::components`]) are searched (a
//! natural-evolution-strategy step: antithetic random directions, one batch per step, the
//! best face kept) so the drawing's embedding comes
//! nearer the photo's, under the model's prior (a penalty on the coefficients' size, and no
//! coefficient past [`SearchOptions::limit_sd`]): the search stays among plausible faces.
//!
//! Units: identity coefficients in standard deviations of the model; photo pixels (whole
//! numbers at pixel centres); the network's crop is [`CROP`] pixels square, RGB 0..255,
//! channel-major, as `glyptic::detect::embed::aligned_input` writes a photo's. The network
//! itself is a closure: this module is pure computation.

use image::GrayImage;
use nalgebra::Vector3;

use crate::fit::Pose;
use crate::raster;
use crate::shapemodel::SurreyModel;

/// The recognition network's crop side, pixels.
pub const CROP: usize = 112;

/// ArcFace's five points in the crop (eye centres, nose tip, mouth corners; image order).
pub const TEMPLATE: [[f32; 2]; 5] = [
    [38.2946, 51.6963],
    [73.5318, 51.5014],
    [56.0252, 71.7366],
    [41.5493, 92.3655],
    [70.7299, 92.2041],
];

/// The search's size and its prior.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SearchOptions {
    /// Steps; each draws `pairs` antithetic directions (2 `pairs` faces, one batch).
    pub steps: usize,
    pub pairs: usize,
    /// How far a direction reaches, standard deviations per coefficient.
    pub sigma: f32,
    /// Length of a step (standard deviations, over all coefficients together).
    pub step: f32,
    /// Penalty per squared standard deviation (summed over the coefficients), in the
    /// embedding's distance units: the model's prior.
    pub prior: f32,
    /// No coefficient goes further from the mean than this.
    pub limit_sd: f32,
    /// The random directions' seed: the same photo gives the same face.
    pub seed: u64,
    /// Search only the model's first `components` identity coefficients (the others stay as
    /// fitted); 0 or more than the model has: all of them. The first 20 carry most of the
    /// face's visible form; the small ones are what the caricature exaggerates most (up to
    /// about 5x), so random steps in them come out as lumps, and a search of a few dozen faces
    /// finds less in 63 dimensions than in 20 (BENCHMARKS.md, issue #37).
    pub components: usize,
}

impl SearchOptions {
    /// About `faces` faces drawn and judged in all (at least one step): 2 directions a step
    /// below 15 faces, 3 up to 40, 6 beyond.
    pub fn with_faces(faces: usize) -> Self {
        let pairs = match faces {
            0..15 => 2,
            15..40 => 3,
            _ => 6,
        };
        SearchOptions {
            steps: (faces.saturating_sub(1) / (2 * pairs + 1)).max(1),
            pairs,
            ..SearchOptions::default()
        }
    }

    /// Faces drawn and judged by a search with these options.
    pub fn faces(&self) -> usize {
        1 + self.steps * (2 * self.pairs + 1)
    }
}

impl Default for SearchOptions {
    /// 11 faces in three runs of the network: about 190 ms with SFace on two CPU cores, the
    /// photo's whole path +270 ms with its loading (BENCHMARKS.md, issue #37).
    fn default() -> Self {
        SearchOptions {
            steps: 2,
            pairs: 2,
            sigma: 0.4,
            step: 1.2,
            prior: 0.0015,
            limit_sd: 2.5,
            seed: 0x9e37_79b9_7f4a_7c15,
            components: 20,
        }
    }
}

/// How the photo shows the face: the fit's camera, the light on it, and the crop the
/// network sees.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    pose: Pose,
    /// Photo brightness ~ `light[0] + light[1..4] . n` (n in the camera's frame, y up), 0..1.
    light: [f32; 4],
    /// Photo pixels -> crop pixels: `[a, b, tx, ty]` for `[a -b; b a] p + t`.
    align: [f32; 4],
}

/// Why the search could not start.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum IdentityError {
    #[error("expected 68 finite landmarks")]
    Landmarks,
    #[error("the photo is empty")]
    EmptyPhoto,
    #[error("too little of the face is seen to estimate its light")]
    Light,
    #[error("the network gave {got} embeddings for {asked} faces")]
    Network { asked: usize, got: usize },
}

/// What the search found.
#[derive(Clone, Debug, PartialEq)]
pub struct Searched {
    /// The identity, standard deviations.
    pub shape: Vec<f32>,
    /// Distance of the starting face's and the found face's drawings to the photo (`1 - cos`).
    pub before: f32,
    pub after: f32,
    /// Faces drawn and embedded.
    pub evaluations: usize,
    /// Time spent drawing the faces and in the network, milliseconds.
    pub draw_ms: f64,
    pub network_ms: f64,
}

/// The five alignment points of 68 landmarks (eye centres, nose tip, mouth corners).
pub fn five_points(landmarks: &[[f32; 2]]) -> Option<[[f32; 2]; 5]> {
    if landmarks.len() != 68 || landmarks.iter().flatten().any(|v| !v.is_finite()) {
        return None;
    }
    let centre = |r: std::ops::Range<usize>| {
        let n = r.len() as f32;
        let s = landmarks[r]
            .iter()
            .fold([0.0f32; 2], |a, p| [a[0] + p[0], a[1] + p[1]]);
        [s[0] / n, s[1] / n]
    };
    Some([
        centre(36..42),
        centre(42..48),
        landmarks[30],
        landmarks[48],
        landmarks[54],
    ])
}

/// The distance between the eyes' centres of 68 landmarks ([`five_points`]), pixels: the
/// scale the face's readings measure themselves in.
pub fn eye_distance(landmarks: &[[f32; 2]]) -> Option<f32> {
    let [re, le, ..] = five_points(landmarks)?;
    Some((le[0] - re[0]).hypot(le[1] - re[1]))
}

/// The similarity transform (rotation, uniform scale, translation; no reflection) that best
/// takes `src` to `dst` in least squares (Umeyama 1991): `[a, b, tx, ty]` for
/// `dst ~ [a -b; b a] src + t`. `None` when `src` has no spread.
pub fn similarity(src: &[[f32; 2]; 5], dst: &[[f32; 2]; 5]) -> Option<[f32; 4]> {
    let n = 5.0;
    let ms = src
        .iter()
        .fold([0.0f32; 2], |a, p| [a[0] + p[0] / n, a[1] + p[1] / n]);
    let md = dst
        .iter()
        .fold([0.0f32; 2], |a, p| [a[0] + p[0] / n, a[1] + p[1] / n]);
    let (mut sxx, mut sxy, mut var) = (0.0f32, 0.0f32, 0.0f32);
    for (s, d) in src.iter().zip(dst) {
        let (sx, sy) = (s[0] - ms[0], s[1] - ms[1]);
        let (dx, dy) = (d[0] - md[0], d[1] - md[1]);
        sxx += sx * dx + sy * dy;
        sxy += sx * dy - sy * dx;
        var += sx * sx + sy * sy;
    }
    if var.is_nan() || var <= 1e-6 {
        return None;
    }
    let (a, b) = (sxx / var, sxy / var);
    let t = [
        md[0] - (a * ms[0] - b * ms[1]),
        md[1] - (b * ms[0] + a * ms[1]),
    ];
    [a, b, t[0], t[1]]
        .iter()
        .all(|v| v.is_finite())
        .then_some([a, b, t[0], t[1]])
}

impl Scene {
    /// The scene of a photo: the fit's `pose`, the light fitted to the photo's brightness at
    /// the fitted `mesh`'s vertices that face the camera (`brightness ~ a + b . n`, least
    /// squares), and the crop the network takes of the photo (by the landmarks' five points).
    pub fn of_photo(
        photo: &GrayImage,
        landmarks: &[[f32; 2]],
        mesh: &[f32],
        triangles: &[[u32; 3]],
        pose: &Pose,
    ) -> Result<Self, IdentityError> {
        if photo.width() == 0 || photo.height() == 0 {
            return Err(IdentityError::EmptyPhoto);
        }
        let five = five_points(landmarks).ok_or(IdentityError::Landmarks)?;
        let align = similarity(&five, &TEMPLATE).ok_or(IdentityError::Landmarks)?;
        let normals = raster::vertex_normals(mesh, triangles);
        let (w, h) = photo.dimensions();
        // The photo's brightness at the vertices that face the camera.
        let samples: Vec<([f32; 3], f64, f64)> = mesh
            .chunks_exact(3)
            .zip(&normals)
            .filter_map(|(v, n)| {
                let nc = turn(pose, *n);
                if nc[2] < 0.3 {
                    return None;
                }
                let p = pose.project(&Vector3::new(
                    f64::from(v[0]),
                    f64::from(v[1]),
                    f64::from(v[2]),
                ));
                if !(p.x >= 0.0 && p.y >= 0.0 && p.x <= f64::from(w - 1) && p.y <= f64::from(h - 1))
                {
                    return None;
                }
                let b = f64::from(photo.get_pixel(p.x.round() as u32, p.y.round() as u32).0[0]);
                Some((nc, b / 255.0, 1.0))
            })
            .collect();
        if samples.len() < 50 {
            return Err(IdentityError::Light);
        }
        let light = raster::fit_light(samples).ok_or(IdentityError::Light)?;
        Ok(Scene {
            pose: *pose,
            light,
            align,
        })
    }

    /// The face with these coefficients drawn grey into a crop (3 x [`CROP`] x [`CROP`], RGB
    /// 0..255, mid-grey where no face is), as the network would be shown the photo.
    pub fn draw(&self, model: &SurreyModel, shape: &[f32], expression: &[f32], out: &mut [f32]) {
        let mesh = model.instance(shape, expression);
        let triangles = &model.shape.triangles;
        let normals = raster::vertex_normals(&mesh, triangles);
        let [a, b, tx, ty] = self.align;
        let r = &self.pose.rotation;
        let points: Vec<Option<[f32; 3]>> = mesh
            .chunks_exact(3)
            .map(|v| {
                let q = Vector3::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2]));
                let p = self.pose.project(&q);
                let depth = (r * q).z as f32;
                let (x, y) = (p.x as f32, p.y as f32);
                // Whole-number pixel centres in the crop; the rasteriser samples at + 0.5.
                let c = [a * x - b * y + tx + 0.5, b * x + a * y + ty + 0.5, depth];
                c.iter().all(|v| v.is_finite()).then_some(c)
            })
            .collect();
        let turned: Vec<[f32; 3]> = normals.iter().map(|n| turn(&self.pose, *n)).collect();
        let mut grey = vec![f32::NAN; CROP * CROP];
        let l = self.light;
        raster::shade_points(
            &points,
            &turned,
            triangles,
            &|n| raster::lambert(&l, n).clamp(0.0, 1.0),
            CROP,
            CROP,
            &mut grey,
        );
        let plane = CROP * CROP;
        for (i, g) in grey.iter().enumerate() {
            let v = if g.is_finite() { g * 255.0 } else { 128.0 };
            for k in 0..3 {
                out[k * plane + i] = v;
            }
        }
    }
}

fn turn(pose: &Pose, n: [f32; 3]) -> [f32; 3] {
    let v = pose.rotation * Vector3::new(f64::from(n[0]), f64::from(n[1]), f64::from(n[2]));
    [v.x as f32, v.y as f32, v.z as f32]
}

/// Cosine distance of two embeddings (`1 - cos`, each normalised here); 2 when either has no
/// length or a non-finite value.
pub fn distance(a: &[f32], b: &[f32]) -> f32 {
    let dot: f32 = a.iter().zip(b).map(|(x, y)| x * y).sum();
    let (na, nb) = (
        a.iter().map(|x| x * x).sum::<f32>().sqrt(),
        b.iter().map(|x| x * x).sum::<f32>().sqrt(),
    );
    let d = 1.0 - dot / (na * nb);
    if d.is_finite() { d } else { 2.0 }
}

/// Searches the identity from `start` so the drawn face's embedding nears `target` (the
/// photo's). `embed` runs the network on `n` crops laid one after another and returns their
/// embeddings. The expression stays as fitted.
pub fn search(
    model: &SurreyModel,
    scene: &Scene,
    start: &[f32],
    expression: &[f32],
    target: &[f32],
    mut embed: impl FnMut(&[f32], usize) -> Option<Vec<Vec<f32>>>,
    opts: &SearchOptions,
) -> Result<Searched, IdentityError> {
    let k = start.len();
    let crop = 3 * CROP * CROP;
    let clamp = |c: &mut [f32]| {
        for v in c.iter_mut() {
            *v = if v.is_finite() {
                v.clamp(-opts.limit_sd, opts.limit_sd)
            } else {
                0.0
            };
        }
    };
    let loss = |d: f32, c: &[f32]| d + opts.prior * c.iter().map(|v| v * v).sum::<f32>();
    let (mut draw_ms, mut network_ms) = (0.0, 0.0);
    let mut run = |faces: &[Vec<f32>]| -> Result<Vec<f32>, IdentityError> {
        let t = std::time::Instant::now();
        let mut buf = vec![0f32; faces.len() * crop];
        for (f, chunk) in faces.iter().zip(buf.chunks_exact_mut(crop)) {
            scene.draw(model, f, expression, chunk);
        }
        draw_ms += t.elapsed().as_secs_f64() * 1e3;
        let t = std::time::Instant::now();
        let got = embed(&buf, faces.len()).unwrap_or_default();
        network_ms += t.elapsed().as_secs_f64() * 1e3;
        if got.len() != faces.len() {
            return Err(IdentityError::Network {
                asked: faces.len(),
                got: got.len(),
            });
        }
        Ok(got.iter().map(|e| distance(e, target)).collect())
    };
    // Each network run judges one centre and the antithetic pairs around it; the next centre
    // is a step down the slope those pairs measure, from the best face found so far; the last
    // centre is judged alone. So `steps` steps cost `steps + 1` runs of the network.
    let mut centre = start.to_vec();
    clamp(&mut centre);
    let searched = if opts.components == 0 {
        k
    } else {
        opts.components.min(k)
    };
    let mut rng = SplitMix(opts.seed);
    let mut before = None;
    let mut evaluations = 0;
    let (mut best, mut best_loss, mut best_d) = (centre.clone(), f32::INFINITY, f32::NAN);
    for _ in 0..opts.steps {
        let dirs: Vec<Vec<f32>> = (0..opts.pairs)
            .map(|_| {
                (0..k)
                    .map(|i| if i < searched { rng.normal() } else { 0.0 })
                    .collect()
            })
            .collect();
        let mut faces = Vec::with_capacity(1 + 2 * opts.pairs);
        faces.push(centre.clone());
        for d in &dirs {
            for sign in [1.0f32, -1.0] {
                let mut c: Vec<f32> = centre
                    .iter()
                    .zip(d)
                    .map(|(c, e)| c + sign * opts.sigma * e)
                    .collect();
                clamp(&mut c);
                faces.push(c);
            }
        }
        let dist = run(&faces)?;
        evaluations += faces.len();
        before.get_or_insert(dist[0]);
        let losses: Vec<f32> = dist.iter().zip(&faces).map(|(d, c)| loss(*d, c)).collect();
        for ((l, d), c) in losses.iter().zip(&dist).zip(&faces) {
            if *l < best_loss {
                (best, best_loss, best_d) = (c.clone(), *l, *d);
            }
        }
        // The loss's slope along the directions, and a step of fixed length down it.
        let mut grad = vec![0f32; k];
        for (j, d) in dirs.iter().enumerate() {
            let diff = (losses[1 + 2 * j] - losses[2 + 2 * j]) / (2.0 * opts.sigma);
            for (g, e) in grad.iter_mut().zip(d) {
                *g += diff * e / opts.pairs as f32;
            }
        }
        let norm = grad.iter().map(|g| g * g).sum::<f32>().sqrt();
        centre = if norm.is_nan() || norm <= 1e-9 {
            best.clone()
        } else {
            best.iter()
                .zip(&grad)
                .map(|(c, g)| c - opts.step * g / norm)
                .collect()
        };
        clamp(&mut centre);
    }
    let d = run(std::slice::from_ref(&centre))?[0];
    evaluations += 1;
    let before = *before.get_or_insert(d);
    if loss(d, &centre) < best_loss {
        (best, best_d) = (centre, d);
    }
    Ok(Searched {
        shape: best,
        before,
        after: best_d,
        evaluations,
        draw_ms,
        network_ms,
    })
}

/// SplitMix64 with Box-Muller normals: reproducible without a dependency.
struct SplitMix(u64);

impl SplitMix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn uniform(&mut self) -> f32 {
        ((self.next() >> 40) as f32 + 0.5) / (1u64 << 24) as f32
    }
    fn normal(&mut self) -> f32 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f32::consts::TAU * v).cos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normals_are_standard_and_reproducible() {
        let mut r = SplitMix(7);
        let v: Vec<f32> = (0..20000).map(|_| r.normal()).collect();
        let mean = v.iter().sum::<f32>() / v.len() as f32;
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f32>() / v.len() as f32;
        assert!(
            mean.abs() < 0.03 && (var - 1.0).abs() < 0.05,
            "{mean} {var}"
        );
        let mut again = SplitMix(7);
        assert_eq!(again.normal(), v[0]);
    }

    #[test]
    fn a_search_of_n_faces_draws_about_n() {
        assert_eq!(SearchOptions::default().faces(), 11);
        assert_eq!(SearchOptions::with_faces(11), SearchOptions::default());
        for n in [5, 22, 30, 53, 100, 400] {
            let f = SearchOptions::with_faces(n).faces();
            assert!(f <= n.max(8) && f + 13 > n, "{n}: {f}");
        }
    }

    #[test]
    fn the_distance_is_cosine_and_refuses_nan() {
        assert!(distance(&[1.0, 0.0], &[2.0, 0.0]).abs() < 1e-6);
        assert!((distance(&[1.0, 0.0], &[0.0, 3.0]) - 1.0).abs() < 1e-6);
        assert_eq!(distance(&[f32::NAN, 0.0], &[1.0, 0.0]), 2.0);
        assert_eq!(distance(&[0.0, 0.0], &[1.0, 0.0]), 2.0);
    }

    #[test]
    fn the_similarity_recovers_a_turned_scaled_shift_and_refuses_a_point() {
        let (a, b, tx, ty) = (0.8f32, -0.35f32, 12.0f32, -7.5f32);
        let dst: [[f32; 2]; 5] =
            TEMPLATE.map(|p| [a * p[0] - b * p[1] + tx, b * p[0] + a * p[1] + ty]);
        let got = similarity(&TEMPLATE, &dst).expect("a transform");
        for (g, w) in got.iter().zip([a, b, tx, ty]) {
            assert!((g - w).abs() < 1e-3, "{got:?}");
        }
        assert!(similarity(&[[1.0, 1.0]; 5], &TEMPLATE).is_none());
    }

    #[test]
    fn the_similarity_maps_the_template_onto_itself_scaled() {
        let dst: [[f32; 2]; 5] = TEMPLATE.map(|p| [2.0 * p[0] + 3.0, 2.0 * p[1] - 1.0]);
        let s = similarity(&TEMPLATE, &dst).expect("similarity");
        assert!((s[0] - 2.0).abs() < 1e-4 && s[1].abs() < 1e-4, "{s:?}");
        assert!(
            (s[2] - 3.0).abs() < 1e-3 && (s[3] + 1.0).abs() < 1e-3,
            "{s:?}"
        );
    }
}
