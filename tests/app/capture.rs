//! Capture sources on real files and devices: video files written and read back through
//! OpenCV (whole, truncated, looping, not a video), and the webcam source on a machine without
//! a camera.
//!
//! Needs a capture feature (`video` or `webcam`, both default).
#![cfg(any(feature = "video", feature = "webcam"))]

use std::path::PathBuf;
use std::time::Duration;

use glyptic::capture::{
    Backoff, Capture, CaptureEvent, CaptureOptions, FrameSource, RawFrame, SourceError,
};
use image::RgbImage;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("glyptic-capture-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Frame `i` of a test clip: grey level `8 * i` with a white square moving right.
fn clip_frame(i: usize) -> RgbImage {
    let level = (8 * i).min(255) as u8;
    RgbImage::from_fn(96, 64, |x, y| {
        let in_square = (x as usize).abs_diff(10 + 2 * i) < 6 && (28..36).contains(&y);
        if in_square {
            image::Rgb([255, 255, 255])
        } else {
            image::Rgb([level, level, level])
        }
    })
}

#[cfg(feature = "video")]
mod video {
    use super::*;
    use glyptic::capture::video::{VideoSource, write_mjpeg_avi};
    use glyptic::capture::video_process::VideoProcess;

    fn write_clip(dir: &std::path::Path, n: usize) -> PathBuf {
        let path = dir.join("clip.avi");
        let frames: Vec<RgbImage> = (0..n).map(clip_frame).collect();
        write_mjpeg_avi(&path, &frames, 25.0).unwrap();
        path
    }

    fn read_all(src: &mut dyn FrameSource) -> Vec<RawFrame> {
        std::iter::from_fn(|| src.next_frame().expect("no error mid-video")).collect()
    }

    /// The helper process `glyptic` itself reads videos with (built with this test binary).
    const HELPER: &str = env!("CARGO_BIN_EXE_glyptic-video");

    /// Both readers of a video: OpenCV in this process, and through the helper process.
    fn readers(path: &std::path::Path, looping: bool) -> [(&'static str, Box<dyn FrameSource>); 2] {
        [
            ("in process", Box::new(VideoSource::new(path, looping))),
            (
                "helper",
                Box::new(VideoProcess::with_helper(HELPER, path, looping)),
            ),
        ]
    }

    #[test]
    fn video_reads_back_every_frame_with_its_time() {
        let dir = scratch("whole");
        let path = write_clip(&dir, 30);
        let mut seen = Vec::new();
        for (how, mut src) in readers(&path, false) {
            let frames = read_all(&mut *src);
            assert_eq!(frames.len(), 30, "{how}");
            assert_eq!(src.frame_rate(), Some(25.0), "{how}");
            assert!(src.end_note().is_none(), "{how}: {:?}", src.end_note());
            for (i, f) in frames.iter().enumerate() {
                assert_eq!(f.image.dimensions(), (96, 64));
                let t = f.time_s.unwrap();
                assert!(
                    (t - i as f64 / 25.0).abs() < 1e-3,
                    "{how}: frame {i} at {t} s"
                );
                // JPEG-compressed grey level.
                let v = f.image.get_pixel(80, 5)[0] as i32;
                assert!(
                    (v - (8 * i) as i32).abs() <= 4,
                    "{how}: frame {i}: grey {v}"
                );
            }
            seen.push(frames);
        }
        let same = seen[0]
            .iter()
            .zip(&seen[1])
            .all(|(a, b)| a.image == b.image && a.time_s == b.time_s);
        assert!(same, "the helper's frames differ from OpenCV's own");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn truncated_video_plays_what_it_has_and_ends_cleanly() {
        let dir = scratch("truncated");
        let whole = write_clip(&dir, 30);
        let bytes = std::fs::read(&whole).unwrap();
        let cut = dir.join("cut.avi");
        std::fs::write(&cut, &bytes[..bytes.len() * 6 / 10]).unwrap();

        let mut counts = Vec::new();
        for (how, mut src) in readers(&cut, false) {
            let frames = read_all(&mut *src);
            assert!(
                (10..30).contains(&frames.len()),
                "{how}: {} frames from 60 % of the file",
                frames.len()
            );
            let note = src.end_note().expect("says it ended early");
            assert!(
                note.contains(&format!("after {} of 30", frames.len())),
                "{how}: {note}"
            );
            counts.push(frames.len());
        }
        assert_eq!(counts[0], counts[1]);

        // Through the capture thread, as the kiosk reads it: frames, then an end event with
        // the note.
        let capture = Capture::spawn(
            move || Box::new(VideoProcess::with_helper(HELPER, cut, false)),
            CaptureOptions {
                pace: false,
                ..CaptureOptions::default()
            },
        );
        while capture.frames().recv().is_ok() {}
        let events: Vec<CaptureEvent> = capture.events().try_iter().collect();
        assert!(
            matches!(events.last(), Some(CaptureEvent::Ended { note: Some(n) }) if n.contains("truncated")),
            "{events:?}"
        );
        let summary = capture.stop();
        assert_eq!(summary.frames, counts[0] as u64);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn looping_video_restarts_with_times_that_keep_rising() {
        let dir = scratch("loop");
        let path = write_clip(&dir, 10);
        for (how, mut src) in readers(&path, true) {
            let times: Vec<f64> = (0..25)
                .map(|_| src.next_frame().unwrap().unwrap().time_s.unwrap())
                .collect();
            assert!(times.windows(2).all(|w| w[1] > w[0]), "{how}: {times:?}");
            assert!(
                (times[10] - 0.4).abs() < 1e-3,
                "{how}: second pass starts at 0.4 s: {times:?}"
            );
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_file_that_is_not_a_video_is_a_named_fatal_error() {
        let dir = scratch("notvideo");
        let path = dir.join("notes.avi");
        std::fs::write(&path, b"this is not a video file").unwrap();
        for p in [path.clone(), dir.join("missing.avi")] {
            for (how, mut src) in readers(&p, false) {
                let e = src.next_frame().unwrap_err();
                assert!(matches!(e, SourceError::Fatal { .. }), "{how}: {e}");
                assert!(e.to_string().contains(&*p.to_string_lossy()), "{how}: {e}");
                // Ended: the next call says so, and starts nothing again.
                if how == "helper" {
                    assert!(matches!(src.next_frame(), Ok(None)), "{how}");
                }
            }
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_reader_that_dies_is_a_fatal_error_not_a_hang() {
        // A helper that is no video reader: exits at once without a word (as a crashed one).
        let mut src = VideoProcess::with_helper("/bin/true", "clip.avi", false);
        let e = src.next_frame().unwrap_err();
        assert!(matches!(e, SourceError::Fatal { .. }), "{e}");
        assert!(e.to_string().contains("video reader stopped"), "{e}");
    }

    #[test]
    fn another_program_as_the_reader_is_refused_by_name() {
        // /bin/echo says its arguments: more than a greeting's twelve bytes, and not one.
        let clip = "a-video-file-with-a-long-name.avi";
        let mut src = VideoProcess::with_helper("/bin/echo", clip, false);
        let e = src.next_frame().unwrap_err();
        assert!(matches!(e, SourceError::Fatal { .. }), "{e}");
        assert!(
            e.to_string()
                .contains("/bin/echo is not glyptic's video reader"),
            "{e}"
        );
        assert!(matches!(src.next_frame(), Ok(None)), "ended, not retried");
    }

    #[test]
    fn glyptic_itself_links_no_video_reader() {
        // The point of the helper: `glyptic` starts without OpenCV's video reader and the
        // couple of hundred libraries behind it (GStreamer, GDAL, codecs).
        let libs = |exe: &str| {
            let out = std::process::Command::new("ldd").arg(exe).output().unwrap();
            assert!(out.status.success(), "ldd {exe}");
            String::from_utf8_lossy(&out.stdout).into_owned()
        };
        let (ours, helper) = (libs(env!("CARGO_BIN_EXE_glyptic")), libs(HELPER));
        for heavy in ["opencv_videoio", "gstreamer", "gdal", "avcodec"] {
            assert!(!ours.contains(heavy), "glyptic links {heavy}:\n{ours}");
        }
        assert!(helper.contains("opencv_videoio"), "{helper}");
        assert!(
            ours.lines().count() * 4 < helper.lines().count(),
            "glyptic {} libraries, the helper {}",
            ours.lines().count(),
            helper.lines().count()
        );
    }
}

/// No camera exists on the test machines: the real webcam source must say so, and the capture
/// thread must keep retrying with back-off instead of giving up or panicking.
#[cfg(feature = "webcam")]
#[test]
fn missing_webcam_is_unavailable_and_retried() {
    use glyptic::capture::camera::CameraSource;
    if std::path::Path::new("/dev/video7").exists() {
        eprintln!("skipped: /dev/video7 exists on this machine");
        return;
    }
    let e = CameraSource::new(7).next_frame().unwrap_err();
    assert!(
        matches!(&e, SourceError::Unavailable { .. }) && e.to_string().contains("camera 7"),
        "{e}"
    );
    let capture = Capture::spawn(
        || Box::new(CameraSource::new(7)),
        CaptureOptions {
            backoff: Backoff {
                initial: Duration::from_millis(5),
                max: Duration::from_millis(20),
                factor: 2.0,
            },
            ..CaptureOptions::default()
        },
    );
    std::thread::sleep(Duration::from_millis(200));
    assert!(!capture.finished(), "keeps retrying");
    let attempts: Vec<u32> = capture
        .events()
        .try_iter()
        .filter_map(|e| match e {
            CaptureEvent::Unavailable { attempt, .. } => Some(attempt),
            _ => None,
        })
        .collect();
    assert!(attempts.len() >= 3, "{attempts:?}");
    assert!(attempts.windows(2).all(|w| w[1] == w[0] + 1));
    let summary = capture.stop();
    assert_eq!(summary.frames, 0);
    assert!(summary.unavailable >= 3);
}
