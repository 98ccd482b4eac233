//! A bounded channel of capacity one where the newest item wins: the sender never blocks, and
//! an item the receiver has not taken yet is replaced by the next one (and counted as dropped).
//!
//! This is how live stages hand work on (camera -> face pipeline -> renderer): a slow consumer
//! sees the latest frame instead of a growing queue of stale ones, and a slow producer never
//! holds the consumer up. Built on a crossbeam `bounded(1)` channel whose sender also keeps a
//! receiver, so it can take the stale item out itself.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;

use crossbeam_channel::{Receiver, RecvTimeoutError, Sender, TryRecvError, TrySendError};

/// The sending half. Cloning gives another sender into the same slot.
#[derive(Debug)]
pub struct LatestSender<T> {
    tx: Sender<T>,
    stale: Receiver<T>,
    counts: Arc<Counts>,
}

impl<T> Clone for LatestSender<T> {
    fn clone(&self) -> Self {
        LatestSender {
            tx: self.tx.clone(),
            stale: self.stale.clone(),
            counts: self.counts.clone(),
        }
    }
}

/// The receiving half.
#[derive(Debug)]
pub struct LatestReceiver<T> {
    rx: Receiver<T>,
    counts: Arc<Counts>,
}

#[derive(Debug, Default)]
struct Counts {
    sent: AtomicU64,
    replaced: AtomicU64,
    closed: AtomicBool,
}

/// The receiver is gone: nobody will read what is sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("the receiving side has closed")]
pub struct Closed;

/// A new newest-wins channel.
pub fn latest<T>() -> (LatestSender<T>, LatestReceiver<T>) {
    let (tx, rx) = crossbeam_channel::bounded(1);
    let counts = Arc::new(Counts::default());
    (
        LatestSender {
            tx,
            stale: rx.clone(),
            counts: counts.clone(),
        },
        LatestReceiver { rx, counts },
    )
}

impl<T> LatestSender<T> {
    /// Puts `item` in the slot, replacing an item not yet taken. Never blocks.
    pub fn send(&self, mut item: T) -> Result<(), Closed> {
        // Every sender holds a `stale` receiver, which keeps the channel open: the real
        // receiver says when it is gone.
        if self.counts.closed.load(Ordering::Relaxed) {
            return Err(Closed);
        }
        loop {
            match self.tx.try_send(item) {
                Ok(()) => {
                    self.counts.sent.fetch_add(1, Ordering::Relaxed);
                    return Ok(());
                }
                Err(TrySendError::Full(back)) => {
                    // Another sender may have refilled the slot between the two calls: loop.
                    if self.stale.try_recv().is_ok() {
                        self.counts.replaced.fetch_add(1, Ordering::Relaxed);
                    }
                    item = back;
                }
                Err(TrySendError::Disconnected(_)) => return Err(Closed),
            }
        }
    }

    /// Items replaced before the receiver took them, so far.
    pub fn replaced(&self) -> u64 {
        self.counts.replaced.load(Ordering::Relaxed)
    }
}

impl<T> LatestReceiver<T> {
    /// The newest item, waiting at most `timeout`. `Ok(None)` on time-out; `Err(Closed)` when
    /// every sender is gone and the slot is empty.
    pub fn recv_timeout(&self, timeout: Duration) -> Result<Option<T>, Closed> {
        match self.rx.recv_timeout(timeout) {
            Ok(item) => Ok(Some(item)),
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err(Closed),
        }
    }

    /// The newest item if there is one, without waiting.
    pub fn try_recv(&self) -> Result<Option<T>, Closed> {
        match self.rx.try_recv() {
            Ok(item) => Ok(Some(item)),
            Err(TryRecvError::Empty) => Ok(None),
            Err(TryRecvError::Disconnected) => Err(Closed),
        }
    }

    /// Waits for the newest item; `Err(Closed)` when every sender is gone and nothing is left.
    pub fn recv(&self) -> Result<T, Closed> {
        self.rx.recv().map_err(|_| Closed)
    }

    /// Items sent so far, and how many of them were replaced before being taken.
    pub fn counts(&self) -> (u64, u64) {
        (
            self.counts.sent.load(Ordering::Relaxed),
            self.counts.replaced.load(Ordering::Relaxed),
        )
    }
}

impl<T> Drop for LatestReceiver<T> {
    fn drop(&mut self) {
        self.counts.closed.store(true, Ordering::Relaxed);
        // Free a waiting item now rather than when the last sender goes.
        while self.rx.try_recv().is_ok() {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn newest_item_wins_and_replacements_are_counted() {
        let (tx, rx) = latest();
        for i in 0..5 {
            tx.send(i).unwrap();
        }
        assert_eq!(rx.try_recv(), Ok(Some(4)));
        assert_eq!(rx.try_recv(), Ok(None));
        assert_eq!(rx.counts(), (5, 4));
    }

    #[test]
    fn closing_is_seen_from_both_sides() {
        let (tx, rx) = latest::<u32>();
        tx.send(1).unwrap();
        drop(tx);
        // What was sent before the sender left is still delivered, then closure.
        assert_eq!(rx.try_recv(), Ok(Some(1)));
        assert_eq!(rx.try_recv(), Err(Closed));
        assert_eq!(rx.recv_timeout(Duration::from_millis(1)), Err(Closed));
        assert_eq!(rx.recv(), Err(Closed));

        let (tx, rx) = latest::<u32>();
        drop(rx);
        assert_eq!(tx.send(1), Err(Closed));
    }

    #[test]
    fn a_slow_receiver_never_blocks_the_sender() {
        let (tx, rx) = latest();
        let producer = std::thread::spawn(move || {
            for i in 0..10_000u32 {
                tx.send(i).unwrap();
            }
        });
        let mut last = None;
        while let Ok(item) = rx.recv() {
            if let Some(prev) = last {
                assert!(item > prev, "items arrive in order, stale ones skipped");
            }
            last = Some(item);
            std::thread::sleep(Duration::from_micros(50));
        }
        producer.join().unwrap();
        assert_eq!(last, Some(9_999), "the newest item is always delivered");
    }
}
