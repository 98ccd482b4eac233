//! Wavefront OBJ face meshes (`glyptic photo --face-obj`): every triangle refers to a vertex.
#![no_main]

use glyptic_core::gem::parse_obj;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok((positions, triangles)) = parse_obj(text) {
        assert_eq!(positions.len() % 3, 0);
        assert!(positions.iter().all(|v| v.is_finite()));
        let n = positions.len() / 3;
        assert!(triangles.iter().flatten().all(|&v| (v as usize) < n));
        // What a face mesh must be to be carved (issue #40): said, never a panic.
        if glyptic_core::gem::check_face_mesh(&positions, &triangles).is_ok() {
            assert!(triangles.len() >= glyptic_core::gem::MIN_FACE_TRIANGLES);
        }
    }
});
