//! The command line: the commands and their arguments (`args`: the groups several share;
//! `photo`: photo and render; `inspect`: landmarks, fit, kernel; `batch`; `track`), and what
//! they share: the stage table, the checks and atomic writes of outputs.

mod args;
#[cfg(feature = "face")]
mod batch;
mod inspect;
mod photo;
mod setup;
#[cfg(feature = "face")]
pub mod track;

pub use args::*;
use inspect::{FitArgs, KernelArgs, fit_landmarks, print_kernel};
#[cfg(feature = "face")]
use inspect::{LandmarksArgs, find_landmarks};
#[cfg(feature = "face")]
use photo::{PhotoArgs, photo};
use photo::{RenderArgs, render_mean};
use setup::{DoctorArgs, SetupArgs, doctor, setup};

use std::path::Path;

use anyhow::Result;
use clap::{Parser, Subcommand};

use glyptic::stage::Stage;

#[derive(Parser, Debug)]
#[command(
    name = "glyptic",
    version,
    about = "Turns a face into an engraved gem: a cameo portrait in marble or agate."
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
    /// More on stderr: -v each stage as it ends and the libraries' notes, -vv debug, -vvv
    /// everything (`RUST_LOG`, when set, decides instead).
    #[arg(short, long, global = true, action = clap::ArgAction::Count, conflicts_with = "quiet")]
    pub verbose: u8,
    /// Errors only: no stage table, no warnings, no progress bar.
    #[arg(short, long, global = true)]
    pub quiet: bool,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Makes a gem image from a portrait photo.
    #[cfg(feature = "face")]
    Photo(PhotoArgs),
    /// Renders the cameo with the Surrey model's mean face (no photo needed).
    Render(RenderArgs),
    /// Fits the face model to a landmark file (iBUG .pts, 1-based) and reports pose and error.
    Fit(FitArgs),
    /// Finds the faces in an image and their 68 iBUG landmarks.
    #[cfg(feature = "face")]
    Landmarks(LandmarksArgs),
    /// Follows the face through a video, folder, photo or webcam; reports speed per stage.
    #[cfg(feature = "face")]
    Track(track::TrackArgs),
    /// Makes a gem from every photo in a folder (all cores), with a CSV of status and times.
    #[cfg(feature = "face")]
    Batch(batch::BatchArgs),
    /// The museum window: the visitor's face as a live cameo, with touch controls.
    Kiosk(crate::kiosk::KioskArgs),
    /// Prints the subsurface-scattering kernel: one line per tap, `offset  r g b`, centre first.
    Kernel(KernelArgs),
    /// Copies the models from a checkout where scripts/setup.sh ran into the user's data
    /// folder, so an installed glyptic works from anywhere.
    Setup(SetupArgs),
    /// Says where glyptic looks for its models, what it found and what is missing.
    Doctor(DoctorArgs),
}

impl Cli {
    /// What clap cannot check alone, checked when the command line is read (exit 2, before
    /// any work): options that contradict each other by value (`--background transparent`
    /// with `--style toon`, or with a `.jpg` output), settings the renderer would refuse
    /// after the whole pipeline (issue #40).
    pub fn check(&self) -> Result<(), clap::Error> {
        let (view, output): (&ViewArgs, Option<&Path>) = match &self.command {
            #[cfg(feature = "face")]
            Command::Photo(a) => (&a.view, Some(&a.output)),
            Command::Render(a) => (&a.view, Some(&a.output)),
            #[cfg(feature = "face")]
            Command::Batch(a) => (&a.view, None),
            _ => return Ok(()),
        };
        let refuse = |msg: String| {
            <Cli as clap::CommandFactory>::command()
                .error(clap::error::ErrorKind::ArgumentConflict, msg)
        };
        let params = view.params().map_err(|e| refuse(format!("{e:#}")))?;
        params.check().map_err(|e| refuse(e.to_string()))?;
        if let Some(output) = output {
            photo::output_kind(output, &params).map_err(|e| refuse(e.to_string()))?;
        }
        Ok(())
    }
}

pub fn run(cli: Cli) -> Result<()> {
    QUIET.store(cli.quiet, std::sync::atomic::Ordering::Relaxed);
    match cli.command {
        #[cfg(feature = "face")]
        Command::Photo(args) => photo(&args),
        Command::Render(args) => render_mean(&args),
        Command::Fit(args) => fit_landmarks(&args),
        #[cfg(feature = "face")]
        Command::Landmarks(args) => find_landmarks(&args),
        #[cfg(feature = "face")]
        Command::Track(args) => track::track(&args),
        #[cfg(feature = "face")]
        Command::Batch(args) => batch::batch(&args),
        Command::Kernel(args) => print_kernel(&args),
        Command::Kiosk(args) => crate::kiosk::kiosk(&args),
        Command::Setup(args) => setup(&args),
        Command::Doctor(args) => doctor(&args),
    }
}

/// Whether `-q` asked for errors only (set once, before any command runs).
static QUIET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// With `--json` (photo, render) the stage table is collected here instead of printed, and
/// the command prints one JSON object at its end.
static JSON_STAGES: std::sync::Mutex<Option<Vec<Stage>>> = std::sync::Mutex::new(None);

/// Turns the JSON report on: stages are collected from now on.
fn collect_stages() {
    if let Ok(mut s) = JSON_STAGES.lock() {
        *s = Some(Vec::new());
    }
}

/// The collected stages as JSON (`[{"name", "ms", "detail"}]`).
fn stages_json() -> serde_json::Value {
    let stages = JSON_STAGES
        .lock()
        .ok()
        .and_then(|s| s.clone())
        .unwrap_or_default();
    stages
        .iter()
        .map(|s| serde_json::json!({ "name": s.name, "ms": s.ms, "detail": s.detail }))
        .collect()
}

/// The stage table's lines: name, time, what the stage found (nothing with `-q`; collected
/// for the report with `--json`).
fn print_stages(stages: &[Stage]) {
    if let Ok(mut collected) = JSON_STAGES.lock()
        && let Some(all) = collected.as_mut()
    {
        all.extend(stages.iter().cloned());
        return;
    }
    if QUIET.load(std::sync::atomic::Ordering::Relaxed) {
        return;
    }
    for s in stages {
        say!("{:<16} {:>9.1} ms  {}", s.name, s.ms, s.detail);
    }
}
