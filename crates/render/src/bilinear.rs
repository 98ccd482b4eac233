//! Bilinear sampling of an image on the CPU (the styles, and the SSS blur's CPU reference):
//! pixel centres at whole numbers, the caller's `at` clamps or wraps at the edges.

/// The `N` channels at (`x`, `y`) pixels, between the four pixels `at` gives around it.
pub(crate) fn bilinear<const N: usize>(
    at: impl Fn(i64, i64) -> [f32; N],
    x: f32,
    y: f32,
) -> [f32; N] {
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (xi, yi) = (x0 as i64, y0 as i64);
    let (a, b, c, d) = (
        at(xi, yi),
        at(xi + 1, yi),
        at(xi, yi + 1),
        at(xi + 1, yi + 1),
    );
    std::array::from_fn(|k| {
        (a[k] * (1.0 - fx) + b[k] * fx) * (1.0 - fy) + (c[k] * (1.0 - fx) + d[k] * fx) * fy
    })
}

#[cfg(test)]
mod tests {
    use super::bilinear;

    #[test]
    fn bilinear_weighs_the_four_pixels_by_their_nearness() {
        let at = |x: i64, y: i64| [(x + 10 * y) as f32];
        assert_eq!(bilinear(at, 0.0, 0.0), [0.0]);
        assert_eq!(bilinear(at, 0.5, 0.0), [0.5]);
        assert_eq!(bilinear(at, 0.25, 0.5), [5.25]);
    }
}
