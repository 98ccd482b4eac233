//! The `glyptic` command line.
//!
//! Errors are reported as one line on stderr naming the file and the problem, with a
//! non-zero exit code (under `--json`, also as the report on stdout); no output file is left
//! behind by a failed run. A command that succeeded prints its stage table on stderr
//! (`report`); stdout carries the command's answer (a JSON report, an image written to `-`,
//! the kernel, doctor's findings, a summary), never the table. The rest of stderr is the
//! log: glyptic's warnings by default, `-v` adds each stage as it ends and the libraries'
//! own notes (wgpu, naga, ONNX Runtime), `-q` leaves errors only, `RUST_LOG` overrides both.

/// `println!` that survives a closed stdout (`glyptic photo ... | head -1`): what goes to
/// stdout is a report, and the work and its files must not depend on someone reading it.
/// Write errors are dropped; the first one is noted on the log.
macro_rules! say {
    ($($arg:tt)*) => {
        $crate::report::say(format_args!($($arg)*))
    };
}

mod cli;
mod kiosk;
mod outputs;
mod report;
mod signals;
mod values;

use std::process::ExitCode;

use clap::Parser;
use tracing_subscriber::EnvFilter;

fn main() -> ExitCode {
    ensure_runtime_dir();
    no_telemetry();
    let args = cli::Cli::parse();
    if let Err(e) = args.check() {
        e.exit();
    }
    quiet_ffmpeg(args.verbose);
    init_log(args.verbose, args.quiet);
    signals::install();
    // doctor and setup say themselves where the models are and what is missing.
    let hint = !matches!(
        args.command,
        cli::Command::Doctor(_)
            | cli::Command::Setup(_)
            | cli::Command::Completions(_)
            | cli::Command::Man(_)
    );
    let json = args.json_report();
    if json.is_some() {
        report::report_in_json();
    }
    match cli::run(args) {
        Ok(()) => {
            report::print_table();
            ExitCode::SUCCESS
        }
        Err(err) => {
            let line = one_line(&err);
            report::complain(format_args!("glyptic: error: {line}"));
            let code = match err.downcast_ref::<signals::Interrupted>() {
                Some(stop) => u8::try_from(128 + stop.signal).unwrap_or(1),
                None => 1,
            };
            if let Some(command) = json {
                report::print_error(command, &line, code);
            }
            if code != 1 {
                return ExitCode::from(code);
            }
            let (root, _) = glyptic::assets::locate_root();
            if hint && !glyptic::assets::looks_like_root(&root) {
                report::complain(format_args!(
                    "glyptic: {} holds no models: `glyptic doctor` says where glyptic looks \
                     and how to get them",
                    root.display()
                ));
            }
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes on one line ("photo.jpg: no face found"), each piece once: many
/// errors already say their source, and `{:#}` would repeat it ("Is a directory (os error
/// 21): Is a directory (os error 21)").
fn one_line(err: &anyhow::Error) -> String {
    let mut line = String::new();
    for part in err
        .chain()
        .map(|e| e.to_string())
        .collect::<Vec<_>>()
        .iter()
        .rev()
    {
        if line.is_empty() || part.contains(line.as_str()) {
            line = part.clone();
        } else if !line.contains(part.as_str()) {
            line = format!("{part}: {line}");
        }
    }
    line
}

/// Graphics drivers (Mesa's Wayland probe) print "XDG_RUNTIME_DIR is invalid or not set" on
/// every run without one, as on a server or in a container: give the process a private one,
/// as `scripts/env.sh` does for the shell.
fn ensure_runtime_dir() {
    use std::os::unix::fs::{MetadataExt as _, PermissionsExt as _};
    let usable = std::env::var_os("XDG_RUNTIME_DIR")
        .map(std::path::PathBuf::from)
        .is_some_and(|p| p.is_absolute() && p.is_dir());
    if usable {
        return;
    }
    let uid = std::fs::metadata("/proc/self").map_or(0, |m| m.uid());
    let dir = std::env::temp_dir().join(format!("glyptic-xdg-{uid}"));
    let made = std::fs::create_dir_all(&dir)
        .and_then(|()| std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700)));
    if made.is_ok() {
        // SAFETY: called first thing in `main`, before any thread exists that could read the
        // environment concurrently.
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", &dir) };
    }
}

/// OpenCV's FFmpeg prints its own errors raw on stderr ("moov atom not found" for a file
/// that is no video), even with `-q`, beside glyptic's one line that says the same. Silenced
/// unless `-vv` asks for the libraries' debug notes or the user set OpenCV's own variable.
fn quiet_ffmpeg(verbose: u8) {
    const VAR: &str = "OPENCV_FFMPEG_LOGLEVEL";
    if verbose < 2 && std::env::var_os(VAR).is_none() {
        // SAFETY: called from `main` before any thread is started (the log, the signal
        // thread and the work come after).
        unsafe { std::env::set_var(VAR, "-8") };
    }
}

/// ONNX Runtime (1.29 on, on Linux) starts a telemetry uploader with its environment: it
/// writes a device id and an event store under `~/.cache/Microsoft/DeveloperTools/`, a
/// session file in the temporary folder, and queues an event for Microsoft, on every run
/// (found by the kiosk's privacy test, issue #40). The environment's own switch
/// (`DisableTelemetryEvents`) comes too late for that; `ORT_DISABLE_TELEMETRY=1` before the
/// library starts stops all of it. Always set: a museum's visitors, and glyptic's users,
/// are not asked.
fn no_telemetry() {
    // SAFETY: called first thing in `main`, before any thread exists.
    unsafe { std::env::set_var("ORT_DISABLE_TELEMETRY", "1") };
}

/// The log's filter for `-v` / `-q`: glyptic's own notes and everyone's warnings by default.
/// wgpu's and naga's warnings about the software rasteriser are kept for `-v`: on a machine
/// without a GPU they repeat what the stage table already says.
fn default_filter(verbose: u8, quiet: bool) -> &'static str {
    match (quiet, verbose) {
        (true, _) => "error",
        (false, 0) => "warn,glyptic=info,wgpu_hal=error,wgpu_core=error,naga=error",
        (false, 1) => "info,glyptic=debug,ort=warn",
        (false, 2) => "debug",
        _ => "trace",
    }
}

/// Sends `tracing` events (and the `log` records of wgpu and its kin) to stderr.
fn init_log(verbose: u8, quiet: bool) {
    let filter = EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| EnvFilter::new(default_filter(verbose, quiet)));
    let detailed = verbose >= 2 || std::env::var_os("RUST_LOG").is_some();
    let builder = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        // A log line that cannot be written (stderr closed or full) is dropped: the
        // subscriber's own complaint about it is an `eprintln!`, which panics there.
        .log_internal_errors(false)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()));
    // A second subscriber (a test harness) is not an error worth stopping for.
    let _ = if detailed {
        builder.try_init()
    } else {
        builder.without_time().with_target(false).try_init()
    };
}
