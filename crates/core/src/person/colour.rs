//! The colour models of the person pass: an opponent colour space, Gaussian mixtures fitted
//! and refitted as in GrabCut, and the small image helpers the labelling uses.

/// A colour as the models see it: brightness and two opponent chroma axes, 0..1 scale.
pub(super) type Colour = [f32; 3];

pub(super) fn colour(p: [f32; 3]) -> Colour {
    let [r, g, b] = p;
    [(r + g + b) / 3.0, r - g, 0.5 * (r + g) - b]
}

/// One Gaussian of a mixture, full covariance.
#[derive(Clone, Debug)]
pub(super) struct Gauss {
    mean: Colour,
    inv: [[f32; 3]; 3],
    /// log(weight) - log(sqrt((2 pi)^3 det)).
    log_norm: f32,
}

impl Gauss {
    pub(super) fn d2(&self, c: Colour) -> f32 {
        let d = [
            c[0] - self.mean[0],
            c[1] - self.mean[1],
            c[2] - self.mean[2],
        ];
        let mut s = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                s += d[i] * self.inv[i][j] * d[j];
            }
        }
        s
    }
}

/// A Gaussian mixture over colours.
#[derive(Clone, Debug)]
pub(super) struct Gmm(Vec<Gauss>);

impl Gmm {
    /// Fits `k` components (k-means from farthest-point seeds, then one Gaussian per
    /// cluster); `None` with fewer than 20 samples. Deterministic.
    pub(super) fn fit(samples: &[Colour], k: usize) -> Option<Gmm> {
        if samples.len() < 20 {
            return None;
        }
        // At most about 3000 samples, evenly strided.
        let stride = samples.len().div_ceil(3000);
        let xs: Vec<Colour> = samples.iter().step_by(stride).copied().collect();
        let dist = |a: &Colour, b: &Colour| (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f32>();
        let mean = mean_of(&xs);
        let mut centres = vec![mean];
        while centres.len() < k.min(xs.len()) {
            let far = xs.iter().max_by(|a, b| {
                let da = centres.iter().map(|c| dist(a, c)).fold(f32::MAX, f32::min);
                let db = centres.iter().map(|c| dist(b, c)).fold(f32::MAX, f32::min);
                da.total_cmp(&db)
            })?;
            centres.push(*far);
        }
        let members_of = |c: usize, assign: &[usize]| -> Vec<Colour> {
            xs.iter()
                .zip(assign)
                .filter(|(_, a)| **a == c)
                .map(|(x, _)| *x)
                .collect()
        };
        let mut assign = vec![0usize; xs.len()];
        for _ in 0..8 {
            for (a, x) in assign.iter_mut().zip(&xs) {
                *a = (0..centres.len())
                    .min_by(|&i, &j| dist(x, &centres[i]).total_cmp(&dist(x, &centres[j])))
                    .unwrap_or(0);
            }
            for (c, centre) in centres.iter_mut().enumerate() {
                let members = members_of(c, &assign);
                if !members.is_empty() {
                    *centre = mean_of(&members);
                }
            }
        }
        let mut comps = Vec::new();
        for c in 0..centres.len() {
            let members = members_of(c, &assign);
            if members.len() < 5 {
                continue;
            }
            let m = mean_of(&members);
            let mut cov = [[0f32; 3]; 3];
            for x in &members {
                for i in 0..3 {
                    for j in 0..3 {
                        cov[i][j] += (x[i] - m[i]) * (x[j] - m[j]) / members.len() as f32;
                    }
                }
            }
            // Noise floor: JPEG and sensor noise, about 2 % of full scale.
            for (i, row) in cov.iter_mut().enumerate() {
                row[i] += 0.02f32.powi(2);
            }
            let mat = nalgebra::Matrix3::from_fn(|i, j| f64::from(cov[i][j]));
            let det = mat.determinant();
            let inv = mat.try_inverse()?;
            let weight = members.len() as f64 / xs.len() as f64;
            comps.push(Gauss {
                mean: m,
                inv: std::array::from_fn(|i| std::array::from_fn(|j| inv[(i, j)] as f32)),
                log_norm: (weight.ln()
                    - 0.5 * ((2.0 * std::f64::consts::PI).powi(3) * det.max(1e-30)).ln())
                    as f32,
            });
        }
        (!comps.is_empty()).then_some(Gmm(comps))
    }

    /// The mixture's log density (log-sum-exp). Called for every canvas pixel each round:
    /// no allocation (each component's term is computed twice, cheaper than a heap buffer).
    pub(super) fn log_pdf(&self, c: Colour) -> f32 {
        let term = |g: &Gauss| g.log_norm - 0.5 * g.d2(c);
        let m = self.0.iter().map(term).fold(f32::NEG_INFINITY, f32::max);
        m + self.0.iter().map(|g| (term(g) - m).exp()).sum::<f32>().ln()
    }

    /// The smallest squared Mahalanobis distance to a component.
    pub(super) fn d2(&self, c: Colour) -> f32 {
        self.0.iter().map(|g| g.d2(c)).fold(f32::MAX, f32::min)
    }
}

pub(super) fn mean_of(xs: &[Colour]) -> Colour {
    let n = xs.len().max(1) as f32;
    let mut m = [0f32; 3];
    for x in xs {
        for i in 0..3 {
            m[i] += x[i] / n;
        }
    }
    m
}

/// Even-odd point-in-polygon.
pub(crate) fn inside(poly: &[[f32; 2]], p: [f32; 2]) -> bool {
    let mut c = false;
    let mut j = poly.len() - 1;
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[j]);
        if (a[1] > p[1]) != (b[1] > p[1])
            && p[0] < (b[0] - a[0]) * (p[1] - a[1]) / (b[1] - a[1]) + a[0]
        {
            c = !c;
        }
        j = i;
    }
    c
}

/// Box blur of a canvas field, radius `r` pixels, edges renormalised.
/// Whether `p` and the points `inset` away from it in the four directions and the diagonals
/// (0.7 of it) all lie in `region` (head frame, IOD): a cell that far inside a region's
/// outline, so the outline's own edge is not read as the region's texture.
pub(super) fn inside_by(region: &dyn Fn([f32; 2]) -> bool, p: [f32; 2], inset: f32) -> bool {
    let (d, e) = (inset, 0.7 * inset);
    [
        [0.0, 0.0],
        [d, 0.0],
        [-d, 0.0],
        [0.0, d],
        [0.0, -d],
        [e, e],
        [-e, e],
        [e, -e],
        [-e, -e],
    ]
    .iter()
    .all(|o| region([p[0] + o[0], p[1] + o[1]]))
}

pub(super) fn box_blur(f: &[f32], w: usize, h: usize, r: usize) -> Vec<f32> {
    let pass = |src: &[f32], horizontal: bool| {
        let mut out = vec![0f32; src.len()];
        let (n, m) = if horizontal { (h, w) } else { (w, h) };
        for line in 0..n {
            let idx = |k: usize| {
                if horizontal {
                    line * w + k
                } else {
                    k * w + line
                }
            };
            let mut prefix = vec![0f32; m + 1];
            for k in 0..m {
                prefix[k + 1] = prefix[k] + src[idx(k)];
            }
            for k in 0..m {
                let (lo, hi) = (k.saturating_sub(r), (k + r + 1).min(m));
                out[idx(k)] = (prefix[hi] - prefix[lo]) / (hi - lo) as f32;
            }
        }
        out
    };
    pass(&pass(f, true), false)
}
