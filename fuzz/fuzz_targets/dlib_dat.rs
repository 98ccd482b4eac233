//! dlib's serialized `shape_predictor` (`.dat`): whatever parses must also predict without
//! reading out of bounds (the parser promises it validates every index and size).
#![no_main]

use glyptic_core::landmarks::FaceBox;
use glyptic_core::landmarks::predictor::ShapePredictor;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(model) = ShapePredictor::from_bytes(data) else {
        return;
    };
    let img = image::GrayImage::from_fn(24, 20, |x, y| image::Luma([(x * 7 + y * 13) as u8]));
    let rect = FaceBox {
        left: 3.0,
        top: 2.0,
        width: 15.0,
        height: 14.0,
    };
    if let Ok(points) = model.predict_refined(&img, &rect, 1) {
        assert_eq!(points.len(), model.num_parts());
    }
    let _ = model.info();
});
