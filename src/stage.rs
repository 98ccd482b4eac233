//! Timed stages as `tracing` spans: every step of the program reports how long it took.
//!
//! A stage is a span named `stage` (target `glyptic::stage`, level INFO) with the field `name`;
//! [`timed`] opens it round the work, and a debug event in it says the time and what the
//! stage found (`glyptic -v` logs these: `stage{name="fit"}: 1.9 ms, yaw 20 ...`). The same
//! measurement goes to the calling thread's [`record`]ing, if there is one, and that is what
//! the stage table, the batch CSV and `glyptic track`'s per-frame times are built from; with
//! nobody recording, a stage costs one disabled span and a clock read. Times are wall-clock
//! milliseconds.

use std::cell::RefCell;
use std::time::Instant;

/// One timed stage (serialised as `{name, ms, detail}` in the JSON reports).
#[derive(Clone, Debug, serde::Serialize)]
pub struct Stage {
    pub name: &'static str,
    pub ms: f64,
    pub detail: String,
}

thread_local! {
    /// The open recordings of this thread, innermost last.
    static RECORDINGS: RefCell<Vec<Vec<Stage>>> = const { RefCell::new(Vec::new()) };
}

/// Runs `f` as the stage `name`; on success records its time and `describe`'s account of
/// the result. A failed stage is logged (debug) and not recorded: its error says enough.
pub fn timed<T, E>(
    name: &'static str,
    f: impl FnOnce() -> Result<T, E>,
    describe: impl FnOnce(&T) -> String,
) -> Result<T, E> {
    let span = tracing::info_span!(target: "glyptic::stage", "stage", name);
    let t = Instant::now();
    let out = span.in_scope(f);
    let ms = t.elapsed().as_secs_f64() * 1e3;
    match &out {
        Ok(v) => {
            let detail = describe(v);
            tracing::debug!(target: "glyptic::stage", parent: &span, "{ms:.1} ms, {detail}");
            report(Stage { name, ms, detail });
        }
        Err(_) => {
            tracing::debug!(target: "glyptic::stage", parent: &span, "failed after {ms:.1} ms")
        }
    }
    out
}

/// Hands a stage measured elsewhere (another thread's, or a sum) to this thread's recording.
pub fn report(stage: Stage) {
    RECORDINGS.with(|r| {
        if let Some(open) = r.borrow_mut().last_mut() {
            open.push(stage);
        }
    });
}

/// Runs `f`, returning the stages it ran on this thread, in order. Recordings nest: an outer
/// recording also receives what an inner one saw.
pub fn record<T>(f: impl FnOnce() -> T) -> (T, Vec<Stage>) {
    /// Closes the recording when `f` unwinds (a batch worker catches panics per image).
    struct Unwinding(bool);
    impl Drop for Unwinding {
        fn drop(&mut self) {
            if self.0 {
                RECORDINGS.with(|r| r.borrow_mut().pop());
            }
        }
    }
    RECORDINGS.with(|r| r.borrow_mut().push(Vec::new()));
    let mut guard = Unwinding(true);
    let out = f();
    guard.0 = false;
    let stages = RECORDINGS.with(|r| {
        let mut open = r.borrow_mut();
        let stages = open.pop().unwrap_or_default();
        if let Some(outer) = open.last_mut() {
            outer.extend(stages.iter().cloned());
        }
        stages
    });
    (out, stages)
}

/// Runs `other` on a second thread while `here` runs on this one and returns both results:
/// for independent work (models loading, a photo decoding) that would otherwise wait its
/// turn. The stages `other` times go to this thread's recording after `here`'s; a panic in
/// `other` resumes here, as it would have had both run on this thread.
pub fn alongside<A: Send, B>(other: impl FnOnce() -> A + Send, here: impl FnOnce() -> B) -> (A, B) {
    let (joined, b) = std::thread::scope(|s| {
        let handle = s.spawn(|| record(other));
        let b = here();
        (handle.join(), b)
    });
    match joined {
        Ok((a, stages)) => {
            for stage in stages {
                report(stage);
            }
            (a, b)
        }
        Err(panic) => std::panic::resume_unwind(panic),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ok(name: &'static str) -> Result<u32, ()> {
        timed(name, || Ok(7), |v| format!("value {v}"))
    }

    #[test]
    fn a_recording_gets_the_stages_in_order_and_only_its_own_thread_s() {
        let ((), outside) = record(|| {
            std::thread::spawn(|| ok("elsewhere")).join().ok();
        });
        assert!(outside.is_empty(), "{outside:?}");
        let (v, stages) = record(|| {
            ok("first").ok();
            let _ = timed::<u32, ()>("failed", || Err(()), |_| String::new());
            ok("second")
        });
        assert_eq!(v, Ok(7));
        let names: Vec<_> = stages.iter().map(|s| s.name).collect();
        assert_eq!(names, ["first", "second"]);
        assert_eq!(stages[0].detail, "value 7");
        assert!(stages.iter().all(|s| s.ms >= 0.0 && s.ms.is_finite()));
    }

    #[test]
    fn alongside_runs_both_and_records_the_other_thread_s_stages_after_these() {
        let here_thread = std::thread::current().id();
        let ((a, b), stages) = record(|| {
            alongside(
                || {
                    ok("other").ok();
                    std::thread::current().id()
                },
                || ok("here"),
            )
        });
        assert_ne!(a, here_thread, "`other` ran on this thread");
        assert_eq!(b, Ok(7));
        let names: Vec<_> = stages.iter().map(|s| s.name).collect();
        assert_eq!(names, ["here", "other"]);
        let caught = std::panic::catch_unwind(|| alongside(|| panic!("on purpose"), || 1));
        assert!(caught.is_err(), "a panic on the other thread resumes here");
    }

    #[test]
    fn recordings_nest_and_survive_a_panic() {
        let ((), outer) = record(|| {
            ok("before").ok();
            let ((), inner) = record(|| {
                ok("inner").ok();
            });
            assert_eq!(inner.len(), 1);
            let caught = std::panic::catch_unwind(|| {
                record(|| {
                    ok("panicking").ok();
                    panic!("on purpose");
                })
            });
            assert!(caught.is_err());
            report(Stage {
                name: "reported",
                ms: 1.0,
                detail: String::new(),
            });
        });
        let names: Vec<_> = outer.iter().map(|s| s.name).collect();
        assert_eq!(names, ["before", "inner", "reported"]);
        // Nothing is left open: a stage now is nobody's.
        ok("after").ok();
        let ((), fresh) = record(|| {});
        assert!(fresh.is_empty());
    }
}
