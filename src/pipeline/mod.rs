//! From a photo to a gem. [`FacePipeline`] (feature `face`): the face on one frame, detect ->
//! 68 landmarks -> morphable-model fit; [`gem`]: the rest of the way, person pass, relief,
//! render, PNG (its steps after the face also serve the mean face without the feature).
//!
//! Each step is a timed [`crate::stage`], so callers can report speed per stage by recording
//! them ([`crate::stage::record`]).

#[cfg(feature = "face")]
mod face;
pub mod gem;
#[cfg(feature = "face")]
mod person;

#[cfg(feature = "face")]
pub use face::*;
#[cfg(feature = "face")]
pub use gem::{GemPipeline, LoadOptions, PhotoGem};
pub use gem::{GemPipelineError, Hair};
