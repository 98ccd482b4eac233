//! Video files through OpenCV's videoio (FFmpeg backend on Debian).
//!
//! A file that cannot be opened is fatal; a frame that cannot be read ends the video cleanly
//! (a truncated file plays what it has), and [`FrameSource::end_note`] says how many of the
//! declared frames were read. Times are the container's presentation times, seconds.

use std::path::{Path, PathBuf};

use image::RgbImage;
use opencv::core::{Mat, Scalar, Size};
use opencv::prelude::*;
use opencv::videoio::{self, VideoCapture, VideoWriter};

use super::source::{FrameSource, RawFrame, SourceError};

/// A video file, optionally looping back to its start when it ends.
pub struct VideoSource {
    path: PathBuf,
    looping: bool,
    capture: Option<VideoCapture>,
    fps: Option<f64>,
    declared_frames: Option<u64>,
    /// Frames read in the current pass through the file.
    read: u64,
    /// Time offset of the current pass (looping), seconds.
    pass_offset_s: f64,
    last_time_s: f64,
    mat: Mat,
}

fn cv_err(path: &Path, what: &str, e: opencv::Error) -> SourceError {
    SourceError::Fatal {
        source_name: path.display().to_string(),
        reason: format!("{what}: {}", e.message),
    }
}

impl VideoSource {
    pub fn new(path: impl Into<PathBuf>, looping: bool) -> Self {
        VideoSource {
            path: path.into(),
            looping,
            capture: None,
            fps: None,
            declared_frames: None,
            read: 0,
            pass_offset_s: 0.0,
            last_time_s: 0.0,
            mat: Mat::default(),
        }
    }

    fn open(&mut self) -> Result<(), SourceError> {
        let fatal = |reason: String| SourceError::Fatal {
            source_name: self.path.display().to_string(),
            reason,
        };
        if !self.path.is_file() {
            // A looping video that has played and is gone (a share unmounted, a file being
            // replaced) is waited for, as an unplugged camera is; missing at the start, it is
            // a mistake.
            if self.looping && self.pass_offset_s > 0.0 {
                return Err(SourceError::Unavailable {
                    source_name: self.path.display().to_string(),
                    reason: "video file gone".into(),
                });
            }
            return Err(fatal("video file not found".into()));
        }
        let cap = VideoCapture::from_file(&self.path, videoio::CAP_FFMPEG)
            .map_err(|e| cv_err(&self.path, "cannot open", e))?;
        if !cap.is_opened().unwrap_or(false) {
            return Err(fatal(
                "not a video OpenCV can read (unknown container or codec)".into(),
            ));
        }
        let fps = cap.get(videoio::CAP_PROP_FPS).unwrap_or(0.0);
        self.fps = (fps.is_finite() && fps > 0.0 && fps < 1000.0).then_some(fps);
        let n = cap.get(videoio::CAP_PROP_FRAME_COUNT).unwrap_or(0.0);
        self.declared_frames = (n.is_finite() && n >= 1.0).then_some(n as u64);
        self.read = 0;
        self.capture = Some(cap);
        Ok(())
    }
}

impl FrameSource for VideoSource {
    fn name(&self) -> String {
        self.path.display().to_string()
    }

    fn next_frame(&mut self) -> Result<Option<RawFrame>, SourceError> {
        if self.capture.is_none() {
            self.open()?;
        }
        let Some(cap) = self.capture.as_mut() else {
            return Ok(None);
        };
        // A read error mid-file is the end of what can be played.
        let got = cap.read(&mut self.mat).unwrap_or(false) && !self.mat.empty();
        if !got {
            if self.looping && self.read > 0 {
                // Start the next pass where the last one's times ended.
                self.pass_offset_s = self.last_time_s + 1.0 / self.fps.unwrap_or(30.0);
                self.capture = None;
                return self.next_frame();
            }
            self.capture = None;
            self.looping = false;
            return Ok(None);
        }
        let pos_ms = cap.get(videoio::CAP_PROP_POS_MSEC).unwrap_or(f64::NAN);
        let time_s = if pos_ms.is_finite() && pos_ms >= 0.0 {
            pos_ms / 1e3
        } else {
            self.read as f64 / self.fps.unwrap_or(30.0)
        } + self.pass_offset_s;
        self.read += 1;
        self.last_time_s = time_s;
        let image = bgr_mat_to_rgb(&self.mat).map_err(|reason| SourceError::BadFrame {
            source_name: self.path.display().to_string(),
            reason,
        })?;
        Ok(Some(RawFrame {
            image,
            time_s: Some(time_s),
            path: None,
        }))
    }

    fn frame_rate(&self) -> Option<f64> {
        self.fps
    }

    fn end_note(&self) -> Option<String> {
        let declared = self.declared_frames?;
        (self.read < declared).then(|| {
            format!(
                "ended after {} of {declared} declared frames (truncated or damaged file)",
                self.read
            )
        })
    }
}

/// Converts an 8-bit BGR (or grey) OpenCV image to RGB.
fn bgr_mat_to_rgb(mat: &Mat) -> Result<RgbImage, String> {
    let (w, h) = (mat.cols(), mat.rows());
    let channels = mat.channels();
    if mat.depth() != opencv::core::CV_8U || !(channels == 1 || channels == 3) {
        return Err(format!(
            "unsupported pixel type {} ({channels} channels)",
            mat.typ()
        ));
    }
    let owned;
    let continuous = if mat.is_continuous() {
        mat
    } else {
        owned = mat.try_clone().map_err(|e| e.message)?;
        &owned
    };
    let bytes = continuous.data_bytes().map_err(|e| e.message)?;
    let (w, h) = (w as u32, h as u32);
    let mut rgb = Vec::with_capacity(w as usize * h as usize * 3);
    if channels == 3 {
        for px in bytes.chunks_exact(3) {
            rgb.extend_from_slice(&[px[2], px[1], px[0]]);
        }
    } else {
        for &g in bytes {
            rgb.extend_from_slice(&[g, g, g]);
        }
    }
    RgbImage::from_raw(w, h, rgb).ok_or_else(|| format!("frame {w}x{h} has the wrong size"))
}

/// Writes frames to a Motion-JPEG AVI (for generated test and benchmark videos). All frames
/// must have the first one's size.
pub fn write_mjpeg_avi(path: &Path, frames: &[RgbImage], fps: f64) -> Result<(), SourceError> {
    let fatal = |reason: String| SourceError::Fatal {
        source_name: path.display().to_string(),
        reason,
    };
    let Some(first) = frames.first() else {
        return Err(fatal("no frames to write".into()));
    };
    let (w, h) = first.dimensions();
    let fourcc = VideoWriter::fourcc('M', 'J', 'P', 'G').map_err(|e| cv_err(path, "fourcc", e))?;
    let size = Size::new(w as i32, h as i32);
    let mut writer = VideoWriter::new(path, fourcc, fps, size, true)
        .map_err(|e| cv_err(path, "cannot create", e))?;
    if !writer.is_opened().unwrap_or(false) {
        return Err(fatal("cannot create video (no MJPEG writer?)".into()));
    }
    let mut mat = Mat::new_rows_cols_with_default(
        h as i32,
        w as i32,
        opencv::core::CV_8UC3,
        Scalar::all(0.0),
    )
    .map_err(|e| cv_err(path, "allocating a frame", e))?;
    for (i, f) in frames.iter().enumerate() {
        if f.dimensions() != (w, h) {
            return Err(fatal(format!(
                "frame {i} is {}x{}, the video is {w}x{h}",
                f.width(),
                f.height()
            )));
        }
        let dst = mat
            .data_bytes_mut()
            .map_err(|e| cv_err(path, "frame buffer", e))?;
        for (d, s) in dst.chunks_exact_mut(3).zip(f.as_raw().chunks_exact(3)) {
            d.copy_from_slice(&[s[2], s[1], s[0]]);
        }
        writer
            .write(&mat)
            .map_err(|e| cv_err(path, "writing a frame", e))?;
    }
    writer
        .release()
        .map_err(|e| cv_err(path, "finishing the file", e))?;
    Ok(())
}
