//! The command line: the commands and their arguments (`args`: the groups several share;
//! `photo`: photo and render; `inspect`: landmarks, fit, kernel; `batch`; `track`), and what
//! they share: the stage table, the checks and atomic writes of outputs.

mod args;
#[cfg(feature = "face")]
mod batch;
mod inspect;
mod make;
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

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};

#[derive(Parser, Debug)]
#[command(
    name = "glyptic",
    version,
    about = "Turns a face into an engraved gem: a cameo portrait in marble or agate.",
    after_help = "Examples:
  glyptic photo portrait.jpg -o gem.png              a gem from a photo (frontal, marble)
  glyptic photo portrait.jpg -o gem.png --portrait profile --material agate
  glyptic photo - -o - < portrait.jpg > gem.png      standard input to standard output
  glyptic photo portrait.jpg -o gem.png --stl gem.stl --json | jq .face
  glyptic batch photos/ -o gems/                     every photo of a folder, with a CSV
  glyptic kiosk                                      the museum window (live webcam)
  glyptic render -o mean.png                         the cameo of the model's mean face
  glyptic doctor                                     where the models are, what is missing
  glyptic completions bash > ~/.local/share/bash-completion/completions/glyptic
  glyptic man --dir ~/.local/share/man/man1          the manual pages

Reports: the stage table on stderr; --json writes one object on stdout (docs/reports.md)."
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
    /// Prints the shell's completion script (bash, zsh, fish, elvish, powershell) on stdout.
    Completions(CompletionsArgs),
    /// Prints glyptic's manual page (roff) on stdout, or writes one page a command to --dir.
    Man(ManArgs),
}

#[derive(clap::Args, Debug)]
pub struct CompletionsArgs {
    /// The shell to complete in.
    pub shell: clap_complete::Shell,
}

#[derive(clap::Args, Debug)]
pub struct ManArgs {
    /// Writes glyptic.1 and glyptic-COMMAND.1 for each command into this folder instead.
    #[arg(long, value_name = "FOLDER")]
    pub dir: Option<std::path::PathBuf>,
}

/// The completion script for `shell`, on stdout.
fn completions(args: &CompletionsArgs) -> Result<()> {
    let mut cmd = <Cli as clap::CommandFactory>::command();
    let mut script = Vec::new();
    clap_complete::generate(args.shell, &mut cmd, "glyptic", &mut script);
    crate::outputs::write_stdout(&script, "the completion script")
}

/// The manual page(s), from the same definitions as `--help`.
fn man(args: &ManArgs) -> Result<()> {
    let cmd = <Cli as clap::CommandFactory>::command();
    match &args.dir {
        Some(dir) => {
            crate::outputs::check_writable_folder(dir)?;
            clap_mangen::generate_to(cmd, dir)
                .with_context(|| format!("{}: cannot write the manual pages", dir.display()))
        }
        None => {
            let mut page = Vec::new();
            clap_mangen::Man::new(cmd)
                .render(&mut page)
                .context("rendering the manual page")?;
            crate::outputs::write_stdout(&page, "the manual page")
        }
    }
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
            if crate::values::is_stdio(output) && self.json_report().is_some() {
                return Err(refuse(
                    "-o - writes the image to standard output, where --json writes the report: \
                     name a file for one of them"
                        .into(),
                ));
            }
        }
        Ok(())
    }

    /// The command's name when it reports in JSON on stdout (`--json`), so that an error is
    /// reported there too.
    pub fn json_report(&self) -> Option<&'static str> {
        match &self.command {
            #[cfg(feature = "face")]
            Command::Photo(a) => a.json.then_some("photo"),
            // `render --photo` is `photo`, and reports as it.
            #[cfg(feature = "face")]
            Command::Render(a) if a.photo.is_some() => a.json.then_some("photo"),
            Command::Render(a) => a.json.then_some("render"),
            Command::Fit(a) => a.json.then_some("fit"),
            #[cfg(feature = "face")]
            Command::Landmarks(a) => a.json.then_some("landmarks"),
            #[cfg(feature = "face")]
            Command::Batch(a) => a.json.then_some("batch"),
            _ => None,
        }
    }
}

pub fn run(cli: Cli) -> Result<()> {
    crate::report::set_quiet(cli.quiet);
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
        Command::Completions(args) => completions(&args),
        Command::Man(args) => man(&args),
    }
}
