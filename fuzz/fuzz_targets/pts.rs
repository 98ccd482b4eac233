//! Landmark files: iBUG's `.pts` and menpo's `.ljson` (the first byte picks which and whether
//! missing points are allowed; the rest is the file).
#![no_main]

use glyptic_core::landmarks::pts;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&pick, rest)) = data.split_first() else {
        return;
    };
    let Ok(text) = std::str::from_utf8(rest) else {
        return;
    };
    let read = match pick % 4 {
        0 => pts::read_pts(text),
        1 => pts::read_pts_with_missing(text),
        2 => pts::read_ljson(text),
        _ => pts::read_ljson_group(text, Some("face")),
    };
    if let Ok(points) = read {
        // What was read can be written and read back.
        let finite = points.iter().all(|p| p[0].is_finite() && p[1].is_finite());
        if finite && !points.is_empty() {
            let again = pts::read_pts(&pts::write_pts(&points));
            assert_eq!(again.map(|p| p.len()).ok(), Some(points.len()));
        }
    }
});
