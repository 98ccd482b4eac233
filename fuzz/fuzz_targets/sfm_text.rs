//! The Surrey model's text files: the first byte picks the landmark mapping (TOML), the model
//! contour (JSON) or the edge topology (JSON); the rest is the file.
#![no_main]

use glyptic_core::shapemodel::{parse_edge_topology, parse_mapping, parse_model_contour};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&pick, rest)) = data.split_first() else {
        return;
    };
    let Ok(text) = std::str::from_utf8(rest) else {
        return;
    };
    match pick % 3 {
        0 => drop(parse_mapping(text, "fuzz.txt")),
        1 => drop(parse_model_contour(text, "fuzz.json")),
        _ => drop(parse_edge_topology(text, "fuzz.json")),
    }
});
