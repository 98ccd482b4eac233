//! The gem for other programs, beside the image (`photo`, `render`, `batch`): the stone as a
//! closed STL solid for a 3D printer, its relief as a 16-bit height map for a CNC router, the
//! cameo as binary glTF for a 3D viewer and as OBJ; each made in memory and written with the
//! command's other outputs, all or none. Gem millimetres (glTF: metres).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};

use glyptic::files::Staged;
use glyptic::gem;
use glyptic::render::RenderParams;
use glyptic::stage::Stage;

use crate::outputs::stage;
use crate::report::note_stages;

/// The gem for other programs (`render`, `photo`): the cameo mesh as OBJ, the stone for a 3D
/// printer or a CNC router, the cameo for a 3D viewer.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct MakeArgs {
    /// Also write the whole cameo mesh (gem millimetres, with normals) as Wavefront OBJ.
    #[arg(long, value_name = "FILE.obj",
          value_parser = crate::values::file_named(&["obj"], "Wavefront OBJ"))]
    pub gem_obj: Option<PathBuf>,
    /// Also write the stone as a closed solid for a 3D printer or CAM program: binary STL in
    /// millimetres, the relief on a flat-bottomed oval slab (the bezel left out).
    #[arg(long, value_name = "FILE.stl",
          value_parser = crate::values::file_named(&["stl"], "binary STL"))]
    pub stl: Option<PathBuf>,
    /// The slab's thickness below the ground, mm (with --stl).
    #[arg(long, default_value_t = 3.0, value_name = "MM",
          value_parser = crate::values::finite_in::<f32>(0.1, 100.0))]
    pub base: f32,
    /// Also write the relief as a 16-bit grey PNG for a CNC router: one pixel per grid node
    /// (0.2 mm; 0.1 mm where a frontal face is stippled, `--stipple`), 0 the ground; the
    /// millimetres per level are printed and stored in the PNG's text
    /// (`glyptic:mm_per_level`).
    #[arg(long, value_name = "FILE.png",
          value_parser = crate::values::file_named(&["png"], "a 16-bit PNG"))]
    pub heightmap: Option<PathBuf>,
    /// Also write the cameo as shown (stone and gold bezel, with their materials) as binary
    /// glTF 2.0 for a 3D viewer: metres, +Y up, facing +Z.
    #[arg(long, value_name = "FILE.glb",
          value_parser = crate::values::file_named(&["glb"], "binary glTF (.glb)"))]
    pub gltf: Option<PathBuf>,
}

impl MakeArgs {
    /// The files asked for.
    pub(super) fn outputs(&self) -> impl Iterator<Item = &Path> {
        self.named().into_iter().filter_map(|(_, path)| path)
    }

    /// Each file by its kind in the reports (`None`: not asked for).
    pub(super) fn named(&self) -> [(&'static str, Option<&Path>); 4] {
        [
            ("gem_obj", self.gem_obj.as_deref()),
            ("stl", self.stl.as_deref()),
            ("heightmap", self.heightmap.as_deref()),
            ("gltf", self.gltf.as_deref()),
        ]
    }
}

/// How a made file names what it was made from: the input's file name only. The files travel
/// (a print shop, a CNC shop, a viewer online) and must not carry the user's folders
/// (issue #41: the STL header held the photo's absolute path).
pub(super) fn source_label(path: &Path) -> String {
    if crate::values::is_stdio(path) {
        return "standard input".into();
    }
    path.file_name()
        .map_or_else(|| "a photo".into(), |n| n.to_string_lossy().into_owned())
}

/// Files made in memory, written only once everything else has succeeded.
pub(super) struct Made {
    /// Each file's path, bytes and what it holds (for the stage line).
    pub files: Vec<(PathBuf, Vec<u8>, String)>,
    /// How long making them took.
    pub ms: f64,
}

/// The cameo as binary glTF, its materials the renderer's for `params`' stone.
pub(super) fn glb(
    mesh: &glyptic::render::Mesh,
    params: &RenderParams,
    source: &str,
) -> Result<Vec<u8>, gem::gltf::GltfError> {
    let stone = gem::gltf::Stone {
        material: params.material,
        hair_layer: params.hair_layer,
    };
    gem::gltf::to_glb(
        mesh,
        &gem::gltf::GltfOptions {
            stone,
            generator: concat!("glyptic ", env!("CARGO_PKG_VERSION")),
            source,
        },
    )
}

/// The files `make` asks for: the STL and height map of the relief cut from `face` (model
/// mm) for `cameo` with the photo's `detail` carved as in the gem (the relief again, ~30 ms,
/// since the gem's mesh is made for rendering), and the GLB of the gem's `mesh` as `params`
/// shows it.
#[allow(clippy::too_many_arguments)]
pub(super) fn make_files(
    make: &MakeArgs,
    face: &[f32],
    triangles: &[[u32; 3]],
    cameo: &gem::CameoParams,
    detail: Option<&gem::FaceDetail>,
    (mesh, params): (&glyptic::render::Mesh, &RenderParams),
    source: &str,
) -> Result<Made> {
    let start = Instant::now();
    let mut files = Vec::new();
    if let Some(path) = &make.gltf {
        let t = Instant::now();
        let bytes = glb(mesh, params, source)
            .with_context(|| format!("{}: cannot make the glTF", path.display()))?;
        let detail = format!(
            "{}: {} triangles, {:.2} MB, {:.1} ms",
            path.display(),
            mesh.indices.len() / 3,
            bytes.len() as f64 / 1e6,
            t.elapsed().as_secs_f64() * 1e3
        );
        files.push((path.clone(), bytes, detail));
    }
    if make.stl.is_none() && make.heightmap.is_none() {
        return Ok(Made {
            files,
            ms: start.elapsed().as_secs_f64() * 1e3,
        });
    }
    // The same relief the gem's mesh was cut from: the photo's brows, eyes, lines and light
    // and dark too (without them a print was a smoother face than the picture showed).
    let relief = gem::CameoBuilder::new(cameo)?.relief_detailed(face, triangles, &[], detail)?;
    let field = relief.height_field();
    let half = [cameo.half_width, cameo.half_height];
    if let Some(path) = &make.stl {
        let solid = gem::solid::solid(&field, half, make.base)
            .with_context(|| format!("{}: cannot make the solid", path.display()))?;
        let volume = gem::solid::volume(&solid);
        let header = format!("glyptic cameo from {source}, mm");
        files.push((
            path.clone(),
            gem::solid::stl(&solid, &header),
            format!(
                "{}: {} triangles, closed, {:.0} mm^3",
                path.display(),
                solid.triangles.len(),
                volume
            ),
        ));
    }
    if let Some(path) = &make.heightmap {
        let map = gem::solid::height_map(&field, half)
            .with_context(|| format!("{}: cannot make the height map", path.display()))?;
        let png = height_map_png(&map, source)
            .with_context(|| format!("{}: cannot encode the height map", path.display()))?;
        files.push((
            path.clone(),
            png,
            format!(
                "{}: {}x{} px, {} mm a pixel, {:.6} mm a level (highest point {:.3} mm)",
                path.display(),
                map.width,
                map.height,
                map.mm_per_pixel,
                map.mm_per_level,
                65535.0 * map.mm_per_level
            ),
        ));
    }
    Ok(Made {
        files,
        ms: start.elapsed().as_secs_f64() * 1e3,
    })
}

/// A 16-bit grey PNG with its scale in its text chunks, where CAM programs and people look.
fn height_map_png(map: &gem::solid::HeightMap, source: &str) -> Result<Vec<u8>> {
    let mut bytes = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut bytes, map.width, map.height);
        encoder.set_color(png::ColorType::Grayscale);
        encoder.set_depth(png::BitDepth::Sixteen);
        // The pixel's size where CAM programs look for it (pHYs, pixels per metre).
        let per_metre = (1000.0 / f64::from(map.mm_per_pixel)).round() as u32;
        encoder.set_pixel_dims(Some(png::PixelDimensions {
            xppu: per_metre,
            yppu: per_metre,
            unit: png::Unit::Meter,
        }));
        encoder.add_text_chunk(
            "Description".into(),
            format!(
                "glyptic relief height map from {source}: level x {} mm = height above the ground; {} mm a pixel; 0 = the ground and outside the stone",
                map.mm_per_level, map.mm_per_pixel
            ),
        )?;
        encoder.add_text_chunk("glyptic:mm_per_level".into(), map.mm_per_level.to_string())?;
        encoder.add_text_chunk("glyptic:mm_per_pixel".into(), map.mm_per_pixel.to_string())?;
        let mut writer = encoder.write_header()?;
        let data: Vec<u8> = map.levels.iter().flat_map(|l| l.to_be_bytes()).collect();
        writer.write_image_data(&data)?;
        writer.finish()?;
    }
    Ok(bytes)
}

/// Stages the files of [`make_files`] and prints their stage line (making and writing).
pub(super) fn stage_made(staged: &mut Staged, made: Made) -> Result<()> {
    let t = Instant::now();
    let mut details = Vec::new();
    for (path, bytes, detail) in made.files {
        stage(staged, &path, &bytes)?;
        details.push(detail);
    }
    if !details.is_empty() {
        note_stages(&[Stage {
            name: "make files",
            ms: made.ms + t.elapsed().as_secs_f64() * 1e3,
            detail: details.join("; "),
        }]);
    }
    Ok(())
}

/// Stages the cameo mesh as OBJ (gem millimetres, normals).
pub(super) fn stage_gem_obj(
    staged: &mut Staged,
    path: &Path,
    mesh: &glyptic::render::Mesh,
    source: &str,
) -> Result<()> {
    let comment = format!(
        "glyptic cameo from {source}\ngem millimetres: the cameo in the XY plane facing +Z, ground at z = 0"
    );
    stage(staged, path, gem::mesh_to_obj(mesh, &comment).as_bytes())
}
