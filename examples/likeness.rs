//! The likeness test (issue #17): can a person's gems be told from other people's?
//!
//! Photos of several people, several photos each, used for measurement only and never
//! committed: deepface's `tests/unit/dataset` (61 photos of 13 people; its `master.csv` and
//! `face-recognition-pivot.csv` say which photos show the same person), or any folder with one
//! sub-folder of photos per person, such as the ten people of Labeled Faces in the Wild with ten
//! photos each in krasserm/face-recognition's `images/` (ten men of similar age, hair and
//! dress, 250 x 250 pixels: a much harder test). Every photo is made into a gem (the relief as
//! the photo path builds it, profile or frontal) and every gem's nearest other gem is looked up
//! by a descriptor of the gem alone:
//!
//! * `relief`: the relief's heights (gem mm) averaged over 1 mm squares of the stone, compared
//!   by root-mean-square difference: what the eye sees of the carving, outline and depth;
//! * `outline`: the share of 1 mm squares inside one portrait's outline and not the other's:
//!   the silhouette alone, as a shadow play would show it;
//! * `face`: the relief over the union of both faces' footprints only;
//! * `shape`: the relief over the squares that are face in most gems of the set, each gem's
//!   mean height there taken away first: the face's form, whatever depth the carving sets it
//!   at (a head with big hair is compressed more, and sits lower in the stone).
//!
//! The figure is the share of gems whose nearest other gem is the same person's (chance is
//! about 1 / number of people); with 61 gems one gem is 1.6 % and the figure's standard error
//! about 5 %, so a steadier figure is printed beside it: how often a gem's fellow (another of
//! the same person's) is nearer to it than a stranger's gem (50 % is chance).
//!
//! `--dump DIR` writes each relief (f32, little-endian, cols x rows) and its face footprint
//! (one byte per cell) for further study.
//!
//! `--colour-only` reads the hair without the person segmentation network;
//! `--classical` gives everyone the template's classical hair (the gems before issue #17);
//! `--caricature GAIN,DETAIL` sets the portrait's caricature (`1,0`: the fitted face as it is;
//! see [`glyptic::shapemodel::Caricature`]); `--prior LAMBDA` the portrait fit's identity
//! prior ([`glyptic::pipeline::FacePipeline::portrait_prior`]; 1: the mesh's fit);
//! `--expression SHARE` how much of the expression the portrait carves
//! ([`glyptic::pipeline::FacePipeline::portrait_expression`]); `--single-landmarks` finds the
//! landmarks on the photo alone, not also on its mirror image
//! ([`glyptic::pipeline::LandmarkPipeline::mirror_average`]).
//!
//! Also printed, for comparison and not a descriptor of the gem: the same test on the fitted
//! identities themselves, by standard deviations of the model and by millimetres of the mesh,
//! and on the portrait fit's identities (under the portrait's firmer prior) by standard
//! deviations.
//!
//! `cargo run --release --example likeness -- DATASET_DIR [--frontal] [--classical]
//! [--caricature G,D] [--prior LAMBDA] [--expression SHARE] [--single-landmarks] [--dump DIR]`

use std::path::PathBuf;

use anyhow::{Context, Result};
use glyptic::gem::{self, CameoParams, Relief};
use glyptic::pipeline::FacePipeline;
use glyptic::shapemodel::Caricature;

#[path = "common/identities.rs"]
mod identities;
use identities::identities;

/// The relief's heights over 1 mm squares (a square outside the portrait is 0).
struct Descriptor {
    heights: Vec<f32>,
    outline: Vec<bool>,
    face: Vec<bool>,
}

fn describe(r: &Relief) -> Descriptor {
    let k = (1.0 / r.cell).round().max(1.0) as usize;
    let (w, h) = (r.cols / k, r.rows / k);
    let mut d = Descriptor {
        heights: vec![0.0; w * h],
        outline: vec![false; w * h],
        face: vec![false; w * h],
    };
    for y in 0..h {
        for x in 0..w {
            let (mut sum, mut inside, mut face) = (0.0, 0, 0);
            for yy in y * k..(y + 1) * k {
                for xx in x * k..(x + 1) * k {
                    let i = yy * r.cols + xx;
                    sum += r.height[i];
                    inside += usize::from(r.portrait[i] > 0.0);
                    face += usize::from(r.face[i]);
                }
            }
            let j = y * w + x;
            d.heights[j] = sum / (k * k) as f32;
            d.outline[j] = 2 * inside > k * k;
            d.face[j] = 2 * face > k * k;
        }
    }
    d
}

/// The squares that are face in more than half of the gems.
fn common_face(gems: &[&Descriptor]) -> Vec<bool> {
    let n = gems.first().map_or(0, |g| g.face.len());
    (0..n)
        .map(|i| 2 * gems.iter().filter(|g| g.face[i]).count() > gems.len())
        .collect()
}

fn distance(kind: &str, a: &Descriptor, b: &Descriptor, common: &[bool]) -> f64 {
    let n = a.heights.len();
    match kind {
        "shape" => {
            let d: Vec<f64> = (0..n)
                .filter(|&i| common[i])
                .map(|i| f64::from(a.heights[i] - b.heights[i]))
                .collect();
            let m = d.iter().sum::<f64>() / d.len().max(1) as f64;
            (d.iter().map(|v| (v - m).powi(2)).sum::<f64>() / d.len().max(1) as f64).sqrt()
        }
        "relief" => {
            let s: f64 = (0..n)
                .map(|i| f64::from(a.heights[i] - b.heights[i]).powi(2))
                .sum();
            (s / n as f64).sqrt()
        }
        "outline" => (0..n).filter(|&i| a.outline[i] != b.outline[i]).count() as f64 / n as f64,
        _ => {
            let idx: Vec<usize> = (0..n).filter(|&i| a.face[i] || b.face[i]).collect();
            let s: f64 = idx
                .iter()
                .map(|&i| f64::from(a.heights[i] - b.heights[i]).powi(2))
                .sum();
            (s / idx.len().max(1) as f64).sqrt()
        }
    }
}

/// How often, over every item (gem or fitted identity; `ids[i]` its person) and every pair
/// (one of the same person's other items, one of another person's), the same person's is the
/// nearer: a steadier figure than the nearest neighbour's share (0.5 is chance, ties count
/// half).
fn same_nearer(ids: &[usize], dist: impl Fn(usize, usize) -> f64) -> f64 {
    let (mut wins, mut pairs) = (0.0, 0.0);
    for i in 0..ids.len() {
        let (same, other): (Vec<usize>, Vec<usize>) = (0..ids.len())
            .filter(|&j| j != i)
            .partition(|&j| ids[j] == ids[i]);
        let d_other: Vec<f64> = other.iter().map(|&j| dist(i, j)).collect();
        for &s in &same {
            let ds = dist(i, s);
            for &o in &d_other {
                wins += if ds < o {
                    1.0
                } else if ds == o {
                    0.5
                } else {
                    0.0
                };
                pairs += 1.0;
            }
        }
    }
    if pairs > 0.0 { wins / pairs } else { 0.5 }
}

/// For each of `n` items, the nearest other one by `dist` (`None` when there is no other).
fn nearest_others(n: usize, dist: impl Fn(usize, usize) -> f64) -> Vec<Option<usize>> {
    (0..n)
        .map(|i| {
            (0..n)
                .filter(|&j| j != i)
                .min_by(|&a, &b| dist(i, a).total_cmp(&dist(i, b)))
        })
        .collect()
}

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let mut dir = None;
    let mut dump = None;
    let mut params = CameoParams::default();
    let mut classical = false;
    let mut colour_only = false;
    let mut caricature = Caricature::default();
    let mut prior = None;
    let mut single_landmarks = false;
    let mut expression = None;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--frontal" => params = CameoParams::frontal(),
            "--classical" => classical = true,
            "--colour-only" => colour_only = true,
            "--caricature" => {
                let v = args.next().context("--caricature GAIN,DETAIL")?;
                let (g, d) = v.split_once(',').context("--caricature GAIN,DETAIL")?;
                caricature = Caricature {
                    gain: g.parse()?,
                    detail: d.parse()?,
                };
            }
            "--prior" => prior = Some(args.next().context("--prior LAMBDA")?.parse()?),
            "--single-landmarks" => single_landmarks = true,
            "--expression" => {
                expression = Some(args.next().context("--expression SHARE")?.parse()?)
            }
            "--dump" => dump = Some(PathBuf::from(args.next().context("--dump DIR")?)),
            _ => dir = Some(PathBuf::from(a)),
        }
    }
    let dir = dir.context("usage: likeness DATASET_DIR [--frontal] [--classical] [--dump DIR]")?;
    let ids = identities(&dir)?;
    let mut pipeline = FacePipeline::load(&glyptic::assets::ModelPaths::locate())?;
    pipeline.caricature = caricature;
    pipeline.faces.mirror_average = !single_landmarks;
    if let Some(e) = expression {
        pipeline.portrait_expression = e;
    }
    if let Some(p) = prior {
        pipeline.portrait_prior = p;
    }
    let builder = gem::CameoBuilder::new(&params)?;
    let triangles = pipeline.model.shape.triangles.clone();
    if let Some(d) = &dump {
        std::fs::create_dir_all(d)?;
    }
    let mut segmenter = if colour_only {
        None
    } else {
        Some(glyptic::detect::PersonSegmenter::load(
            &glyptic::assets::segmenter_model(),
            &glyptic::assets::onnxruntime_lib(),
        )?)
    };
    let mut gems: Vec<(String, usize, Descriptor)> = Vec::new();
    let mut fitted: Vec<(usize, Vec<f32>)> = Vec::new();
    let mut portraits: Vec<(usize, Vec<f32>)> = Vec::new();
    let mut per_photo_ms = Vec::new();
    for (name, &id) in &ids {
        let path = dir.join(name);
        let t = std::time::Instant::now();
        let (img, face) = match pipeline.photo(&path) {
            Ok(found) => found,
            Err(e) => {
                eprintln!("{name}: no gem: {e}");
                continue;
            }
        };
        // The person's own hair (unless --classical: the same hair for everyone).
        let relief = if classical {
            builder.relief(&face.portrait, &triangles)?
        } else {
            let mask = segmenter
                .as_mut()
                .map(|s| s.segment(&img, &face.landmarks))
                .transpose()?;
            let person = glyptic::person::analyse_with(&img, &face.landmarks, mask.as_ref())?;
            let own = CameoParams {
                hair: gem::hair_style(&person),
                ..params.clone()
            };
            gem::CameoBuilder::new(&own)?.relief(&face.portrait, &triangles)?
        };
        per_photo_ms.push(t.elapsed().as_secs_f64() * 1e3);
        if let Some(d) = &dump {
            let name = name.replace('/', "__");
            let bytes: Vec<u8> = relief.height.iter().flat_map(|v| v.to_le_bytes()).collect();
            std::fs::write(
                d.join(format!("{name}.{}x{}.f32", relief.cols, relief.rows)),
                bytes,
            )?;
            let face: Vec<u8> = relief.face.iter().map(|&f| u8::from(f)).collect();
            std::fs::write(
                d.join(format!("{name}.{}x{}.face", relief.cols, relief.rows)),
                face,
            )?;
        }
        gems.push((name.clone(), id, describe(&relief)));
        fitted.push((id, face.fit.shape.clone()));
        let (firm, _) = pipeline.portrait_coefficients(&face.landmarks, &face.fit);
        portraits.push((id, firm));
    }
    let people = gems
        .iter()
        .map(|g| g.1)
        .collect::<std::collections::BTreeSet<_>>()
        .len();
    println!(
        "{} gems of {} people from {}; chance about {:.0} %",
        gems.len(),
        people,
        dir.display(),
        100.0 / people as f64
    );
    let gem_ids: Vec<usize> = gems.iter().map(|g| g.1).collect();
    let common = common_face(&gems.iter().map(|g| &g.2).collect::<Vec<_>>());
    for kind in ["relief", "outline", "face", "shape"] {
        let mut right = 0;
        let mut misses = Vec::new();
        let nearest = nearest_others(gems.len(), |i, j| {
            distance(kind, &gems[i].2, &gems[j].2, &common)
        });
        for ((name, id, _), j) in gems.iter().zip(nearest) {
            if let Some((other, oid, _)) = j.map(|j| &gems[j]) {
                if oid == id {
                    right += 1;
                } else {
                    misses.push(format!("{name}->{other}"));
                }
            }
        }
        println!(
            "descriptor {kind:8}: nearest other gem the same person's for {right} / {} = {:.1} %; \
             same person nearer than another {:.1} % of the time",
            gems.len(),
            100.0 * right as f64 / gems.len().max(1) as f64,
            100.0
                * same_nearer(&gem_ids, |i, j| distance(
                    kind, &gems[i].2, &gems[j].2, &common
                ))
        );
        println!("  misses: {}", misses.join(" "));
    }
    // The fitted identities themselves: by standard deviations, and by millimetres (the
    // model's basis is orthonormal, so a coefficient's millimetres are it times sqrt(variance)).
    let sd: Vec<f32> = pipeline
        .model
        .shape
        .eigenvalues
        .iter()
        .map(|v| v.sqrt())
        .collect();
    for (label, scale, fitted) in [
        ("standard deviations", None, &fitted),
        ("millimetres", Some(&sd), &fitted),
        ("SD, portrait's prior", None, &portraits),
    ] {
        let d = |i: usize, j: usize| -> f64 {
            let (a, b) = (&fitted[i].1, &fitted[j].1);
            a.iter()
                .zip(b)
                .enumerate()
                .map(|(k, (x, y))| f64::from((x - y) * scale.map_or(1.0, |s| s[k])).powi(2))
                .sum()
        };
        let right = nearest_others(fitted.len(), d)
            .into_iter()
            .enumerate()
            .filter(|(i, j)| j.is_some_and(|j| fitted[j].0 == fitted[*i].0))
            .count();
        let ids: Vec<usize> = fitted.iter().map(|f| f.0).collect();
        let pairwise = same_nearer(&ids, d);
        println!(
            "fitted identity by {label:20}: nearest the same person's for {right} / {} = {:.1} %; same person nearer {:.1} % (not a gem descriptor)",
            fitted.len(),
            100.0 * right as f64 / fitted.len().max(1) as f64,
            100.0 * pairwise
        );
    }
    per_photo_ms.sort_by(f64::total_cmp);
    if let Some(m) = per_photo_ms.get(per_photo_ms.len() / 2) {
        println!("photo -> relief median {m:.0} ms (decode, detect, landmarks, fit, relief)");
    }
    Ok(())
}
