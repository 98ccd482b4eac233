//! glyptic: a face becomes an engraved gem.
//!
//! The modules follow the pipeline: [`capture`] -> [`detect`] -> [`landmarks`] -> [`fit`] ->
//! [`gem`] -> [`render`], tied together by [`pipeline`] and
//! the binary. Pure computation (landmark regression, fitting, relief geometry) does
//! no I/O and no GPU work; [`shapemodel`] and [`assets`] are where files are read.

pub use glyptic_core::{
    files, fit, gem, identity, landmarks, person, photometric, pin, raster, scene, shapemodel,
    smooth, warp,
};
pub use glyptic_render as render;
pub use glyptic_render::{sss, styles};

pub mod assets;
pub mod capture;
#[cfg(feature = "face")]
pub mod detect;
pub mod kiosk;
pub mod memory;
pub mod pipeline;
pub mod stage;
#[cfg(feature = "face")]
pub mod stream;
#[cfg(feature = "face")]
pub mod track;
