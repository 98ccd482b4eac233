//! A worker thread's deaths and restarts (the gem thread's, the face side's): restarted
//! while it dies seldom, given up when it keeps dying.

use std::time::Instant;

/// A worker thread may die this many times within [`RESTART_WINDOW`] and be restarted; once
/// more and the kiosk exits 1 (a supervisor such as systemd starts it afresh).
pub(super) const MAX_RESTARTS: usize = 3;
pub(super) const RESTART_WINDOW: std::time::Duration = std::time::Duration::from_secs(60);

/// A worker's deaths and restarts (the gem thread's, the face side's).
#[derive(Default)]
pub(super) struct Restarts {
    deaths: Vec<Instant>,
    /// Restarts so far (the trace's `gem_restarts`, `face_restarts`).
    pub(super) count: u64,
}

impl Restarts {
    /// Notes a death. `Ok`: restart it (counted); `Err`: the deaths within [`RESTART_WINDOW`],
    /// more than [`MAX_RESTARTS`]: give up.
    pub(super) fn died(&mut self) -> Result<(), String> {
        let now = Instant::now();
        self.deaths
            .retain(|t| now.duration_since(*t) < RESTART_WINDOW);
        self.deaths.push(now);
        if self.deaths.len() > MAX_RESTARTS {
            return Err(format!(
                "{} times within {} s",
                self.deaths.len(),
                RESTART_WINDOW.as_secs()
            ));
        }
        self.count += 1;
        Ok(())
    }
}
