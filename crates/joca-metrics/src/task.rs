//! The paper's task measures over a set of frames (Sec. 6.1): mAP@[.5:.95], AP50, and the ratio
//! of true positives at IoU 0.5 to all objects visible in a 180° field around the vehicle.
//!
//! The k frames of a hardware candidate are scored together (docs/design.md): their detections and
//! ground truth form one COCO evaluation, and the TP ratio sums true positives and visible
//! objects over the frames. Per-frame AP would be undefined on frames without objects.

use crate::coco::{CocoEvaluator, GroundTruth, ScoredBox};
use joca_core::{Annotation, Class, Detection};
use serde::{Deserialize, Serialize};

/// Weight of the TP ratio in the hardware fitness (paper Sec. 6.1).
pub const TP_RATIO_WEIGHT: f64 = 1.1;

/// Distance bands of [`TaskMetrics::bands`], metres from the camera, `[from, to)`.
pub const DISTANCE_BANDS_M: [(f64, f64); 4] =
    [(0.0, 20.0), (20.0, 40.0), (40.0, 70.0), (70.0, 100.0)];

/// Accumulates frames and scores them together.
#[derive(Debug, Clone, Default)]
pub struct TaskMetrics {
    coco: CocoEvaluator,
    visible_180: u64,
    frames: u64,
    class_objects: [u64; 3],
    /// Class index and distance of every reference object added.
    objects: Vec<(usize, Option<f32>)>,
}

/// Scores of the reference objects in one distance band.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BandScores {
    /// Nearest distance of the band, metres (inclusive).
    pub from_m: f64,
    /// Farthest distance of the band, metres (exclusive).
    pub to_m: f64,
    /// Reference objects in the band per class (`Class::ALL` order).
    pub class_objects: [u64; 3],
    /// mAP@[.5:.95] over the band's objects (objects of other bands ignored; false positives,
    /// having no distance, count in every band); `None` without objects.
    pub map: Option<f64>,
    /// AP at IoU 0.5, as `map`.
    pub ap50: Option<f64>,
    /// Share of the band's objects found at IoU 0.5 (any score, the 100 best detections of a
    /// frame); `None` without objects.
    pub recall50: Option<f64>,
}

/// Scores of a set of frames.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TaskScores {
    /// COCO mAP@[.5:.95]; 0 when no frame had ground truth.
    pub map: f64,
    /// COCO AP at IoU 0.5; 0 when no frame had ground truth.
    pub ap50: f64,
    /// True positives at IoU 0.5 over objects visible in the 180° field.
    pub tp_ratio: f64,
    /// True positives at IoU 0.5.
    pub true_positives: u64,
    /// Objects visible in the 180° field, summed over frames.
    pub visible_180: u64,
    /// Frames scored.
    pub frames: u64,
    /// AP@[.50:.95] per class in `Class::ALL` order (vehicle, walker, traffic sign); `None`
    /// for a class without ground truth in these frames.
    #[serde(default)]
    pub class_map: [Option<f64>; 3],
    /// AP at IoU 0.5 per class, as `class_map`.
    #[serde(default)]
    pub class_ap50: [Option<f64>; 3],
    /// Annotated objects (not ignore regions) per class, summed over frames: how many boxes
    /// each entry of `class_map` rests on.
    #[serde(default)]
    pub class_objects: [u64; 3],
}

impl TaskScores {
    /// The hardware GA's fitness: `mAP + 1.1 · TP ratio`.
    pub fn fitness(&self) -> f64 {
        self.map + TP_RATIO_WEIGHT * self.tp_ratio
    }

    /// AP@[.50:.95] of one class (`None` without ground truth of it).
    pub fn class_ap(&self, class: Class) -> Option<f64> {
        self.class_map[class.index()]
    }
}

impl TaskMetrics {
    /// Adds one frame: its ground truth, its ignore regions (scored as COCO crowd regions: a
    /// detection mostly inside one is neither a true nor a false positive), the detector's output
    /// and the 180° visible count.
    pub fn update(
        &mut self,
        truth: &[Annotation],
        ignore: &[Annotation],
        detections: &[Detection],
        visible_180: u32,
    ) {
        let (gts, dts) = coco_frame(truth, ignore, detections);
        for a in truth {
            self.class_objects[a.class.index()] += 1;
            self.objects.push((a.class.index(), a.distance_m));
        }
        self.coco.add_image(self.frames, gts, dts);
        self.visible_180 += u64::from(visible_180);
        self.frames += 1;
    }

    /// Scores every frame added since the last reset.
    pub fn compute(&self) -> TaskScores {
        let summary = self.coco.evaluate();
        let defined = |v: f64| if v < 0.0 { 0.0 } else { v };
        let tp = summary.true_positives_50 as u64;
        let class_map = Class::ALL.map(|c| summary.per_category_ap.get(&c.coco_id()).copied());
        let class_ap50 = Class::ALL.map(|c| summary.per_category_ap50.get(&c.coco_id()).copied());
        TaskScores {
            map: defined(summary.stats[0]),
            ap50: defined(summary.stats[1]),
            tp_ratio: if self.visible_180 == 0 { 0.0 } else { tp as f64 / self.visible_180 as f64 },
            true_positives: tp,
            visible_180: self.visible_180,
            frames: self.frames,
            class_map,
            class_ap50,
            class_objects: self.class_objects,
        }
    }

    /// Scores per distance band ([`DISTANCE_BANDS_M`]) of the objects whose distance the
    /// source knows (none for recorded frames without depth).
    pub fn bands(&self) -> Vec<BandScores> {
        DISTANCE_BANDS_M
            .iter()
            .map(|&(from_m, to_m)| {
                let inside = |d: f64| d >= from_m && d < to_m;
                let mut class_objects = [0u64; 3];
                for &(c, d) in &self.objects {
                    if d.is_some_and(|d| inside(f64::from(d))) {
                        class_objects[c] += 1;
                    }
                }
                let s = self.coco.evaluate_where(|g| g.distance_m.is_some_and(inside));
                let defined = |v: f64| (v >= 0.0).then_some(v);
                BandScores {
                    from_m,
                    to_m,
                    class_objects,
                    map: defined(s.stats[0]),
                    ap50: defined(s.stats[1]),
                    recall50: (s.ground_truths > 0)
                        .then(|| s.true_positives_50 as f64 / s.ground_truths as f64),
                }
            })
            .collect()
    }

    /// Forgets every frame.
    pub fn reset(&mut self) {
        *self = Self::default();
    }
}

/// One frame's ground truth (its ignore regions as COCO crowd regions) and detections as the
/// COCO evaluation reads them.
fn coco_frame(
    truth: &[Annotation],
    ignore: &[Annotation],
    detections: &[Detection],
) -> (Vec<GroundTruth>, Vec<ScoredBox>) {
    let gts = truth
        .iter()
        .map(|a| {
            GroundTruth::new(a.bbox.to_xywh().map(f64::from), a.class.coco_id())
                .at_distance(a.distance_m.map(f64::from))
        })
        .chain(
            ignore
                .iter()
                .map(|a| GroundTruth::crowd(a.bbox.to_xywh().map(f64::from), a.class.coco_id())),
        )
        .collect();
    let dts = detections
        .iter()
        .map(|d| {
            ScoredBox::new(d.bbox.to_xywh().map(f64::from), d.class.coco_id(), f64::from(d.score))
        })
        .collect();
    (gts, dts)
}

/// [`crate::frame_utility`] of one frame given as the task measures take it.
pub fn frame_utility_of(
    truth: &[Annotation],
    ignore: &[Annotation],
    detections: &[Detection],
) -> f64 {
    let (gts, dts) = coco_frame(truth, ignore, detections);
    crate::frame_utility(&gts, &dts)
}

#[cfg(test)]
mod tests {
    use super::*;
    use joca_core::{BBox, Class};

    #[test]
    fn perfect_detection_of_half_the_visible_objects() {
        let mut m = TaskMetrics::default();
        let gt = [Annotation::new(BBox::new(10.0, 10.0, 50.0, 40.0), Class::Vehicle)];
        let dt = [Detection {
            bbox: BBox::new(10.0, 10.0, 50.0, 40.0),
            class: Class::Vehicle,
            score: 0.9,
        }];
        m.update(&gt, &[], &dt, 2);
        m.update(&[], &[], &[], 0);
        let s = m.compute();
        assert_eq!((s.true_positives, s.visible_180, s.frames), (1, 2, 2));
        assert!((s.map - 1.0).abs() < 1e-12 && (s.tp_ratio - 0.5).abs() < 1e-12);
        assert!((s.class_map[0].unwrap() - 1.0).abs() < 1e-12);
        assert_eq!(s.class_map[1..], [None, None]);
        assert!((s.class_ap50[0].unwrap() - 1.0).abs() < 1e-12);
        assert_eq!(s.class_ap50[1..], [None, None]);
        assert_eq!(s.class_objects, [1, 0, 0]);
        assert!((s.fitness() - 1.55).abs() < 1e-12);
        m.reset();
        assert_eq!(m.compute().frames, 0);
        assert_eq!(m.compute().map, 0.0);
    }

    #[test]
    fn a_distance_band_scores_its_own_objects_and_every_false_alarm() {
        let near = Annotation::at_distance(BBox::new(0.0, 0.0, 40.0, 40.0), Class::Vehicle, 12.0);
        let far = Annotation::at_distance(BBox::new(100.0, 0.0, 104.0, 4.0), Class::Vehicle, 80.0);
        let det = |b: BBox, score: f32| Detection { bbox: b, class: Class::Vehicle, score };
        // The near car found; the far one missed; a false alarm scored between them.
        let dt = [det(near.bbox, 0.9), det(BBox::new(200.0, 0.0, 220.0, 20.0), 0.8)];
        let mut m = TaskMetrics::default();
        m.update(&[near, far], &[], &dt, 2);
        let bands = m.bands();
        assert_eq!(bands.len(), DISTANCE_BANDS_M.len());
        // 0–20 m: one object, found first: AP 1 and recall 1, the false alarm ranked after it.
        assert_eq!(bands[0].class_objects, [1, 0, 0]);
        assert!((bands[0].ap50.unwrap() - 1.0).abs() < 1e-12 && bands[0].recall50 == Some(1.0));
        // 20–40 and 40–70 m: no objects, nothing defined.
        assert!(bands[1].ap50.is_none() && bands[2].recall50.is_none());
        // 70–100 m: the missed car: recall 0, AP 0 (the near detection is ignored there, the
        // false alarm is not).
        assert_eq!(bands[3].class_objects, [1, 0, 0]);
        assert_eq!((bands[3].ap50, bands[3].recall50), (Some(0.0), Some(0.0)));
        // Over all objects: recall 1/2, and AP50 = precision 1 up to recall 0.5 (51 of the 101
        // recall points).
        let s = m.compute();
        assert!((s.ap50 - 51.0 / 101.0).abs() < 1e-12, "{s:?}");
    }

    #[test]
    fn a_box_at_iou_below_half_is_no_true_positive() {
        let mut m = TaskMetrics::default();
        let gt = [Annotation::new(BBox::new(0.0, 0.0, 10.0, 10.0), Class::Walker)];
        // IoU = 50 / 150 = 1/3.
        let dt =
            [Detection { bbox: BBox::new(5.0, 0.0, 15.0, 10.0), class: Class::Walker, score: 0.9 }];
        m.update(&gt, &[], &dt, 1);
        assert_eq!(m.compute().true_positives, 0);
        // The right box of the wrong class is no true positive either.
        let mut m = TaskMetrics::default();
        let dt = [Detection {
            bbox: BBox::new(0.0, 0.0, 10.0, 10.0),
            class: Class::Vehicle,
            score: 0.9,
        }];
        m.update(&gt, &[], &dt, 1);
        assert_eq!(m.compute().true_positives, 0);
    }

    #[test]
    fn a_detection_on_an_ignore_region_is_neither_true_nor_false() {
        let gt = [Annotation::new(BBox::new(10.0, 10.0, 50.0, 40.0), Class::Vehicle)];
        let far = Annotation::new(BBox::new(100.0, 20.0, 106.0, 25.0), Class::Vehicle);
        let dt = [
            Detection {
                bbox: BBox::new(101.0, 21.0, 105.0, 25.0),
                class: Class::Vehicle,
                score: 0.9,
            },
            Detection { bbox: gt[0].bbox, class: Class::Vehicle, score: 0.5 },
        ];
        // The first lies inside the region, so its crowd IoU (intersection over the detection's
        // area) is 1.
        // Without the region the confident detection is a false positive ranked first: precision
        // 1/2 at full recall, AP 0.5 at every threshold.
        let mut plain = TaskMetrics::default();
        plain.update(&gt, &[], &dt, 1);
        let s = plain.compute();
        assert!((s.map - 0.5).abs() < 1e-12, "{s:?}");
        let mut m = TaskMetrics::default();
        m.update(&gt, &[far], &dt, 1);
        let s = m.compute();
        assert!((s.map - 1.0).abs() < 1e-12 && s.true_positives == 1, "{s:?}");
        // A region of another class ignores nothing.
        let mut m = TaskMetrics::default();
        m.update(&gt, &[Annotation { class: Class::Walker, ..far }], &dt, 1);
        assert!((m.compute().map - 0.5).abs() < 1e-12);
    }
}
