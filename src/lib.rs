//! glyptic: a face becomes an engraved gem.
//!
//! The modules follow the pipeline: [`capture`] -> [`detect`] -> [`landmarks`] -> [`fit`] ->
//! [`gem`] -> [`render`], tied together by [`pipeline`] and
//! the binary. Pure computation (landmark regression, fitting, relief geometry) does
//! no I/O and no GPU work; [`shapemodel`] and [`assets`] are where files are read.

pub mod assets;
pub mod capture;
#[cfg(feature = "face")]
pub mod detect;
pub mod fit;
pub mod gem;
pub mod kiosk;
pub mod landmarks;
pub mod person;
#[cfg(feature = "face")]
pub mod pipeline;
pub mod render;
pub mod shapemodel;
pub mod smooth;
pub mod sss;
pub mod stage;
#[cfg(feature = "face")]
pub mod stream;
pub mod styles;
#[cfg(feature = "face")]
pub mod track;
