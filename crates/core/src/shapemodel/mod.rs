//! The Surrey Face Model (SFM) and the files that describe it, read from eos's formats.
//!
//! Units: model coordinates are millimetres, right-handed, y up, the face looking along +z
//! (the mean face spans about x +-74, y -83..105, z -104..3.4). Vertex ids are 0-based here;
//! eos's text and JSON files use 1-based landmark names and (for the edge topology) 1-based ids.
//!
//! Parsing is pure (`parse_*` take bytes or text); [`SurreyModel::load_dir`] is the one place
//! that reads files, so every error can name the file and the field that is wrong.
//!
//! Licence of the data: free for non-commercial use only (see README.md).

mod cereal;
mod parse;

pub use parse::{
    parse_blendshapes, parse_edge_topology, parse_mapping, parse_model_contour, parse_shape_model,
};

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use nalgebra::{DMatrix, DVector};

use crate::simd::with_avx2;

pub use cereal::CerealError;

/// Number of vertices of the low-resolution SFM.
pub const SFM_VERTICES: usize = 3448;

/// File names inside a Surrey model folder, as eos ships them.
pub const SHAPE_FILE: &str = "sfm_shape_3448.bin";
pub const BLENDSHAPES_FILE: &str = "expression_blendshapes_3448.bin";
pub const MAPPING_FILE: &str = "ibug_to_sfm.txt";
pub const CONTOURS_FILE: &str = "sfm_model_contours.json";
pub const EDGE_TOPOLOGY_FILE: &str = "sfm_3448_edge_topology.json";

/// The contents of the five files of a Surrey model folder, for [`SurreyModel::from_parts`].
#[derive(Clone, Copy, Debug)]
pub struct ModelFiles<'a> {
    /// [`SHAPE_FILE`]
    pub shape: &'a [u8],
    /// [`BLENDSHAPES_FILE`]
    pub blendshapes: &'a [u8],
    /// [`MAPPING_FILE`]
    pub mapping: &'a str,
    /// [`CONTOURS_FILE`]
    pub contours: &'a str,
    /// [`EDGE_TOPOLOGY_FILE`]
    pub edge_topology: &'a str,
}

/// Why a model file could not be used. Each variant names the file and what is wrong.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    #[error("{path}: cannot read: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error(
        "{path}: not found. The Surrey Face Model files come from the share/ folder of the eos \
         library (github.com/patrikhuber/eos); free for non-commercial use only. Run \
         scripts/setup.sh or set GLYPTIC_SFM_DIR to a folder holding them"
    )]
    Missing { path: PathBuf },
    #[error("{file}: {field}: {source}")]
    Binary {
        file: String,
        field: &'static str,
        source: CerealError,
    },
    #[error("{file}: {field}: {problem}")]
    Invalid {
        file: String,
        field: String,
        problem: String,
    },
}

impl ModelError {
    fn invalid(file: &str, field: impl Into<String>, problem: impl Into<String>) -> Self {
        ModelError::Invalid {
            file: file.to_string(),
            field: field.into(),
            problem: problem.into(),
        }
    }

    /// The error with its file named by its path in `dir` (the parsers know only file names).
    fn in_folder(self, dir: &Path) -> Self {
        let path = |file: String| dir.join(file).display().to_string();
        match self {
            ModelError::Binary {
                file,
                field,
                source,
            } => ModelError::Binary {
                file: path(file),
                field,
                source,
            },
            ModelError::Invalid {
                file,
                field,
                problem,
            } => ModelError::Invalid {
                file: path(file),
                field,
                problem,
            },
            other => other,
        }
    }
}

/// A PCA shape model: `shape = mean + basis * diag(sqrt(eigenvalues)) * coefficients`.
#[derive(Clone, Debug)]
pub struct ShapeModel {
    /// Mean shape, `[x0, y0, z0, x1, ...]`, mm.
    pub mean: DVector<f32>,
    /// Orthonormal basis, 3N x K.
    pub orthonormal_basis: DMatrix<f32>,
    /// PCA variances (mm^2), K.
    pub eigenvalues: DVector<f32>,
    /// Basis with each column scaled by `sqrt(eigenvalue)`: coefficients are then N(0, 1).
    pub rescaled_basis: DMatrix<f32>,
    /// Triangles, 0-based vertex ids, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
    /// Texture coordinates per vertex.
    pub texcoords: Vec<[f64; 2]>,
}

impl ShapeModel {
    pub fn num_vertices(&self) -> usize {
        self.mean.len() / 3
    }

    pub fn num_components(&self) -> usize {
        self.orthonormal_basis.ncols()
    }

    /// Mean position of vertex `v`.
    pub fn mean_vertex(&self, v: usize) -> [f32; 3] {
        [self.mean[3 * v], self.mean[3 * v + 1], self.mean[3 * v + 2]]
    }
}

/// A portrait artist's exaggeration of a face's difference from the mean face.
///
/// Identity coefficient `k` (in standard deviations) is multiplied by
/// `gain * (λ_0 / λ_k)^(detail / 2)`, `λ` the model's variances. The model's large components
/// (face size, width, length) vary most between people but are also what a single photo's
/// landmarks get most wrong; its small ones (the nose's bridge, the set of the eyes, the
/// chin's shape) are a few tenths of a millimetre on the mean face and vanish once the face is
/// carved, yet they are what tells two faces apart best: measured on deepface's photos
/// (`cargo run --release --example likeness`), a face's nearest fitted neighbour is the same
/// person's for 61 % by millimetres and 82 % by standard deviations. `detail` moves the carved
/// face from the first towards the second.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Caricature {
    /// Multiplies every identity coefficient (1 with `detail` 0: the fitted face unchanged).
    pub gain: f32,
    /// How much more the model's small components are exaggerated than its large ones: 0 all
    /// alike, 1 every component as large in millimetres as the first.
    pub detail: f32,
}

impl Caricature {
    /// The fitted face as it is.
    pub const NONE: Caricature = Caricature {
        gain: 1.0,
        detail: 0.0,
    };

    /// The likeness test's choice (see BENCHMARKS.md, "The caricature").
    pub const PORTRAIT: Caricature = Caricature {
        gain: 1.0,
        detail: 0.5,
    };

    /// Both numbers finite, the gain in 0..=4 and the detail in 0..=1.
    pub fn is_valid(&self) -> bool {
        (0.0..=4.0).contains(&self.gain) && (0.0..=1.0).contains(&self.detail)
    }
}

impl Default for Caricature {
    fn default() -> Self {
        Caricature::PORTRAIT
    }
}

impl ShapeModel {
    /// Identity coefficients with the caricature applied (missing coefficients stay 0; a
    /// caricature outside [`Caricature::is_valid`] leaves them as they are).
    pub fn caricature(&self, shape: &[f32], c: Caricature) -> Vec<f32> {
        let ev = &self.eigenvalues;
        let first = ev.iter().copied().fold(0.0f32, f32::max);
        if !c.is_valid() || first <= 0.0 {
            return shape.to_vec();
        }
        shape
            .iter()
            .enumerate()
            .map(|(k, &v)| match ev.get(k) {
                Some(&l) if l > 0.0 => v * c.gain * (first / l).powf(0.5 * c.detail),
                _ => v * c.gain,
            })
            .collect()
    }
}

/// Expression blendshapes: offsets from the neutral face, one column per expression.
#[derive(Clone, Debug)]
pub struct Blendshapes {
    pub names: Vec<String>,
    /// 3N x E offsets, mm.
    pub offsets: DMatrix<f32>,
}

/// Which 2D landmarks (iBUG 68, 1-based names) map to which model vertex.
#[derive(Clone, Debug, Default)]
pub struct LandmarkMapping {
    /// iBUG landmark number (1-based) -> vertex id (0-based).
    pub to_vertex: BTreeMap<u32, u32>,
    /// iBUG landmarks of the subject's right contour (1-based), in order.
    pub contour_right: Vec<u32>,
    /// iBUG landmarks of the left contour (1-based), in order.
    pub contour_left: Vec<u32>,
}

/// Model vertices (0-based) along the face outline, candidates for contour landmarks.
#[derive(Clone, Debug, Default)]
pub struct ModelContour {
    pub right: Vec<u32>,
    pub left: Vec<u32>,
}

/// Mesh adjacency used to find occluding edges: for each edge, its two faces and two vertices,
/// 0-based, `None` where the edge lies on the mesh boundary.
#[derive(Clone, Debug, Default)]
pub struct EdgeTopology {
    pub adjacent_faces: Vec<[Option<u32>; 2]>,
    pub adjacent_vertices: Vec<[Option<u32>; 2]>,
}

/// Everything eos ships for the SFM, validated against each other.
#[derive(Clone, Debug)]
pub struct SurreyModel {
    pub shape: ShapeModel,
    pub blendshapes: Blendshapes,
    pub mapping: LandmarkMapping,
    pub contour: ModelContour,
    pub edges: EdgeTopology,
    /// Vertex-major copy of mean, rescaled identity basis and expression offsets.
    pub packed: PackedRows,
    /// Built on first use by [`SurreyModel::landmark_products`].
    products: OnceLock<BasisProducts>,
}

/// Axis pairs `(a, b)` of [`BasisProducts::sums`], in order.
pub const AXIS_PAIRS: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)];

/// Products of basis rows summed over a set of vertices, for fitting with an affine camera.
/// With `m_va` vertex `v`'s basis row for axis `a` (identity then expression coefficients) and
/// `J` the camera's 2x3 Jacobian, the same for every point, the Gauss-Newton Hessian of those
/// vertices' reprojection residuals is `sum_v M_v^T J^T J M_v = sum_ab (J^T J)_ab Q_ab` with
/// `Q_ab = sum_v m_va^T m_vb`: six fixed matrices summed with six weights instead of a Gram
/// product over two rows per vertex at every step.
#[derive(Clone, Debug, PartialEq)]
pub struct BasisProducts {
    /// Identity plus expression coefficients: each matrix is `columns x columns`, row-major.
    pub columns: usize,
    /// `Q_aa`, and `Q_ab + Q_ba` for `a != b`, in the order of [`AXIS_PAIRS`]: the upper
    /// triangles (the matrices are symmetric; entries below the diagonal stay 0).
    pub sums: [Vec<f64>; 6],
}

impl BasisProducts {
    pub fn new(columns: usize) -> Self {
        BasisProducts {
            columns,
            sums: std::array::from_fn(|_| vec![0.0; columns * columns]),
        }
    }

    /// Adds (`sign` 1) or removes (`sign` -1) the products of the given vertices (a vertex
    /// listed twice counts twice).
    pub fn add_vertices(&mut self, packed: &PackedRows, vertices: &[usize], sign: f64) {
        add_vertices(self, packed, vertices, sign);
    }
}

with_avx2! {
    fn add_vertices / add_vertices_avx2 => add_vertices_generic
        (products: &mut BasisProducts, packed: &PackedRows, vertices: &[usize], sign: f64)
}

impl BasisProducts {
    /// All vertices row by row of the six upper triangles, so that each row stays in cache
    /// while every vertex adds to it (a pass over all six matrices per vertex was bound by
    /// memory: 19 hidden landmarks cost 40 % of a fit).
    #[inline(always)]
    fn add_vertices_to(&mut self, packed: &PackedRows, vertices: &[usize], sign: f64) {
        let c = self.columns;
        let nv = vertices.len();
        if nv == 0 {
            return;
        }
        // rows[a][v * c + j], vertex-major per axis.
        let rows: [Vec<f64>; 3] = std::array::from_fn(|axis| {
            vertices
                .iter()
                .flat_map(|&v| {
                    let (_, identity, expr) = packed.row(3 * v + axis);
                    identity.iter().chain(expr).map(|&x| x as f64)
                })
                .collect()
        });
        let [r0, r1, r2] = &rows;
        let [s0, s1, s2, s3, s4, s5] = &mut self.sums;
        for i in 0..c {
            // Row i of the six matrices (a few kB) stays in cache while every vertex adds to it.
            let span = i * c + i..(i + 1) * c;
            let n = c - i;
            let d0 = &mut s0[span.clone()][..n];
            let d1 = &mut s1[span.clone()][..n];
            let d2 = &mut s2[span.clone()][..n];
            let d3 = &mut s3[span.clone()][..n];
            let d4 = &mut s4[span.clone()][..n];
            let d5 = &mut s5[span][..n];
            for v in 0..nv {
                let at = v * c + i;
                let (x0, x1, x2) = (&r0[at..at + n], &r1[at..at + n], &r2[at..at + n]);
                let (f0, f1, f2) = (sign * x0[0], sign * x1[0], sign * x2[0]);
                for j in 0..n {
                    d0[j] += f0 * x0[j];
                    d1[j] += f1 * x1[j];
                    d2[j] += f2 * x2[j];
                    d3[j] += f0 * x1[j] + f1 * x0[j];
                    d4[j] += f0 * x2[j] + f2 * x0[j];
                    d5[j] += f1 * x2[j] + f2 * x1[j];
                }
            }
        }
    }
}

#[inline(always)]
fn add_vertices_generic(
    products: &mut BasisProducts,
    packed: &PackedRows,
    vertices: &[usize],
    sign: f64,
) {
    products.add_vertices_to(packed, vertices, sign);
}

/// The model's rows laid out vertex-major: coordinate row `r = 3 v + axis` holds
/// `[mean, identity basis (K, eigenvalue-scaled), expression offsets (E)]` contiguously, so
/// that evaluating or differentiating one vertex reads one short run of memory (the
/// column-major PCA matrices put a vertex's values 10,344 floats apart). Rows are padded with
/// zeros to a multiple of eight floats, so a coordinate is one dot product with no scalar tail.
#[derive(Clone, Debug)]
pub struct PackedRows {
    pub identity: usize,
    pub expressions: usize,
    stride: usize,
    data: Vec<f32>,
}

impl PackedRows {
    pub fn new(shape: &ShapeModel, blendshapes: &Blendshapes) -> Self {
        let (k, e) = (shape.rescaled_basis.ncols(), blendshapes.offsets.ncols());
        let rows = shape.mean.len();
        let stride = (1 + k + e).next_multiple_of(8);
        let mut data = vec![0f32; rows * stride];
        for (r, row) in data.chunks_exact_mut(stride).enumerate() {
            row[0] = shape.mean[r];
            for c in 0..k {
                row[1 + c] = shape.rescaled_basis[(r, c)];
            }
            for c in 0..e {
                row[1 + k + c] = blendshapes.offsets[(r, c)];
            }
        }
        PackedRows {
            identity: k,
            expressions: e,
            stride,
            data,
        }
    }

    /// Coordinate row `r` (= 3 * vertex + axis): `(mean, identity row, expression row)`.
    #[inline]
    pub fn row(&self, r: usize) -> (f32, &[f32], &[f32]) {
        let row = &self.data[r * self.stride..(r + 1) * self.stride];
        let k = self.identity;
        (
            row[0],
            &row[1..1 + k],
            &row[1 + k..1 + k + self.expressions],
        )
    }

    /// Coordinate row `r` without its mean: identity then expression columns.
    #[inline]
    pub fn basis(&self, r: usize) -> &[f32] {
        &self.data[r * self.stride + 1..r * self.stride + 1 + self.identity + self.expressions]
    }

    pub fn rows(&self) -> usize {
        self.data.len() / self.stride
    }

    /// Floats per row, padding included (the length of [`PackedRows::coefficients`]).
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// Writes into `out` (at least [`PackedRows::stride`] long) the coefficient vector laid
    /// out like a row, `[1, identity, expressions, 0...]` (missing coefficients count as 0).
    #[inline]
    pub fn fill_coefficients(&self, identity: &[f32], expressions: &[f32], out: &mut [f32]) {
        let (k, e) = (self.identity, self.expressions);
        let (ki, ei) = (identity.len().min(k), expressions.len().min(e));
        let out = &mut out[..self.stride];
        out.fill(0.0);
        out[0] = 1.0;
        out[1..1 + ki].copy_from_slice(&identity[..ki]);
        out[1 + k..1 + k + ei].copy_from_slice(&expressions[..ei]);
    }

    /// Position of vertex `v` for a coefficient vector from [`PackedRows::fill_coefficients`].
    #[inline]
    pub fn point(&self, v: usize, coefficients: &[f32]) -> [f32; 3] {
        let rows = &self.data[3 * v * self.stride..3 * (v + 1) * self.stride];
        let (x, rest) = rows.split_at(self.stride);
        let (y, z) = rest.split_at(self.stride);
        [
            dot(x, coefficients),
            dot(y, coefficients),
            dot(z, coefficients),
        ]
    }

    /// All coordinates for the given coefficients (missing ones count as 0), `[x0, y0, z0, ...]`.
    pub fn evaluate(&self, identity: &[f32], expressions: &[f32]) -> Vec<f32> {
        let mut coeffs = vec![0f32; self.stride];
        self.fill_coefficients(identity, expressions, &mut coeffs);
        self.data
            .chunks_exact(self.stride)
            .map(|row| dot(row, &coeffs))
            .collect()
    }
}

/// Dot product with eight independent partial sums, which the compiler can keep in SIMD
/// registers (a single running sum fixes the order of additions and cannot be vectorised).
#[inline(always)]
pub fn dot(a: &[f32], b: &[f32]) -> f32 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0f32; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for i in 0..8 {
            acc[i] += x[i] * y[i];
        }
    }
    let tail: f32 = ra.iter().zip(rb).map(|(x, y)| x * y).sum();
    acc.iter().sum::<f32>() + tail
}

impl SurreyModel {
    /// [`BasisProducts`] summed over every landmark of the iBUG mapping (one term per
    /// landmark), computed on first use (about a millisecond) and kept.
    pub fn landmark_products(&self) -> &BasisProducts {
        self.products.get_or_init(|| {
            let mut products = BasisProducts::new(self.packed.identity + self.packed.expressions);
            let vertices: Vec<usize> = self
                .mapping
                .to_vertex
                .values()
                .map(|&v| v as usize)
                .collect();
            products.add_vertices(&self.packed, &vertices, 1.0);
            products
        })
    }

    /// Reads the five files from `dir` (each verified against the checksum list beside them,
    /// if there is one: [`crate::files::read_verified`]) and checks that they agree.
    pub fn load_dir(dir: &Path) -> Result<Self, ModelError> {
        let read = |name: &str| -> Result<Vec<u8>, ModelError> {
            let path = dir.join(name);
            crate::files::read_verified(&path).map_err(|source| {
                if source.kind() == std::io::ErrorKind::NotFound {
                    ModelError::Missing { path: path.clone() }
                } else {
                    ModelError::Io {
                        path: path.clone(),
                        source,
                    }
                }
            })
        };
        let text = |name: &str| -> Result<String, ModelError> {
            String::from_utf8(read(name)?)
                .map_err(|_| ModelError::invalid(name, "text", "not valid UTF-8"))
        };
        Self::from_parts(&ModelFiles {
            shape: &read(SHAPE_FILE)?,
            blendshapes: &read(BLENDSHAPES_FILE)?,
            mapping: &text(MAPPING_FILE)?,
            contours: &text(CONTOURS_FILE)?,
            edge_topology: &text(EDGE_TOPOLOGY_FILE)?,
        })
        .map_err(|e| e.in_folder(dir))
    }

    /// Parses the five files' contents (named as in eos's folder in errors) and checks that
    /// they agree with each other: what [`SurreyModel::load_dir`] does once it has read them.
    pub fn from_parts(files: &ModelFiles) -> Result<Self, ModelError> {
        let shape = parse_shape_model(files.shape, SHAPE_FILE)?;
        let blendshapes = parse_blendshapes(files.blendshapes, BLENDSHAPES_FILE)?;
        let mapping = parse_mapping(files.mapping, MAPPING_FILE)?;
        let contour = parse_model_contour(files.contours, CONTOURS_FILE)?;
        let edges = parse_edge_topology(files.edge_topology, EDGE_TOPOLOGY_FILE)?;
        // Checked before the rows are packed, which assumes they agree.
        check_blendshape_rows(&shape, &blendshapes)?;
        let packed = PackedRows::new(&shape, &blendshapes);
        let model = SurreyModel {
            shape,
            blendshapes,
            mapping,
            contour,
            edges,
            packed,
            products: OnceLock::new(),
        };
        model.validate()?;
        Ok(model)
    }

    /// Cross-file checks: every id refers to something that exists.
    fn validate(&self) -> Result<(), ModelError> {
        let n = self.shape.num_vertices() as u32;
        let nt = self.shape.triangles.len() as u32;
        // A cut-off mapping still parses (TOML tables simply end); the fit would then use a
        // few landmarks without a word. The brows, nose, eyes and outer lips (iBUG 18-60) are
        // what any 68-point fit stands on: all must be mapped.
        let missing: Vec<u32> = (18..=60)
            .filter(|lm| !self.mapping.to_vertex.contains_key(lm))
            .collect();
        if let (Some(first), Some(last)) = (missing.first(), missing.last()) {
            return Err(ModelError::invalid(
                MAPPING_FILE,
                "landmark_mappings",
                format!(
                    "maps {} landmarks; iBUG 18-60 (brows, nose, eyes, lips) must all be mapped, \
                     {} are not ({first}..{last}): is the file cut off?",
                    self.mapping.to_vertex.len(),
                    missing.len()
                ),
            ));
        }
        for (lm, v) in &self.mapping.to_vertex {
            if *v >= n {
                return Err(ModelError::invalid(
                    MAPPING_FILE,
                    format!("landmark_mappings.{lm}"),
                    format!("vertex {v} does not exist (model has {n})"),
                ));
            }
        }
        for (side, ids) in [
            ("right_contour", &self.contour.right),
            ("left_contour", &self.contour.left),
        ] {
            if let Some(v) = ids.iter().find(|&&v| v >= n) {
                return Err(ModelError::invalid(
                    CONTOURS_FILE,
                    side,
                    format!("vertex {v} does not exist (model has {n})"),
                ));
            }
        }
        for (i, pair) in self.edges.adjacent_faces.iter().enumerate() {
            if let Some(f) = pair.iter().flatten().find(|&&f| f >= nt) {
                return Err(ModelError::invalid(
                    EDGE_TOPOLOGY_FILE,
                    format!("adjacent_faces[{i}]"),
                    format!("face {} does not exist (model has {nt})", f + 1),
                ));
            }
        }
        for (i, pair) in self.edges.adjacent_vertices.iter().enumerate() {
            if let Some(v) = pair.iter().flatten().find(|&&v| v >= n) {
                return Err(ModelError::invalid(
                    EDGE_TOPOLOGY_FILE,
                    format!("adjacent_vertices[{i}]"),
                    format!("vertex {} does not exist (model has {n})", v + 1),
                ));
            }
        }
        Ok(())
    }
}

/// The expression blendshapes must have one row per coordinate of the shape model.
fn check_blendshape_rows(shape: &ShapeModel, blendshapes: &Blendshapes) -> Result<(), ModelError> {
    if blendshapes.offsets.nrows() == shape.mean.len() {
        return Ok(());
    }
    Err(ModelError::invalid(
        BLENDSHAPES_FILE,
        "rows",
        format!(
            "{} rows, but the shape model has {} coordinates",
            blendshapes.offsets.nrows(),
            shape.mean.len()
        ),
    ))
}
