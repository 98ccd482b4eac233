//! What a rendered image can be checked for, by the tests and by anyone who renders many:
//! isolated dead pixels. Pixels are 8-bit sRGB.

/// Isolated dead pixels: near black (mean of the channels at most 12) while all four
/// neighbours are lit (at least 60), where a shader made a NaN or a negative light that the
/// MSAA resolve turned black (issue #40: 2-5 in every photo's gem before the scene shader
/// held its interpolated weights to their range). Styles that draw black dots on purpose
/// (dither, toon's outlines) have them by design. Returns their positions.
pub fn dead_pixels(img: &image::RgbaImage) -> Vec<(u32, u32)> {
    let (w, h) = img.dimensions();
    let grey = |x: u32, y: u32| {
        let p = img.get_pixel(x, y);
        (u32::from(p[0]) + u32::from(p[1]) + u32::from(p[2])) / 3
    };
    let mut out = Vec::new();
    for y in 1..h.saturating_sub(1) {
        for x in 1..w.saturating_sub(1) {
            if grey(x, y) <= 12
                && [(x - 1, y), (x + 1, y), (x, y - 1), (x, y + 1)]
                    .iter()
                    .all(|&(u, v)| grey(u, v) >= 60)
            {
                out.push((x, y));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_black_pixel_amid_light_ones_is_found_and_dark_detail_is_not() {
        let mut img = image::RgbaImage::from_pixel(8, 8, image::Rgba([180, 170, 160, 255]));
        img.put_pixel(3, 3, image::Rgba([0, 0, 0, 255]));
        // A dark line (two pixels) is detail, not a dead pixel; so is a dark edge pixel.
        img.put_pixel(5, 5, image::Rgba([5, 5, 5, 255]));
        img.put_pixel(6, 5, image::Rgba([5, 5, 5, 255]));
        img.put_pixel(0, 2, image::Rgba([0, 0, 0, 255]));
        assert_eq!(super::dead_pixels(&img), [(3, 3)]);
    }
}
