//! Reading an input file safely: only a regular file (a folder, a device such as `/dev/zero`
//! or a pipe is refused before it is opened, so nothing blocks or streams forever), and never
//! more than the input's cap (checked against the declared size first, and while reading, for
//! files whose size lies). Units: bytes.

use std::io::Read as _;
use std::path::Path;

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
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a regular file (a folder, a device or a pipe)",
        ));
    }
    let too_large = |bytes: u64| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("{bytes} bytes, more than the {max} this input may have"),
        )
    };
    if meta.len() > max {
        return Err(too_large(meta.len()));
    }
    let mut bytes = Vec::with_capacity(usize::try_from(meta.len()).unwrap_or(0));
    std::fs::File::open(path)?
        .take(max + 1)
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max {
        return Err(too_large(bytes.len() as u64));
    }
    Ok(bytes)
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

/// Writes `bytes` to `path` whole or not at all: into a hidden file beside it, synced, then
/// renamed over it, so a reader (or a crash) never sees half a file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write as _;
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .ok_or_else(|| std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a file name"))?;
    // Unique per process and call: two threads may write the same file at once.
    static CALLS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let tmp = dir.join(format!(
        ".{}.{}.{call}.tmp",
        name.to_string_lossy(),
        std::process::id()
    ));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
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
}
