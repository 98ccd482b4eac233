//! Frames in: photos decoded with checks (a hostile or broken file gives a clear error instead
//! of a panic or a huge allocation), frame sources behind one interface ([`source`]: photo,
//! folder, memory; [`video`] files with the `video` feature, read in a helper process
//! ([`video_process`]); [`camera`] with `webcam`), and the
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
pub mod video_process;

use std::path::{Path, PathBuf};

pub use latest::{Closed, LatestReceiver, LatestSender, latest};
pub use live::{Backoff, Capture, CaptureEvent, CaptureOptions, CaptureSummary, Frame};
pub use source::{
    FailedSource, FolderSource, FrameSource, ImageFileSource, MemorySource, RawFrame, SourceError,
    StillSource,
};

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
    let bytes =
        crate::files::read_limited(path, crate::files::MAX_PHOTO_BYTES).map_err(|source| {
            match source.kind() {
                std::io::ErrorKind::NotFound => CaptureError::NotFound { path: p() },
                _ => CaptureError::Io { path: p(), source },
            }
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
    use image::ImageDecoder;
    let decode_error = |e: image::ImageError| CaptureError::Decode {
        path: p(),
        reason: e.to_string(),
    };
    let mut decoder = reader().into_decoder().map_err(decode_error)?;
    decoder.set_limits(limits).map_err(decode_error)?;
    // Phones store the picture as the sensor saw it and say in EXIF how to turn it; a face
    // on its side is found by no detector, so the photo is turned upright first. A broken
    // orientation tag is not worth refusing the photo for: it is then taken as it is.
    let orientation = decoder
        .orientation()
        .unwrap_or(image::metadata::Orientation::NoTransforms);
    let mut img = image::DynamicImage::from_decoder(decoder).map_err(decode_error)?;
    img.apply_orientation(orientation);
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

    /// A JPEG of `w` x `h` pixels, red on its left half and blue on its right, with an EXIF
    /// orientation tag (`None`: no EXIF at all).
    fn jpeg_with_orientation(w: u32, h: u32, orientation: Option<u16>) -> Vec<u8> {
        let img = image::RgbImage::from_fn(w, h, |x, _| {
            if x < w / 2 {
                image::Rgb([220, 20, 20])
            } else {
                image::Rgb([20, 20, 220])
            }
        });
        let mut jpeg = Vec::new();
        image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, 95)
            .encode_image(&img)
            .unwrap();
        let Some(o) = orientation else {
            return jpeg;
        };
        // APP1 "Exif": a little-endian TIFF header and one IFD entry, 0x0112 SHORT.
        let mut tiff = b"II*\0".to_vec();
        tiff.extend(8u32.to_le_bytes());
        tiff.extend(1u16.to_le_bytes());
        tiff.extend(0x0112u16.to_le_bytes());
        tiff.extend(3u16.to_le_bytes());
        tiff.extend(1u32.to_le_bytes());
        tiff.extend(o.to_le_bytes());
        tiff.extend([0, 0]);
        tiff.extend(0u32.to_le_bytes());
        let mut app1 = b"Exif\0\0".to_vec();
        app1.extend(tiff);
        let mut out = jpeg[..2].to_vec();
        out.extend([0xFF, 0xE1]);
        out.extend(((app1.len() + 2) as u16).to_be_bytes());
        out.extend(app1);
        out.extend(&jpeg[2..]);
        out
    }

    #[test]
    fn exif_orientation_turns_the_photo_upright() {
        let is_red = |p: &image::Rgb<u8>| p[0] > 150 && p[2] < 100;
        let is_blue = |p: &image::Rgb<u8>| p[2] > 150 && p[0] < 100;
        let plain = decode_photo(&jpeg_with_orientation(96, 48, None), Path::new("a.jpg")).unwrap();
        assert_eq!(plain.dimensions(), (96, 48));
        assert!(is_red(plain.get_pixel(10, 24)) && is_blue(plain.get_pixel(86, 24)));
        let upright =
            decode_photo(&jpeg_with_orientation(96, 48, Some(1)), Path::new("b.jpg")).unwrap();
        assert_eq!(upright.dimensions(), (96, 48));
        // 6: the camera was turned a quarter clockwise; shown turned 90 degrees clockwise, the
        // left (red) half is on top.
        let turned =
            decode_photo(&jpeg_with_orientation(96, 48, Some(6)), Path::new("c.jpg")).unwrap();
        assert_eq!(turned.dimensions(), (48, 96));
        assert!(
            is_red(turned.get_pixel(24, 10)),
            "{:?}",
            turned.get_pixel(24, 10)
        );
        assert!(is_blue(turned.get_pixel(24, 86)));
        // 8: a quarter anticlockwise, the red half at the bottom.
        let other =
            decode_photo(&jpeg_with_orientation(96, 48, Some(8)), Path::new("d.jpg")).unwrap();
        assert_eq!(other.dimensions(), (48, 96));
        assert!(is_red(other.get_pixel(24, 86)) && is_blue(other.get_pixel(24, 10)));
        // 3: upside down, red on the right.
        let flipped =
            decode_photo(&jpeg_with_orientation(96, 48, Some(3)), Path::new("e.jpg")).unwrap();
        assert!(is_red(flipped.get_pixel(86, 24)) && is_blue(flipped.get_pixel(10, 24)));
    }
}
