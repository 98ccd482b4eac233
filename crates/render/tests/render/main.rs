//! The renderer's integration tests, one binary with one device (lavapipe or llvmpipe): the
//! passes end to end on small frames, the gallery styles, and cameos compared with golden images.
//! `GLYPTIC_BLESS=1` rewrites the goldens in `tests/golden/` (look at them before committing).

#[path = "../../../../tests/common/mod.rs"]
mod common;

mod cameo;
mod golden;
mod scene;
mod styles;

use std::sync::{Mutex, MutexGuard, OnceLock};

use glyptic_render::Renderer;

/// The binary's one renderer, shared by its tests one at a time: a device per test would make
/// lavapipe compile every pipeline again, and tests run in parallel threads.
fn renderer() -> MutexGuard<'static, Renderer> {
    static RENDERER: OnceLock<Mutex<Renderer>> = OnceLock::new();
    RENDERER
        .get_or_init(|| {
            Mutex::new(Renderer::new_headless().expect("a headless adapter (lavapipe or llvmpipe)"))
        })
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}
