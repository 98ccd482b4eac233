//! Every WGSL file in `shaders/` parses and validates with naga (the compiler inside wgpu), both
//! as assembled from the files on disk and exactly as the renderer embeds it.
//!
//! A file that uses another's functions names it on its first line, `// requires: a.wgsl, b.wgsl`;
//! those files are prepended (WGSL has no includes), the way `render::shaders` does it.

use std::fs;
use std::path::Path;

use glyptic::render::shaders;

fn validate(name: &str, source: &str) -> Result<(), String> {
    let module = naga::front::wgsl::parse_str(source)
        .map_err(|e| format!("{name}: {}", e.emit_to_string(source)))?;
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::default(),
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
    let dir = glyptic::assets::shaders_dir();
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
    let failures: Vec<String> = shaders::modules()
        .iter()
        .filter_map(|(name, source)| validate(name, source).err())
        .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn embedded_modules_match_the_files() {
    let dir = glyptic::assets::shaders_dir();
    for (name, source) in shaders::modules() {
        let assembled = assemble(&dir, &format!("{name}.wgsl"));
        assert_eq!(
            assembled, source,
            "{name}.wgsl on disk differs from the embedded module"
        );
    }
}
