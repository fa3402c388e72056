//! A single frame's score, for choosing among captures of one instant in hindsight (the
//! per-frame oracle of `joca headroom`). COCO's mAP is a property of a set of frames and is not
//! a sum over frames, so no per-frame number can be maximised frame by frame to maximise it
//! exactly; this one rewards what raises mAP and punishes what lowers it.
//!
//! The utility of a frame is, averaged over the ten IoU thresholds 0.50:0.95, the summed
//! confidence of its true positives minus the summed confidence of its false positives, with
//! pycocotools' matching (each category alone, best score first, crowd regions absorbing
//! detections that are then neither). A confident hit raises it, a confident false alarm lowers
//! it, a hit that holds at strict thresholds counts more than one that holds at 0.5 only.

use crate::coco::{GroundTruth, ScoredBox, image::evaluate_image, iou_thresholds};
use std::collections::BTreeSet;

/// The utility of one frame's detections `dts` against its ground truth `gts` (crowd regions
/// included), in confidence units: see the module documentation.
pub fn frame_utility(gts: &[GroundTruth], dts: &[ScoredBox]) -> f64 {
    let thresholds = iou_thresholds();
    let categories: BTreeSet<u32> =
        gts.iter().map(|g| g.category).chain(dts.iter().map(|d| d.category)).collect();
    let mut total = 0.0;
    for category in categories {
        let g: Vec<&GroundTruth> = gts.iter().filter(|g| g.category == category).collect();
        let d: Vec<&ScoredBox> = dts.iter().filter(|d| d.category == category).collect();
        let Some(e) = evaluate_image(&g, &d, (0.0, 1e10), &thresholds, &|_| true) else {
            continue;
        };
        for (matched, ignored) in e.matched.iter().zip(&e.ignored) {
            for ((&m, &i), &score) in matched.iter().zip(ignored).zip(&e.scores) {
                if !i {
                    total += if m { score } else { -score };
                }
            }
        }
    }
    total / thresholds.len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gt(x: f64) -> GroundTruth {
        GroundTruth::new([x, 10.0, 20.0, 20.0], 1)
    }

    #[test]
    fn an_exact_hit_scores_its_confidence_a_false_alarm_minus_its_confidence() {
        let hit = ScoredBox::new([0.0, 10.0, 20.0, 20.0], 1, 0.8);
        assert!((frame_utility(&[gt(0.0)], &[hit]) - 0.8).abs() < 1e-12);
        let miss = ScoredBox::new([100.0, 10.0, 20.0, 20.0], 1, 0.3);
        assert!((frame_utility(&[gt(0.0)], &[miss]) + 0.3).abs() < 1e-12);
        // A detection of another category is a false alarm of its own category.
        let wrong_class = ScoredBox::new([0.0, 10.0, 20.0, 20.0], 2, 0.5);
        assert!((frame_utility(&[gt(0.0)], &[wrong_class]) + 0.5).abs() < 1e-12);
        assert_eq!(frame_utility(&[gt(0.0)], &[]), 0.0);
    }

    #[test]
    fn a_box_shifted_to_iou_two_thirds_holds_at_four_of_ten_thresholds() {
        // Shifted by 4 px of 20: intersection 16·20, union 24·20, IoU 2/3: a hit at
        // 0.50, 0.55, 0.60, 0.65 and a false alarm at the six thresholds above.
        let d = ScoredBox::new([4.0, 10.0, 20.0, 20.0], 1, 1.0);
        assert!((frame_utility(&[gt(0.0)], &[d]) - (4.0 - 6.0) / 10.0).abs() < 1e-12);
    }

    #[test]
    fn a_detection_inside_a_crowd_region_counts_neither_way() {
        let crowd = GroundTruth::crowd([0.0, 0.0, 100.0, 100.0], 1);
        let d = ScoredBox::new([10.0, 10.0, 20.0, 20.0], 1, 0.9);
        assert_eq!(frame_utility(&[crowd], &[d]), 0.0);
    }
}
