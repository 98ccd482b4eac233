//! The compact copy of a landmark model: the predictor's own arrays written out once, so a
//! later start reads them back with one read instead of decoding dlib's 100 MB of variable-
//! length integers and floats (about 450 ms on this project's machine).
//!
//! Layout (all little-endian; sizes in bytes):
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 8 | magic `GLYPTERT` |
//! | 8 | 4 | format version (1) |
//! | 12 | 4 | zero |
//! | 16 | 32 | SHA-256 of the dlib file this copy was made from |
//! | 48 | 16 | XXH3-128 of everything from offset 80 on (the payload) |
//! | 64 | 16 | zero |
//! | 80 | 16 | `num_parts`, `num_levels`, tree `depth`, zero (u32 each) |
//! | 96 | 8 per level | trees, feature pixels (u32 each) |
//! | | 8 per part | mean shape (f32 x, y) |
//! | | 12 per split | `idx1`, `idx2` (u32), `thresh` (f32) |
//! | | 4 per leaf value | leaves (f32) |
//! | | 4 per feature | anchors (u32) |
//! | | 8 per feature | deltas (f32 x, y) |
//!
//! Trust: the copy is used only when its source digest equals the one the checksum list gives
//! for the dlib file (so it was made from the very file set-up verified), and its payload
//! hashes to its own checksum; then it is checked exactly as
//! a parsed model is ([`ShapePredictor::assemble`]: every index in range, sizes consistent;
//! every value finite here). Its predictions are bit-identical to the parsed model's: the
//! arrays are the same `f32` and `u32` values. The payload's checksum is XXH3-128, not SHA-256:
//! it is there to catch a damaged or cut copy (which any 128-bit checksum does), and it hashes
//! the 66 MB in a few milliseconds where SHA-256 takes about 40 on this machine. Whoever could
//! forge a copy could as well edit the checksum list itself.

use xxhash_rust::xxh3::xxh3_128;

use super::{LandmarkError, Leaves, Level, Parts, ShapePredictor, Split};

/// The file's first eight bytes.
const MAGIC: &[u8; 8] = b"GLYPTERT";
/// Bumped whenever the layout changes; an older copy is then made again.
const VERSION: u32 = 1;
/// Bytes before the payload.
const HEADER: usize = 80;
/// Deeper trees would have more leaves than any file could hold.
const MAX_DEPTH: u32 = 24;

/// File name suffix of the compact copy, added to the dlib file's name beside it.
pub const COMPACT_SUFFIX: &str = ".compact";

fn compact_err(problem: impl Into<String>) -> LandmarkError {
    LandmarkError::Model {
        field: "compact copy".into(),
        problem: problem.into(),
    }
}

fn put_u32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_f32(out: &mut Vec<u8>, v: f32) {
    out.extend_from_slice(&v.to_le_bytes());
}

/// A little-endian cursor whose reads are checked against the bytes left.
struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], LandmarkError> {
        let end = self
            .pos
            .checked_add(n)
            .filter(|&e| e <= self.bytes.len())
            .ok_or_else(|| compact_err(format!("cut short in its {what}")))?;
        let s = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(s)
    }

    fn u32(&mut self, what: &str) -> Result<u32, LandmarkError> {
        let b = self.take(4, what)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// `count` records of `size` bytes, each decoded by `f` (checked size first, so a bad
    /// count allocates nothing).
    fn records<T>(
        &mut self,
        count: usize,
        size: usize,
        what: &str,
        f: impl Fn(&[u8]) -> T,
    ) -> Result<Vec<T>, LandmarkError> {
        let n = count
            .checked_mul(size)
            .ok_or_else(|| compact_err(format!("{what}: size overflows")))?;
        Ok(self.take(n, what)?.chunks_exact(size).map(f).collect())
    }

    /// Skips `count` floats, saying where they lie (bytes from the cursor's start).
    fn skip_f32s(
        &mut self,
        count: usize,
        what: &str,
    ) -> Result<std::ops::Range<usize>, LandmarkError> {
        let n = count
            .checked_mul(4)
            .ok_or_else(|| compact_err(format!("{what}: size overflows")))?;
        let start = self.pos;
        self.take(n, what)?;
        Ok(start..self.pos)
    }
}

/// True when no value is infinite or NaN; branch-free so that it vectorises (16 M leaves).
fn all_finite(values: &[f32]) -> bool {
    const EXPONENT: u32 = 0x7f80_0000;
    values.chunks(1024).all(|c| {
        c.iter().fold(0u32, |acc, v| {
            acc | u32::from(v.to_bits() & EXPONENT == EXPONENT)
        }) == 0
    })
}

fn le_u32(b: &[u8]) -> u32 {
    u32::from_le_bytes([b[0], b[1], b[2], b[3]])
}

fn le_f32(b: &[u8]) -> f32 {
    f32::from_le_bytes([b[0], b[1], b[2], b[3]])
}

impl ShapePredictor {
    /// This model as a compact copy (see the module doc), recording the SHA-256 of the dlib
    /// file it was read from.
    pub fn to_compact(&self, source_sha256: &[u8; 32]) -> Vec<u8> {
        let mut p = Vec::with_capacity(
            16 + 8 * self.levels.len()
                + 8 * self.mean.len()
                + 12 * self.splits.len()
                + 4 * self.leaves.len
                + 12 * self.anchors.len(),
        );
        put_u32(&mut p, self.mean.len() as u32);
        put_u32(&mut p, self.levels.len() as u32);
        put_u32(&mut p, self.depth);
        put_u32(&mut p, 0);
        for l in &self.levels {
            put_u32(&mut p, l.num_trees as u32);
            put_u32(&mut p, l.num_features as u32);
        }
        for m in &self.mean {
            put_f32(&mut p, m[0]);
            put_f32(&mut p, m[1]);
        }
        for s in &self.splits {
            put_u32(&mut p, s.idx1);
            put_u32(&mut p, s.idx2);
            put_f32(&mut p, s.thresh);
        }
        for &v in self.leaves.as_slice() {
            put_f32(&mut p, v);
        }
        for &a in &self.anchors {
            put_u32(&mut p, a);
        }
        for d in &self.deltas {
            put_f32(&mut p, d[0]);
            put_f32(&mut p, d[1]);
        }
        let mut out = Vec::with_capacity(HEADER + p.len());
        out.extend_from_slice(MAGIC);
        put_u32(&mut out, VERSION);
        put_u32(&mut out, 0);
        out.extend_from_slice(source_sha256);
        out.extend_from_slice(&xxh3_128(&p).to_le_bytes());
        out.extend_from_slice(&[0; 16]);
        out.extend_from_slice(&p);
        out
    }

    /// Reads a compact copy made from the dlib file whose SHA-256 is `source_sha256`, its
    /// payload checked against its checksum before anything is read from it.
    pub fn from_compact(bytes: &[u8], source_sha256: &[u8; 32]) -> Result<Self, LandmarkError> {
        let mut words = vec![0.0f32; bytes.len().div_ceil(4)];
        bytemuck::cast_slice_mut::<f32, u8>(&mut words)[..bytes.len()].copy_from_slice(bytes);
        Self::from_compact_words(words, bytes.len(), source_sha256)
    }

    /// As [`ShapePredictor::from_compact`], on a file's `len` bytes held in `words` (4-byte
    /// aligned, as [`read_compact`] reads them): the leaves stay where they lie.
    pub(super) fn from_compact_words(
        words: Vec<f32>,
        len: usize,
        source_sha256: &[u8; 32],
    ) -> Result<Self, LandmarkError> {
        let bytes = bytemuck::cast_slice::<f32, u8>(&words)
            .get(..len)
            .ok_or_else(|| compact_err("shorter than its stated length"))?;
        if bytes.len() < HEADER || &bytes[..8] != MAGIC {
            return Err(compact_err("not a glyptic compact landmark model"));
        }
        let version = le_u32(&bytes[8..12]);
        if version != VERSION {
            return Err(compact_err(format!(
                "format version {version}, this build reads {VERSION}"
            )));
        }
        if &bytes[16..48] != source_sha256 {
            return Err(compact_err("made from another dlib file"));
        }
        let payload = &bytes[HEADER..];
        if xxh3_128(payload).to_le_bytes() != bytes[48..64] {
            return Err(compact_err(
                "damaged (its payload does not match its checksum)",
            ));
        }
        let (parts, at) = read_parts(payload)?;
        // Every record before the leaves is a whole number of 4-byte words, and so is the
        // header: the leaves start on a word.
        let (start, end) = (HEADER + at.start, HEADER + at.end);
        if start % 4 != 0 {
            return Err(compact_err("its leaves do not start on a 4-byte word"));
        }
        let mut leaves = Leaves {
            words,
            start: start / 4,
            len: (end - start) / 4,
        };
        if cfg!(target_endian = "big") {
            let span = leaves.start..leaves.start + leaves.len;
            for w in &mut leaves.words[span] {
                *w = f32::from_bits(u32::from_le(w.to_bits()));
            }
        }
        if !all_finite(leaves.as_slice()) {
            return Err(compact_err("a value is not finite"));
        }
        Self::assemble(Parts { leaves, ..parts })
    }
}

/// Reads a compact copy's bytes into 4-byte words (zeroed pages the read fills once: no
/// second copy), refusing a file over `max` bytes or one that is not a regular file.
pub(super) fn read_compact(path: &std::path::Path, max: u64) -> std::io::Result<(Vec<f32>, usize)> {
    use std::io::Read as _;
    let len = usize::try_from(crate::files::regular_file_len(path, max)?)
        .map_err(|_| std::io::Error::new(std::io::ErrorKind::InvalidInput, "too large"))?;
    let mut words = vec![0.0f32; len.div_ceil(4)];
    let mut file = std::fs::File::open(path)?;
    file.read_exact(&mut bytemuck::cast_slice_mut::<f32, u8>(&mut words)[..len])?;
    Ok((words, len))
}

/// The arrays of a compact payload, sized from its counts and checked to fill it exactly;
/// the leaves are left where they lie (their byte range in `payload` is returned with an
/// empty array in their place).
fn read_parts(payload: &[u8]) -> Result<(Parts, std::ops::Range<usize>), LandmarkError> {
    let mut c = Cursor {
        bytes: payload,
        pos: 0,
    };
    let num_parts = c.u32("counts")? as usize;
    let num_levels = c.u32("counts")? as usize;
    let depth = c.u32("counts")?;
    c.u32("counts")?;
    if num_parts == 0 || depth > MAX_DEPTH {
        return Err(compact_err(format!(
            "{num_parts} parts, trees of depth {depth}"
        )));
    }
    let sizes = c.records(num_levels, 8, "levels", |b| {
        (le_u32(b) as usize, le_u32(&b[4..]) as usize)
    })?;
    let mut levels = Vec::with_capacity(num_levels);
    let (mut trees, mut features) = (0usize, 0usize);
    for (num_trees, num_features) in sizes {
        levels.push(Level {
            first_tree: trees,
            num_trees,
            first_feature: features,
            num_features,
        });
        trees += num_trees;
        features += num_features;
    }
    let splits_per_tree = (1usize << depth) - 1;
    let leaf_values = (1usize << depth)
        .checked_mul(2 * num_parts)
        .and_then(|n| n.checked_mul(trees))
        .ok_or_else(|| compact_err("leaf count overflows"))?;
    let mean = c.records(num_parts, 8, "mean shape", |b| [le_f32(b), le_f32(&b[4..])])?;
    let splits = c.records(
        trees
            .checked_mul(splits_per_tree)
            .ok_or_else(|| compact_err("split count overflows"))?,
        12,
        "splits",
        |b| Split {
            idx1: le_u32(b),
            idx2: le_u32(&b[4..]),
            thresh: le_f32(&b[8..]),
        },
    )?;
    let leaves = c.skip_f32s(leaf_values, "leaves")?;
    let anchors = c.records(features, 4, "anchors", le_u32)?;
    let deltas = c.records(features, 8, "deltas", |b| [le_f32(b), le_f32(&b[4..])])?;
    if c.pos != payload.len() {
        return Err(compact_err(format!(
            "{} bytes after its last array",
            payload.len() - c.pos
        )));
    }
    let finite = mean
        .iter()
        .chain(&deltas)
        .all(|p| p[0].is_finite() && p[1].is_finite())
        && splits.iter().all(|s| s.thresh.is_finite());
    if !finite {
        return Err(compact_err("a value is not finite"));
    }
    Ok((
        Parts {
            mean,
            levels,
            depth,
            splits,
            leaves: Leaves::owned(Vec::new()),
            anchors,
            deltas,
        },
        leaves,
    ))
}
