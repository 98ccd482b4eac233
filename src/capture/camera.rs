//! Webcams through nokhwa (v4l2 on Linux).
//!
//! The camera is opened on the first [`FrameSource::next_frame`] and after every failure: a
//! missing camera, or one unplugged mid-run, is [`SourceError::Unavailable`], which the capture
//! thread retries with back-off, so plugging it (back) in resumes the stream.

use nokhwa::Camera;
use nokhwa::pixel_format::RgbFormat;
use nokhwa::utils::{CameraIndex, RequestedFormat, RequestedFormatType};

use super::source::{FrameSource, RawFrame, SourceError};

/// A webcam by index (`/dev/videoN`).
pub struct CameraSource {
    index: u32,
    camera: Option<Camera>,
}

impl CameraSource {
    pub fn new(index: u32) -> Self {
        CameraSource {
            index,
            camera: None,
        }
    }

    fn unavailable(&self, reason: String) -> SourceError {
        SourceError::Unavailable {
            source_name: self.name(),
            reason,
        }
    }
}

impl FrameSource for CameraSource {
    fn name(&self) -> String {
        format!("camera {}", self.index)
    }

    fn next_frame(&mut self) -> Result<Option<RawFrame>, SourceError> {
        if self.camera.is_none() {
            let format =
                RequestedFormat::new::<RgbFormat>(RequestedFormatType::AbsoluteHighestFrameRate);
            let mut cam = Camera::new(CameraIndex::Index(self.index), format)
                .map_err(|e| self.unavailable(e.to_string()))?;
            cam.open_stream()
                .map_err(|e| self.unavailable(format!("cannot start streaming: {e}")))?;
            self.camera = Some(cam);
        }
        let Some(cam) = self.camera.as_mut() else {
            return Ok(None);
        };
        let frame = match cam.frame() {
            Ok(frame) => frame,
            Err(e) => {
                // Unplugged or failing: drop the handle so the next call reopens it.
                self.camera = None;
                return Err(self.unavailable(format!("lost: {e}")));
            }
        };
        let image = frame
            .decode_image::<RgbFormat>()
            .map_err(|e| SourceError::BadFrame {
                source_name: self.name(),
                reason: e.to_string(),
            })?;
        Ok(Some(RawFrame::new(image)))
    }
}
