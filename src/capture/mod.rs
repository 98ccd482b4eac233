//! Frames in: photos decoded with checks (a hostile or broken file gives a clear error instead
//! of a panic or a huge allocation), frame sources behind one interface ([`source`]: photo,
//! folder, memory; [`video`] files with the `video` feature; [`camera`] with `webcam`), and the
//! capture thread ([`live`]) that hands the newest frame on through a [`latest`] channel.
//!
//! Units: pixels. Frames are 8-bit RGB, top-left origin.

#[cfg(feature = "webcam")]
pub mod camera;
pub mod latest;
pub mod live;
pub mod source;
#[cfg(feature = "video")]
pub mod video;

use std::path::{Path, PathBuf};

pub use latest::{Closed, LatestReceiver, LatestSender, latest};
pub use live::{Backoff, Capture, CaptureEvent, CaptureOptions, CaptureSummary, Frame};
pub use source::{FolderSource, FrameSource, ImageFileSource, MemorySource, RawFrame, SourceError};

/// Largest accepted side, pixels (a 16k photo is already beyond any camera we serve).
pub const MAX_SIDE: u32 = 16_384;
/// Largest accepted pixel count (100 megapixels).
pub const MAX_PIXELS: u64 = 100_000_000;
/// Smallest side that can hold a face worth fitting.
pub const MIN_SIDE: u32 = 32;

/// Why a photo could not be read.
#[derive(Debug, thiserror::Error)]
pub enum CaptureError {
    #[error("{path}: file not found")]
    NotFound { path: PathBuf },
    #[error("{path}: cannot read: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: not an image (unrecognised format)")]
    NotAnImage { path: PathBuf },
    #[error(
        "{path}: image is {width}x{height} pixels, too large (limit {MAX_SIDE} per side, {MAX_PIXELS} pixels)"
    )]
    TooLarge {
        path: PathBuf,
        width: u32,
        height: u32,
    },
    #[error(
        "{path}: image is {width}x{height} pixels, too small to hold a face (minimum {MIN_SIDE}x{MIN_SIDE})"
    )]
    TooSmall {
        path: PathBuf,
        width: u32,
        height: u32,
    },
    #[error("{path}: cannot decode image: {reason}")]
    Decode { path: PathBuf, reason: String },
}

/// Reads and decodes a photo to RGB, checking its declared size before decoding it.
pub fn load_photo(path: &Path) -> Result<image::RgbImage, CaptureError> {
    let p = || path.to_path_buf();
    let bytes = std::fs::read(path).map_err(|source| match source.kind() {
        std::io::ErrorKind::NotFound => CaptureError::NotFound { path: p() },
        _ => CaptureError::Io { path: p(), source },
    })?;
    decode_photo(&bytes, path)
}

/// Decodes photo bytes (`path` only names them in errors).
pub fn decode_photo(bytes: &[u8], path: &Path) -> Result<image::RgbImage, CaptureError> {
    let p = || path.to_path_buf();
    let format = image::guess_format(bytes).map_err(|_| CaptureError::NotAnImage { path: p() })?;
    if format == image::ImageFormat::Jpeg && !jpeg_is_complete(bytes) {
        // The decoder would fill the missing part with grey and carry on.
        return Err(CaptureError::Decode {
            path: p(),
            reason: "truncated JPEG (no end-of-image marker after the image data)".into(),
        });
    }
    let reader = || image::ImageReader::with_format(std::io::Cursor::new(bytes), format);
    let (width, height) = reader()
        .into_dimensions()
        .map_err(|e| CaptureError::Decode {
            path: p(),
            reason: e.to_string(),
        })?;
    if width > MAX_SIDE || height > MAX_SIDE || u64::from(width) * u64::from(height) > MAX_PIXELS {
        return Err(CaptureError::TooLarge {
            path: p(),
            width,
            height,
        });
    }
    if width < MIN_SIDE || height < MIN_SIDE {
        return Err(CaptureError::TooSmall {
            path: p(),
            width,
            height,
        });
    }
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_SIDE);
    limits.max_image_height = Some(MAX_SIDE);
    limits.max_alloc = Some(MAX_PIXELS * 8);
    let mut r = reader();
    r.limits(limits);
    let img = r.decode().map_err(|e| CaptureError::Decode {
        path: p(),
        reason: e.to_string(),
    })?;
    Ok(img.to_rgb8())
}

/// Whether a JPEG's last scan is followed by an end-of-image marker. Entropy-coded data never
/// contains 0xFF followed by 0xD9 or 0xDA (0xFF bytes are stuffed), so the last start-of-scan
/// marker belongs to the main image's final scan even when an EXIF thumbnail (with markers of
/// its own) comes first.
pub fn jpeg_is_complete(bytes: &[u8]) -> bool {
    let last = |marker: u8| {
        bytes
            .windows(2)
            .rposition(|w| w[0] == 0xFF && w[1] == marker)
    };
    match (last(0xDA), last(0xD9)) {
        (Some(sos), Some(eoi)) => eoi > sos,
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jpeg_completeness() {
        // SOI, SOS, data, EOI.
        let whole = [0xFF, 0xD8, 0xFF, 0xDA, 0x12, 0xFF, 0x00, 0x34, 0xFF, 0xD9];
        assert!(jpeg_is_complete(&whole));
        assert!(!jpeg_is_complete(&whole[..8]));
        // A thumbnail's EOI before the main scan does not count.
        let thumb = [
            0xFF, 0xD8, 0xFF, 0xDA, 0x01, 0xFF, 0xD9, 0xFF, 0xDA, 0x02, 0x03,
        ];
        assert!(!jpeg_is_complete(&thumb));
    }

    #[test]
    fn declared_size_is_checked_before_decoding() {
        let huge = b"P6\n100000 100000\n255\n\x80\x80";
        let err = decode_photo(huge, Path::new("huge.ppm")).unwrap_err();
        assert!(
            matches!(
                err,
                CaptureError::TooLarge {
                    width: 100_000,
                    height: 100_000,
                    ..
                }
            ),
            "{err}"
        );
    }
}
