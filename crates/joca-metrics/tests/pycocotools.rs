//! Agreement with pycocotools on fixtures it produced (see fixtures/make_fixtures.py).
#![allow(clippy::unwrap_used)]

use joca_metrics::{CocoEvaluator, GroundTruth, STAT_NAMES, ScoredBox, iou_xywh};
use serde_json::Value;

/// Per category: AP@[.5:.95] and AP50 as pycocotools' precision array gives them.
type PerCategory = Vec<(u32, [f64; 2])>;

fn load(name: &str) -> (CocoEvaluator, Vec<f64>, PerCategory) {
    let path = format!("{}/tests/fixtures/{name}.json", env!("CARGO_MANIFEST_DIR"));
    let v: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let mut eval = CocoEvaluator::default();
    let bbox = |b: &Value| -> [f64; 4] { std::array::from_fn(|i| b[i].as_f64().unwrap()) };
    for img in v["gt"]["images"].as_array().unwrap() {
        eval.add_image(img["id"].as_u64().unwrap(), vec![], vec![]);
    }
    for a in v["gt"]["annotations"].as_array().unwrap() {
        let g = GroundTruth {
            bbox: bbox(&a["bbox"]),
            category: a["category_id"].as_u64().unwrap() as u32,
            area: a["area"].as_f64().unwrap(),
            crowd: a["iscrowd"].as_u64().unwrap() == 1,
            distance_m: None,
        };
        eval.add_image(a["image_id"].as_u64().unwrap(), vec![g], vec![]);
    }
    for d in v["dt"].as_array().unwrap() {
        let s = ScoredBox::new(
            bbox(&d["bbox"]),
            d["category_id"].as_u64().unwrap() as u32,
            d["score"].as_f64().unwrap(),
        );
        eval.add_image(d["image_id"].as_u64().unwrap(), vec![], vec![s]);
    }
    let stats = v["stats"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    let per_category = v["per_category"]
        .as_object()
        .unwrap()
        .iter()
        .map(|(c, x)| (c.parse().unwrap(), [0, 1].map(|i| x[i].as_f64().unwrap())))
        .collect();
    (eval, stats, per_category)
}

fn agree(name: &str) {
    let (eval, want, want_per_category) = load(name);
    let summary = eval.evaluate();
    for (i, (g, w)) in summary.stats.iter().zip(&want).enumerate() {
        assert!((g - w).abs() < 1e-6, "{name}: {} = {g}, pycocotools {w}", STAT_NAMES[i]);
    }
    // The same categories (those with ground truth), each with pycocotools' AP and AP50.
    let got: Vec<u32> = summary.per_category_ap.keys().copied().collect();
    assert_eq!(got, want_per_category.iter().map(|(c, _)| *c).collect::<Vec<_>>(), "{name}");
    assert_eq!(summary.per_category_ap50.len(), got.len(), "{name}");
    for (c, [ap, ap50]) in want_per_category {
        let (g, g50) = (summary.per_category_ap[&c], summary.per_category_ap50[&c]);
        assert!((g - ap).abs() < 1e-6, "{name}: category {c} AP {g}, pycocotools {ap}");
        assert!((g50 - ap50).abs() < 1e-6, "{name}: category {c} AP50 {g50}, pycocotools {ap50}");
    }
}

#[test]
fn classes_without_ground_truth_or_detections() {
    agree("classes_missing");
}

#[test]
fn duplicate_detections_and_tied_scores() {
    agree("duplicates_ties");
}

#[test]
fn boxes_touching_the_image_border() {
    agree("borders");
}

#[test]
fn crowd_regions() {
    agree("crowd");
}

#[test]
fn images_without_ground_truth_or_detections() {
    agree("empty_images");
}

#[test]
fn more_than_100_detections_per_image() {
    agree("max_dets");
}

#[test]
fn randomised_scenes() {
    agree("random_a");
    agree("random_b");
    agree("random_many");
}

#[test]
fn iou_is_symmetric_bounded_and_has_no_plus_one() {
    let a = [0.0, 0.0, 10.0, 10.0];
    let b = [5.0, 5.0, 10.0, 10.0];
    assert!((iou_xywh(&a, &b, false) - 25.0 / 175.0).abs() < 1e-15);
    assert_eq!(iou_xywh(&a, &b, false), iou_xywh(&b, &a, false));
    assert_eq!(iou_xywh(&a, &a, false), 1.0);
    assert_eq!(iou_xywh(&a, &[10.0, 0.0, 5.0, 5.0], false), 0.0);
    // Crowd: intersection over the detection's area.
    assert!((iou_xywh(&[2.0, 2.0, 4.0, 4.0], &a, true) - 1.0).abs() < 1e-15);
    for k in 0..200 {
        let f = k as f64;
        let d = [f * 0.37 % 50.0, f * 0.73 % 40.0, 1.0 + f % 30.0, 1.0 + f * 1.3 % 20.0];
        let v = iou_xywh(&d, &b, false);
        assert!((0.0..=1.0).contains(&v));
        assert!((v - iou_xywh(&b, &d, false)).abs() < 1e-15);
    }
}
