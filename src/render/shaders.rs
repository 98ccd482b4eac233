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

/// One face of the lamp's shadow cube (`vs_main`, `fs_main`): distance to the lamp as depth.
pub const SHADOW: &str = include_str!("../../shaders/shadow.wgsl");

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

/// What the gallery style passes share: their uniform, input and bilinear read.
pub const STYLE_COMMON: &str = include_str!("../../shaders/style_common.wgsl");

/// A style pass's module: the full-screen vertex stage, the shared part, the style.
macro_rules! style_module {
    ($file:literal) => {
        concat!(
            include_str!("../../shaders/fullscreen.wgsl"),
            "\n",
            include_str!("../../shaders/style_common.wgsl"),
            "\n",
            include_str!(concat!("../../shaders/", $file))
        )
    };
}

/// Gallery style passes (`vs_main`, `fs_main`).
pub const TOON: &str = style_module!("toon.wgsl");
pub const FISHEYE: &str = style_module!("fisheye.wgsl");
pub const CHROMATIC: &str = style_module!("chromatic.wgsl");
pub const PAINTERLY: &str = style_module!("painterly.wgsl");

/// Every module the renderer compiles, by name, exactly as it hands them to wgpu.
pub fn modules() -> [(&'static str, &'static str); 11] {
    [
        ("shadow", SHADOW),
        ("noise", NOISE),
        ("fullscreen", FULLSCREEN),
        ("scene", SCENE),
        ("composite", COMPOSITE),
        ("sss", SSS),
        ("style_common", STYLE_COMMON),
        ("toon", TOON),
        ("fisheye", FISHEYE),
        ("chromatic", CHROMATIC),
        ("painterly", PAINTERLY),
    ]
}
