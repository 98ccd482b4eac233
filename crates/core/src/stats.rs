//! Small statistics shared by the measuring code and the tests: dimensionless, no I/O.

/// Pearson's correlation of two series of the same length (0 when either is flat or empty).
pub fn correlation(a: &[f32], b: &[f32]) -> f32 {
    let n = a.len().min(b.len());
    if n == 0 {
        return 0.0;
    }
    let (a, b) = (&a[..n], &b[..n]);
    let k = n as f32;
    let (ma, mb) = (a.iter().sum::<f32>() / k, b.iter().sum::<f32>() / k);
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        ab += (x - ma) * (y - mb);
        aa += (x - ma) * (x - ma);
        bb += (y - mb) * (y - mb);
    }
    ab / (aa * bb).sqrt().max(1e-12)
}

#[cfg(test)]
mod tests {
    use super::correlation;

    #[test]
    fn correlation_is_one_for_a_line_minus_one_reversed_and_zero_when_flat() {
        let a = [1.0, 2.0, 3.0, 4.0];
        assert!((correlation(&a, &[2.0, 4.0, 6.0, 8.0]) - 1.0).abs() < 1e-6);
        assert!((correlation(&a, &[4.0, 3.0, 2.0, 1.0]) + 1.0).abs() < 1e-6);
        assert_eq!(correlation(&a, &[5.0; 4]), 0.0);
        assert_eq!(correlation(&[], &[]), 0.0);
    }
}
