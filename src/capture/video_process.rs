//! Video files read by a helper process, `glyptic-video` (the `video` feature's OpenCV reader,
//! [`super::video::VideoSource`], in a program of its own), its frames streamed through a pipe.
//!
//! Why a process: OpenCV's Debian build links about 240 shared libraries (GStreamer, GDAL,
//! codecs); linked into `glyptic` itself they cost every start of every command 150-200 ms
//! of symbol lookups before `main` (BENCHMARKS.md, issue #42), though few commands read a
//! video. The reader now starts when a video is opened, and only then. A crash in a decoder
//! ends the video with an error instead of the kiosk.
//!
//! The helper first says who it is: the eight bytes `GLYPTVID` and the stream's version (u32),
//! so that a helper from another build is refused by name instead of misread. Then it answers
//! requests: each byte `n` on its standard input asks for the reader's next `next_frame`,
//! whose result it writes to its standard output (little-endian), a tag byte and its body:
//!
//! | tag | body | meaning |
//! |---|---|---|
//! | `R` | f64 | the file's frame rate (before its first frame; after each reopening) |
//! | `F` | u32 width, u32 height, f64 time s (NaN: none), width x height x 3 bytes RGB | a frame |
//! | `E` | u8 kind (0 unavailable, 1 bad frame, 2 fatal), u32 length, UTF-8 reason | an error |
//! | `N` | u32 length, UTF-8 | the end note (a truncated file) |
//! | `D` | none | the end |
//!
//! [`VideoProcess`] asks for the next frame as soon as it has one, so the helper decodes one
//! frame ahead; after an error it asks only when asked itself, so a file that is gone is
//! looked for again at the capture thread's own back-off, not queued up meanwhile. Units:
//! pixels, seconds.

use std::io::{BufReader, Read, Write};
use std::path::PathBuf;
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};

use image::RgbImage;

use super::source::{FrameSource, RawFrame, SourceError};

/// The helper program's file name; it is looked for beside the running program.
pub const HELPER_NAME: &str = "glyptic-video";
/// Environment variable naming the helper's path, for installs that keep it elsewhere.
pub const HELPER_ENV: &str = "GLYPTIC_VIDEO_HELPER";

/// Where the helper is: [`HELPER_ENV`] when set, else beside the running program.
pub fn helper_path() -> Result<PathBuf, String> {
    if let Some(p) = std::env::var_os(HELPER_ENV) {
        return Ok(PathBuf::from(p));
    }
    let exe = std::env::current_exe().map_err(|e| format!("where this program is: {e}"))?;
    Ok(exe.with_file_name(HELPER_NAME))
}

/// The helper's first eight bytes, then [`VERSION`].
const GREETING: &[u8; 8] = b"GLYPTVID";
/// The stream's version: bumped whenever a message changes.
const VERSION: u32 = 1;

/// Error kinds on the wire.
const UNAVAILABLE: u8 = 0;
const BAD_FRAME: u8 = 1;
const FATAL: u8 = 2;

/// Longest error or note text accepted from the helper, bytes.
const MAX_TEXT: u32 = 1 << 16;

/// The running helper and its two pipes.
struct Helper {
    child: Child,
    requests: ChildStdin,
    out: BufReader<ChildStdout>,
    /// A request was sent and its answer not yet read.
    asked: bool,
}

/// A video file read by the helper process, looping or not.
pub struct VideoProcess {
    helper: PathBuf,
    path: PathBuf,
    looping: bool,
    child: Option<Helper>,
    fps: Option<f64>,
    note: Option<String>,
    done: bool,
}

impl VideoProcess {
    /// The video at `path`, read by the helper found by [`helper_path`].
    pub fn new(path: impl Into<PathBuf>, looping: bool) -> Self {
        let helper = helper_path().unwrap_or_else(|_| PathBuf::from(HELPER_NAME));
        Self::with_helper(helper, path, looping)
    }

    /// As [`VideoProcess::new`], with the helper at `helper`.
    pub fn with_helper(
        helper: impl Into<PathBuf>,
        path: impl Into<PathBuf>,
        looping: bool,
    ) -> Self {
        VideoProcess {
            helper: helper.into(),
            path: path.into(),
            looping,
            child: None,
            fps: None,
            note: None,
            done: false,
        }
    }

    fn fatal(&self, reason: String) -> SourceError {
        SourceError::Fatal {
            source_name: self.path.display().to_string(),
            reason,
        }
    }

    fn start(&mut self) -> Result<(), SourceError> {
        let mut cmd = Command::new(&self.helper);
        cmd.arg(&self.path);
        if self.looping {
            cmd.arg("--loop");
        }
        let mut child = cmd
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            // OpenCV's and FFmpeg's own warnings go where they went when OpenCV ran in-process.
            .stderr(Stdio::inherit())
            .spawn()
            .map_err(|e| {
                self.fatal(format!(
                    "cannot start the video reader {}: {e} (it is built with the cargo feature `video` and installed beside glyptic)",
                    self.helper.display()
                ))
            })?;
        let (Some(requests), Some(out)) = (child.stdin.take(), child.stdout.take()) else {
            let _ = child.kill();
            let _ = child.wait();
            return Err(self.fatal("the video reader has no pipes".into()));
        };
        let mut helper = Helper {
            child,
            requests,
            out: BufReader::with_capacity(1 << 20, out),
            asked: false,
        };
        let mut hello = [0u8; 12];
        let greeted = helper.out.read_exact(&mut hello);
        self.child = Some(helper);
        if let Err(e) = greeted {
            return Err(self.broken(e));
        }
        let version = u32::from_le_bytes([hello[8], hello[9], hello[10], hello[11]]);
        if &hello[..8] != GREETING || version != VERSION {
            self.stop();
            return Err(self.fatal(format!(
                "{} is not glyptic's video reader of this build (its stream version {}, this glyptic reads {VERSION}): install glyptic and glyptic-video from the same build",
                self.helper.display(),
                if &hello[..8] == GREETING {
                    version.to_string()
                } else {
                    "unknown".into()
                }
            )));
        }
        Ok(())
    }

    /// Ends the helper (killed if it still runs) and the video; its exit status, if any.
    fn stop(&mut self) -> Option<std::io::Result<std::process::ExitStatus>> {
        self.done = true;
        self.child.take().map(|mut h| {
            let _ = h.child.kill();
            h.child.wait()
        })
    }

    /// The helper's stream ended or went wrong without its saying so: a garbled stream is
    /// named as such; one that stopped, by the helper's exit status.
    fn broken(&mut self, what: std::io::Error) -> SourceError {
        let status = self.stop();
        let why = match status {
            _ if what.kind() == std::io::ErrorKind::InvalidData => {
                format!("the video reader's stream is garbled: {what}")
            }
            Some(Ok(s)) => format!("the video reader stopped ({s})"),
            _ => format!("the video reader's output broke off: {what}"),
        };
        self.fatal(why)
    }

    /// Asks for the next result, unless that is asked already.
    fn ask(&mut self) -> std::io::Result<()> {
        let Some(h) = self.child.as_mut() else {
            return Err(std::io::Error::other("no video reader"));
        };
        if !h.asked {
            h.requests.write_all(b"n")?;
            h.requests.flush()?;
            h.asked = true;
        }
        Ok(())
    }

    /// The next message; a result (not a rate or a note) answers the request.
    fn read_message(&mut self) -> Result<Message, std::io::Error> {
        let Some(h) = self.child.as_mut() else {
            return Err(std::io::Error::other("no video reader"));
        };
        let m = read_message(&mut h.out)?;
        if !matches!(m, Message::Rate(_) | Message::Note(_)) {
            h.asked = false;
        }
        Ok(m)
    }
}

/// One message of the helper's stream.
#[derive(Debug)]
enum Message {
    Rate(f64),
    Frame(RgbImage, Option<f64>),
    Error(u8, String),
    Note(String),
    Done,
}

fn read_u32(r: &mut impl Read) -> std::io::Result<u32> {
    let mut b = [0; 4];
    r.read_exact(&mut b)?;
    Ok(u32::from_le_bytes(b))
}

fn read_f64(r: &mut impl Read) -> std::io::Result<f64> {
    let mut b = [0; 8];
    r.read_exact(&mut b)?;
    Ok(f64::from_le_bytes(b))
}

fn bad(what: impl Into<String>) -> std::io::Error {
    std::io::Error::new(std::io::ErrorKind::InvalidData, what.into())
}

fn read_text(r: &mut impl Read) -> std::io::Result<String> {
    let n = read_u32(r)?;
    if n > MAX_TEXT {
        return Err(bad(format!("a text of {n} bytes")));
    }
    let mut b = vec![0; n as usize];
    r.read_exact(&mut b)?;
    Ok(String::from_utf8_lossy(&b).into_owned())
}

fn read_message(r: &mut impl Read) -> std::io::Result<Message> {
    let mut tag = [0u8; 1];
    r.read_exact(&mut tag)?;
    Ok(match tag[0] {
        b'R' => Message::Rate(read_f64(r)?),
        b'F' => {
            let (w, h) = (read_u32(r)?, read_u32(r)?);
            let time = read_f64(r)?;
            if w == 0 || h == 0 || w > super::MAX_SIDE || h > super::MAX_SIDE {
                return Err(bad(format!("a frame of {w}x{h}")));
            }
            let mut rgb = vec![0; w as usize * h as usize * 3];
            r.read_exact(&mut rgb)?;
            let image = RgbImage::from_raw(w, h, rgb).ok_or_else(|| bad("frame size"))?;
            Message::Frame(image, time.is_finite().then_some(time))
        }
        b'E' => {
            let mut kind = [0u8; 1];
            r.read_exact(&mut kind)?;
            Message::Error(kind[0], read_text(r)?)
        }
        b'N' => Message::Note(read_text(r)?),
        b'D' => Message::Done,
        t => return Err(bad(format!("unknown message {t:#04x}"))),
    })
}

impl FrameSource for VideoProcess {
    fn name(&self) -> String {
        self.path.display().to_string()
    }

    fn next_frame(&mut self) -> Result<Option<RawFrame>, SourceError> {
        if self.done {
            return Ok(None);
        }
        if self.child.is_none() {
            self.start()?;
        }
        if let Err(e) = self.ask() {
            return Err(self.broken(e));
        }
        loop {
            let message = match self.read_message() {
                Ok(m) => m,
                Err(e) => return Err(self.broken(e)),
            };
            let source_name = self.path.display().to_string();
            return match message {
                Message::Rate(fps) => {
                    self.fps = (fps.is_finite() && fps > 0.0).then_some(fps);
                    continue;
                }
                Message::Frame(image, time_s) => {
                    // The next one decodes while this one is used; a helper gone by now is
                    // found out on the next call.
                    let _ = self.ask();
                    Ok(Some(RawFrame {
                        image,
                        time_s,
                        path: None,
                    }))
                }
                Message::Error(UNAVAILABLE, reason) => Err(SourceError::Unavailable {
                    source_name,
                    reason,
                }),
                Message::Error(BAD_FRAME, reason) => Err(SourceError::BadFrame {
                    source_name,
                    reason,
                }),
                Message::Error(kind, reason) => {
                    self.finish();
                    let reason = if kind == FATAL {
                        reason
                    } else {
                        format!("{reason} (error kind {kind})")
                    };
                    Err(SourceError::Fatal {
                        source_name,
                        reason,
                    })
                }
                Message::Note(note) => {
                    self.note = Some(note);
                    continue;
                }
                Message::Done => {
                    self.finish();
                    Ok(None)
                }
            };
        }
    }

    fn frame_rate(&self) -> Option<f64> {
        self.fps
    }

    fn end_note(&self) -> Option<String> {
        self.note.clone()
    }
}

impl VideoProcess {
    /// The helper has said its last: wait for it (it exits by itself).
    fn finish(&mut self) {
        self.done = true;
        if let Some(mut h) = self.child.take() {
            // Its standard input closed, it exits if it has not.
            drop(h.requests);
            let _ = h.child.wait();
        }
    }
}

impl Drop for VideoProcess {
    fn drop(&mut self) {
        self.stop();
    }
}

/// The helper's side: for each request byte read from `requests`, the next result of
/// `source` written to `out` as the module doc says; returns when the source has ended or
/// failed for good, or either pipe is closed (the reader went away).
pub fn serve(
    source: &mut dyn FrameSource,
    requests: &mut impl Read,
    out: &mut impl Write,
) -> std::io::Result<()> {
    out.write_all(GREETING)?;
    out.write_all(&VERSION.to_le_bytes())?;
    out.flush()?;
    let mut rate_sent = None;
    let mut request = [0u8; 1];
    loop {
        if requests.read(&mut request)? == 0 {
            return Ok(());
        }
        let result = source.next_frame();
        if source.frame_rate() != rate_sent {
            if let Some(fps) = source.frame_rate() {
                out.write_all(b"R")?;
                out.write_all(&fps.to_le_bytes())?;
            }
            rate_sent = source.frame_rate();
        }
        match result {
            Ok(Some(frame)) => {
                let (w, h) = frame.image.dimensions();
                out.write_all(b"F")?;
                out.write_all(&w.to_le_bytes())?;
                out.write_all(&h.to_le_bytes())?;
                out.write_all(&frame.time_s.unwrap_or(f64::NAN).to_le_bytes())?;
                out.write_all(frame.image.as_raw())?;
            }
            Ok(None) => {
                if let Some(note) = source.end_note() {
                    write_text(out, b"N", &note)?;
                }
                out.write_all(b"D")?;
                return out.flush();
            }
            Err(e) => {
                let (kind, reason) = match e {
                    SourceError::Unavailable { reason, .. } => (UNAVAILABLE, reason),
                    SourceError::BadFrame { reason, .. } => (BAD_FRAME, reason),
                    SourceError::Fatal { reason, .. } => (FATAL, reason),
                };
                out.write_all(b"E")?;
                out.write_all(&[kind])?;
                write_text(out, b"", &reason)?;
                if kind == FATAL {
                    return out.flush();
                }
            }
        }
        out.flush()?;
    }
}

fn write_text(out: &mut impl Write, tag: &[u8], text: &str) -> std::io::Result<()> {
    let bytes = &text.as_bytes()[..text.len().min(MAX_TEXT as usize)];
    out.write_all(tag)?;
    out.write_all(&(bytes.len() as u32).to_le_bytes())?;
    out.write_all(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::capture::MemorySource;

    fn frames() -> Vec<RgbImage> {
        (0..3u8)
            .map(|i| RgbImage::from_fn(5, 4, |x, y| image::Rgb([i, x as u8, y as u8])))
            .collect()
    }

    /// The stream after its greeting, which must be there.
    fn greeted(bytes: &[u8]) -> &[u8] {
        assert_eq!(&bytes[..8], GREETING);
        assert_eq!(bytes[8..12], VERSION.to_le_bytes());
        &bytes[12..]
    }

    #[test]
    fn frames_errors_and_the_end_cross_the_stream_unchanged() {
        let mut bytes = Vec::new();
        let mut src = MemorySource::new("memory", frames(), 10.0);
        // More requests than results: it stops at the end.
        serve(&mut src, &mut [b'n'; 10].as_slice(), &mut bytes).unwrap();
        let mut r = greeted(&bytes);
        let mut got = Vec::new();
        loop {
            match read_message(&mut r).unwrap() {
                Message::Frame(img, _) => got.push(img),
                Message::Rate(fps) => assert_eq!(fps, 10.0),
                Message::Done => break,
                m => panic!("unexpected {m:?}"),
            }
        }
        assert_eq!(got, frames());
        assert!(r.is_empty());
        assert!(matches!(
            read_message(&mut [b"E".as_slice(), &[2], &1u32.to_le_bytes(), b"x"].concat().as_slice()),
            Ok(Message::Error(2, s)) if s == "x"
        ));
    }

    /// A source whose device is never there.
    struct Gone;
    impl FrameSource for Gone {
        fn name(&self) -> String {
            "gone".into()
        }
        fn next_frame(&mut self) -> Result<Option<RawFrame>, SourceError> {
            Err(SourceError::Unavailable {
                source_name: "gone".into(),
                reason: "video file gone".into(),
            })
        }
    }

    #[test]
    fn an_absent_source_is_looked_for_once_per_request_not_queued() {
        let mut bytes = Vec::new();
        serve(&mut Gone, &mut [b'n'; 3].as_slice(), &mut bytes).unwrap();
        let mut r = greeted(&bytes);
        for _ in 0..3 {
            assert!(matches!(
                read_message(&mut r),
                Ok(Message::Error(UNAVAILABLE, s)) if s == "video file gone"
            ));
        }
        assert!(r.is_empty(), "more answers than requests");
    }

    #[test]
    fn a_broken_stream_is_an_error_not_a_panic_nor_a_huge_allocation() {
        let huge = [
            b"F".as_slice(),
            &u32::MAX.to_le_bytes(),
            &u32::MAX.to_le_bytes(),
            &0f64.to_le_bytes(),
        ]
        .concat();
        assert!(read_message(&mut huge.as_slice()).is_err());
        let cut = [
            b"F".as_slice(),
            &4u32.to_le_bytes(),
            &4u32.to_le_bytes(),
            &0f64.to_le_bytes(),
            &[1, 2, 3],
        ]
        .concat();
        assert!(read_message(&mut cut.as_slice()).is_err());
        let long = [b"N".as_slice(), &(MAX_TEXT + 1).to_le_bytes()].concat();
        assert!(read_message(&mut long.as_slice()).is_err());
        assert!(read_message(&mut b"?".as_slice()).is_err());
        assert!(read_message(&mut b"".as_slice()).is_err());
    }

    #[test]
    fn a_missing_helper_is_a_fatal_error_naming_it() {
        let mut v = VideoProcess::with_helper("/nonexistent/glyptic-video", "clip.avi", false);
        let e = v.next_frame().unwrap_err();
        assert!(matches!(e, SourceError::Fatal { .. }), "{e}");
        assert!(e.to_string().contains("/nonexistent/glyptic-video"), "{e}");
    }
}
