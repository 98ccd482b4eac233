//! glyptic: a face becomes an engraved gem.
//!
//! The modules follow the pipeline: [`capture`] -> [`detect`] -> [`landmarks`] -> [`fit`] ->
//! [`gem`] -> [`render`], driven by the binary's `app`. Pure computation (landmark regression,
//! fitting, relief geometry) does no I/O and no GPU work.

pub mod assets;
