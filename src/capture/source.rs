//! Frame sources behind one interface: a photo, a folder of photos, frames in memory, and (with
//! their cargo features) video files through OpenCV and webcams through nokhwa.
//!
//! A source is pulled one frame at a time by the capture thread ([`super::live`]). It says what
//! went wrong in a way the thread can act on: a device that is not there (yet) is
//! [`SourceError::Unavailable`] and is retried with back-off, a single unreadable frame or file
//! is [`SourceError::BadFrame`] and is skipped and counted, anything else ends the source.
//! Sources open their device lazily in [`FrameSource::next_frame`] and drop it after an
//! `Unavailable` error, so a retry is simply the next call.
//!
//! Units: pixels (8-bit RGB, top-left origin); times in seconds from the source's start.

use std::path::{Path, PathBuf};

use image::RgbImage;

/// A frame as a source delivers it.
#[derive(Clone, Debug)]
pub struct RawFrame {
    pub image: RgbImage,
    /// Presentation time in the source, seconds (video files); `None` for live sources, whose
    /// frames are stamped with the time they were read.
    pub time_s: Option<f64>,
    /// Where the frame came from, when that is a file of its own (folders).
    pub path: Option<PathBuf>,
}

impl RawFrame {
    pub fn new(image: RgbImage) -> Self {
        RawFrame {
            image,
            time_s: None,
            path: None,
        }
    }
}

/// What went wrong in a source, by what the capture thread should do about it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SourceError {
    /// The device is missing or has gone away: retry later.
    #[error("{source_name}: unavailable: {reason}")]
    Unavailable { source_name: String, reason: String },
    /// One frame or file could not be read: skip it and go on.
    #[error("{source_name}: bad frame: {reason}")]
    BadFrame { source_name: String, reason: String },
    /// The source cannot go on (a folder that does not exist, a file that is not a video).
    #[error("{source_name}: {reason}")]
    Fatal { source_name: String, reason: String },
}

/// Something that yields frames.
pub trait FrameSource {
    /// A short name for status lines and errors (a path, "camera 0").
    fn name(&self) -> String;
    /// The next frame, or `Ok(None)` when the source has ended.
    fn next_frame(&mut self) -> Result<Option<RawFrame>, SourceError>;
    /// The rate the source is meant to be played at, frames per second (video files).
    fn frame_rate(&self) -> Option<f64> {
        None
    }
    /// Why the source ended, when that is worth telling (a video shorter than it declares).
    fn end_note(&self) -> Option<String> {
        None
    }
}

/// A source that could not be opened where it was to run (the capture thread reopens it):
/// its one frame is the error, as fatal, so the thread's owner hears why.
pub struct FailedSource(pub String);

impl FrameSource for FailedSource {
    fn name(&self) -> String {
        "source".into()
    }
    fn next_frame(&mut self) -> Result<Option<RawFrame>, SourceError> {
        Err(SourceError::Fatal {
            source_name: "source".into(),
            reason: self.0.clone(),
        })
    }
}

/// Image file extensions a folder source picks up (case-insensitive).
pub const IMAGE_EXTENSIONS: [&str; 10] = [
    "jpg", "jpeg", "png", "ppm", "pgm", "pnm", "bmp", "tif", "tiff", "webp",
];

/// Whether `path` names a file a folder source would read, by its extension.
pub fn is_image_path(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| IMAGE_EXTENSIONS.iter().any(|x| x.eq_ignore_ascii_case(e)))
}

/// The image files in `dir`, sorted by name (not recursive; hidden files skipped).
pub fn list_images(dir: &Path) -> Result<Vec<PathBuf>, SourceError> {
    let fatal = |reason: String| SourceError::Fatal {
        source_name: dir.display().to_string(),
        reason,
    };
    let entries = std::fs::read_dir(dir).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => fatal("folder not found".into()),
        std::io::ErrorKind::NotADirectory => fatal("not a folder".into()),
        _ => fatal(format!("cannot list: {e}")),
    })?;
    let mut files = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| fatal(format!("cannot list: {e}")))?;
        let path = entry.path();
        let hidden = path
            .file_name()
            .and_then(|n| n.to_str())
            .is_some_and(|n| n.starts_with('.'));
        if !hidden && is_image_path(&path) && path.is_file() {
            files.push(path);
        }
    }
    files.sort();
    Ok(files)
}

/// One photo, delivered once.
pub struct ImageFileSource {
    path: PathBuf,
    done: bool,
}

impl ImageFileSource {
    pub fn new(path: impl Into<PathBuf>) -> Self {
        ImageFileSource {
            path: path.into(),
            done: false,
        }
    }
}

impl FrameSource for ImageFileSource {
    fn name(&self) -> String {
        self.path.display().to_string()
    }

    fn next_frame(&mut self) -> Result<Option<RawFrame>, SourceError> {
        if self.done {
            return Ok(None);
        }
        self.done = true;
        let image = super::load_photo(&self.path).map_err(|e| SourceError::Fatal {
            source_name: self.name(),
            reason: e.to_string(),
        })?;
        Ok(Some(RawFrame {
            image,
            time_s: None,
            path: Some(self.path.clone()),
        }))
    }
}

/// One photo seen again and again at `fps`, as by a camera pointed at it: a kiosk shown
/// without a camera (a demonstration, the documentation's screenshots). The photo is read once.
pub struct StillSource {
    path: PathBuf,
    image: Option<RgbImage>,
    fps: f64,
    index: u64,
}

impl StillSource {
    pub fn new(path: impl Into<PathBuf>, fps: f64) -> Self {
        StillSource {
            path: path.into(),
            image: None,
            fps: if fps.is_finite() && fps > 0.0 {
                fps
            } else {
                10.0
            },
            index: 0,
        }
    }
}

impl FrameSource for StillSource {
    fn name(&self) -> String {
        self.path.display().to_string()
    }

    fn next_frame(&mut self) -> Result<Option<RawFrame>, SourceError> {
        let image = match &self.image {
            Some(image) => image.clone(),
            None => {
                let image = super::load_photo(&self.path).map_err(|e| SourceError::Fatal {
                    source_name: self.name(),
                    reason: e.to_string(),
                })?;
                self.image = Some(image.clone());
                image
            }
        };
        let time_s = self.index as f64 / self.fps;
        self.index += 1;
        Ok(Some(RawFrame {
            image,
            time_s: Some(time_s),
            path: None,
        }))
    }

    fn frame_rate(&self) -> Option<f64> {
        Some(self.fps)
    }
}

/// The images of a folder in name order; an unreadable one is a [`SourceError::BadFrame`]
/// and the next call goes on with the next file.
pub struct FolderSource {
    dir: PathBuf,
    files: Option<std::vec::IntoIter<PathBuf>>,
}

impl FolderSource {
    pub fn new(dir: impl Into<PathBuf>) -> Self {
        FolderSource {
            dir: dir.into(),
            files: None,
        }
    }
}

impl FrameSource for FolderSource {
    fn name(&self) -> String {
        self.dir.display().to_string()
    }

    fn next_frame(&mut self) -> Result<Option<RawFrame>, SourceError> {
        let files = match &mut self.files {
            Some(files) => files,
            None => self.files.insert(list_images(&self.dir)?.into_iter()),
        };
        let Some(path) = files.next() else {
            return Ok(None);
        };
        match super::load_photo(&path) {
            Ok(image) => Ok(Some(RawFrame {
                image,
                time_s: None,
                path: Some(path),
            })),
            Err(e) => Err(SourceError::BadFrame {
                source_name: self.dir.display().to_string(),
                reason: e.to_string(),
            }),
        }
    }
}

/// Frames already in memory (generated sequences, tests of the pipeline on known motion),
/// played at `fps` with times `index / fps`.
pub struct MemorySource {
    name: String,
    frames: std::vec::IntoIter<RgbImage>,
    fps: f64,
    index: u64,
}

impl MemorySource {
    pub fn new(name: impl Into<String>, frames: Vec<RgbImage>, fps: f64) -> Self {
        MemorySource {
            name: name.into(),
            frames: frames.into_iter(),
            fps,
            index: 0,
        }
    }
}

impl FrameSource for MemorySource {
    fn name(&self) -> String {
        self.name.clone()
    }

    fn next_frame(&mut self) -> Result<Option<RawFrame>, SourceError> {
        let Some(image) = self.frames.next() else {
            return Ok(None);
        };
        let time_s = self.index as f64 / self.fps;
        self.index += 1;
        Ok(Some(RawFrame {
            image,
            time_s: Some(time_s),
            path: None,
        }))
    }

    fn frame_rate(&self) -> Option<f64> {
        Some(self.fps)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("glyptic-source-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn folder_skips_bad_files_and_goes_on() {
        let dir = scratch("folder");
        let img = RgbImage::from_pixel(40, 40, image::Rgb([10, 20, 30]));
        img.save(dir.join("a.png")).unwrap();
        std::fs::write(dir.join("b.jpg"), b"not a jpeg at all").unwrap();
        img.save(dir.join("c.PNG")).unwrap();
        std::fs::write(dir.join("notes.txt"), b"ignored").unwrap();
        std::fs::write(dir.join(".hidden.png"), b"ignored").unwrap();

        let mut src = FolderSource::new(&dir);
        let a = src.next_frame().unwrap().unwrap();
        assert_eq!(a.path.as_deref(), Some(dir.join("a.png").as_path()));
        let b = src.next_frame().unwrap_err();
        assert!(
            matches!(&b, SourceError::BadFrame { reason, .. } if reason.contains("b.jpg")),
            "{b}"
        );
        let c = src.next_frame().unwrap().unwrap();
        assert_eq!(c.image.dimensions(), (40, 40));
        assert!(src.next_frame().unwrap().is_none());
        assert!(src.next_frame().unwrap().is_none(), "stays ended");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn missing_folder_is_fatal_and_named() {
        let mut src = FolderSource::new("/nonexistent/glyptic-folder");
        let e = src.next_frame().unwrap_err();
        assert!(
            matches!(&e, SourceError::Fatal { .. }) && e.to_string().contains("glyptic-folder"),
            "{e}"
        );
    }

    #[test]
    fn memory_source_stamps_frames_at_its_rate() {
        let frames = vec![RgbImage::new(32, 32); 3];
        let mut src = MemorySource::new("mem", frames, 25.0);
        let times: Vec<f64> = std::iter::from_fn(|| src.next_frame().unwrap())
            .map(|f| f.time_s.unwrap())
            .collect();
        assert_eq!(times, [0.0, 0.04, 0.08]);
    }
    #[test]
    fn a_still_photo_plays_as_an_endless_camera() {
        let dir = scratch("still");
        let path = dir.join("face.png");
        RgbImage::from_pixel(48, 40, image::Rgb([200, 10, 10]))
            .save(&path)
            .unwrap();
        let mut src = StillSource::new(&path, 10.0);
        assert_eq!(src.frame_rate(), Some(10.0));
        for i in 0..5 {
            let f = src.next_frame().unwrap().expect("never ends");
            assert_eq!(f.image.dimensions(), (48, 40));
            assert!((f.time_s.unwrap() - f64::from(i) * 0.1).abs() < 1e-9);
        }
        // Damaged or missing: fatal and named, not a panic.
        std::fs::write(&path, b"not a png").unwrap();
        let e = StillSource::new(&path, f64::NAN).next_frame().unwrap_err();
        assert!(
            matches!(e, SourceError::Fatal { .. }) && e.to_string().contains("face.png"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
