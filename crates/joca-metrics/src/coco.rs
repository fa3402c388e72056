//! COCO box evaluation, following pycocotools' `COCOeval` (evaluateImg, accumulate, summarize)
//! step by step, so that results agree with it to floating-point precision:
//!
//! - per image and category, detections are sorted by score with a stable sort (numpy's
//!   mergesort) and cut to the 100 best; ground truth that is crowd or outside the area range is
//!   "ignored" and sorted after the rest;
//! - greedy matching per IoU threshold: each detection, best score first, takes the unmatched
//!   ground truth of highest IoU ≥ threshold, preferring non-ignored ground truth; a crowd region
//!   may absorb many detections; a detection matched to ignored ground truth, or unmatched and
//!   outside the area range, is ignored;
//! - per category, area range and detection limit, detections of all images are merged by score
//!   (stable), precision is made monotone from the right and sampled at 101 recall points
//!   (`searchsorted`, side "left"); categories without non-ignored ground truth are left out.

use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};

pub(crate) mod image;
use image::{ImageEval, accumulate, counts_at_50, evaluate_image};

/// Names of the 12 summary numbers, in pycocotools' order.
pub const STAT_NAMES: [&str; 12] = [
    "AP @[ IoU=0.50:0.95 | area=   all | maxDets=100 ]",
    "AP @[ IoU=0.50      | area=   all | maxDets=100 ]",
    "AP @[ IoU=0.75      | area=   all | maxDets=100 ]",
    "AP @[ IoU=0.50:0.95 | area= small | maxDets=100 ]",
    "AP @[ IoU=0.50:0.95 | area=medium | maxDets=100 ]",
    "AP @[ IoU=0.50:0.95 | area= large | maxDets=100 ]",
    "AR @[ IoU=0.50:0.95 | area=   all | maxDets=  1 ]",
    "AR @[ IoU=0.50:0.95 | area=   all | maxDets= 10 ]",
    "AR @[ IoU=0.50:0.95 | area=   all | maxDets=100 ]",
    "AR @[ IoU=0.50:0.95 | area= small | maxDets=100 ]",
    "AR @[ IoU=0.50:0.95 | area=medium | maxDets=100 ]",
    "AR @[ IoU=0.50:0.95 | area= large | maxDets=100 ]",
];

const MAX_DETS: [usize; 3] = [1, 10, 100];
/// Area ranges all, small, medium, large (square pixels), inclusive at both ends as in
/// pycocotools.
const AREA_RANGES: [(f64, f64); 4] =
    [(0.0, 1e10), (0.0, 32.0 * 32.0), (32.0 * 32.0, 96.0 * 96.0), (96.0 * 96.0, 1e10)];
const RECALL_POINTS: usize = 101;

/// IoU thresholds 0.50:0.05:0.95 computed as `numpy.linspace(.5, .95, 10)` does, so that
/// comparisons at exactly a threshold break the same way.
pub(crate) fn iou_thresholds() -> [f64; 10] {
    let step = (0.95 - 0.5) / 9.0;
    let mut t: [f64; 10] = std::array::from_fn(|i| i as f64 * step + 0.5);
    t[9] = 0.95;
    t
}

/// Recall sample points 0:0.01:1 as `numpy.linspace(0, 1, 101)`.
fn recall_thresholds() -> [f64; RECALL_POINTS] {
    let mut r: [f64; RECALL_POINTS] = std::array::from_fn(|i| i as f64 * 0.01);
    r[RECALL_POINTS - 1] = 1.0;
    r
}

/// Intersection over union of two `[x, y, w, h]` boxes (pycocotools' `bbIou`): no `+1`; when
/// `crowd` the union is the detection's area alone.
pub fn iou_xywh(dt: &[f64; 4], gt: &[f64; 4], crowd: bool) -> f64 {
    let w = (dt[0] + dt[2]).min(gt[0] + gt[2]) - dt[0].max(gt[0]);
    if w <= 0.0 {
        return 0.0;
    }
    let h = (dt[1] + dt[3]).min(gt[1] + gt[3]) - dt[1].max(gt[1]);
    if h <= 0.0 {
        return 0.0;
    }
    let inter = w * h;
    let union = if crowd { dt[2] * dt[3] } else { dt[2] * dt[3] + gt[2] * gt[3] - inter };
    inter / union
}

/// A ground-truth object.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GroundTruth {
    /// `[x, y, w, h]`, pixels.
    pub bbox: [f64; 4],
    /// COCO category id.
    pub category: u32,
    /// Area used for the area ranges (COCO's `area` field; `w·h` for boxes).
    pub area: f64,
    /// A crowd region (`iscrowd = 1`).
    pub crowd: bool,
    /// Distance from the camera, metres, where known: [`CocoEvaluator::evaluate_where`] can
    /// score a distance band.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distance_m: Option<f64>,
}

impl GroundTruth {
    /// A non-crowd object with area `w·h`.
    pub fn new(bbox: [f64; 4], category: u32) -> Self {
        Self { bbox, category, area: bbox[2] * bbox[3], crowd: false, distance_m: None }
    }

    /// The object, `distance_m` metres from the camera.
    pub fn at_distance(self, distance_m: Option<f64>) -> Self {
        Self { distance_m, ..self }
    }

    /// A crowd (ignore) region with area `w·h`.
    pub fn crowd(bbox: [f64; 4], category: u32) -> Self {
        Self { crowd: true, ..Self::new(bbox, category) }
    }
}

/// A detection.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ScoredBox {
    /// `[x, y, w, h]`, pixels.
    pub bbox: [f64; 4],
    /// COCO category id.
    pub category: u32,
    /// Confidence.
    pub score: f64,
}

impl ScoredBox {
    /// A detection.
    pub fn new(bbox: [f64; 4], category: u32, score: f64) -> Self {
        Self { bbox, category, score }
    }
}

/// The result of an evaluation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CocoSummary {
    /// The 12 numbers of `COCOeval.summarize()` ([`STAT_NAMES`]); −1 where undefined.
    pub stats: [f64; 12],
    /// AP@[.50:.95] per category that has ground truth.
    pub per_category_ap: BTreeMap<u32, f64>,
    /// AP at IoU 0.5 per category that has ground truth.
    pub per_category_ap50: BTreeMap<u32, f64>,
    /// Detections matched at IoU 0.5 (area all, 100 detections per image), not ignored.
    pub true_positives_50: usize,
    /// Non-ignored ground-truth objects.
    pub ground_truths: usize,
}

/// Accumulates images of ground truth and detections, then evaluates them together.
#[derive(Debug, Clone, Default)]
pub struct CocoEvaluator {
    images: BTreeMap<u64, (Vec<GroundTruth>, Vec<ScoredBox>)>,
}

impl CocoEvaluator {
    /// Adds an image (or more objects to an image already added). Images without ground truth
    /// count: their detections are false positives.
    pub fn add_image(&mut self, image_id: u64, gts: Vec<GroundTruth>, dts: Vec<ScoredBox>) {
        let entry = self.images.entry(image_id).or_default();
        entry.0.extend(gts);
        entry.1.extend(dts);
    }

    /// Forgets every image.
    pub fn reset(&mut self) {
        self.images.clear();
    }

    /// Number of images added.
    pub fn len(&self) -> usize {
        self.images.len()
    }

    /// Whether no image was added.
    pub fn is_empty(&self) -> bool {
        self.images.is_empty()
    }

    /// Evaluates everything added so far.
    pub fn evaluate(&self) -> CocoSummary {
        self.evaluate_where(|_| true)
    }

    /// Evaluates everything added so far on the ground truth that `keep` accepts (e.g. one
    /// distance band). The rest is ignored as COCO ignores objects outside an area range: a
    /// detection matched to it is neither a true nor a false positive. Unlike an area range,
    /// an unmatched detection has no distance, so it stays a false positive in every subset.
    pub fn evaluate_where(&self, keep: impl Fn(&GroundTruth) -> bool) -> CocoSummary {
        let thresholds = iou_thresholds();
        let categories: BTreeSet<u32> =
            self.images.values().flat_map(|(g, _)| g.iter().map(|g| g.category)).collect();
        // precision[t][r][k][a][m], recall[t][k][a][m], with −1 meaning "no ground truth".
        let (nt, nk, na, nm) =
            (thresholds.len(), categories.len(), AREA_RANGES.len(), MAX_DETS.len());
        let mut precision = vec![-1.0f64; nt * RECALL_POINTS * nk * na * nm];
        let mut recall = vec![-1.0f64; nt * nk * na * nm];
        let p_index = |t: usize, r: usize, k: usize, a: usize, m: usize| {
            (((t * RECALL_POINTS + r) * nk + k) * na + a) * nm + m
        };
        let r_index = |t: usize, k: usize, a: usize, m: usize| ((t * nk + k) * na + a) * nm + m;
        let recall_points = recall_thresholds();
        let mut true_positives_50 = 0;
        let mut ground_truths = 0;
        for (k, &category) in categories.iter().enumerate() {
            for (a, &range) in AREA_RANGES.iter().enumerate() {
                let evals: Vec<ImageEval> = self
                    .images
                    .values()
                    .filter_map(|(g, d)| {
                        let g: Vec<&GroundTruth> =
                            g.iter().filter(|x| x.category == category).collect();
                        let d: Vec<&ScoredBox> =
                            d.iter().filter(|x| x.category == category).collect();
                        evaluate_image(&g, &d, range, &thresholds, &keep)
                    })
                    .collect();
                if a == 0 {
                    let (g, tp) = counts_at_50(&evals);
                    ground_truths += g;
                    true_positives_50 += tp;
                }
                let npig = evals.iter().flat_map(|e| &e.gt_ignored).filter(|&&i| !i).count();
                if npig == 0 {
                    continue;
                }
                for (m, &max_det) in MAX_DETS.iter().enumerate() {
                    // Merge the images' detections by score (stable, images in id order).
                    let mut merged: Vec<(f64, usize, usize)> = Vec::new();
                    for (e_index, e) in evals.iter().enumerate() {
                        for (d, &s) in e.scores.iter().take(max_det).enumerate() {
                            merged.push((s, e_index, d));
                        }
                    }
                    merged.sort_by(|x, y| y.0.total_cmp(&x.0));
                    for t in 0..nt {
                        let (rec, prec) = accumulate(&evals, &merged, t, npig, &recall_points);
                        recall[r_index(t, k, a, m)] = rec;
                        for (r, p) in prec.into_iter().enumerate() {
                            precision[p_index(t, r, k, a, m)] = p;
                        }
                    }
                }
            }
        }
        let mean_of = |values: Vec<f64>| {
            let kept: Vec<f64> = values.into_iter().filter(|&v| v > -1.0).collect();
            if kept.is_empty() { -1.0 } else { kept.iter().sum::<f64>() / kept.len() as f64 }
        };
        let ap = |t_sel: Option<usize>, a: usize, m: usize| {
            let mut v = Vec::new();
            for t in 0..nt {
                if t_sel.is_some_and(|s| s != t) {
                    continue;
                }
                for r in 0..RECALL_POINTS {
                    for k in 0..nk {
                        v.push(precision[p_index(t, r, k, a, m)]);
                    }
                }
            }
            mean_of(v)
        };
        let ar = |a: usize, m: usize| {
            let mut v = Vec::new();
            for t in 0..nt {
                for k in 0..nk {
                    v.push(recall[r_index(t, k, a, m)]);
                }
            }
            mean_of(v)
        };
        let stats = [
            ap(None, 0, 2),
            ap(Some(0), 0, 2),
            ap(Some(5), 0, 2),
            ap(None, 1, 2),
            ap(None, 2, 2),
            ap(None, 3, 2),
            ar(0, 0),
            ar(0, 1),
            ar(0, 2),
            ar(1, 2),
            ar(2, 2),
            ar(3, 2),
        ];
        // Area "all", maxDets 100, over the IoU thresholds `ts`, as summarize() averages.
        let per_category = |ts: std::ops::Range<usize>| -> BTreeMap<u32, f64> {
            categories
                .iter()
                .enumerate()
                .filter_map(|(k, &c)| {
                    let mut v = Vec::new();
                    for t in ts.clone() {
                        for r in 0..RECALL_POINTS {
                            v.push(precision[p_index(t, r, k, 0, 2)]);
                        }
                    }
                    let m = mean_of(v);
                    (m > -1.0).then_some((c, m))
                })
                .collect()
        };
        let per_category_ap = per_category(0..nt);
        let per_category_ap50 = per_category(0..1);
        CocoSummary { stats, per_category_ap, per_category_ap50, true_positives_50, ground_truths }
    }
}
