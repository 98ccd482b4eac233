//! The application's integration tests, one binary (one link): capture from files and devices,
//! the ONNX face detector and person segmentation, the photo pipeline end to end, tracking over
//! frames, and the `glyptic` binary itself (photo, batch, track, kiosk) run as a user would.

#[path = "../common/mod.rs"]
mod common;

mod capture;
mod cli;
mod corpus;
mod detect;
mod docs;
mod kiosk;
mod likeness;
mod pipeline;
mod track;
