//! A whole Surrey model folder: five files, each preceded by its length (u32, little-endian),
//! parsed and cross-checked (ids within the model, blendshape rows matching the shape model),
//! then the landmark products built, which index the model with the mapping's vertex ids.
#![no_main]

use glyptic_core::shapemodel::{ModelFiles, SurreyModel};
use libfuzzer_sys::fuzz_target;

fn split(mut data: &[u8]) -> Option<[&[u8]; 5]> {
    let mut parts = [&data[..0]; 5];
    for part in &mut parts {
        let (len, rest) = data.split_first_chunk::<4>()?;
        let len = u32::from_le_bytes(*len) as usize;
        if len > rest.len() {
            return None;
        }
        (*part, data) = rest.split_at(len);
    }
    Some(parts)
}

fuzz_target!(|data: &[u8]| {
    let Some([shape, blendshapes, mapping, contours, edges]) = split(data) else {
        return;
    };
    let (Ok(mapping), Ok(contours), Ok(edge_topology)) = (
        std::str::from_utf8(mapping),
        std::str::from_utf8(contours),
        std::str::from_utf8(edges),
    ) else {
        return;
    };
    let files = ModelFiles {
        shape,
        blendshapes,
        mapping,
        contours,
        edge_topology,
    };
    if let Ok(model) = SurreyModel::from_parts(&files) {
        let _ = model.landmark_products();
    }
});
