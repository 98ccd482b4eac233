//! Stubble: a short beard is skin dotted with the cut ends of hairs. On the person canvas
//! (0.04 IOD cells, each a mean) it averages to skin a little darker or greyer than the
//! cheeks, which a day's shadow or a grey beard on pale skin can also be; at the photo's own
//! resolution it is **fine detail** the shaven skin above it lacks. This measures that
//! detail on the chin and on the upper cheeks (where no beard grows) alike, and gives their
//! ratio: the photo's sharpness, noise and exposure are in both and cancel.
//!
//! Frame and units: the head frame of `super` (IOD, `t` down the face). Lightness 0..1.

use super::Frame;

/// Cell size, IOD: about a millimetre and a quarter on an adult, a stubble's dot or two.
const RES: f32 = 0.02;
/// How far inside a region a cell must be to be read (IOD): its outline (the jaw's edge
/// against the neck, the lip's shadow) is not the skin's texture. The upper lip is a narrow
/// band (about 0.2 IOD from the nose to the lip): half as far there.
const INSET: f32 = 0.08;
const LIP_INSET: f32 = 0.04;
/// Fewer cells than this in either region (or a photo under this many pixels between the
/// eyes, where a cell is under a pixel) read nothing.
const MIN_CELLS: usize = 30;
const MIN_IOD: f32 = 50.0;
/// Detail under this (a fifth of a percent of the lightness) is a clean photo's noise floor:
/// two flat regions read a ratio of 1, not a ratio of rounding errors.
const FLOOR: f32 = 0.002;

/// A chin (or upper lip) with more than this many times the cheeks' fine detail is stubble.
/// On the 177 labelled photos with at least 50 pixels between the eyes, shaven chins read
/// 0.3-2.2 and upper lips 0.3-2.3; the stubble beards the colour missed (grey on tan skin,
/// dark and short) 3.8-4.9, their upper lips 5.0-6.1, full beards 3.0-15.6.
pub const STUBBLE: f32 = 3.0;

/// What was measured of the chin's and the cheeks' fine detail.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stubble {
    /// Mean absolute difference of a cell from its eight neighbours, over the mean
    /// lightness, on the chin and on the upper cheeks (0 where unread).
    pub chin: f32,
    pub cheeks: f32,
    /// The same on the upper lip (a moustache's stubble).
    pub lip: f32,
}

impl Stubble {
    /// How much finer detail the chin has than the cheeks (1: as much; 0 where unread).
    pub fn ratio(&self) -> f32 {
        Self::against(self.chin, self.cheeks)
    }
    /// How much finer detail the upper lip has than the cheeks.
    pub fn lip_ratio(&self) -> f32 {
        Self::against(self.lip, self.cheeks)
    }
    /// Whether the chin is stubbled ([`STUBBLE`]).
    pub fn on_chin(&self) -> bool {
        self.ratio() > STUBBLE
    }
    /// Whether the upper lip is stubbled.
    pub fn on_lip(&self) -> bool {
        self.lip_ratio() > STUBBLE
    }
    fn against(region: f32, cheeks: f32) -> f32 {
        if region > 0.0 && cheeks > 0.0 {
            region.max(FLOOR) / cheeks.max(FLOOR)
        } else {
            0.0
        }
    }
}

/// Reads the chin (`chin`) and the cheeks (`cheeks`), each a head-frame region.
pub(super) fn measure(
    frame: Frame,
    iod: f32,
    lightness: &dyn Fn(f32, f32) -> f32,
    chin: &dyn Fn([f32; 2]) -> bool,
    lip: &dyn Fn([f32; 2]) -> bool,
    cheeks: &dyn Fn([f32; 2]) -> bool,
) -> Stubble {
    if iod.is_nan() || iod < MIN_IOD {
        return Stubble::default();
    }
    let (Some(chin), Some(cheeks)) = (
        detail(frame, iod, lightness, chin, INSET),
        detail(frame, iod, lightness, cheeks, INSET),
    ) else {
        return Stubble::default();
    };
    let lip = detail(frame, iod, lightness, lip, LIP_INSET).unwrap_or(0.0);
    Stubble { chin, cheeks, lip }
}

/// The region's fine detail: each cell against the mean of its eight neighbours, averaged
/// over the cells `inset` inside the region, over the region's mean lightness.
fn detail(
    frame: Frame,
    iod: f32,
    lightness: &dyn Fn(f32, f32) -> f32,
    region: &dyn Fn([f32; 2]) -> bool,
    inset: f32,
) -> Option<f32> {
    // The head frame's box that holds every face region (IOD).
    let (s0, s1, t0, t1) = (-1.4f32, 1.4f32, -0.5f32, 2.4f32);
    let w = ((s1 - s0) / RES) as usize;
    let h = ((t1 - t0) / RES) as usize;
    let at = |c: usize, r: usize| [s0 + (c as f32 + 0.5) * RES, t0 + (r as f32 + 0.5) * RES];
    let read: Vec<(usize, usize)> = (1..h - 1)
        .flat_map(|r| (1..w - 1).map(move |c| (c, r)))
        .filter(|&(c, r)| super::colour::inside_by(region, at(c, r), inset))
        .collect();
    if read.len() < MIN_CELLS {
        return None;
    }
    let k = ((RES * iod).ceil() as usize).clamp(1, 3);
    // Each cell sampled once (a read cell and its neighbours overlap); NaN: not yet.
    let mut cache = vec![f32::NAN; w * h];
    let mut value = |c: usize, r: usize| -> f32 {
        let slot = &mut cache[r * w + c];
        if slot.is_nan() {
            *slot = frame.cell_mean(at(c, r), RES, k, lightness);
        }
        *slot
    };
    let (mut diff, mut mean) = (0.0f64, 0.0f64);
    for &(c, r) in &read {
        let v = value(c, r);
        let mut around = 0.0;
        for (dc, dr) in [
            (0, 0),
            (1, 0),
            (2, 0),
            (0, 1),
            (2, 1),
            (0, 2),
            (1, 2),
            (2, 2),
        ] {
            around += value(c + dc - 1, r + dr - 1);
        }
        diff += f64::from((v - around / 8.0).abs());
        mean += f64::from(v);
    }
    (mean > 0.0).then(|| (diff / mean) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A frame one pixel per 0.01 IOD (100 pixels between the eyes) with its origin at
    /// (200, 100).
    fn frame() -> Frame {
        Frame {
            origin: [200.0, 100.0],
            axis: [100.0, 0.0],
        }
    }

    /// Skin dotted with dark points on the chin and smooth cheeks read a ratio well over 1;
    /// the same smooth skin everywhere about 1 or less; a small photo nothing.
    #[test]
    fn dots_on_the_chin_read_as_stubble() {
        let f = frame();
        let chin = |p: [f32; 2]| p[0].abs() < 0.4 && (1.2..1.6).contains(&p[1]);
        let cheeks = |p: [f32; 2]| (0.25..0.6).contains(&p[0].abs()) && (0.3..0.6).contains(&p[1]);
        // Photo pixels: a gentle gradient (light falling off), and dots on the chin.
        let shaved = |x: f32, y: f32| 0.6 + 0.0004 * x - 0.0002 * y;
        let dotted = |x: f32, y: f32| {
            let t = (y - 100.0) / 100.0;
            let dot = (x as i32 % 3 == 0) && (y as i32 % 3 == 0);
            shaved(x, y) - if t > 1.1 && dot { 0.25 } else { 0.0 }
        };
        let stubble = measure(f, 100.0, &dotted, &chin, &chin, &cheeks);
        let clean = measure(f, 100.0, &shaved, &chin, &chin, &cheeks);
        assert!(stubble.ratio() > 3.0, "{stubble:?}");
        assert!(clean.ratio() < 1.5, "{clean:?}");
        assert_eq!(
            measure(f, 20.0, &dotted, &chin, &chin, &cheeks).ratio(),
            0.0
        );
        assert_eq!(
            measure(f, f32::NAN, &dotted, &chin, &chin, &cheeks).ratio(),
            0.0
        );
        let nowhere = |_: [f32; 2]| false;
        assert_eq!(
            measure(f, 100.0, &dotted, &nowhere, &chin, &cheeks).ratio(),
            0.0
        );
    }
}
