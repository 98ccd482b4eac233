//! Reading a dlib `shape_predictor` file (or the compact copy made from it, `compact`) into
//! [`ShapePredictor`]'s flat layout, every index and size validated so that the regression
//! can never read out of bounds. The regression itself is the parent module's.

use std::path::Path;

use super::super::LandmarkError;
use super::super::dlib_format::{MIN_FLOAT_BYTES, MIN_INT_BYTES, Reader};
use super::{Leaves, Level, Parts, ShapePredictor, Split, centre, compact};

/// The only serialization version of `dlib::shape_predictor` that exists.
const SERIALIZATION_VERSION: i32 = 1;

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
            leaves: Leaves::owned(leaves),
            anchors,
            deltas,
        })
    }

    /// The checks every reader shares, once the arrays have their sizes: every split indexes
    /// the feature pixels of its own level, every anchor a part; then the derived fields.
    pub(super) fn assemble(p: Parts) -> Result<Self, LandmarkError> {
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
            || leaves.len != trees * leaves_per_tree * 2 * num_parts
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
        let remade = match compact::read_compact(&copy, crate::files::MAX_MODEL_BYTES) {
            Ok((words, len)) => match Self::from_compact_words(words, len, &sha) {
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
