//! The perturbation search's pooled score (`perturbation_window`): a member's detections are
//! ranked together with those of the frames the controller captured before it in the
//! candidate's sequence, in one COCO evaluation, as the test ranks every frame's. A single
//! frame's AP cannot see how a detection's confidence ranks against the other frames' (a false
//! positive above another frame's true positive costs the test precision); the pooled score
//! does, and takes more values, so members tie less.

use joca_core::{Annotation, Detection};
use joca_metrics::{TaskMetrics, TaskScores};
use std::collections::VecDeque;

/// One frame as the score sees it: its reference objects, ignore regions, 180° visible count
/// and the detector's output on it.
#[derive(Debug, Clone, Copy)]
pub(super) struct Capture<'a> {
    pub(super) truth: &'a [Annotation],
    pub(super) ignore: &'a [Annotation],
    pub(super) visible_180: u32,
    pub(super) detections: &'a [Detection],
}

/// A captured frame the window keeps.
#[derive(Debug, Clone)]
struct Kept {
    truth: Vec<Annotation>,
    ignore: Vec<Annotation>,
    visible_180: u32,
    detections: Vec<Detection>,
}

/// The last W − 1 frames of a candidate's sequence, W = `perturbation_window` (none for W = 1).
#[derive(Debug, Clone)]
pub(super) struct Window {
    frames: VecDeque<Kept>,
    keep: usize,
}

impl Window {
    /// An empty window that pools `window` frames (the perturbed one and `window − 1` before it).
    pub(super) fn new(window: usize) -> Self {
        Self { frames: VecDeque::new(), keep: window.saturating_sub(1) }
    }

    /// Adds the frame the controller captured (its detections at the applied settings),
    /// forgetting the oldest beyond the window.
    pub(super) fn push(&mut self, frame: Capture<'_>) {
        if self.keep == 0 {
            return;
        }
        self.frames.push_back(Kept {
            truth: frame.truth.to_vec(),
            ignore: frame.ignore.to_vec(),
            visible_180: frame.visible_180,
            detections: frame.detections.to_vec(),
        });
        while self.frames.len() > self.keep {
            self.frames.pop_front();
        }
    }

    /// Each member's scores: its frame pooled with the window's in one evaluation.
    pub(super) fn scores<'a>(
        &self,
        members: impl Iterator<Item = Capture<'a>>,
    ) -> impl Iterator<Item = TaskScores> {
        let mut before = TaskMetrics::default();
        for f in &self.frames {
            before.update(&f.truth, &f.ignore, &f.detections, f.visible_180);
        }
        members.map(move |m| {
            let mut pooled = before.clone();
            pooled.update(m.truth, m.ignore, m.detections, m.visible_180);
            pooled.compute()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use joca_core::{BBox, Class};

    fn object(x: f32) -> Annotation {
        let bbox = BBox { x_min: x, y_min: 10.0, x_max: x + 40.0, y_max: 50.0 };
        Annotation { bbox, class: Class::Vehicle, distance_m: None }
    }

    fn found(at: &Annotation, score: f32) -> Detection {
        Detection { bbox: at.bbox, class: at.class, score }
    }

    /// Two members that find their frame's one object, at confidence 0.3 and 0.9, tie alone
    /// (AP 1 each). Pooled with a frame before them whose object was found at 0.5 below a
    /// false positive at 0.6, they differ as COCO's 101-point interpolated AP says: the 0.3
    /// member ranks last (precisions 0, 1/2, 2/3: AP 2/3), the 0.9 member first (1, 1/2, 2/3:
    /// precision 1 up to recall 1/2, then 2/3: (51 + 50 · 2/3) / 101).
    #[test]
    fn a_pooled_member_is_scored_by_where_its_confidence_ranks_among_the_frames_before() {
        let (here, there) = ([object(100.0)], [object(300.0)]);
        let (low, high) = ([found(&here[0], 0.3)], [found(&here[0], 0.9)]);
        let before = [found(&there[0], 0.5), found(&object(500.0), 0.6)];
        let capture =
            |truth, detections| Capture { truth, ignore: &[], visible_180: 1, detections };
        let members = || [capture(&here, &low), capture(&here, &high)].into_iter();
        let alone: Vec<f64> = Window::new(1).scores(members()).map(|s| s.ap50).collect();
        assert!(alone[0] == alone[1] && (alone[0] - 1.0).abs() < 1e-9, "{alone:?}");
        let mut window = Window::new(2);
        window.push(capture(&there, &before));
        let p: Vec<TaskScores> = window.scores(members()).collect();
        assert!((p[0].ap50 - 2.0 / 3.0).abs() < 1e-9, "{}", p[0].ap50);
        assert!((p[1].ap50 - (51.0 + 50.0 * 2.0 / 3.0) / 101.0).abs() < 1e-9, "{}", p[1].ap50);
        // Exact boxes match at every IoU threshold: mAP is AP50 here.
        assert!((p[1].map - p[1].ap50).abs() < 1e-9 && (p[0].map - p[0].ap50).abs() < 1e-9);
    }

    /// The window keeps W − 1 frames: a third push forgets the first.
    #[test]
    fn the_window_forgets_frames_beyond_its_length() {
        let o = object(100.0);
        let mut w = Window::new(3);
        for _ in 0..3 {
            w.push(Capture { truth: &[o], ignore: &[], visible_180: 1, detections: &[] });
        }
        assert_eq!(w.frames.len(), 2);
        let mut none = Window::new(1);
        none.push(Capture { truth: &[o], ignore: &[], visible_180: 1, detections: &[] });
        assert!(none.frames.is_empty());
    }
}
