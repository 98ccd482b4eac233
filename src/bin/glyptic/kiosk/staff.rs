//! The staff's side of the kiosk: the panel's state, the problems it lists, the PIN pad.
//! What a key or a touch does to them is `visit`'s.

use std::collections::VecDeque;

use glyptic::kiosk::{HoldGesture, PinGate, STAFF_HOLD_S};
use glyptic::pin::StaffPin;

/// The staff panel's state and the problems it lists.
pub(super) struct Staff {
    pub(super) open: bool,
    /// The newest problems, each with its time since start and how often it came in a row.
    pub(super) log: VecDeque<(f64, String, u32)>,
    /// Problems noted since start (the trace's `problems`).
    pub(super) problems: u64,
    pub(super) gesture: HoldGesture,
    /// The staff asked to quit (a key or the panel's button).
    pub(super) quit: bool,
    /// The staff's PIN (`None`: the keys open the panel, the corner nothing).
    pub(super) pin: Option<StaffPin>,
    pub(super) gate: PinGate,
    /// The PIN pad, while it asks.
    pub(super) pad: Option<PinPad>,
    /// The corner was held without a PIN configured (said once on the log).
    pub(super) gesture_noted: bool,
}

/// The PIN pad's state: the digits typed (shown as dots), what it said last, when it was
/// last touched (it closes itself after [`PAD_IDLE_S`]).
pub(super) struct PinPad {
    pub(super) digits: String,
    pub(super) said: String,
    pub(super) touched_s: f64,
}

/// A key or a button of the PIN pad.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum PadInput {
    Digit(char),
    Back,
    Enter,
    Cancel,
}

/// Seconds an untouched PIN pad stays (a visitor who opened it and walked away).
pub(super) const PAD_IDLE_S: f64 = 30.0;

/// Problems the staff panel keeps.
pub(super) const LOG_LINES: usize = 12;

impl Staff {
    pub(super) fn new(open: bool, pin: Option<StaffPin>) -> Self {
        Staff {
            open,
            log: VecDeque::new(),
            problems: 0,
            gesture: HoldGesture::new(STAFF_HOLD_S),
            quit: false,
            pin,
            gate: PinGate::default(),
            pad: None,
            gesture_noted: false,
        }
    }

    pub(super) fn lines(&self) -> Vec<String> {
        self.log
            .iter()
            .map(|(t, what, n)| {
                let s = *t as u64;
                let times = if *n > 1 {
                    format!(" (x{n})")
                } else {
                    String::new()
                };
                format!(
                    "{:02}:{:02}:{:02} {what}{times}",
                    s / 3600,
                    s / 60 % 60,
                    s % 60
                )
            })
            .collect()
    }
}
