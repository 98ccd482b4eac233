//! Reading an input file safely: only a regular file (a folder, a device such as `/dev/zero`
//! or a pipe is refused before it is opened, so nothing blocks or streams forever), and never
//! more than the input's cap (checked against the declared size first, and while reading, for
//! files whose size lies). Units: bytes.

use std::io::Read as _;
use std::path::{Path, PathBuf};

/// Caps per kind of input: generous for real files, far below what would hurt the machine.
pub const MAX_PHOTO_BYTES: u64 = 256 << 20;
/// dlib's landmark model is 99.7 MB, the ONNX models 1-8 MB, the Surrey files up to 30 MB.
pub const MAX_MODEL_BYTES: u64 = 512 << 20;
/// A face mesh (OBJ): the Surrey mesh is 0.3 MB as OBJ.
pub const MAX_MESH_BYTES: u64 = 256 << 20;
/// Landmark and configuration text files.
pub const MAX_TEXT_BYTES: u64 = 16 << 20;

/// The whole of the regular file at `path`, at most `max` bytes; a refused file is an
/// `InvalidInput` error saying why (its kind stays `NotFound` for a missing file).
pub fn read_limited(path: &Path, max: u64) -> std::io::Result<Vec<u8>> {
    let capacity = usize::try_from(regular_file_len(path, max)?).unwrap_or(0);
    read_all_limited(std::fs::File::open(path)?, max, capacity)
}

/// The size of the regular file at `path`, refused past `max` bytes (a folder, a device or a
/// pipe refused too): what [`read_limited`] checks before it reads.
pub fn regular_file_len(path: &Path, max: u64) -> std::io::Result<u64> {
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a regular file (a folder, a device or a pipe)",
        ));
    }
    if meta.len() > max {
        return Err(too_large(meta.len(), max));
    }
    Ok(meta.len())
}

/// Everything `reader` holds, refused past `max` bytes without reading more than one byte
/// beyond it (a file that grows while read, a pipe: `glyptic photo -`). `capacity`: the
/// expected size, when known.
pub fn read_all_limited(
    reader: impl std::io::Read,
    max: u64,
    capacity: usize,
) -> std::io::Result<Vec<u8>> {
    let mut bytes = Vec::with_capacity(capacity);
    reader.take(max + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max {
        return Err(too_large(bytes.len() as u64, max));
    }
    Ok(bytes)
}

fn too_large(bytes: u64, max: u64) -> std::io::Error {
    std::io::Error::new(
        std::io::ErrorKind::InvalidInput,
        format!("{bytes} bytes, more than the {max} this input may have"),
    )
}

/// [`read_limited`] as UTF-8 text.
pub fn read_text_limited(path: &Path, max: u64) -> std::io::Result<String> {
    String::from_utf8(read_limited(path, max)?)
        .map_err(|_| std::io::Error::new(std::io::ErrorKind::InvalidData, "not UTF-8 text"))
}

/// The checksum list a folder of model files may hold, in `sha256sum`'s format
/// (`<64 hex digits>  <file name>` a line; `sha256sum -c SHA256SUMS` checks it by hand).
/// Set-up's `models/` and `shapemodel/sfm/` carry one for the files it fetches.
pub const CHECKSUM_LIST: &str = "SHA256SUMS";

/// What the [`CHECKSUM_LIST`] beside `path` says its SHA-256 must be: `None` when the folder
/// has no list or the list does not name the file (a model of the user's own). The list is
/// looked up beside the path as given, not beside a link's target.
pub fn listed_sha256(path: &Path) -> std::io::Result<Option<[u8; 32]>> {
    let (Some(dir), Some(name)) = (path.parent(), path.file_name()) else {
        return Ok(None);
    };
    let list = dir.join(CHECKSUM_LIST);
    let text = match read_text_limited(&list, MAX_TEXT_BYTES) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e),
    };
    let bad = |line: usize, problem: &str| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("{} line {line}: {problem}", list.display()),
        )
    };
    let name = name.to_string_lossy();
    for (k, line) in text.lines().enumerate() {
        let line = line.trim_end_matches('\r');
        if line.trim().is_empty() || line.starts_with('#') {
            continue;
        }
        let (hex, file) = line
            .split_once(char::is_whitespace)
            .ok_or_else(|| bad(k + 1, "not `<sha256>  <file name>`"))?;
        let file = file.trim_start().trim_start_matches('*');
        if file != name {
            continue;
        }
        return parse_sha256(hex)
            .map(Some)
            .ok_or_else(|| bad(k + 1, "not 64 hexadecimal digits"));
    }
    Ok(None)
}

fn parse_sha256(hex: &str) -> Option<[u8; 32]> {
    if hex.len() != 64 || !hex.is_ascii() {
        return None;
    }
    let mut out = [0u8; 32];
    for (i, b) in out.iter_mut().enumerate() {
        *b = u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).ok()?;
    }
    Some(out)
}

fn hex(digest: &[u8]) -> String {
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

/// Checks `bytes`, read from `path`, against the [`CHECKSUM_LIST`] beside it (see
/// [`listed_sha256`]); a mismatch is an `InvalidData` error saying the copy is damaged.
pub fn verify_listed(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use sha2::Digest as _;
    let Some(want) = listed_sha256(path)? else {
        return Ok(());
    };
    let got: [u8; 32] = sha2::Sha256::digest(bytes).into();
    if got == want {
        return Ok(());
    }
    Err(std::io::Error::new(
        std::io::ErrorKind::InvalidData,
        format!(
            "damaged or replaced: its SHA-256 is {}..., but {CHECKSUM_LIST} beside it lists {}... \
             (fetch it again: scripts/setup.sh)",
            &hex(&got)[..16],
            &hex(&want)[..16]
        ),
    ))
}

/// A model file read with [`read_limited`] (cap [`MAX_MODEL_BYTES`]) and handed to `parse`
/// while, on another thread, its checksum is verified ([`verify_listed`]): dlib's model is
/// 100 MB, and hashing it (~60 ms) beside the parse costs no time on two cores. A damaged
/// file is refused as damaged (the outer error), whatever `parse` made of it; a file that
/// reads and verifies gives `parse`'s own result. Only for parsers that are safe on any
/// bytes (ours): a C++ parser such as ONNX Runtime's gets [`read_verified`]'s bytes.
pub fn read_model<T, E>(
    path: &Path,
    parse: impl FnOnce(&[u8]) -> Result<T, E>,
) -> std::io::Result<Result<T, E>> {
    let bytes = read_limited(path, MAX_MODEL_BYTES)?;
    let (parsed, verified) = std::thread::scope(|s| {
        let check = s.spawn(|| verify_listed(path, &bytes));
        let parsed = parse(&bytes);
        let verified = check
            .join()
            .unwrap_or_else(|_| Err(std::io::Error::other("checksum thread failed")));
        (parsed, verified)
    });
    verified?;
    Ok(parsed)
}

/// A small model file (cap [`MAX_MODEL_BYTES`]), verified ([`verify_listed`]) before it is
/// returned: for files that hash in a few milliseconds.
pub fn read_verified(path: &Path) -> std::io::Result<Vec<u8>> {
    let bytes = read_limited(path, MAX_MODEL_BYTES)?;
    verify_listed(path, &bytes)?;
    Ok(bytes)
}

/// The hidden files this process is writing or holding staged right now: what an
/// interrupted run must remove ([`remove_pending`]). Held locked while staged files are put
/// in place, so an interruption waits for a commit to finish rather than splitting it.
static PENDING: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

fn pending() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    PENDING
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

fn forget_pending(path: &Path) {
    pending().retain(|p| p != path);
}

/// Removes every hidden file this process is writing or holding staged, and keeps the list
/// locked so that no new one starts: for a signal handler about to end the process
/// (SIGINT, SIGTERM), so an interrupted command leaves no `.NAME.PID.N.tmp` behind. A
/// commit under way finishes first. Returns how many files were removed.
pub fn remove_pending() -> usize {
    let list = pending();
    let removed = list
        .iter()
        .filter(|p| std::fs::remove_file(p).is_ok())
        .count();
    // The guard is leaked: the process is about to end, and nothing may stage after this.
    #[allow(
        clippy::mem_forget,
        reason = "the list stays locked until the process ends"
    )]
    std::mem::forget(list);
    removed
}

/// A hidden name beside `path`, unique per process and call (two threads may write the
/// same file at once): `.NAME.PID.N.tag`.
fn hidden_beside(path: &Path, tag: &str) -> std::io::Result<PathBuf> {
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .ok_or_else(|| std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a file name"))?;
    static CALLS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    // At most 120 characters of the name: a target named near the filesystem's 255-byte
    // limit must not fail for its hidden twin's longer name.
    let name: String = name.to_string_lossy().chars().take(120).collect();
    Ok(dir.join(format!(".{name}.{}.{call}.{tag}", std::process::id())))
}

/// Whether this process may write the existing file at `path` (opened for writing, neither
/// truncated nor changed): a rename in a writable folder would replace a file its owner
/// protected, so callers ask this first.
pub fn may_write(path: &Path) -> bool {
    std::fs::OpenOptions::new().write(true).open(path).is_ok()
}

/// Creates the new hidden file `tmp`, registered as pending (so an interruption removes it),
/// with the permissions of the file it will replace (a 0600 file stays 0600), lets `fill`
/// write it, and syncs it.
fn fill_hidden<T>(
    tmp: &Path,
    target: &Path,
    fill: impl FnOnce(&mut std::fs::File) -> std::io::Result<T>,
) -> std::io::Result<T> {
    pending().push(tmp.to_path_buf());
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(tmp)?;
    if let Ok(meta) = std::fs::metadata(target) {
        f.set_permissions(meta.permissions())?;
    }
    let out = fill(&mut f)?;
    f.sync_all()?;
    Ok(out)
}

/// Replaces `target` whole or not at all with what `fill` writes: into a hidden file beside
/// it ([`fill_hidden`]), renamed over it; on any failure the hidden file is removed and
/// `target` is as it was.
fn replace_with<T>(
    target: &Path,
    fill: impl FnOnce(&mut std::fs::File) -> std::io::Result<T>,
) -> std::io::Result<T> {
    let tmp = hidden_beside(target, "tmp")?;
    let result =
        fill_hidden(&tmp, target, fill).and_then(|out| std::fs::rename(&tmp, target).map(|()| out));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    forget_pending(&tmp);
    result
}

/// Writes `bytes` to `path` whole or not at all: into a hidden file beside it, synced, then
/// renamed over it, so a reader (or a crash) never sees half a file. For one file; a
/// command with several outputs stages them together ([`Staged`]).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write as _;
    replace_with(path, |f| f.write_all(bytes))
}

/// Copies the file `from` to `to` whole or not at all, as [`write_atomic`] writes (on a full
/// disk `to` is as it was and nothing is left beside it). Streams, so a 100 MB model is never
/// held in memory. Returns the bytes copied.
pub fn copy_atomic(from: &Path, to: &Path) -> std::io::Result<u64> {
    let mut src = std::fs::File::open(from)?;
    replace_with(to, |f| std::io::copy(&mut src, f))
}

/// A file [`Staged::commit`] could not put in place, and why.
#[derive(Debug, thiserror::Error)]
#[error("{}: {source}", path.display())]
pub struct StageError {
    pub path: PathBuf,
    #[source]
    pub source: std::io::Error,
}

/// A command's output files, written together or not at all (issue #40): each is written
/// whole into a hidden file beside its target ([`Staged::add`]), and only when all are
/// written are they renamed into place ([`Staged::commit`]); a failure there puts back what
/// the earlier renames replaced. Dropped uncommitted (an error, a panic), or the process
/// interrupted ([`remove_pending`]), the hidden files are removed and no target changes.
#[derive(Debug, Default)]
pub struct Staged {
    /// (target, hidden file) in the order added.
    files: Vec<(PathBuf, PathBuf)>,
}

impl Staged {
    pub fn new() -> Self {
        Self::default()
    }

    /// Writes `bytes` for `target` into a hidden file beside it; nothing is replaced yet.
    pub fn add(&mut self, target: &Path, bytes: &[u8]) -> Result<(), StageError> {
        let fail = |source| StageError {
            path: target.to_path_buf(),
            source,
        };
        let tmp = hidden_beside(target, "tmp").map_err(fail)?;
        // Recorded before writing, so a half-written file is removed too.
        self.files.push((target.to_path_buf(), tmp.clone()));
        fill_hidden(&tmp, target, |f| {
            use std::io::Write as _;
            f.write_all(bytes)
        })
        .map_err(fail)
    }

    /// Renames every staged file over its target. An existing target is first linked to a
    /// hidden backup, so if a later rename fails, the targets already replaced get their old
    /// contents back and new ones are removed: the folder is as before, and the error names
    /// the file that failed.
    pub fn commit(mut self) -> Result<(), StageError> {
        let files = std::mem::take(&mut self.files);
        let mut list = pending();
        let mut done: Vec<(&Path, Option<PathBuf>)> = Vec::new();
        let mut failed = None;
        for (target, tmp) in &files {
            let backup = match std::fs::symlink_metadata(target) {
                Ok(_) => match hidden_beside(target, "old")
                    .and_then(|b| std::fs::hard_link(target, &b).map(|()| b))
                {
                    Ok(b) => Some(b),
                    Err(source) => {
                        failed = Some(StageError {
                            path: target.clone(),
                            source,
                        });
                        break;
                    }
                },
                Err(_) => None,
            };
            match std::fs::rename(tmp, target) {
                Ok(()) => done.push((target, backup)),
                Err(source) => {
                    if let Some(b) = backup {
                        let _ = std::fs::remove_file(b);
                    }
                    failed = Some(StageError {
                        path: target.clone(),
                        source,
                    });
                    break;
                }
            }
        }
        if failed.is_some() {
            for (target, backup) in done.iter().rev() {
                let _ = match backup {
                    Some(b) => std::fs::rename(b, target),
                    None => std::fs::remove_file(target),
                };
            }
        } else {
            for (_, backup) in &done {
                if let Some(b) = backup {
                    let _ = std::fs::remove_file(b);
                }
            }
        }
        for (_, tmp) in &files {
            let _ = std::fs::remove_file(tmp);
        }
        list.retain(|p| !files.iter().any(|(_, tmp)| tmp == p));
        failed.map_or(Ok(()), Err)
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        for (_, tmp) in &self.files {
            let _ = std::fs::remove_file(tmp);
            forget_pending(tmp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checksum_lists_are_honoured_and_damage_is_named() {
        use sha2::Digest as _;
        let dir = std::env::temp_dir().join(format!("glyptic-sums-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let model = dir.join("m.bin");
        std::fs::write(&model, b"weights").unwrap();
        let parse = |b: &[u8]| Ok::<usize, ()>(b.len());
        // No list, or a list without the file: not checked.
        assert_eq!(read_model(&model, parse).unwrap(), Ok(7));
        let sum = hex(&sha2::Sha256::digest(b"weights"));
        let list = dir.join(CHECKSUM_LIST);
        std::fs::write(&list, format!("{sum}  other.bin\n")).unwrap();
        assert_eq!(read_model(&model, parse).unwrap(), Ok(7));
        // Listed and equal (CRLF, a comment and the binary-mode star are fine).
        std::fs::write(&list, format!("# models\r\n{sum} *m.bin\r\n")).unwrap();
        assert_eq!(read_model(&model, parse).unwrap(), Ok(7));
        // One byte changed: refused as damaged, whatever the parser thought.
        std::fs::write(&model, b"weighs!").unwrap();
        let e = read_model(&model, parse).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidData);
        assert!(e.to_string().contains("damaged"), "{e}");
        // A malformed list names itself and the line.
        std::fs::write(&list, "xyz  m.bin\n").unwrap();
        let e = read_model(&model, parse).unwrap_err();
        assert!(e.to_string().contains("SHA256SUMS line 1"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn devices_folders_and_oversized_files_are_refused() {
        for p in ["/dev/zero", "/dev/null", "/"] {
            let e = read_limited(Path::new(p), 1 << 20).unwrap_err();
            assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput, "{p}: {e}");
        }
        let dir = std::env::temp_dir().join(format!("glyptic-files-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("ten.bin");
        std::fs::write(&f, [7u8; 10]).unwrap();
        assert_eq!(read_limited(&f, 10).unwrap(), vec![7u8; 10]);
        let e = read_limited(&f, 9).unwrap_err();
        assert!(e.to_string().contains("10 bytes"), "{e}");
        let missing = read_limited(&dir.join("none"), 9).unwrap_err();
        assert_eq!(missing.kind(), std::io::ErrorKind::NotFound);
        std::fs::remove_dir_all(&dir).ok();
    }

    /// The names in a folder, sorted (hidden files included).
    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn staged_outputs_appear_together_or_not_at_all() {
        use std::os::unix::fs::PermissionsExt as _;
        let dir = std::env::temp_dir().join(format!("glyptic-staged-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let (a, b, c) = (dir.join("a.png"), dir.join("b.obj"), dir.join("c.stl"));
        std::fs::write(&a, b"old a").unwrap();
        std::fs::set_permissions(&a, std::fs::Permissions::from_mode(0o600)).unwrap();

        // Dropped before the commit (an error after staging): nothing changes.
        let mut s = Staged::new();
        s.add(&a, b"new a").unwrap();
        s.add(&b, b"new b").unwrap();
        assert_eq!(names(&dir).len(), 3, "staged beside: {:?}", names(&dir));
        drop(s);
        assert_eq!(names(&dir), ["a.png"]);
        assert_eq!(std::fs::read(&a).unwrap(), b"old a");

        // Interrupted (the signal handler's cleanup) while staged: the hidden files go.
        let mut s = Staged::new();
        s.add(&b, b"new b").unwrap();
        assert!(pending().iter().any(|p| p.starts_with(&dir)));
        // (remove_pending would keep the list locked for the dying process: emulate it.)
        for p in pending().iter().filter(|p| p.starts_with(&dir)) {
            std::fs::remove_file(p).unwrap();
        }
        assert_eq!(names(&dir), ["a.png"]);
        drop(s);

        // A rename that fails midway (the third target became a folder holding a file):
        // the first file's old contents come back, the second new file goes, nothing
        // hidden is left, and the error names the file.
        let mut s = Staged::new();
        s.add(&a, b"new a").unwrap();
        s.add(&b, b"new b").unwrap();
        s.add(&c, b"new c").unwrap();
        std::fs::create_dir(&c).unwrap();
        std::fs::write(c.join("x"), b"x").unwrap();
        let e = s.commit().unwrap_err();
        assert_eq!(e.path, c, "{e}");
        assert_eq!(names(&dir), ["a.png", "c.stl"]);
        assert_eq!(std::fs::read(&a).unwrap(), b"old a");
        std::fs::remove_dir_all(&c).unwrap();

        // All well: every file in place, a replaced file keeps its permissions.
        let mut s = Staged::new();
        s.add(&a, b"new a").unwrap();
        s.add(&b, b"new b").unwrap();
        s.commit().unwrap();
        assert_eq!(names(&dir), ["a.png", "b.obj"]);
        assert_eq!(std::fs::read(&a).unwrap(), b"new a");
        assert_eq!(std::fs::read(&b).unwrap(), b"new b");
        let mode = std::fs::metadata(&a).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o600);
        assert!(!pending().iter().any(|p| p.starts_with(&dir)));

        // A name at the filesystem's limit (255 bytes) is written too (its hidden twin's
        // name is shortened).
        let long = dir.join(format!("{}.png", "n".repeat(251)));
        write_atomic(&long, b"long").unwrap();
        assert_eq!(std::fs::read(&long).unwrap(), b"long");
        std::fs::remove_file(&long).unwrap();

        // A streamed copy: whole, or nothing left beside its target when the rename fails.
        let copy = dir.join("copy.bin");
        assert_eq!(copy_atomic(&b, &copy).unwrap(), 5);
        assert_eq!(std::fs::read(&copy).unwrap(), b"new b");
        let blocked = dir.join("blocked");
        std::fs::create_dir(&blocked).unwrap();
        std::fs::write(blocked.join("x"), b"x").unwrap();
        assert!(copy_atomic(&b, &blocked).is_err());
        assert!(copy_atomic(&dir.join("none"), &dir.join("never")).is_err());
        assert_eq!(names(&dir), ["a.png", "b.obj", "blocked", "copy.bin"]);
        std::fs::remove_dir_all(&dir).ok();
    }
}
