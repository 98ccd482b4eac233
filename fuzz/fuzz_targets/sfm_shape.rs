//! eos's shape model (`sfm_shape_3448.bin`, cereal portable binary).
#![no_main]

use glyptic_core::shapemodel::parse_shape_model;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(model) = parse_shape_model(data, "fuzz.bin") {
        assert_eq!(model.mean.len(), 3 * model.num_vertices());
        assert_eq!(model.eigenvalues.len(), model.num_components());
    }
});
