//! eos's expression blendshapes (`expression_blendshapes_3448.bin`, cereal portable binary).
#![no_main]

use glyptic_core::shapemodel::parse_blendshapes;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(b) = parse_blendshapes(data, "fuzz.bin") {
        assert_eq!(b.names.len(), b.offsets.ncols());
    }
});
