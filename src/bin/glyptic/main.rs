//! The `glyptic` command line.
//!
//! Errors are reported as one line on stderr naming the file and the problem, with a
//! non-zero exit code; no output file is left behind by a failed run. Everything else on
//! stderr is the log: glyptic's warnings by default, `-v` adds each stage as it ends and the
//! libraries' own notes (wgpu, naga, ONNX Runtime), `-q` leaves errors only, `RUST_LOG`
//! overrides both.

/// `println!` that survives a closed stdout (`glyptic photo ... | head -1`): what goes to
/// stdout is a report, and the work and its files must not depend on someone reading it.
/// Write errors are dropped; the first one is noted on the log.
macro_rules! say {
    ($($arg:tt)*) => {
        $crate::report(format_args!($($arg)*))
    };
}

mod cli;
mod kiosk;

use std::process::ExitCode;

use clap::Parser;
use tracing_subscriber::EnvFilter;

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    init_log(args.verbose, args.quiet);
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            // `{:#}` joins the context chain on one line: "photo.jpg: no face found".
            eprintln!("glyptic: error: {err:#}");
            ExitCode::FAILURE
        }
    }
}

/// Writes one line of the report to stdout; see `say!`.
fn report(line: std::fmt::Arguments<'_>) {
    use std::io::Write as _;
    static NOTED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_fmt(line).and_then(|()| out.write_all(b"\n"))
        && !NOTED.swap(true, std::sync::atomic::Ordering::Relaxed)
    {
        tracing::debug!("stdout closed ({e}): the report stops, the work goes on");
    }
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
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()));
    // A second subscriber (a test harness) is not an error worth stopping for.
    let _ = if detailed {
        builder.try_init()
    } else {
        builder.without_time().with_target(false).try_init()
    };
}
