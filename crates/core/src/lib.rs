//! glyptic's pure core: from 68 landmarks on a photo to the cameo's draw data.
//!
//! Read top-down, the modules are the pipeline's pure half:
//! [`landmarks`] (dlib's regression trees) -> [`shapemodel`] (the Surrey Face Model) ->
//! [`fit`] (pose, shape, expressions) -> [`smooth`] (steadying a fit over frames) ->
//! [`person`] (which pixels are hair) -> [`gem`] (the relief, carved into the cameo) ->
//! [`scene`] (the draw data the renderer takes). Beside them, [`raster`] draws the fitted
//! face grey on the CPU and [`identity`] steers its identity towards the photo by a
//! recognition network's embedding (the network is the caller's).
//!
//! Nothing here opens a camera, a window, a GPU or an ONNX session, and nothing decides where a
//! file lives: readers take the path (or bytes) they are given. So this crate builds and tests
//! alone (`cargo test -p glyptic-core`), and its benches measure computation only.

mod cg;
pub mod files;
pub mod fit;
pub mod gem;
pub mod identity;
pub mod landmarks;
pub mod par;
pub mod person;
mod photo_grid;
pub mod photometric;
pub mod pin;
pub mod raster;
pub mod scene;
pub mod shapemodel;
mod simd;
pub mod smooth;
pub mod stats;
pub mod stone;
pub mod vec3;
pub mod warp;
