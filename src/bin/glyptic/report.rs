//! What the commands report: the stage table (stderr, for people) and the `--json` objects
//! (stdout, for scripts), one vocabulary for all of them.
//!
//! Every JSON report is one object with `schema` ([`SCHEMA`]) and `command`; what a command
//! read is `input`, the files it wrote `outputs` (kind -> path), its timed steps `stages`
//! (a list of `{name, ms, detail}`, in order) and its wall time `total_ms`. A face is the same
//! object wherever it appears (`photo`, `landmarks`, `track`). A failed command under
//! `--json` prints `{schema, command, error: {message, exit_code}}` instead, unless it failed
//! after its report (`batch` with failed images, `landmarks` with no face). The shape is
//! documented, and checked by the tests, in `docs/report.schema.json` (`docs/reports.md`).
//! Times are wall-clock milliseconds, pixels are the input image's, angles degrees.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

use serde::Serialize;

use glyptic::stage::Stage;

/// The reports' shape version: raised when a field changes meaning or goes away (new fields
/// may appear without it).
pub const SCHEMA: u32 = 1;

/// Whether `-q` asked for errors only (set once, before any command runs).
static QUIET: AtomicBool = AtomicBool::new(false);

/// The stages of the command, collected as they end: the table printed once the command
/// has succeeded (a failed command's stderr is its one error line; `-v` logs each stage as it
/// ends), or the report's `stages`.
static COLLECTED: Mutex<Vec<Stage>> = Mutex::new(Vec::new());

/// Whether the command reports in JSON (no table then).
static JSON: AtomicBool = AtomicBool::new(false);

/// Whether a JSON report went to stdout (a command that fails after it prints no second
/// object for its error).
static REPORTED: AtomicBool = AtomicBool::new(false);

/// `-q`: no stage table.
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, Ordering::Relaxed);
}

/// Whether `-q` asked for errors only.
pub fn quiet() -> bool {
    QUIET.load(Ordering::Relaxed)
}

/// The command reports in JSON (`main` says so before it runs): its stages go into the
/// report, not a table.
pub fn report_in_json() {
    JSON.store(true, Ordering::Relaxed);
}

/// The stages collected so far, for a report (the total is the report's own `total_ms`).
pub fn collected_stages() -> Vec<Stage> {
    COLLECTED
        .lock()
        .map(|s| s.iter().filter(|s| s.name != "total").cloned().collect())
        .unwrap_or_default()
}

/// Notes stages that ended, for the table or the report.
pub fn note_stages(stages: &[Stage]) {
    if let Ok(mut all) = COLLECTED.lock() {
        all.extend(stages.iter().cloned());
    }
}

/// The stage table on stderr, once the command has succeeded (stdout is kept for data: the
/// JSON report, an image written to `-`): name, time, what the stage found. Nothing with `-q`
/// or `--json`.
pub fn print_table() {
    if quiet() || JSON.load(Ordering::Relaxed) {
        return;
    }
    let Ok(stages) = COLLECTED.lock() else {
        return;
    };
    for s in stages.iter() {
        complain(format_args!(
            "{:<16} {:>9.1} ms  {}",
            s.name, s.ms, s.detail
        ));
    }
}

/// A report object: the schema, the command, then the command's own fields.
#[derive(Serialize)]
pub struct Report<T: Serialize> {
    pub schema: u32,
    pub command: &'static str,
    #[serde(flatten)]
    pub body: T,
}

/// Prints `body` as the command's one JSON report on stdout.
pub fn print<T: Serialize>(command: &'static str, body: T) {
    let report = Report {
        schema: SCHEMA,
        command,
        body,
    };
    match serde_json::to_string(&report) {
        Ok(line) => {
            REPORTED.store(true, Ordering::Relaxed);
            say!("{line}");
        }
        Err(e) => tracing::error!("the report could not be written as JSON: {e}"),
    }
}

/// A command's error as its JSON report, when it had none yet.
pub fn print_error(command: &'static str, message: &str, exit_code: u8) {
    if REPORTED.load(Ordering::Relaxed) {
        return;
    }
    #[derive(Serialize)]
    struct Failure<'a> {
        message: &'a str,
        exit_code: u8,
    }
    #[derive(Serialize)]
    struct Body<'a> {
        error: Failure<'a>,
    }
    print(
        command,
        Body {
            error: Failure { message, exit_code },
        },
    );
}

/// What every command's report says of its run: what it read, the files it wrote, its
/// stages and its wall time.
#[derive(Serialize)]
pub struct Run {
    pub input: String,
    pub outputs: Outputs,
    pub stages: Vec<Stage>,
    pub total_ms: f64,
}

impl Run {
    /// The run so far: the stages collected since the command began at `start`.
    pub fn so_far(input: impl Into<String>, outputs: Outputs, start: std::time::Instant) -> Self {
        Run {
            input: input.into(),
            outputs,
            stages: collected_stages(),
            total_ms: ms_since(start),
        }
    }
}

/// The files a command wrote, by kind (`image`, `landmarks`, `obj`, `gem_obj`, `stl`,
/// `heightmap`, `gltf`, `csv`).
#[derive(Serialize, Default)]
pub struct Outputs(BTreeMap<&'static str, String>);

impl Outputs {
    /// The outputs among `pairs` that were asked for.
    pub fn of(pairs: &[(&'static str, Option<&Path>)]) -> Self {
        Outputs(
            pairs
                .iter()
                .filter_map(|(kind, path)| path.map(|p| (*kind, p.display().to_string())))
                .collect(),
        )
    }
}

/// A face found in an image: its detector box `[x, y, w, h]` and score, its 68 iBUG
/// landmarks `[x, y]` (image pixels, 0-based), and where it was fitted, the pose and the
/// fit's mean reprojection error.
#[cfg(feature = "face")]
#[derive(Serialize, Default)]
pub struct Face {
    #[serde(rename = "box", skip_serializing_if = "Option::is_none")]
    pub bbox: Option<[f32; 4]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub score: Option<f32>,
    pub landmarks: Vec<[f32; 2]>,
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    pub pose: Option<Pose>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reprojection_px: Option<f64>,
}

/// A head's orientation, degrees, for `R = Rz(roll) Ry(yaw) Rx(pitch)` in the face model's
/// frame; positive yaw turns the face towards its own left.
#[derive(Serialize, Clone, Copy)]
pub struct Pose {
    pub yaw_deg: f64,
    pub pitch_deg: f64,
    pub roll_deg: f64,
}

impl Pose {
    pub fn of(pose: &glyptic::fit::Pose) -> Self {
        let [yaw_deg, pitch_deg, roll_deg] = pose.yaw_pitch_roll_deg();
        Pose {
            yaw_deg,
            pitch_deg,
            roll_deg,
        }
    }
}

/// Milliseconds since `start`.
pub fn ms_since(start: std::time::Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

/// Writes one line of the report to stdout; see `say!`.
pub fn say(line: std::fmt::Arguments<'_>) {
    use std::io::Write as _;
    static NOTED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_fmt(line).and_then(|()| out.write_all(b"\n"))
        && !NOTED.swap(true, std::sync::atomic::Ordering::Relaxed)
    {
        tracing::debug!("stdout closed ({e}): the report stops, the work goes on");
    }
}

/// `eprintln!` that survives a closed or full stderr (`glyptic ... 2>&1 | head -0`, `2>/dev/full`):
/// `eprintln!` panics there, and an error to report would end as exit 101 instead of 1. The
/// line is dropped; the exit code still says what happened.
pub fn complain(line: std::fmt::Arguments<'_>) {
    use std::io::Write as _;
    let mut err = std::io::stderr().lock();
    let _ = err.write_fmt(line).and_then(|()| err.write_all(b"\n"));
}
