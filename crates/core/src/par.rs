//! Per-element work spread over the machine's cores (scoped threads, no pool).
//!
//! Each element is computed from shared, read-only inputs by the same closure whatever the
//! split, so the result is identical to the bit to a serial loop's on every machine (tested):
//! the split changes only who computes what. Work under `min_chunk` elements a thread stays
//! on the caller's thread, so small grids (the tests', the kiosk's moving frames) pay nothing.
//! The photo path measured why: on a GPU machine with 16 cores the one-shot photo was bound by
//! serial loops over the person's canvas and the cameo's template (issue #42).

use std::sync::OnceLock;

/// Cores this process may use (1 where the system cannot tell). `GLYPTIC_THREADS` caps it
/// (e.g. to compare with a serial run); read once.
pub fn cores() -> usize {
    static CORES: OnceLock<usize> = OnceLock::new();
    *CORES.get_or_init(|| {
        let machine = std::thread::available_parallelism().map_or(1, |n| n.get());
        std::env::var("GLYPTIC_THREADS")
            .ok()
            .and_then(|v| v.trim().parse::<usize>().ok())
            .filter(|&n| n >= 1)
            .map_or(machine, |cap| cap.min(machine))
    })
}

/// How many threads `n` elements get: at most [`cores`], and at least one block of
/// `min_chunk` elements each.
fn threads_for(n: usize, min_chunk: usize) -> usize {
    (n / min_chunk.max(1)).clamp(1, cores())
}

/// Fills `out[i] = f(i)` for every index. The slice is cut into blocks of `min_chunk`
/// elements that the threads take in turn as they finish (work is seldom even across a grid:
/// the cameo's head fills some rows, the background others).
pub fn fill<T: Send>(out: &mut [T], min_chunk: usize, f: impl Fn(usize) -> T + Sync) {
    let n = out.len();
    let threads = threads_for(n, min_chunk);
    if threads <= 1 {
        for (i, o) in out.iter_mut().enumerate() {
            *o = f(i);
        }
        return;
    }
    let block = min_chunk.max(1);
    let blocks = std::sync::Mutex::new(out.chunks_mut(block).enumerate());
    let work = || loop {
        // The lock is held only to take the next block (a poisoned lock means another
        // thread panicked, which the scope re-raises: stop here).
        let next = match blocks.lock() {
            Ok(mut it) => it.next(),
            Err(_) => None,
        };
        let Some((k, part)) = next else { break };
        for (j, o) in part.iter_mut().enumerate() {
            *o = f(k * block + j);
        }
    };
    std::thread::scope(|s| {
        for _ in 1..threads {
            s.spawn(work);
        }
        work();
    });
}

/// `(0..n).map(f).collect()`, spread as [`fill`] spreads it.
pub fn map<T: Send + Default + Clone>(
    n: usize,
    min_chunk: usize,
    f: impl Fn(usize) -> T + Sync,
) -> Vec<T> {
    let mut out = vec![T::default(); n];
    fill(&mut out, min_chunk, f);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_split_gives_the_serial_result() {
        let f = |i: usize| ((i as f32) * 0.37).sin() * (i % 7) as f32;
        let serial: Vec<f32> = (0..10_007).map(f).collect();
        for min_chunk in [1, 3, 64, 1000, 5000, 20_000] {
            let spread = map(10_007, min_chunk, f);
            assert!(
                spread
                    .iter()
                    .zip(&serial)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "min_chunk {min_chunk}"
            );
        }
        assert!(map(0, 1, f).is_empty());
        assert_eq!(map(1, 1, f), vec![f(0)]);
    }

    #[test]
    fn small_work_stays_on_the_callers_thread() {
        let me = std::thread::current().id();
        let ids = map(100, 1000, |_| Some(std::thread::current().id()));
        assert!(ids.iter().all(|id| *id == Some(me)));
        assert_eq!(threads_for(100, 1000), 1);
        assert_eq!(threads_for(0, 0), 1);
    }
}
