//! SIGINT, SIGTERM and SIGHUP (issue #40): an interrupted command leaves no hidden
//! half-written output behind. By default the signal removes the files being written or
//! staged ([`glyptic::files::remove_pending`], after a commit under way has finished) and
//! then ends the process as the signal would have. A command that can stop cleanly on its
//! own (`batch`: it finishes the image in hand, writes its CSV and says so) holds an
//! [`Interruptible`] guard: the first signal only asks it to stop, a second one ends it at
//! once as above.

use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};

use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};

/// The signal that asked an [`Interruptible`] command to stop (0: none).
static ASKED: AtomicI32 = AtomicI32::new(0);
/// Whether an [`Interruptible`] guard is alive.
static GUARDED: AtomicBool = AtomicBool::new(false);

/// Starts the thread that handles the signals; without it (the handler could not be
/// installed) signals keep their default action, which is noted on the log.
pub fn install() {
    let mut signals = match signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) {
        Ok(s) => s,
        Err(e) => {
            tracing::debug!("signals keep their default action: {e}");
            return;
        }
    };
    let spawned = std::thread::Builder::new()
        .name("signals".into())
        .spawn(move || {
            for signal in signals.forever() {
                if GUARDED.load(Ordering::SeqCst)
                    && ASKED
                        .compare_exchange(0, signal, Ordering::SeqCst, Ordering::SeqCst)
                        .is_ok()
                {
                    continue;
                }
                glyptic::files::remove_pending();
                let _ = signal_hook::low_level::emulate_default_handler(signal);
                // Only reached if the default action did not end the process.
                std::process::exit(128 + signal);
            }
        });
    if let Err(e) = spawned {
        tracing::debug!("signals keep their default action: {e}");
    }
}

/// While alive, the first SIGINT/SIGTERM/SIGHUP only asks the command to stop
/// ([`Interruptible::asked`]); a second one ends the process. (`batch`'s, which the build
/// without the face pipeline lacks.)
#[cfg_attr(not(feature = "face"), allow(dead_code))]
pub struct Interruptible(());

#[cfg_attr(not(feature = "face"), allow(dead_code))]
impl Interruptible {
    pub fn new() -> Self {
        ASKED.store(0, Ordering::SeqCst);
        GUARDED.store(true, Ordering::SeqCst);
        Interruptible(())
    }

    /// The signal that asked the command to stop, if one did.
    pub fn asked(&self) -> Option<i32> {
        match ASKED.load(Ordering::SeqCst) {
            0 => None,
            s => Some(s),
        }
    }
}

impl Drop for Interruptible {
    fn drop(&mut self) {
        GUARDED.store(false, Ordering::SeqCst);
    }
}

/// The signal's name, for messages.
pub fn name(signal: i32) -> &'static str {
    match signal {
        SIGINT => "SIGINT",
        SIGTERM => "SIGTERM",
        SIGHUP => "SIGHUP",
        _ => "a signal",
    }
}

/// A command that stopped because a signal asked it to: the process exits with 128 + the
/// signal's number, as a shell reports a command the signal ended.
#[derive(Debug, thiserror::Error)]
#[error("interrupted by {}: {what}", name(*signal))]
pub struct Interrupted {
    pub signal: i32,
    pub what: String,
}
