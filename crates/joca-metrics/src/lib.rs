//! Detection metrics with the conventions of pycocotools, the reference implementation of the
//! COCO benchmark.
//!
//! - [`iou_xywh`] — intersection over union of `[x, y, w, h]` boxes, no `+1` convention; a crowd
//!   region divides by the detection's area only.
//! - [`CocoEvaluator`] — an accumulator (`add_image`, `evaluate`, `reset`) that computes the 12
//!   summary numbers of `COCOeval.summarize()` for boxes: AP@[.50:.05:.95] with 101-point
//!   interpolated precision, AP50, AP75, AP by area, and AR at 1/10/100 detections; per-category
//!   AP averaged over the categories that have ground truth.
//! - [`TaskMetrics`] — the paper's task measures over many frames: mAP@[.5:.95], AP50 and the TP
//!   ratio (true positives at IoU 0.5 over all objects visible in a 180° field), and the hardware
//!   fitness `mAP + 1.1·TP ratio`.
//!
//! ```
//! use joca_metrics::{CocoEvaluator, GroundTruth, ScoredBox};
//!
//! let mut eval = CocoEvaluator::default();
//! let truth = vec![GroundTruth::new([10.0, 10.0, 40.0, 30.0], 1)];
//! eval.add_image(1, truth, vec![ScoredBox::new([10.0, 10.0, 40.0, 30.0], 1, 0.9)]);
//! let summary = eval.evaluate();
//! assert!((summary.stats[0] - 1.0).abs() < 1e-12); // a perfect detection
//! ```
#![deny(missing_docs)]

mod coco;
mod frame;
mod task;

pub use coco::{CocoEvaluator, CocoSummary, GroundTruth, STAT_NAMES, ScoredBox, iou_xywh};
pub use frame::frame_utility;
pub use task::{BandScores, DISTANCE_BANDS_M, TaskMetrics, TaskScores, frame_utility_of};
