//! `glyptic setup` and `glyptic doctor`: an installed binary's files. `scripts/setup.sh`
//! fetches and prepares the models in a checkout; `setup` copies what the program needs from
//! there into the user's data folder, so a `glyptic` installed with `cargo install` works from
//! any folder after the checkout is gone; `doctor` says where glyptic looks, what it found and
//! what is missing.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

use glyptic::assets::{self, RootSource};

#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:
  scripts/setup.sh && cargo install --path . --locked && glyptic setup
      (in a checkout: fetch the models, install the binary, copy the models for it)
  glyptic setup --from ~/src/glyptic
      (from a checkout elsewhere where scripts/setup.sh ran)")]
pub struct SetupArgs {
    /// The checkout to copy from, where `scripts/setup.sh` ran (default: the one glyptic finds
    /// from here).
    #[arg(long, value_name = "DIR")]
    pub from: Option<PathBuf>,
    /// Where to copy to (default: the user's data folder, `$XDG_DATA_HOME/glyptic` or
    /// `~/.local/share/glyptic`).
    #[arg(long, value_name = "DIR")]
    pub to: Option<PathBuf>,
}

#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:
  glyptic doctor
  GLYPTIC_ROOT=~/src/glyptic glyptic doctor")]
pub struct DoctorArgs {}

fn describe(source: &RootSource) -> &'static str {
    match source {
        RootSource::Env => "from GLYPTIC_ROOT",
        RootSource::WorkingDir => "a checkout above the current folder",
        RootSource::Executable => "a checkout above the executable",
        RootSource::DataDir => "the user's data folder (glyptic setup)",
        RootSource::BuildTree => "the checkout this binary was built from",
        RootSource::NotFound => "nowhere: no set-up files found",
    }
}

/// How to get the missing files, for messages.
const HOW: &str = "run scripts/setup.sh in a glyptic checkout, then `glyptic setup --from CHECKOUT` \
                   (or set GLYPTIC_ROOT to the checkout)";

/// Copies one file (or re-creates an absolute symlink that points outside the checkout, such
/// as dlib's model in /usr/share) unless the destination already has its size; returns what
/// it did.
fn install_file(from: &Path, to: &Path, checkout: &Path) -> Result<&'static str> {
    if let Some(parent) = to.parent() {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("{}: cannot make the folder", parent.display()))?;
    }
    if let Ok(target) = std::fs::read_link(from)
        && target.is_absolute()
        && !target.starts_with(checkout)
        && target.is_file()
    {
        if std::fs::read_link(to).ok().as_deref() == Some(target.as_path()) {
            return Ok("up to date");
        }
        let _ = std::fs::remove_file(to);
        std::os::unix::fs::symlink(&target, to)
            .with_context(|| format!("{}: cannot link to {}", to.display(), target.display()))?;
        return Ok("linked");
    }
    let size = std::fs::metadata(from)
        .with_context(|| format!("{}: cannot read", from.display()))?
        .len();
    if std::fs::metadata(to).is_ok_and(|m| m.is_file() && m.len() == size) {
        return Ok("up to date");
    }
    // Whole or not at all: a full disk or an interruption leaves no part file (issue #40:
    // a 44 MB `.compact.part` stayed).
    glyptic::files::copy_atomic(from, to)
        .with_context(|| format!("{}: cannot copy to {}", from.display(), to.display()))?;
    Ok("copied")
}

pub(super) fn setup(args: &SetupArgs) -> Result<()> {
    let from = match &args.from {
        Some(dir) => dir.clone(),
        None => match assets::locate_root() {
            (_, RootSource::NotFound) => bail!("found no checkout with set-up files: {HOW}"),
            (dir, _) => dir,
        },
    };
    if !assets::looks_like_root(&from) {
        bail!(
            "{}: holds no set-up files (models/, shapemodel/sfm/): run scripts/setup.sh there first",
            from.display()
        );
    }
    let to = match &args.to {
        Some(dir) => dir.clone(),
        None => assets::data_dir().context(
            "no user data folder (neither XDG_DATA_HOME nor HOME is set): give --to DIR",
        )?,
    };
    let same = |a: &Path, b: &Path| matches!((a.canonicalize(), b.canonicalize()), (Ok(x), Ok(y)) if x == y);
    if same(&from, &to) {
        bail!("{}: is where the files are already", to.display());
    }
    let checkout = from.canonicalize().unwrap_or_else(|_| from.clone());
    let mut missing = Vec::new();
    for (source, what, needed) in assets::installed_files(&from) {
        let Ok(rel) = source.strip_prefix(&from) else {
            continue;
        };
        if !source.exists() {
            if needed {
                missing.push(format!("{} ({what})", source.display()));
            }
            continue;
        }
        let dest = to.join(rel);
        let done = install_file(&source, &dest, &checkout)?;
        say!("{done:<11} {}  ({what})", dest.display());
    }
    if !missing.is_empty() {
        bail!(
            "{} holds no {}: run scripts/setup.sh there first",
            from.display(),
            missing.join(", ")
        );
    }
    say!(
        "glyptic's files are in {}; `glyptic doctor` checks them",
        to.display()
    );
    Ok(())
}

pub(super) fn doctor(_: &DoctorArgs) -> Result<()> {
    let (root, source) = assets::locate_root();
    say!("files from   {}  ({})", root.display(), describe(&source));
    match assets::data_dir() {
        Some(dir) => say!("data folder  {}", dir.display()),
        None => say!("data folder  none (neither XDG_DATA_HOME nor HOME is set)"),
    }
    for var in [
        assets::ROOT_ENV,
        assets::SFM_ENV,
        assets::DETECTOR_ENV,
        assets::ORT_ENV,
        glyptic::capture::video_process::HELPER_ENV,
    ] {
        match std::env::var_os(var) {
            Some(value) if value.is_empty() => say!("{var:<12} set but empty: ignored"),
            Some(value) => say!("{var:<12} {}", PathBuf::from(value).display()),
            None => {}
        }
    }
    // The files the program will open (the environment may point some elsewhere), and the
    // rest of an installation under the root.
    let mut checks = assets::ModelPaths::locate().files();
    for file in assets::installed_files(&root) {
        if !checks.iter().any(|(p, ..)| *p == file.0) && !file.2 {
            checks.push(file);
        }
    }
    let mut missing = 0;
    for (path, what, needed) in &checks {
        let state = if path.is_file() {
            "ok"
        } else if *needed {
            missing += 1;
            "MISSING"
        } else {
            "absent"
        };
        say!("{state:<8} {}  ({what})", path.display());
    }
    // Video files are read by a helper program beside this one (or where the variable says).
    #[cfg(feature = "video")]
    match glyptic::capture::video_process::helper_path() {
        Ok(helper) => say!(
            "{:<8} {}  (video reader, for the kiosk's and track's video files)",
            if helper.is_file() { "ok" } else { "absent" },
            helper.display()
        ),
        Err(e) => say!("absent   video reader: {e}"),
    }
    if missing > 0 {
        bail!("{missing} needed files missing: {HOW}");
    }
    say!("everything glyptic needs is there");
    Ok(())
}
