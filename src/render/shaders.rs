//! The WGSL sources, embedded at compile time.
//!
//! Shared code (the noise functions, the full-screen vertex stage) lives in its own file and is
//! prepended as text: WGSL has no includes. A file that needs another says so in its first line
//! (`// requires: noise.wgsl`), which is how `tests/shaders.rs` assembles the same modules from
//! the files on disk.

/// Simplex noise and turbulence, shared by the scene shader.
pub const NOISE: &str = include_str!("../../shaders/noise.wgsl");

/// The scene pass (`vs_main`, `fs_main`), with the noise prepended.
pub const SCENE: &str = concat!(
    include_str!("../../shaders/noise.wgsl"),
    "\n",
    include_str!("../../shaders/scene.wgsl")
);

/// The full-screen triangle's vertex stage, shared by the composite and SSS passes.
pub const FULLSCREEN: &str = include_str!("../../shaders/fullscreen.wgsl");

/// The composite pass (`vs_main`, `fs_main`).
pub const COMPOSITE: &str = concat!(
    include_str!("../../shaders/fullscreen.wgsl"),
    "\n",
    include_str!("../../shaders/composite.wgsl")
);

/// The subsurface-scattering blur, one direction per draw (`vs_main`, `fs_main`).
pub const SSS: &str = concat!(
    include_str!("../../shaders/fullscreen.wgsl"),
    "\n",
    include_str!("../../shaders/sss.wgsl")
);

/// Every module the renderer compiles, by name, exactly as it hands them to wgpu.
pub fn modules() -> [(&'static str, &'static str); 5] {
    [
        ("noise", NOISE),
        ("fullscreen", FULLSCREEN),
        ("scene", SCENE),
        ("composite", COMPOSITE),
        ("sss", SSS),
    ]
}
