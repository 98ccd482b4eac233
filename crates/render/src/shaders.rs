//! The WGSL sources, embedded at compile time.
//!
//! Shared code (the noise functions, the full-screen vertex stage) lives in its own file and is
//! prepended as text: WGSL has no includes. A file that needs another says so in its first line
//! (`// requires: noise.wgsl`), which is how this module's tests assemble the same modules from
//! the files on disk.

/// Simplex noise and turbulence, shared by the scene shader.
pub const NOISE: &str = include_str!("../shaders/noise.wgsl");

/// The noise the scene pass reads from a volume instead of computing it (needs the noise).
pub const BAKED_NOISE: &str = concat!(
    include_str!("../shaders/noise.wgsl"),
    "\n",
    include_str!("../shaders/baked_noise.wgsl")
);

/// The scene pass's files: the noise, the baked noise, the scene shader.
const SCENE_FILES: &str = concat!(
    include_str!("../shaders/noise.wgsl"),
    "\n",
    include_str!("../shaders/baked_noise.wgsl"),
    "\n",
    include_str!("../shaders/scene.wgsl")
);

/// The scene pass (`vs_main`, `fs_main`): the stones' constants ([`stones`]), then the noise
/// and the baked noise, then `scene.wgsl`.
pub static SCENE: std::sync::LazyLock<String> =
    std::sync::LazyLock::new(|| format!("{}\n{SCENE_FILES}", stones()));

/// The scene pass's compute form, its visibility image (`vs_vis`, `fs_vis`; needs the
/// device's `PRIMITIVE_INDEX`).
pub const SCENE_VIS: &str = include_str!("../shaders/scene_vis.wgsl");

/// The scene pass's compute form, its shading (`cs_shade_msaa`, `cs_shade`): the scene
/// module with `scene_shade.wgsl` after it.
pub static SCENE_SHADE: std::sync::LazyLock<String> = std::sync::LazyLock::new(|| {
    format!(
        "{}\n{}",
        SCENE.as_str(),
        include_str!("../shaders/scene_shade.wgsl")
    )
});

/// Marble's and gold's constants for the scene shader (`stones.wgsl` in a `// requires:`
/// line), from [`glyptic_core::stone`], the table the GLB export reads too. (The layered
/// stones reach the shader as uniforms from the same table.)
pub fn stones() -> String {
    use glyptic_core::scene::FILL_LIGHT;
    use glyptic_core::stone::{GOLD_BLINN, GOLD_F0, MARBLE_BLINN, MARBLE_GREY, MARBLE_TINT};
    let v3 = |c: [f32; 3]| format!("vec3<f32>({:?}, {:?}, {:?})", c[0], c[1], c[2]);
    format!(
        "// Marble and gold, from glyptic_core::stone.\n\
         const MARBLE_GREY: f32 = {MARBLE_GREY:?};\n\
         const MARBLE_TINT: vec3<f32> = {};\n\
         const MARBLE_BLINN: f32 = {MARBLE_BLINN:?};\n\
         const GOLD_F0: vec3<f32> = {};\n\
         const GOLD_BLINN: f32 = {GOLD_BLINN:?};\n\
         // The room's fill light, from glyptic_core::scene.\n\
         const FILL_LIGHT: f32 = {FILL_LIGHT:?};",
        v3(MARBLE_TINT),
        v3(GOLD_F0)
    )
}

/// Bakes the slowly varying noise into a volume over the mesh (`cs_main`, a compute shader).
pub const NOISE_VOLUME: &str = concat!(
    include_str!("../shaders/noise.wgsl"),
    "\n",
    include_str!("../shaders/baked_noise.wgsl"),
    "\n",
    include_str!("../shaders/noise_volume.wgsl")
);

/// One face of the lamp's shadow cube (`vs_main`, `fs_main`): distance to the lamp as depth.
pub const SHADOW: &str = include_str!("../shaders/shadow.wgsl");

/// The full-screen triangle's vertex stage, shared by the composite and SSS passes.
pub const FULLSCREEN: &str = include_str!("../shaders/fullscreen.wgsl");

/// The composite pass (`vs_main`, `fs_main`).
pub const COMPOSITE: &str = concat!(
    include_str!("../shaders/fullscreen.wgsl"),
    "\n",
    include_str!("../shaders/composite.wgsl")
);

/// The subsurface-scattering blur, one direction per draw (`vs_main`, `fs_main`).
pub const SSS: &str = concat!(
    include_str!("../shaders/fullscreen.wgsl"),
    "\n",
    include_str!("../shaders/sss.wgsl")
);

/// Edge antialiasing (FXAA) for frames drawn with one sample a pixel (`vs_main`, `fs_main`).
pub const EDGE_AA: &str = concat!(
    include_str!("../shaders/fullscreen.wgsl"),
    "\n",
    include_str!("../shaders/edge_aa.wgsl")
);

/// What the gallery style passes share: their uniform, input and bilinear read.
pub const STYLE_COMMON: &str = include_str!("../shaders/style_common.wgsl");

/// A style pass's module: the full-screen vertex stage, the shared part, the style.
macro_rules! style_module {
    ($file:literal) => {
        concat!(
            include_str!("../shaders/fullscreen.wgsl"),
            "\n",
            include_str!("../shaders/style_common.wgsl"),
            "\n",
            include_str!(concat!("../shaders/", $file))
        )
    };
}

/// Gallery style passes (`vs_main`, `fs_main`).
pub const TOON: &str = style_module!("toon.wgsl");
pub const FISHEYE: &str = style_module!("fisheye.wgsl");
pub const CHROMATIC: &str = style_module!("chromatic.wgsl");
pub const PAINTERLY: &str = style_module!("painterly.wgsl");

/// Every module the renderer compiles, by name, exactly as it hands them to wgpu.
pub fn modules() -> [(&'static str, &'static str); 16] {
    [
        ("shadow", SHADOW),
        ("noise", NOISE),
        ("baked_noise", BAKED_NOISE),
        ("noise_volume", NOISE_VOLUME),
        ("fullscreen", FULLSCREEN),
        ("scene", SCENE.as_str()),
        ("scene_vis", SCENE_VIS),
        ("scene_shade", SCENE_SHADE.as_str()),
        ("composite", COMPOSITE),
        ("sss", SSS),
        ("edge_aa", EDGE_AA),
        ("style_common", STYLE_COMMON),
        ("toon", TOON),
        ("fisheye", FISHEYE),
        ("chromatic", CHROMATIC),
        ("painterly", PAINTERLY),
    ]
}

/// Every WGSL file in `shaders/` parses and validates with naga (the compiler inside wgpu), both
/// as assembled from the files on disk and exactly as the renderer embeds it.
#[cfg(test)]
mod tests {
    use std::fs;
    use std::path::Path;

    use super::modules;

    fn validate(name: &str, source: &str) -> Result<(), String> {
        let module = naga::front::wgsl::parse_str(source)
            .map_err(|e| format!("{name}: {}", e.emit_to_string(source)))?;
        // The visibility image's fragment stage reads the primitive index (a device feature
        // the renderer asks for where the adapter has it).
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::default() | naga::valid::Capabilities::PRIMITIVE_INDEX,
        )
        .validate(&module)
        .map_err(|e| format!("{name}: {}", e.emit_to_string(source)))?;
        Ok(())
    }

    /// The files a shader's first line says it needs.
    fn requirements(source: &str) -> Vec<String> {
        source
            .lines()
            .next()
            .and_then(|line| line.trim().strip_prefix("// requires:"))
            .map(|list| {
                list.split(',')
                    .map(|s| s.trim().to_owned())
                    .filter(|s| !s.is_empty())
                    .collect()
            })
            .unwrap_or_default()
    }

    fn assemble(dir: &Path, file: &str) -> String {
        if file == "stones.wgsl" {
            return super::stones();
        }
        let source = fs::read_to_string(dir.join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
        let mut assembled = String::new();
        for required in requirements(&source) {
            assembled.push_str(&assemble(dir, &required));
            assembled.push('\n');
        }
        assembled.push_str(&source);
        assembled
    }

    #[test]
    fn every_shader_file_validates() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
        let mut names: Vec<String> = fs::read_dir(&dir)
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
            .filter_map(|entry| entry.ok())
            .map(|entry| entry.file_name().to_string_lossy().into_owned())
            .filter(|name| name.ends_with(".wgsl"))
            .collect();
        names.sort();
        assert!(
            names.len() >= 3,
            "expected the renderer's shaders in {}, found {names:?}",
            dir.display()
        );
        let failures: Vec<String> = names
            .iter()
            .filter_map(|name| validate(name, &assemble(&dir, name)).err())
            .collect();
        assert!(failures.is_empty(), "{}", failures.join("\n\n"));
    }

    #[test]
    fn embedded_modules_validate() {
        let failures: Vec<String> = modules()
            .iter()
            .filter_map(|(name, source)| validate(name, source).err())
            .collect();
        assert!(failures.is_empty(), "{}", failures.join("\n\n"));
    }

    /// The scene shader takes marble's and gold's numbers from `glyptic_core::stone` (the
    /// table the GLB export reads), never its own: scene.wgsl declares none of them and uses
    /// each; no layered stone's constant lingers in it either.
    #[test]
    fn the_scene_shader_takes_its_stones_from_the_one_table() {
        let file = include_str!("../shaders/scene.wgsl");
        for name in [
            "MARBLE_GREY",
            "MARBLE_TINT",
            "MARBLE_BLINN",
            "GOLD_F0",
            "GOLD_BLINN",
            // Not a stone's: the room's fill light, which the relief's tone match assumes.
            "FILL_LIGHT",
        ] {
            assert!(
                !file.contains(&format!("const {name}")),
                "scene.wgsl declares {name} itself: it belongs in glyptic_core::stone"
            );
            assert!(
                file.matches(name).count() >= 1 && super::SCENE.contains(&format!("const {name}")),
                "{name} is not used or not declared"
            );
        }
        assert!(!file.contains("0.985") && !file.contains("0.71, 0.29"));
        assert!(
            !super::SCENE.contains("AGATE_"),
            "scene.wgsl describes agate itself again: its values belong in glyptic_core::stone"
        );
    }

    #[test]
    fn embedded_modules_match_the_files() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
        for (name, source) in modules() {
            let assembled = assemble(&dir, &format!("{name}.wgsl"));
            assert_eq!(
                assembled, source,
                "{name}.wgsl on disk differs from the embedded module"
            );
        }
    }
}
