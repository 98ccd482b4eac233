//! The 68 landmarks of the synthetic frontal head that the person pass's unit tests and the
//! `hard_cases` example paint (one source: the example includes this file by its path). Image
//! pixels on a 400 x 520 picture.

/// 68 landmarks of a frontal face: eyes 60 px apart at y = 200, chin at y = 320.
pub fn landmarks() -> Vec<[f32; 2]> {
    let mut p = vec![[0f32; 2]; 68];
    for (k, q) in p.iter_mut().enumerate().take(17) {
        let th = std::f32::consts::PI * k as f32 / 16.0;
        *q = [200.0 - 70.0 * th.cos(), 205.0 + 115.0 * th.sin()];
    }
    for k in 0..5 {
        p[17 + k] = [140.0 + 11.0 * k as f32, 180.0];
        p[22 + k] = [216.0 + 11.0 * k as f32, 180.0];
    }
    for k in 0..4 {
        p[27 + k] = [200.0, 195.0 + 15.0 * k as f32];
    }
    for k in 0..5 {
        p[31 + k] = [185.0 + 7.5 * k as f32, 250.0];
    }
    for (e, cx) in [(36, 170.0), (42, 230.0)] {
        for k in 0..6 {
            let th = std::f32::consts::TAU * k as f32 / 6.0;
            p[e + k] = [cx - 10.0 * th.cos(), 200.0 - 4.0 * th.sin()];
        }
    }
    for k in 0..12 {
        let th = std::f32::consts::TAU * k as f32 / 12.0;
        p[48 + k] = [200.0 - 25.0 * th.cos(), 275.0 - 10.0 * th.sin()];
    }
    for k in 0..8 {
        let th = std::f32::consts::TAU * k as f32 / 8.0;
        p[60 + k] = [200.0 - 18.0 * th.cos(), 275.0 - 4.0 * th.sin()];
    }
    p
}
