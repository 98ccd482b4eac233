//! Three-vectors as `[f32; 3]`, the mesh's own type: the few operations the meshes, the
//! relief's exports, the grey raster and the renderer's ground share. Unitless.

/// `a - b`.
pub fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `a + b`.
pub fn add(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// `a` times `s`.
pub fn scaled(a: [f32; 3], s: f32) -> [f32; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// The dot product.
pub fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The cross product (right-handed).
pub fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// The Euclidean length.
pub fn length(a: [f32; 3]) -> f32 {
    dot(a, a).sqrt()
}

/// `n` scaled to length 1 (zero where it has no length or is not finite).
pub fn unit(n: [f32; 3]) -> [f32; 3] {
    let l = length(n);
    if l > 1e-12 && l.is_finite() {
        [n[0] / l, n[1] / l, n[2] / l]
    } else {
        [0.0, 0.0, 0.0]
    }
}

/// The normal of triangle `a`, `b`, `c` (counter-clockwise seen from its front), as long as
/// twice the triangle's area: summed over a vertex's triangles it weights each by its area.
pub fn triangle_normal(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> [f32; 3] {
    cross(sub(b, a), sub(c, a))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_counter_clockwise_triangle_faces_up_as_long_as_twice_its_area() {
        let n = triangle_normal([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 3.0, 0.0]);
        assert_eq!(n, [0.0, 0.0, 6.0]);
        assert_eq!(unit(n), [0.0, 0.0, 1.0]);
        assert_eq!(unit([f32::NAN, 0.0, 0.0]), [0.0; 3]);
        assert_eq!(
            dot(cross([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]), [0.0, 0.0, 1.0]),
            1.0
        );
        assert_eq!(
            add(sub([1.0, 2.0, 3.0], [1.0, 1.0, 1.0]), scaled([1.0; 3], 2.0)),
            [2.0, 3.0, 4.0]
        );
        assert_eq!(length([3.0, 4.0, 0.0]), 5.0);
    }
}
