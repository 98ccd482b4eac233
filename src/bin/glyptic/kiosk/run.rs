//! What a kiosk run is asked and what a frame answers: the command's arguments
//! ([`KioskArgs`]), the faults tests inject ([`Fault`]) and whether the event loop goes on
//! ([`Continue`]). The window's parts read these; they import nothing of the kiosk's root.

use std::path::PathBuf;

use super::gem_thread;

#[derive(clap::Args, Debug, Clone)]
#[command(after_help = "Examples:
  glyptic kiosk --fullscreen                 the webcam, full screen
  glyptic kiosk --video visitor.mp4 --config kiosk.toml
  glyptic kiosk --camera 1 --size 800x1000 --snapshots ~/gems
  glyptic kiosk --video portrait.jpg         a photo, as if a camera saw it

Staff: Ctrl+Shift+S or F12 (or a finger held on the top-left corner for 4 s) opens the staff
panel (timings, recent problems, Quit); Ctrl+Shift+Q quits; Esc closes the panel, and quits in
a window. With staff_pin in the configuration every one of these asks for the PIN first (three
wrong ones pause the pad 30 s, then twice as long each time); without it the corner opens
nothing. `echo 4711 | glyptic kiosk --hash-pin` prints the line to put in the configuration.
Problems are logged to stderr (the journal under systemd), never shown to visitors.
deploy/ holds a systemd unit that starts the kiosk on its own X server and restarts it.

Exit codes: 0 quit by the staff or --frames/--seconds reached; 1 a bad configuration, a
missing video, no display, or a worker that kept dying.")]
pub struct KioskArgs {
    /// Webcam N (/dev/videoN) [config: camera; default 0].
    #[arg(long, value_name = "N", conflicts_with = "video")]
    pub camera: Option<u32>,
    /// Play this video file, looping, or show this photo as a camera would, instead of a
    /// camera [config: video].
    #[arg(long, value_name = "FILE")]
    pub video: Option<PathBuf>,
    /// Fill the screen [config: fullscreen].
    #[arg(long)]
    pub fullscreen: bool,
    /// Kiosk defaults (TOML): camera, video, material, portrait, setting, bail, sss, sss_strength,
    /// idle_seconds, ease_seconds, fullscreen, width, height, render_scale.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Window size WIDTHxHEIGHT when not full-screen [config: width, height].
    #[arg(long)]
    pub size: Option<crate::values::Size>,
    /// Quit after presenting this many frames (scripted runs).
    #[arg(long, value_name = "N")]
    pub frames: Option<u64>,
    /// Quit after this many seconds (scripted runs).
    #[arg(long, value_name = "S", allow_negative_numbers = true,
          value_parser = crate::values::finite_in::<f64>(0.0, 1e7))]
    pub seconds: Option<f64>,
    /// When quitting, save the last presented frame (controls included) as PNG.
    #[arg(long, value_name = "FILE.png", value_parser = crate::values::file_named(&["png"], "PNG"))]
    pub screenshot: Option<PathBuf>,
    /// Where the "Save" button writes its PNGs.
    #[arg(long, value_name = "DIR", default_value = ".")]
    pub snapshots: PathBuf,
    /// Check the set-up (configuration, video, folders, models) and exit without opening a
    /// window: 0 if the kiosk can start, 1 with what is wrong (for install scripts and staff).
    #[arg(long)]
    pub check: bool,
    /// Open the staff panel at start (figures, recent problems, the quit button); staff open
    /// it later with Ctrl+Shift+S, F12 or a finger held on the top-left corner.
    #[arg(long)]
    pub staff: bool,
    /// Print one JSON line per presented frame to stdout (frame, gem, controls, orbit, status).
    #[arg(long)]
    pub trace: bool,
    /// Read a staff PIN (4-12 digits) from stdin and print the `staff_pin = "..."` line for
    /// the configuration (a salted hash), then exit.
    #[arg(long)]
    pub hash_pin: bool,
}

/// A fault injected for tests (`GLYPTIC_KIOSK_FAULT`): `gem-panic:N` makes every gem thread
/// panic on its Nth cameo, `gem-panic-once:N` only the first; `capture-panic:N` makes the first
/// capture thread panic at its Nth frame. Anything else there is ignored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Fault {
    Gem(gem_thread::GemFault),
    #[cfg_attr(not(feature = "face"), allow(dead_code))]
    CapturePanic {
        at: u64,
    },
}

impl Fault {
    pub(super) fn from_env() -> Option<Self> {
        let v = std::env::var("GLYPTIC_KIOSK_FAULT").ok()?;
        let (kind, n) = v.split_once(':')?;
        let at = n.trim().parse().ok()?;
        let gem = |every_thread| Fault::Gem(gem_thread::GemFault { at, every_thread });
        match kind {
            "gem-panic" => Some(gem(true)),
            "gem-panic-once" => Some(gem(false)),
            "capture-panic" => Some(Fault::CapturePanic { at }),
            _ => None,
        }
    }
}

/// Whether the event loop goes on after a frame.
pub(super) enum Continue {
    Yes,
    Quit,
}
