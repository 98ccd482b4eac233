//! Issue #37's likeness test: does a face-recognition network take a person's gem for that
//! person? Every photo of a data set (deepface's `tests/unit/dataset`, or one folder per
//! person as LFW's; measurement only, never committed) is made into a gem, rendered as
//! `glyptic photo` renders it, and the gem is judged against every photo by SFace's embedding
//! (the face found on the gem by the same detector and landmarks as on a photo). Also judged:
//! the fitted face alone (the mesh, and the portrait the gem carves), rendered grey on the CPU
//! and looking out, aligned by its own projected eyes, nose and mouth.
//!
//! Printed per view: faces found, the share of pictures whose nearest photo is their own
//! person's (of all photos, and of the photos other than the one it was made from), the share
//! whose mean distance to their person's photos is under SFace's same-person threshold (0.637
//! as `1 - cos`), mean distances to the source photo, the person's other photos and strangers'
//! photos, and between pictures of different people. The photos against each other give the
//! ceiling.
//!
//! `--out DIR` keeps every picture (`DIR/VIEW/NNN.png`), a manifest (`DIR/manifest.tsv`: kind,
//! person, photo, path) and `DIR/judge-input.txt`: per photo and picture its path and the 68
//! landmarks found on it, for another recognition network. `--score DIR --judge FILE
//! --judge-threshold T` then scores that run by the other network's descriptors (`PATH d1 ...
//! dn` per line, Euclidean distance, e.g. dlib's 128-d descriptors with 0.6), so the pictures
//! are also judged by a network glyptic never runs.
//!
//! `cargo run --release --example likeness_embed -- DATASET_DIR [--views profile,frontal]
//! [--size 480x600] [--limit N] [--out DIR] [--no-detail]`, then
//! `likeness_embed --score DIR --judge FILE [--judge-threshold 0.6]`
//! (`--no-detail`: the fitted shape alone, without the photo's detail carved into the face;
//! `--no-identity`: the landmark fit's identity, not steered by the recognition network;
//! `--identity-steps N`, `--identity-pairs K`: the search's size; `--identity-components K`:
//! search the first K coefficients only; `--no-shading`, `--shading-strength K`,
//! `--shading-band SHORTEST,LONGEST` (inter-ocular distances): the shape read from the
//! photo's shading off, or scaled, or over another band; `--face-yaw DEG`: the grey faces
//! drawn turned by DEG (a three-quarter view at 20-35); `--detail-maps DIR`: each photo's
//! detail map as carved, mid-grey 0, lighter raised, darker incised (`NNN-detail.png`), and
//! where its darks are sunk into the key light's shadow, black fully (`NNN-shadow.png`);
//! `--warp S,SIGMA,RIDGE,MAX,OUTLINE,LIPS`: the landmark warp's parameters
//! (`glyptic::warp::WarpParams`, in order, trailing ones at their defaults);
//! `--caricature GAIN,DETAIL`, `--prior P` (the portrait's identity prior),
//! `--expression E` (the share of the photo's expression the portrait carves),
//! `--detail-scale K` (the detail's depth times K), `--detail-depths BROW,IRIS,MOUTH,LINE`
//! (each region's depth, mm), `--tone K` (the photo's light and dark modelled for the key
//! light, steepest slope K; 0 off), `--stipple MM` (the stipple's depth, canonical mm; 0
//! off), `--engraved-lines MM` (the photo's dark lines engraved, canonical mm; 0 off),
//! `--shadows K` (the share of the darks sunk into the key light's shadow; 0 off),
//! `--photo-modelling K` (the share of the relief's fine modelling the photo's light and dark
//! replaces; 0: none),
//! `--sface-judge DIR` (SFace's descriptors of a kept run's pictures, in the judge's format,
//! on standard output: to score pictures changed after the run by the project's own network
//! as `--score` does by another's), `--classical-hair` (the same classical
//! hair for everyone, as `photo --hair classical`), `--judge-detector MODEL` (the faces on
//! the photos and the pictures judged are found by this detector, e.g. `models/yunet.onnx`,
//! rather than the product's: a stone face a detector misses counts as a miss, and which
//! gems one detector misses says more about that detector than about the gems))

use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use glyptic::assets::ModelPaths;
use glyptic::detect::embed::{self, Embedding, FaceEmbedder};
use glyptic::gem::{CameoParams, View};
use glyptic::pipeline::gem::{GemPipeline, Hair, Recogniser, build_gem_detailed, render};
use glyptic::raster;
use glyptic::render::{RenderParams, Renderer};

#[path = "common/identities.rs"]
mod identities;
#[path = "common/judge.rs"]
mod judge;

/// What a picture is, for the tables.
#[derive(Clone, Copy, PartialEq, Debug)]
enum Kind {
    Gem(View),
    FittedMesh,
    Portrait,
}

impl Kind {
    fn label(self) -> &'static str {
        match self {
            Kind::Gem(View::Profile) => "gem, profile",
            Kind::Gem(View::Frontal) => "gem, frontal",
            Kind::FittedMesh => "fitted face alone (grey)",
            Kind::Portrait => "portrait face alone (grey, caricatured)",
        }
    }
    fn folder(self) -> &'static str {
        match self {
            Kind::Gem(View::Profile) => "profile",
            Kind::Gem(View::Frontal) => "frontal",
            Kind::FittedMesh => "fitted",
            Kind::Portrait => "portrait",
        }
    }
}

/// A photo: whose, its path, its 68 landmarks and its embedding (`None`: no face found).
type PhotoRow = (usize, PathBuf, Option<Vec<[f32; 2]>>, Option<Embedding>);

/// A picture and where the judge finds its face.
struct Picture {
    kind: Kind,
    person: usize,
    photo: usize,
    path: PathBuf,
    landmarks: Option<Vec<[f32; 2]>>,
    embedding: Option<Embedding>,
}

impl Picture {
    /// `(person, photo)`: the picture's person and which of their photos it was made from.
    fn new(
        kind: Kind,
        (person, photo): (usize, usize),
        path: PathBuf,
        landmarks: Option<Vec<[f32; 2]>>,
        embedding: Option<Embedding>,
    ) -> Self {
        Picture {
            kind,
            person,
            photo,
            path,
            landmarks,
            embedding,
        }
    }
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut dir = None;
    let mut views = vec![View::Profile, View::Frontal];
    let (mut width, mut height) = (480u32, 600u32);
    let mut limit = usize::MAX;
    let mut out: Option<PathBuf> = None;
    let mut judge_file: Option<PathBuf> = None;
    let mut judge_threshold = 0.6f64;
    let mut judge_detector: Option<PathBuf> = None;
    let mut detail = true;
    let mut identity = true;
    let mut steps: Option<usize> = None;
    let mut pairs: Option<usize> = None;
    let mut components: Option<usize> = None;
    let mut shading: Option<f32> = None;
    let mut face_yaw = 0f32;
    let mut expression: Option<f32> = None;
    let mut shading_band: Option<(f32, f32)> = None;
    let mut score: Option<PathBuf> = None;
    let mut sface_judge: Option<PathBuf> = None;
    let mut maps: Option<PathBuf> = None;
    let mut caricature: Option<(f32, f32)> = None;
    let mut prior: Option<f64> = None;
    let mut detail_scale: Option<f32> = None;
    let mut detail_depths: Option<glyptic::gem::DetailParams> = None;
    let mut tone: Option<f32> = None;
    let mut stipple: Option<f32> = None;
    let mut engraved_lines: Option<f32> = None;
    let mut shadows: Option<f32> = None;
    let mut photo_modelling: Option<f32> = None;
    let mut warp: Option<glyptic::warp::WarpParams> = None;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || it.next().context("a value after the option");
        match a.as_str() {
            "--views" => {
                views = value()?
                    .split(',')
                    .map(|v| match v {
                        "profile" => Ok(View::Profile),
                        "frontal" => Ok(View::Frontal),
                        other => bail!("unknown view {other}"),
                    })
                    .collect::<Result<_>>()?
            }
            "--size" => {
                let v = value()?;
                let (w, h) = v.split_once('x').context("--size WxH")?;
                (width, height) = (w.parse()?, h.parse()?);
            }
            "--limit" => limit = value()?.parse()?,
            "--out" => out = Some(PathBuf::from(value()?)),
            "--judge" => judge_file = Some(PathBuf::from(value()?)),
            "--judge-threshold" => judge_threshold = value()?.parse()?,
            "--no-detail" => detail = false,
            "--no-identity" => identity = false,
            "--classical-hair" => {}
            "--detail-scale" => detail_scale = Some(value()?.parse::<f32>()?),
            "--tone" => tone = Some(value()?.parse::<f32>()?),
            "--stipple" => stipple = Some(value()?.parse::<f32>()?),
            "--engraved-lines" => engraved_lines = Some(value()?.parse::<f32>()?),
            "--shadows" => shadows = Some(value()?.parse::<f32>()?),
            "--photo-modelling" => photo_modelling = Some(value()?.parse::<f32>()?),
            "--detail-depths" => {
                let v: Vec<f32> = value()?
                    .split(',')
                    .map(str::parse)
                    .collect::<Result<_, _>>()
                    .context("--detail-depths BROW,IRIS,MOUTH,LINE (mm)")?;
                let [brow_mm, iris_mm, mouth_mm, line_mm] = v[..] else {
                    bail!("--detail-depths takes four depths, mm");
                };
                detail_depths = Some(glyptic::gem::DetailParams {
                    brow_mm,
                    iris_mm,
                    mouth_mm,
                    line_mm,
                    ..Default::default()
                });
            }
            "--identity-steps" => steps = Some(value()?.parse()?),
            "--identity-pairs" => pairs = Some(value()?.parse()?),
            "--identity-components" => components = Some(value()?.parse()?),
            "--no-shading" => shading = Some(0.0),
            "--face-yaw" => face_yaw = value()?.parse::<f32>()?.to_radians(),
            "--shading-strength" => shading = Some(value()?.parse()?),
            "--shading-band" => {
                let v = value()?;
                let (a, b) = v
                    .split_once(',')
                    .context("--shading-band SHORTEST,LONGEST")?;
                shading_band = Some((a.parse()?, b.parse()?));
            }
            "--score" => score = Some(PathBuf::from(value()?)),
            "--sface-judge" => sface_judge = Some(PathBuf::from(value()?)),
            "--judge-detector" => judge_detector = Some(PathBuf::from(value()?)),
            "--detail-maps" => maps = Some(PathBuf::from(value()?)),
            "--expression" => expression = Some(value()?.parse()?),
            "--caricature" => {
                let v = value()?;
                let (g, d) = v.split_once(',').context("--caricature GAIN,DETAIL")?;
                caricature = Some((g.parse()?, d.parse()?));
            }
            "--prior" => prior = Some(value()?.parse()?),
            "--warp" => {
                // STRENGTH,SIGMA_IOD,SMOOTHING,MAX_IOD,OUTLINE(0/1)
                let v: Vec<f32> = value()?
                    .split(',')
                    .map(|x| x.parse())
                    .collect::<Result<_, _>>()?;
                let d = glyptic::warp::WarpParams::default();
                warp = Some(glyptic::warp::WarpParams {
                    strength: *v.first().unwrap_or(&d.strength),
                    sigma_iod: *v.get(1).unwrap_or(&d.sigma_iod),
                    smoothing: *v.get(2).unwrap_or(&d.smoothing),
                    max_iod: *v.get(3).unwrap_or(&d.max_iod),
                    outline_sigma_iod: *v.get(4).unwrap_or(&d.outline_sigma_iod),
                    lips: *v.get(5).unwrap_or(&d.lips),
                });
            }
            other if dir.is_none() && !other.starts_with("--") => dir = Some(PathBuf::from(other)),
            other => bail!("unknown argument {other}"),
        }
    }
    if let Some(scored) = score {
        let file = judge_file.context("--score DIR needs --judge FILE")?;
        return score_with_judge(&scored, &file, judge_threshold);
    }
    if let Some(d) = sface_judge {
        return sface_descriptors(&d);
    }
    let dir = dir.context("usage: likeness_embed DATASET_DIR [options]")?;
    let ids = identities::identities(&dir)?;
    let mut photos: Vec<(String, usize)> = ids.into_iter().collect();
    photos.truncate(limit);
    let people = photos.iter().map(|p| p.1).max().map_or(0, |m| m + 1);
    eprintln!("{} photos of {people} people", photos.len());

    let models = ModelPaths::locate();
    let hair = if args.iter().any(|a| a == "--classical-hair") {
        Hair::Classical
    } else {
        Hair::Photo
    };
    let mut pipeline = GemPipeline::load(&models, CameoParams::default(), hair)?;
    // The judge's own detector, for the photos and the pictures alike (the gem's pipeline
    // keeps the product's).
    let mut judge_detector = match &judge_detector {
        Some(p) => Some(
            glyptic::detect::FaceDetector::load(p, &models.onnxruntime)
                .with_context(|| format!("--judge-detector {}", p.display()))?,
        ),
        None => None,
    };
    if !detail {
        pipeline.detail = None;
    }
    if !identity {
        pipeline.recogniser = Recogniser::Off;
    }
    if let Some((gain, detail)) = caricature {
        pipeline.face.caricature = glyptic::shapemodel::Caricature { gain, detail };
    }
    if let Some(p) = prior {
        pipeline.face.portrait_prior = p;
    }
    if let Some(e) = expression {
        pipeline.face.portrait_expression = e;
    }
    if let Some(k) = detail_scale {
        pipeline.detail = Some(glyptic::gem::DetailParams::default().scaled(k));
    }
    if detail_depths.is_some() {
        pipeline.detail = detail_depths;
    }
    if let (Some(t), Some(d)) = (tone, pipeline.detail.as_mut()) {
        d.tone = t;
    }
    if let (Some(mm), Some(d)) = (engraved_lines, pipeline.detail.as_mut()) {
        d.engraved_lines_mm = mm;
    }
    if let (Some(mm), Some(d)) = (stipple, pipeline.detail.as_mut()) {
        d.stipple_mm = mm;
    }
    if let (Some(k), Some(d)) = (photo_modelling, pipeline.detail.as_mut()) {
        *d = d.with_photo_modelling(k);
    }
    if let (Some(k), Some(d)) = (shadows, pipeline.detail.as_mut()) {
        d.shadows = k;
    }
    if warp.is_some() {
        pipeline.warp = warp;
    }
    if let Some(n) = steps {
        pipeline.identity.steps = n;
    }
    if let Some(n) = pairs {
        pipeline.identity.pairs = n;
    }
    if let Some(n) = components {
        pipeline.identity.components = n;
    }
    match shading {
        Some(k) if k <= 0.0 => pipeline.shading = None,
        Some(k) => {
            if let Some(p) = pipeline.shading.as_mut() {
                p.strength = k;
            }
        }
        None => {}
    }
    if let (Some((a, b)), Some(p)) = (shading_band, pipeline.shading.as_mut()) {
        p.shortest_iod = a;
        p.longest_iod = b;
    }
    let mut gem_ms: Vec<f64> = Vec::new();
    let mut embedder = FaceEmbedder::load(&models.recogniser, &models.onnxruntime, 2)?;
    let mut renderer = Renderer::new_headless()?;
    let triangles = pipeline.face.model.shape.triangles.clone();
    if let Some(o) = &out {
        for k in views
            .iter()
            .map(|v| Kind::Gem(*v))
            .chain([Kind::FittedMesh, Kind::Portrait])
        {
            std::fs::create_dir_all(o.join(k.folder()))?;
        }
    }

    if let Some(d) = &maps {
        std::fs::create_dir_all(d)?;
    }
    let mut photo_rows: Vec<PhotoRow> = Vec::new();
    let mut pictures: Vec<Picture> = Vec::new();
    let started = std::time::Instant::now();
    for (j, (name, person)) in photos.iter().enumerate() {
        let path = dir.join(name);
        let t0 = std::time::Instant::now();
        let gem = match glyptic::pipeline::gem::decode(&path)
            .map_err(anyhow::Error::from)
            .and_then(|img| Ok((pipeline.image(&img)?, img)))
        {
            Ok(g) => g,
            Err(e) => {
                eprintln!("{name}: {e:#}");
                photo_rows.push((*person, path, None, None));
                continue;
            }
        };
        let (pg, img) = gem;
        gem_ms.push(t0.elapsed().as_secs_f64() * 1e3);
        if let (Some(dir), Some(d)) = (&maps, &pg.detail) {
            // The detail map as carved: mid-grey 0, lighter raised, darker incised.
            let (c, r, h) = d.map();
            let img = image::GrayImage::from_fn(c as u32, r as u32, |x, y| {
                let v = 128.0 + 60.0 * h[y as usize * c + x as usize];
                image::Luma([v.clamp(0.0, 255.0) as u8])
            });
            img.save(dir.join(format!("{j:03}-detail.png")))?;
            // Where the strongest darks are sunk into the key light's shadow: black fully.
            let s = d.shadow_map();
            if s.len() == c * r {
                let img = image::GrayImage::from_fn(c as u32, r as u32, |x, y| {
                    let v = 255.0 * (1.0 - s[y as usize * c + x as usize]);
                    image::Luma([v.clamp(0.0, 255.0) as u8])
                });
                img.save(dir.join(format!("{j:03}-shadow.png")))?;
            }
        }
        // The photo's landmarks as the judge finds them: the product's, or its own
        // detector's (none found: the photo is judged by the product's).
        let photo_landmarks = match judge_detector.as_mut() {
            Some(d) => {
                find_face(&mut pipeline, Some(d), &img).unwrap_or_else(|| pg.face.landmarks.clone())
            }
            None => pg.face.landmarks.clone(),
        };
        let photo_emb = embedder.embed(&img, &photo_landmarks).ok();
        photo_rows.push((*person, path.clone(), Some(photo_landmarks), photo_emb));
        for &view in &views {
            let cameo = CameoParams {
                view,
                ..pg.cameo.clone()
            };
            let mesh =
                build_gem_detailed(&pg.face.portrait, &triangles, &cameo, pg.detail.as_ref())?;
            let params = RenderParams {
                width,
                height,
                ..RenderParams::default()
            };
            let rgba = render(&mut renderer, &mesh, &params)?;
            let rgb = image::DynamicImage::ImageRgba8(rgba).into_rgb8();
            let kind = Kind::Gem(view);
            let file = save(&out, kind, j, &rgb)?;
            let landmarks = find_face(&mut pipeline, judge_detector.as_mut(), &rgb);
            let embedding = landmarks
                .as_ref()
                .and_then(|l| embedder.embed(&rgb, l).ok());
            pictures.push(Picture::new(kind, (*person, j), file, landmarks, embedding));
        }
        for (kind, mesh) in [
            (Kind::FittedMesh, &pg.face.mesh),
            (Kind::Portrait, &pg.face.portrait),
        ] {
            let (rgb, five) = grey_face(mesh, &triangles, 256, face_yaw);
            let file = save(&out, kind, j, &rgb)?;
            let embedding = five.and_then(|f| {
                let mut buf = vec![0.0; 3 * embed::SIDE * embed::SIDE];
                embed::aligned_by_five(&rgb, &f, &mut buf).ok()?;
                embedder.embed_aligned(&buf, 1).ok()?.pop()
            });
            // For another judge: the 68 landmarks its own pipeline finds on the render.
            let landmarks = find_face(&mut pipeline, judge_detector.as_mut(), &rgb);
            pictures.push(Picture::new(kind, (*person, j), file, landmarks, embedding));
        }
        if (j + 1) % 10 == 0 {
            eprintln!(
                "{} of {} photos, {:.1} s",
                j + 1,
                photos.len(),
                started.elapsed().as_secs_f64()
            );
        }
    }

    if let Some(o) = &out {
        let mut m = std::fs::File::create(o.join("manifest.tsv"))?;
        for (j, r) in photo_rows.iter().enumerate() {
            writeln!(m, "photo\t{}\t{j}\t{}", r.0, r.1.display())?;
        }
        for p in &pictures {
            writeln!(
                m,
                "{}\t{}\t{}\t{}",
                p.kind.folder(),
                p.person,
                p.photo,
                p.path.display()
            )?;
        }
        let mut f = std::fs::File::create(o.join("judge-input.txt"))?;
        let rows = photo_rows
            .iter()
            .map(|r| (&r.1, &r.2))
            .chain(pictures.iter().map(|p| (&p.path, &p.landmarks)));
        for (path, lm) in rows {
            if let Some(lm) = lm {
                write!(f, "{}", path.display())?;
                for p in lm {
                    write!(f, " {:.2} {:.2}", p[0], p[1])?;
                }
                writeln!(f)?;
            }
        }
    }

    let mut kinds: Vec<Kind> = views.iter().map(|v| Kind::Gem(*v)).collect();
    kinds.extend([Kind::FittedMesh, Kind::Portrait]);
    println!("{}", judge::HEADER);
    let photos: Vec<(usize, Option<Embedding>)> =
        photo_rows.iter().map(|r| (r.0, r.3.clone())).collect();
    let dist = |a: &Embedding, b: &Embedding| f64::from(embed::distance(a, b));
    let t = f64::from(embed::SAME_PERSON_DISTANCE);
    println!(
        "{}",
        judge::row("photos (SFace)", &judge::photos_alone(&photos, dist, t))
    );
    for k in kinds {
        let made: Vec<judge::Made<Embedding>> = pictures
            .iter()
            .filter(|p| p.kind == k)
            .map(|p| judge::Made {
                person: p.person,
                photo: p.photo,
                embedding: p.embedding.clone(),
            })
            .collect();
        println!(
            "{}",
            judge::row(k.label(), &judge::judge(&photos, &made, dist, t))
        );
    }
    gem_ms.sort_by(f64::total_cmp);
    if let Some(m) = gem_ms.get(gem_ms.len() / 2) {
        eprintln!(
            "photo -> cameo mesh (decode, face, identity, person, detail, relief): median {m:.0} ms"
        );
    }
    eprintln!("{:.1} s in all", started.elapsed().as_secs_f64());
    Ok(())
}

/// Scores a run kept with `--out DIR` by another network's descriptors (`PATH d1 ... dn` per
/// line; Euclidean distance, same person under `threshold`).
fn score_with_judge(dir: &Path, file: &Path, threshold: f64) -> Result<()> {
    let desc = read_descriptors(file)?;
    let manifest = std::fs::read_to_string(dir.join("manifest.tsv"))
        .with_context(|| format!("{}/manifest.tsv", dir.display()))?;
    let mut photos: Vec<(usize, Option<Vec<f64>>)> = Vec::new();
    let mut made: Vec<(String, judge::Made<Vec<f64>>)> = Vec::new();
    for line in manifest.lines() {
        let f: Vec<&str> = line.split('\t').collect();
        let [kind, person, photo, path] = f[..] else {
            bail!("manifest line {line:?}")
        };
        let (person, photo): (usize, usize) = (person.parse()?, photo.parse()?);
        let e = desc.get(path).cloned();
        if kind == "photo" {
            photos.push((person, e));
        } else {
            made.push((
                kind.to_string(),
                judge::Made {
                    person,
                    photo,
                    embedding: e,
                },
            ));
        }
    }
    let dist = |a: &Vec<f64>, b: &Vec<f64>| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y) * (x - y))
            .sum::<f64>()
            .sqrt()
    };
    println!("{}", judge::HEADER);
    println!(
        "{}",
        judge::row(
            "photos (judge)",
            &judge::photos_alone(&photos, dist, threshold)
        )
    );
    let mut kinds: Vec<String> = made.iter().map(|m| m.0.clone()).collect();
    kinds.dedup();
    kinds.sort();
    kinds.dedup();
    for k in kinds {
        let these: Vec<judge::Made<Vec<f64>>> = made
            .iter()
            .filter(|m| m.0 == k)
            .map(|m| judge::Made {
                person: m.1.person,
                photo: m.1.photo,
                embedding: m.1.embedding.clone(),
            })
            .collect();
        println!(
            "{}",
            judge::row(&k, &judge::judge(&photos, &these, dist, threshold))
        );
    }
    Ok(())
}

/// SFace's descriptors, in the judge's format (unit length, so Euclidean distance
/// `sqrt(2 * (1 - cos))`: SFace's threshold is 1.1287), for every picture a kept run's
/// `judge-input.txt` lists with its landmarks: so pictures changed after the run (a bound's
/// overlays) are scored by the project's own network as by dlib's.
fn sface_descriptors(dir: &Path) -> Result<()> {
    let models = ModelPaths::locate();
    let mut embedder = FaceEmbedder::load(&models.recogniser, &models.onnxruntime, 2)?;
    let input = dir.join("judge-input.txt");
    let text = std::fs::read_to_string(&input).with_context(|| format!("{}", input.display()))?;
    let mut buf = vec![0.0; 3 * embed::SIDE * embed::SIDE];
    for line in text.lines() {
        let mut f = line.split_whitespace();
        let Some(path) = f.next() else { continue };
        let v: Vec<f32> = f.map(str::parse).collect::<Result<_, _>>()?;
        let lm: Vec<[f32; 2]> = v.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
        let img = match image::open(path) {
            Ok(i) => i.to_rgb8(),
            Err(e) => {
                eprintln!("{path}: {e}");
                continue;
            }
        };
        if embed::aligned_input(&img, &lm, &mut buf).is_err() {
            continue;
        }
        if let Some(e) = embedder.embed_aligned(&buf, 1)?.pop() {
            print!("{path}");
            for x in e.0 {
                print!(" {x:.6}");
            }
            println!();
        }
    }
    Ok(())
}

/// The subject's 68 landmarks on a picture, as on a photo (found by `judge` where given, else
/// by the product's detector); `None` without a face.
fn find_face(
    pipeline: &mut GemPipeline,
    judge: Option<&mut glyptic::detect::FaceDetector>,
    rgb: &image::RgbImage,
) -> Option<Vec<[f32; 2]>> {
    let faces = match judge {
        Some(d) => {
            let opts = pipeline.face.faces.detect_options.clone();
            let mut faces = d.detect(rgb, &opts).ok()?;
            glyptic::detect::rank_faces(&mut faces, opts.prefer, rgb.width(), rgb.height());
            faces
        }
        None => pipeline.face.faces.detect(rgb).ok()?,
    };
    let first = faces.first()?;
    let mut found = pipeline
        .face
        .faces
        .landmarks(rgb, std::slice::from_ref(first))
        .ok()?;
    found.pop().map(|f| f.points)
}

/// The face mesh looking out, grey on mid-grey, `side` pixels square, its face filling about
/// half the width; and its five alignment points.
fn grey_face(
    mesh: &[f32],
    triangles: &[[u32; 3]],
    side: u32,
    yaw: f32,
) -> (image::RgbImage, Option<[[f32; 2]; 5]>) {
    let s = side as f32 / 300.0;
    let view = raster::View::turned(yaw, 0.0, s, side as f32 / 2.0, side as f32 * 0.45);
    let normals = raster::vertex_normals(mesh, triangles);
    let grey = raster::shade(
        mesh,
        triangles,
        &normals,
        &view,
        &raster::Light::default(),
        side as usize,
        side as usize,
    );
    let img = image::RgbImage::from_fn(side, side, |x, y| {
        let v = grey[(y * side + x) as usize];
        let g = if v.is_finite() {
            (v * 235.0).round() as u8
        } else {
            110
        };
        image::Rgb([g, g, g])
    });
    (img, raster::sfm_five_points(mesh, &view))
}

fn save(out: &Option<PathBuf>, kind: Kind, j: usize, rgb: &image::RgbImage) -> Result<PathBuf> {
    let Some(o) = out else {
        return Ok(PathBuf::from(format!("{}/{j:03}.png", kind.folder())));
    };
    let path = o.join(kind.folder()).join(format!("{j:03}.png"));
    rgb.save(&path)
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(path)
}

/// `PATH d1 ... dn` per line (a line with `ERROR` is a face the judge could not read).
fn read_descriptors(file: &Path) -> Result<HashMap<String, Vec<f64>>> {
    let text = std::fs::read_to_string(file).with_context(|| format!("{}", file.display()))?;
    let mut out = HashMap::new();
    for line in text.lines() {
        let mut f = line.split_whitespace();
        let Some(path) = f.next() else { continue };
        let v: Result<Vec<f64>, _> = f.map(str::parse::<f64>).collect();
        if let Ok(v) = v
            && !v.is_empty()
        {
            out.insert(path.to_string(), v);
        }
    }
    Ok(out)
}
