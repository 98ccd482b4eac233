//! `glyptic-video PATH [--loop]`: the video reader that `glyptic` starts when it opens a video
//! file. It reads the file with OpenCV ([`glyptic::capture::video::VideoSource`]) and writes
//! its frames to standard output in the stream that
//! [`glyptic::capture::video_process`] describes. A program of its own so that `glyptic`
//! does not link OpenCV's 240 libraries, which cost every start 150-200 ms (issue #42).

use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use glyptic::capture::video::VideoSource;
use glyptic::capture::video_process::serve;

fn main() -> ExitCode {
    let args: Vec<_> = std::env::args_os().skip(1).collect();
    let (path, looping) = match args.as_slice() {
        [p] if p != "--loop" => (PathBuf::from(p), false),
        [p, l] if l == "--loop" => (PathBuf::from(p), true),
        _ => {
            eprintln!("usage: glyptic-video PATH [--loop]   (started by glyptic for video files)");
            return ExitCode::from(2);
        }
    };
    let mut source = VideoSource::new(path, looping);
    let mut out = std::io::BufWriter::with_capacity(1 << 20, std::io::stdout().lock());
    let mut requests = std::io::stdin().lock();
    match serve(&mut source, &mut requests, &mut out).and_then(|()| out.flush()) {
        Ok(()) => ExitCode::SUCCESS,
        // glyptic stopped reading (the kiosk closed, the video was replaced): nothing to say.
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("glyptic-video: writing frames: {e}");
            ExitCode::FAILURE
        }
    }
}
