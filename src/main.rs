//! The `glyptic` command line.
//!
//! Errors are reported as one line on stderr naming the file and the problem, with a
//! non-zero exit code; no output file is left behind by a failed run.

mod cli;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            // `{:#}` joins the context chain on one line: "photo.jpg: no face found".
            eprintln!("glyptic: error: {err:#}");
            ExitCode::FAILURE
        }
    }
}
