//! Gallery styles: the art-gallery seed's post-process looks, as CPU references (the GPU passes
//! are checked against these): toon, Floyd-Steinberg dithering, painterly, fish-eye and
//! chromatic aberration.
//!
//! Images are 8-bit RGBA with display (sRGB-encoded) values, as the renderer writes them; alpha
//! is kept. Distances are in pixels; the fish-eye's radius is relative to half the image's
//! smaller side. Pure computation: no I/O, no GPU.

use image::{Rgba, RgbaImage};

/// One look.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Style {
    Toon,
    Dither,
    Painterly,
    FishEye,
    Chromatic,
}

impl Style {
    pub const ALL: [Style; 5] = [
        Style::Toon,
        Style::Dither,
        Style::Painterly,
        Style::FishEye,
        Style::Chromatic,
    ];

    /// Whether the style is serial: each pixel depends on those done before it (dithering's
    /// error diffusion), so it is done on the CPU, in order. (Painterly's dabs overlap, but
    /// each reads the original picture: a pixel is the last dab over it, which a GPU pass
    /// gathers.)
    pub fn is_serial(self) -> bool {
        matches!(self, Style::Dither)
    }

    /// Whether the style moves with time (its `time_s`): chromatic aberration's periodic shift.
    pub fn is_animated(self) -> bool {
        matches!(self, Style::Chromatic)
    }

    pub fn name(self) -> &'static str {
        match self {
            Style::Toon => "toon",
            Style::Dither => "dither",
            Style::Painterly => "painterly",
            Style::FishEye => "fisheye",
            Style::Chromatic => "chromatic",
        }
    }

    /// A comma-separated chain, applied left to right (`toon,fisheye`).
    pub fn parse_chain(text: &str) -> Result<Vec<Style>, String> {
        text.split(',')
            .map(str::trim)
            .map(|name| {
                Style::ALL
                    .into_iter()
                    .find(|s| s.name() == name)
                    .ok_or_else(|| {
                        let names: Vec<&str> = Style::ALL.iter().map(|s| s.name()).collect();
                        format!("unknown style `{name}` (one of {})", names.join(", "))
                    })
            })
            .collect()
    }
}

/// Applies `style` with its default parameters (the chromatic aberration at `time_s`).
pub fn apply(img: &RgbaImage, style: Style, time_s: f32) -> RgbaImage {
    match style {
        Style::Toon => toon(img, &ToonParams::default()),
        Style::Dither => dither(img, DITHER_LEVELS),
        Style::Painterly => painterly(img, &PainterlyParams::default()),
        Style::FishEye => fisheye(img, &FishEyeParams::default()),
        Style::Chromatic => chromatic(
            img,
            &ChromaticParams {
                time_s,
                ..ChromaticParams::default()
            },
        ),
    }
}

/// Levels per channel of the dithering (27 colours), as in the gallery.
pub const DITHER_LEVELS: u32 = 3;

/// Toon: 6 grey levels, and black where the Sobel gradient of the luminance is an edge.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToonParams {
    pub levels: u32,
    /// The gradient magnitude (luminance 0..1 per pixel, Sobel-weighted) is smoothed by
    /// smoothstep(`edge_low`, `edge_high`, m); above `threshold` the pixel is an edge.
    pub edge_low: f32,
    pub edge_high: f32,
    pub threshold: f32,
}

impl Default for ToonParams {
    fn default() -> Self {
        ToonParams {
            levels: 6,
            edge_low: 0.2,
            edge_high: 0.6,
            threshold: 0.5,
        }
    }
}

fn luminance(p: &Rgba<u8>) -> f32 {
    (0.2126 * f32::from(p[0]) + 0.7152 * f32::from(p[1]) + 0.0722 * f32::from(p[2])) / 255.0
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Sobel gradient magnitude of the luminance at (x, y), edges clamped.
pub fn sobel(luma: &[f32], width: u32, height: u32, x: u32, y: u32) -> f32 {
    let at = |dx: i64, dy: i64| {
        let xx = (i64::from(x) + dx).clamp(0, i64::from(width) - 1) as usize;
        let yy = (i64::from(y) + dy).clamp(0, i64::from(height) - 1) as usize;
        luma[yy * width as usize + xx]
    };
    let gx = at(1, -1) + 2.0 * at(1, 0) + at(1, 1) - at(-1, -1) - 2.0 * at(-1, 0) - at(-1, 1);
    let gy = at(-1, 1) + 2.0 * at(0, 1) + at(1, 1) - at(-1, -1) - 2.0 * at(0, -1) - at(1, -1);
    (gx * gx + gy * gy).sqrt()
}

pub fn toon(img: &RgbaImage, p: &ToonParams) -> RgbaImage {
    let (w, h) = img.dimensions();
    let luma: Vec<f32> = img.pixels().map(luminance).collect();
    let levels = p.levels.max(2) as f32;
    RgbaImage::from_fn(w, h, |x, y| {
        let edge = smoothstep(p.edge_low, p.edge_high, sobel(&luma, w, h, x, y));
        let a = img.get_pixel(x, y)[3];
        if edge > p.threshold {
            return Rgba([0, 0, 0, a]);
        }
        let l = luma[(y * w + x) as usize];
        let step = (l * levels).floor().min(levels - 1.0);
        let grey = (step / (levels - 1.0) * 255.0).round() as u8;
        Rgba([grey, grey, grey, a])
    })
}

/// The display value of quantisation level `i` of `levels` (0 and 255 at the ends).
fn level_value(i: f32, levels: f32) -> f32 {
    (i * 255.0 / (levels - 1.0)).round()
}

/// Floyd-Steinberg dithering to `levels` values per channel (3: 27 colours), serial, rows left
/// to right: each pixel's error (its value with the error it received, less the nearest level's
/// display value) goes 7/16 right, 3/16 down-left, 5/16 down, 1/16 down-right.
///
/// Two rows are worked (this one and the next, a pixel of margin each side, so no pixel needs a
/// bounds check), and every pixel receives its shares in the order the plain serial loop gives
/// them: the same arithmetic, so the same image to the bit (`tests`), three times sooner
/// (18 against 54 ms at 1280x800 on two cores).
pub fn dither(img: &RgbaImage, levels: u32) -> RgbaImage {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let levels = levels.max(2) as f32;
    let values: Vec<f32> = (0..levels as usize)
        .map(|i| level_value(i as f32, levels))
        .collect();
    // Level k is nearest from k - 0.5 up (in level units).
    let halfway: Vec<f32> = (1..values.len()).map(|k| k as f32 - 0.5).collect();
    let mut out = img.clone();
    // Row buffers: index x + 1 for pixel x. `here` holds this row's values with the error they
    // have received so far; `next` the next row's (its values first, as the plain loop's
    // working copy of the whole image starts).
    let load = |y: usize, row: &mut Vec<[f32; 3]>| {
        row.iter_mut().for_each(|e| *e = [0.0; 3]);
        if y < h {
            for (x, p) in img.as_raw()[y * w * 4..(y + 1) * w * 4]
                .chunks_exact(4)
                .enumerate()
            {
                row[x + 1] = [0, 1, 2].map(|c| f32::from(p[c]));
            }
        }
    };
    let mut here = vec![[0f32; 3]; w + 2];
    let mut next = vec![[0f32; 3]; w + 2];
    load(0, &mut here);
    let raw: &mut [u8] = &mut out;
    for y in 0..h {
        load(y + 1, &mut next);
        let row = &mut raw[y * w * 4..(y + 1) * w * 4];
        for x in 0..w {
            let old = here[x + 1];
            let mut err = [0f32; 3];
            for c in 0..3 {
                // The nearest level: `round` (half away from zero) clamped to the levels, as
                // comparisons with the halfway points (exact; `round` is a library call here).
                let v = old[c] / 255.0 * (levels - 1.0);
                let i = halfway.iter().filter(|&&t| v >= t).count();
                let new = values[i];
                err[c] = old[c] - new;
                row[4 * x + c] = new as u8;
            }
            // The shares in the plain loop's order; the margins take what falls outside.
            for c in 0..3 {
                here[x + 2][c] += err[c] * (7.0 / 16.0);
                next[x][c] += err[c] * (3.0 / 16.0);
                next[x + 1][c] += err[c] * (5.0 / 16.0);
                next[x + 2][c] += err[c] * (1.0 / 16.0);
            }
        }
        std::mem::swap(&mut here, &mut next);
    }
    out
}

/// Bilinear sample at (`x`, `y`) pixels (pixel centres at integers), edges clamped.
fn sample(img: &RgbaImage, x: f32, y: f32) -> [f32; 4] {
    let (w, h) = (img.width() as i64, img.height() as i64);
    let px = |xx: i64, yy: i64| {
        let p = img.get_pixel(xx.clamp(0, w - 1) as u32, yy.clamp(0, h - 1) as u32);
        [0, 1, 2, 3].map(|c| f32::from(p[c]))
    };
    crate::bilinear::bilinear(px, x, y)
}

/// Fish-eye: output pixel at offset `d` from the centre (in half the smaller side) shows the
/// image at `d * (1 + strength * |d|^power)`: the centre stays, the rim is pushed out; what
/// would come from outside the image is black.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FishEyeParams {
    pub strength: f32,
    pub power: f32,
}

impl Default for FishEyeParams {
    fn default() -> Self {
        FishEyeParams {
            strength: 0.35,
            power: 2.0,
        }
    }
}

pub fn fisheye(img: &RgbaImage, p: &FishEyeParams) -> RgbaImage {
    let (w, h) = img.dimensions();
    let (cx, cy) = ((w as f32 - 1.0) / 2.0, (h as f32 - 1.0) / 2.0);
    let half = (w.min(h) as f32 / 2.0).max(0.5);
    RgbaImage::from_fn(w, h, |x, y| {
        let (dx, dy) = ((x as f32 - cx) / half, (y as f32 - cy) / half);
        let r = (dx * dx + dy * dy).sqrt();
        let k = 1.0 + p.strength * r.powf(p.power);
        let (sx, sy) = (cx + dx * k * half, cy + dy * k * half);
        if sx < -0.5 || sy < -0.5 || sx > w as f32 - 0.5 || sy > h as f32 - 0.5 {
            return Rgba([0, 0, 0, 255]);
        }
        let v = sample(img, sx, sy);
        Rgba(v.map(|c| c.round().clamp(0.0, 255.0) as u8))
    })
}

/// Chromatic aberration: each colour channel read `amplitude` pixels away from the pixel, in a
/// direction turning at `frequency` Hz, the three a third of a turn apart; `time_s` moves it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChromaticParams {
    pub amplitude: f32,
    pub frequency: f32,
    pub time_s: f32,
}

impl Default for ChromaticParams {
    fn default() -> Self {
        ChromaticParams {
            amplitude: 3.0,
            frequency: 0.25,
            time_s: 0.0,
        }
    }
}

/// Per-channel offsets (pixels) of [`chromatic`] at its time.
pub fn chromatic_offsets(p: &ChromaticParams) -> [[f32; 2]; 3] {
    [0.0f32, 1.0, 2.0].map(|k| {
        let phase = std::f32::consts::TAU * (p.frequency * p.time_s + k / 3.0);
        [p.amplitude * phase.cos(), p.amplitude * phase.sin()]
    })
}

pub fn chromatic(img: &RgbaImage, p: &ChromaticParams) -> RgbaImage {
    let offsets = chromatic_offsets(p);
    RgbaImage::from_fn(img.width(), img.height(), |x, y| {
        let mut out = *img.get_pixel(x, y);
        for (c, [ox, oy]) in offsets.iter().enumerate() {
            out[c] = sample(img, x as f32 + ox, y as f32 + oy)[c]
                .round()
                .clamp(0.0, 255.0) as u8;
        }
        out
    })
}

/// Painterly: brush dabs of the colour under their centre, laid coarse to fine on a jittered
/// grid; a dab is smaller where the colour around it changes (detail keeps small brushes).
#[derive(Clone, Debug, PartialEq)]
pub struct PainterlyParams {
    /// Brush radii of the layers, pixels, coarse first; each layer's grid step is its radius.
    pub radii: Vec<f32>,
    /// Grid jitter, as a fraction of the step.
    pub jitter: f32,
    /// Colour difference (0..1, mean over channels) at which a brush shrinks to its smallest.
    pub difference: f32,
    pub seed: u32,
}

impl Default for PainterlyParams {
    fn default() -> Self {
        PainterlyParams {
            radii: vec![8.0, 4.0, 2.0],
            jitter: 0.5,
            difference: 0.15,
            seed: 2024,
        }
    }
}

/// A small, well-mixed 32-bit hash (Wellons's lowbias32), so the GPU pass can reproduce it.
pub fn hash32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

/// The jitter's seed: from the picture itself (a sparse sample of its pixels) and `base`, so
/// the same picture paints the same and a moved view repaints.
pub fn painting_seed(img: &RgbaImage, base: u32) -> u32 {
    let (w, h) = img.dimensions();
    let mut seed = base;
    for k in 0..16u32 {
        let px = img.get_pixel((k * 7919) % w.max(1), (k * 104_729) % h.max(1));
        seed = hash32(seed ^ u32::from_le_bytes(px.0));
    }
    seed
}

/// A cell's random bits: from the painting's seed, the layer and the cell.
pub fn cell_bits(seed: u32, layer: u32, gx: u32, gy: u32) -> u32 {
    hash32(hash32(hash32(seed ^ layer) ^ gy) ^ gx)
}

/// Jitter in [-0.5, 0.5] from 16 bits (a multiplication, not a division: the GPU pass
/// computes it the same way, to the bit).
fn unit(bits: u32) -> f32 {
    (bits & 0xffff) as f32 * (1.0 / 65535.0) - 0.5
}

/// Painterly: each layer's dabs are painted in grid order over the picture, coarse layers
/// first; a dab is the colour under its jittered centre, its radius shrinking where the colour
/// changes within a brush radius. A pixel ends as the last dab that covers it, so the GPU pass
/// gathers the same result (the dabs read the original picture, never the painting).
pub fn painterly(img: &RgbaImage, p: &PainterlyParams) -> RgbaImage {
    let (w, h) = img.dimensions();
    let seed = painting_seed(img, p.seed);
    // Rounding half up (floor(x + 0.5)), as the GPU pass does (WGSL's round is half-even).
    let colour = |x: f32, y: f32| {
        let p = img.get_pixel(
            ((x + 0.5).floor().max(0.0) as u32).min(w - 1),
            ((y + 0.5).floor().max(0.0) as u32).min(h - 1),
        );
        [0, 1, 2].map(|c| f32::from(p[c]) / 255.0)
    };
    let inv_difference = 1.0 / p.difference;
    let mut out = img.clone();
    for (layer, &radius) in p.radii.iter().enumerate() {
        let step = radius.max(1.0);
        let (nx, ny) = (
            (w as f32 / step).ceil() as u32,
            (h as f32 / step).ceil() as u32,
        );
        for gy in 0..ny {
            for gx in 0..nx {
                let r = cell_bits(seed, layer as u32, gx, gy);
                let cx = (gx as f32 + 0.5 + p.jitter * unit(r)) * step;
                let cy = (gy as f32 + 0.5 + p.jitter * unit(r >> 16)) * step;
                let c = colour(cx, cy);
                // How much the colour changes a brush radius away (four directions).
                let change = [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)]
                    .iter()
                    .map(|(dx, dy)| {
                        let o = colour(cx + dx * radius, cy + dy * radius);
                        ((o[0] - c[0]).abs() + (o[1] - c[1]).abs() + (o[2] - c[2]).abs())
                            * (1.0 / 3.0)
                    })
                    .fold(0.0f32, f32::max);
                let brush = radius * (1.0 - 0.6 * (change * inv_difference).min(1.0));
                let b2 = brush * brush;
                let (x0, x1) = (
                    (cx - brush).floor().max(0.0) as u32,
                    (cx + brush).ceil() as u32,
                );
                let (y0, y1) = (
                    (cy - brush).floor().max(0.0) as u32,
                    (cy + brush).ceil() as u32,
                );
                let rgb = c.map(|v| (v * 255.0).round() as u8);
                for y in y0..=y1.min(h - 1) {
                    for x in x0..=x1.min(w - 1) {
                        let (dx, dy) = (x as f32 - cx, y as f32 - cy);
                        if dx * dx + dy * dy <= b2 {
                            let px = out.get_pixel_mut(x, y);
                            px[0] = rgb[0];
                            px[1] = rgb[1];
                            px[2] = rgb[2];
                        }
                    }
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> RgbaImage {
        // A light square (x, y in 8..24) on a dark ground, 32x32; neither is black in toon.
        RgbaImage::from_fn(32, 32, |x, y| {
            if (8..24).contains(&x) && (8..24).contains(&y) {
                Rgba([220, 220, 220, 255])
            } else {
                Rgba([60, 60, 60, 255])
            }
        })
    }

    #[test]
    fn toon_edges_fall_on_the_squares_border() {
        let out = toon(&square(), &ToonParams::default());
        for y in 0..32u32 {
            for x in 0..32u32 {
                // Sobel sees the border in the pixels on both sides of it.
                let near = |v: u32| v == 7 || v == 8 || v == 23 || v == 24;
                let inside = |v: u32| (7..=24).contains(&v);
                let on_border = inside(x) && inside(y) && (near(x) || near(y));
                let black = out.get_pixel(x, y)[0] == 0;
                assert_eq!(black, on_border, "({x}, {y})");
            }
        }
        // Away from the border: the grey levels of 6, the light square above the dark ground.
        let (ground, face) = (out.get_pixel(2, 2)[0], out.get_pixel(16, 16)[0]);
        assert_eq!((ground, face), (51, 255));
    }

    /// The plain serial loop (a working buffer of the whole image), as the dither was first
    /// written: the reference [`dither`] must equal to the bit.
    fn dither_reference(img: &RgbaImage, levels: u32) -> RgbaImage {
        let (w, h) = (img.width() as usize, img.height() as usize);
        let levels = levels.max(2) as f32;
        let mut work: Vec<[f32; 3]> = img
            .pixels()
            .map(|p| [0, 1, 2].map(|c| f32::from(p[c])))
            .collect();
        let mut out = img.clone();
        for y in 0..h {
            for x in 0..w {
                let old = work[y * w + x];
                let new = [0, 1, 2].map(|c| {
                    let i = (old[c] / 255.0 * (levels - 1.0))
                        .round()
                        .clamp(0.0, levels - 1.0);
                    level_value(i, levels)
                });
                let err = [0, 1, 2].map(|c| old[c] - new[c]);
                let mut spread = |dx: isize, dy: usize, weight: f32| {
                    let (xx, yy) = (x as isize + dx, y + dy);
                    if xx >= 0 && (xx as usize) < w && yy < h {
                        let cell = &mut work[yy * w + xx as usize];
                        for c in 0..3 {
                            cell[c] += err[c] * weight;
                        }
                    }
                };
                spread(1, 0, 7.0 / 16.0);
                spread(-1, 1, 3.0 / 16.0);
                spread(0, 1, 5.0 / 16.0);
                spread(1, 1, 1.0 / 16.0);
                let px = out.get_pixel_mut(x as u32, y as u32);
                for c in 0..3 {
                    px[c] = new[c] as u8;
                }
            }
        }
        out
    }

    /// The row-buffered dither gives the plain loop's image to the bit, on noise and on
    /// smooth ramps, at odd sizes and at 2, 3 and 6 levels.
    #[test]
    fn dithering_is_the_plain_loops_to_the_bit() {
        let mut state = 0x2545_f491_u32;
        let mut rand = move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            (state >> 24) as u8
        };
        for (w, h) in [(1, 1), (1, 7), (9, 1), (37, 23), (128, 96)] {
            let noise = RgbaImage::from_fn(w, h, |_, _| Rgba([rand(), rand(), rand(), 255]));
            let ramp = RgbaImage::from_fn(w, h, |x, y| {
                Rgba([
                    (x * 255 / w) as u8,
                    (y * 255 / h) as u8,
                    ((x + y) % 256) as u8,
                    200,
                ])
            });
            for img in [&noise, &ramp] {
                for levels in [2, 3, 6] {
                    assert!(
                        dither(img, levels) == dither_reference(img, levels),
                        "{w}x{h}, {levels} levels"
                    );
                }
            }
        }
    }

    #[test]
    fn dithering_reproduces_the_serial_result() {
        // One channel worked by hand (levels 0, 128, 255; thresholds 63.75 and 191.25), 3x2,
        // chosen so that every pixel's level depends on the errors it receives:
        // row 0: 100 -> 128 (error -28); 70 - 28 * 7/16 = 57.75 -> 0 (error 57.75; alone, 70
        // would be 128); 180 + 57.75 * 7/16 = 205.27 -> 255 (error -49.73; alone 128).
        // row 1: 60 - 28 * 5/16 + 57.75 * 3/16 = 62.08 -> 0 (error 62.08; without the 5/16 it
        // would be 128); 120 - 28/16 + 57.75 * 5/16 - 49.73 * 3/16 + 62.08 * 7/16 = 154.13 ->
        // 128 (error 26.13); 200 + 57.75/16 - 49.73 * 5/16 + 26.13 * 7/16 = 199.5 -> 255
        // (without the 7/16 from the left it would be 128).
        let img = RgbaImage::from_fn(3, 2, |x, y| {
            let v = [[100, 70, 180], [60, 120, 200]][y as usize][x as usize];
            Rgba([v, v, v, 255])
        });
        let out = dither(&img, 3);
        let rows: Vec<Vec<u8>> = (0..2)
            .map(|y| (0..3).map(|x| out.get_pixel(x, y)[0]).collect())
            .collect();
        assert_eq!(rows, vec![vec![128, 0, 255], vec![0, 128, 255]]);
        // Only 3 values per channel anywhere, and the mean is kept on a smooth ramp.
        let ramp = RgbaImage::from_fn(64, 16, |x, _| Rgba([(x * 4) as u8, 90, 200, 255]));
        let d = dither(&ramp, 3);
        assert!(
            d.pixels()
                .all(|p| (0..3).all(|c| [0, 128, 255].contains(&p[c])))
        );
        let mean = |img: &RgbaImage| {
            img.pixels().map(|p| f64::from(p[0])).sum::<f64>() / f64::from(64 * 16)
        };
        assert!(
            (mean(&d) - mean(&ramp)).abs() < 2.0,
            "{} vs {}",
            mean(&d),
            mean(&ramp)
        );
    }

    #[test]
    fn fisheye_keeps_the_centre_and_blacks_out_the_corners() {
        let img = RgbaImage::from_fn(41, 31, |x, y| Rgba([(x * 6) as u8, (y * 8) as u8, 77, 255]));
        let out = fisheye(&img, &FishEyeParams::default());
        assert_eq!(out.get_pixel(20, 15), img.get_pixel(20, 15));
        for (x, y) in [(0, 0), (40, 0), (0, 30), (40, 30)] {
            assert_eq!(out.get_pixel(x, y).0, [0, 0, 0, 255], "corner ({x}, {y})");
        }
        // No distortion at strength 0.
        let flat = fisheye(
            &img,
            &FishEyeParams {
                strength: 0.0,
                power: 2.0,
            },
        );
        assert_eq!(flat, img);
    }

    #[test]
    fn chromatic_moves_each_channel_its_own_way() {
        let img = square();
        let p = ChromaticParams {
            amplitude: 2.0,
            frequency: 0.25,
            time_s: 0.0,
        };
        let out = chromatic(&img, &p);
        let o = chromatic_offsets(&p);
        // Red reads 2 px to the right at t = 0: the square's red edge moves left by 2.
        assert_eq!(o[0], [2.0, 0.0]);
        assert_eq!(out.get_pixel(6, 16)[0], 220);
        assert_eq!(out.get_pixel(5, 16)[0], 60);
        // The offsets turn with time and stay a third of a turn apart.
        let later = chromatic_offsets(&ChromaticParams { time_s: 1.0, ..p });
        assert!((later[0][1] - 2.0).abs() < 1e-5 && later[0][0].abs() < 1e-5);
        assert_eq!(
            chromatic(
                &img,
                &ChromaticParams {
                    amplitude: 0.0,
                    ..p
                }
            ),
            img
        );
    }

    #[test]
    fn painterly_is_stable_for_a_still_view_and_follows_detail() {
        let img = square();
        let p = PainterlyParams::default();
        let a = painterly(&img, &p);
        assert_eq!(a, painterly(&img, &p), "a still view must paint the same");
        // Flat areas keep their colour; the square stays a square give or take a brush.
        assert_eq!(a.get_pixel(16, 16)[0], 220);
        assert_eq!(a.get_pixel(2, 2)[0], 60);
        // A moved view repaints: the square one pixel to the right gets another jitter.
        let moved = RgbaImage::from_fn(32, 32, |x, y| *img.get_pixel(x.saturating_sub(1), y));
        assert_ne!(painting_seed(&img, p.seed), painting_seed(&moved, p.seed));
        assert_eq!(
            painting_seed(&img, p.seed),
            painting_seed(&img.clone(), p.seed)
        );
    }

    #[test]
    fn chains_parse_by_name() {
        assert_eq!(
            Style::parse_chain("toon, fisheye").unwrap(),
            vec![Style::Toon, Style::FishEye]
        );
        let e = Style::parse_chain("toon,sepia").unwrap_err();
        assert!(e.contains("sepia") && e.contains("dither"), "{e}");
    }
}
