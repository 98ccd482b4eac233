//! How the commands and the kiosk write files: outputs checked before any work (their
//! folders, inputs named as outputs, files that must not be replaced), then written whole
//! through hidden files and renamed into place ([`glyptic::files`]), several together or none.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

/// Fails early, before any work, when an output could not be written or would destroy
/// something: its folder is missing, it is an input of the same run (`photo a.jpg -o a.jpg`),
/// two outputs are the same file (`-o x --obj x`), or it exists and is not a regular file (a
/// symlink, a device, a folder: glyptic replaces only regular files).
pub fn check_outputs<'a>(
    inputs: impl IntoIterator<Item = &'a Path>,
    outputs: impl IntoIterator<Item = &'a Path>,
) -> Result<()> {
    // `-` is standard input or output: no file to check.
    let inputs: Vec<&Path> = inputs
        .into_iter()
        .filter(|p| !crate::values::is_stdio(p))
        .collect();
    let mut seen: Vec<(&Path, PathBuf)> = Vec::new();
    for out in outputs.into_iter().filter(|p| !crate::values::is_stdio(p)) {
        let dir = out.parent().filter(|d| !d.as_os_str().is_empty());
        if let Some(dir) = dir
            && !dir.is_dir()
        {
            if dir.exists() {
                bail!(
                    "{}: {} is not a folder (a file or device stands there)",
                    out.display(),
                    dir.display()
                );
            }
            bail!(
                "{}: output folder does not exist ({})",
                out.display(),
                dir.display()
            );
        }
        check_replaceable(out)?;
        let key = same_file_key(out);
        for input in &inputs {
            if same_file_key(input) == key {
                bail!(
                    "{}: this is also an input ({}); choose another output",
                    out.display(),
                    input.display()
                );
            }
        }
        if let Some((other, _)) = seen.iter().find(|(_, k)| *k == key) {
            bail!(
                "{}: named twice as an output (also as {}); choose another",
                out.display(),
                other.display()
            );
        }
        seen.push((out, key));
    }
    Ok(())
}

/// The folder a file goes into (`.` for a bare name).
pub fn folder_of(path: &Path) -> &Path {
    path.parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
}

/// Whether a file can be made in `dir`: one is made there and removed (the only way to know
/// on every filesystem: a read-only mount, an ACL, a full disk's quota; root passes mode
/// bits). For checks before a long run, so a folder nobody can write is said at the start.
pub fn check_writable_folder(dir: &Path) -> Result<()> {
    if !dir.is_dir() {
        bail!("{}: not a folder", dir.display());
    }
    let probe = dir.join(format!(".glyptic-check.{}", std::process::id()));
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
        .with_context(|| format!("{}: cannot write a file here", dir.display()))?;
    std::fs::remove_file(&probe)
        .with_context(|| format!("{}: cannot remove a file made here", probe.display()))
}

/// A path as a comparable key: its folder resolved (links, `..`) and its name.
fn same_file_key(path: &Path) -> PathBuf {
    if let Ok(full) = std::fs::canonicalize(path) {
        return full;
    }
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let dir = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
    match path.file_name() {
        Some(name) => dir.join(name),
        None => dir,
    }
}

/// An existing output must be a regular file the user could write for glyptic to replace
/// it: a read-only file (no write permission for anyone, or none for this user) is
/// protected, not replaced behind its owner's back by a rename in a writable folder.
fn check_replaceable(path: &Path) -> Result<()> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if !m.file_type().is_file() => bail!(
            "{}: exists and is not a regular file (a link, folder or device); glyptic replaces \
             only regular files",
            path.display()
        ),
        Ok(m) if m.permissions().readonly() || !glyptic::files::may_write(path) => bail!(
            "{}: exists and is read-only; glyptic does not replace a file you could not write \
             (make it writable or choose another name)",
            path.display()
        ),
        _ => Ok(()),
    }
}

/// Encodes `rgba` as PNG and writes it whole (or not at all) to `path`.
pub fn write_png(rgba: image::RgbaImage, path: &Path) -> Result<()> {
    let png = glyptic::pipeline::gem::encode_png(rgba)
        .with_context(|| format!("{}: encoding the PNG", path.display()))?;
    write_atomic(path, &png)
}

/// Writes `bytes` to `path` through a temporary file in the same folder, so that a failure
/// never leaves a partial file and an existing file is replaced whole. For a command's one
/// output; several go through [`stage`] and [`commit`].
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    check_replaceable(path)?;
    glyptic::files::write_atomic(path, bytes)
        .with_context(|| format!("{}: cannot write", path.display()))
}

/// Stages one of a command's outputs ([`glyptic::files::Staged`]): written beside its
/// target, put in place by [`commit`] with the others or not at all.
pub fn stage(staged: &mut glyptic::files::Staged, path: &Path, bytes: &[u8]) -> Result<()> {
    check_replaceable(path)?;
    staged
        .add(path, bytes)
        .with_context(|| format!("{}: cannot write", path.display()))
}

/// Puts a command's staged outputs in place together; on failure none changed.
pub fn commit(staged: glyptic::files::Staged) -> Result<()> {
    staged.commit().map_err(|e| {
        anyhow::anyhow!(
            "{}: cannot write ({}); no output was written",
            e.path.display(),
            e.source
        )
    })
}

/// Writes `bytes` (`what` they are, for the error) to standard output whole; a closed pipe
/// is an error the user sees, since the bytes are the command's output.
pub fn write_stdout(bytes: &[u8], what: &str) -> Result<()> {
    use std::io::Write as _;
    let mut out = std::io::stdout().lock();
    out.write_all(bytes)
        .and_then(|()| out.flush())
        .with_context(|| format!("standard output: cannot write {what}"))
}
