//! Giving freed memory back to the system in a long-running process (the kiosk).
//!
//! A gem's build makes and frees tens of MB of grids and meshes on the kiosk's gem thread,
//! and the renderer's uploads come and go beside it. glibc's malloc keeps freed pages resident
//! inside its heaps: each new high-water mark of these transient allocations stays in the
//! process's resident memory, so a kiosk's memory climbs in steps for minutes (the stipple's
//! finer, frame-dependent grid made the steps 6 % in a minute) although nothing leaks
//! (heaptrack: under 0.5 MB still allocated at exit). [`Trimmer`] asks malloc, at most once
//! per period, to hand free pages back (`malloc_trim`, which also releases free pages in the
//! middle of each heap); elsewhere than glibc it does nothing.

use std::time::{Duration, Instant};

/// Trims the allocator's free pages at most once per `period`.
#[derive(Debug)]
pub struct Trimmer {
    period: Duration,
    last: Instant,
}

impl Trimmer {
    pub fn new(period: Duration) -> Self {
        Self {
            period,
            last: Instant::now(),
        }
    }

    /// Trims if a period has passed since the last trim; true when it did.
    pub fn tick(&mut self) -> bool {
        if self.last.elapsed() < self.period {
            return false;
        }
        let start = Instant::now();
        trim();
        self.last = Instant::now();
        tracing::debug!(
            "memory: freed pages given back in {:.1} ms",
            (self.last - start).as_secs_f64() * 1e3
        );
        true
    }
}

/// Hands the allocator's free pages back to the system now.
pub fn trim() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim takes no pointers; it only walks and releases glibc's own free
    // lists, under each arena's lock, and is safe to call from any thread at any time.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// Resident memory of this process, kB (Linux; 0 where unknown): the kiosk's trace and staff
/// panel show it.
pub fn resident_kb() -> u64 {
    std::fs::read_to_string("/proc/self/statm")
        .ok()
        .and_then(|s| s.split_whitespace().nth(1)?.parse::<u64>().ok())
        .map_or(0, |pages| pages * 4)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trims_once_per_period() {
        let mut t = Trimmer::new(Duration::from_millis(40));
        assert!(!t.tick(), "a period must pass first");
        std::thread::sleep(Duration::from_millis(50));
        assert!(t.tick());
        assert!(!t.tick(), "not twice in one period");
    }

    /// Freed pages are given back: ~100 MB of blocks touched and freed in the
    /// middle of a heap leave resident memory once trimmed (glibc only).
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    #[test]
    fn freed_pages_leave_resident_memory() {
        // Many medium blocks (below the mmap threshold, so they live in the heap), the last
        // kept so the heap's top cannot simply shrink: the freed ones are in its middle.
        let mut blocks: Vec<Vec<u8>> = (0..1000).map(|i| vec![(i % 251) as u8; 100_000]).collect();
        let keep = blocks.pop();
        let before_free = resident_kb();
        drop(blocks);
        trim();
        let after = resident_kb();
        assert!(keep.is_some_and(|k| k[0] == (999 % 251) as u8));
        assert!(
            after + 60_000 < before_free,
            "resident {before_free} kB -> {after} kB after freeing ~100 MB and trimming"
        );
    }
}
