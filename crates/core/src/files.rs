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

#[cfg(test)]
mod tests {
    use super::*;

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
