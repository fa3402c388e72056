//! The ladder's rungs chosen frame by frame, in the frames' order, as a perturbation search
//! scored by mAP would choose them if its members were the rungs (`perturbation_score = "map"`):
//! each frame's rung of the highest mAP of that frame pooled with the W − 1 frames chosen before
//! it (`perturbation_window` = W; 1: the frame alone), ties to fewer clipped pixels. Each choice
//! sees its own frame's captures at every rung (hindsight of one frame, as the search has), none
//! of the frames after it.

use super::Outcome;
use crate::run::perturbation::TIE_BREAK_WEIGHT;
use crate::run::pooled::{Capture, Window};

/// The windows the headroom scores: the frame alone, and the 16 frames the training experiment
/// pools (experiments/pooled-score-quick.toml).
pub(super) const WINDOWS: [usize; 2] = [1, 16];

/// The name and label of the choice with window `w`.
pub(super) fn row(w: usize) -> (String, String) {
    if w == 1 {
        let label = "each frame's rung of the highest mAP of the frame alone, frame by frame (what \
                     a search scored by one frame's mAP picks over the ladder)";
        ("map-search".into(), label.into())
    } else {
        let label = format!(
            "each frame's rung of the highest mAP of the frame pooled with the {} frames chosen \
             before it, frame by frame (what a search scored by mAP pooled over {w} frames picks \
             over the ladder)",
            w - 1
        );
        (format!("map-search-{w}"), label)
    }
}

/// Each frame from the rung of the highest mAP pooled with the `window − 1` frames chosen before
/// it (`window` at least 1; the perturbation search's [`Window`]), the first of equal fitness.
pub(super) fn by_window<'a>(rungs: &[&'a [Outcome]], window: usize) -> Vec<&'a Outcome> {
    let frames = rungs.first().map_or(0, |r| r.len());
    let capture = |o: &'a Outcome| Capture {
        truth: &o.truth,
        ignore: &o.ignore,
        visible_180: o.visible_180,
        detections: &o.detections,
    };
    let mut before = Window::new(window.max(1));
    let mut chosen: Vec<&'a Outcome> = Vec::with_capacity(frames);
    for f in 0..frames {
        let fitness: Vec<f64> = before
            .scores(rungs.iter().map(|r| capture(&r[f])))
            .zip(rungs)
            .map(|(s, r)| s.map + TIE_BREAK_WEIGHT * (1.0 - r[f].clipped))
            .collect();
        let best = (0..rungs.len())
            .reduce(|a, b| if fitness[b] > fitness[a] { b } else { a })
            .unwrap_or(0);
        before.push(capture(&rungs[best][f]));
        chosen.push(&rungs[best][f]);
    }
    chosen
}

#[cfg(test)]
mod tests {
    use super::super::policies::{score, tests::frame};
    use super::*;
    use joca_camera::DynamicSettings;
    use joca_core::Detection;
    use joca_record::Light;

    /// Two rungs of two day frames. Frame 0 is captured alike at both (its object found at 0.5
    /// below a false positive at 0.6). Frame 1's object is found at 0.3 on rung 0 and at 0.9 on
    /// rung 1, whose frame is half clipped. Alone both score mAP 1 and the tie goes to rung 0,
    /// the less clipped; pooled with frame 0, rung 1's 0.9 ranks above the false positive and
    /// scores (51 + 50 · 2/3) / 101 against rung 0's 2/3 (COCO's 101-point AP), so it wins.
    #[test]
    fn a_pooled_search_picks_the_rung_whose_confidence_ranks_above_the_frames_before() {
        let day = Light::Day;
        let with = |ms: f64, scores: &[f32], clipped: f64, fp: bool| {
            let mut o = frame(day, true, ms);
            let bbox = o.truth[0].bbox;
            o.detections = scores
                .iter()
                .map(|&score| Detection { bbox, class: o.truth[0].class, score })
                .collect();
            if fp {
                let far = joca_core::BBox::new(200.0, 200.0, 240.0, 230.0);
                o.detections.push(Detection { bbox: far, class: o.truth[0].class, score: 0.6 });
            }
            o.clipped = clipped;
            o
        };
        let rung0 = vec![with(1.0, &[0.5], 0.0, true), with(1.0, &[0.3], 0.0, false)];
        let rung1 = vec![with(9.0, &[0.5], 0.0, true), with(9.0, &[0.9], 0.5, false)];
        let sets: [&[Outcome]; 2] = [&rung0, &rung1];
        let rung_of = |o: &Outcome| usize::from(o.settings.exposure_s > 5e-3);
        let alone = by_window(&sets, 1);
        assert_eq!(rung_of(alone[1]), 0, "the tie goes to the less clipped");
        let pooled = by_window(&sets, 16);
        assert_eq!((rung_of(pooled[0]), rung_of(pooled[1])), (0, 1), "frame 0's tie: rung 0");
        // The rows score every chosen frame together: rung 1's pick is the better-ranked.
        let rungs = [DynamicSettings::new(1e-3, 1.0), DynamicSettings::new(9e-3, 1.0)];
        let scored = score(&rungs, &[rung0.clone(), rung1.clone()], &[]);
        let get = |name: &str| scored.iter().find(|p| p.policy == name).unwrap();
        let (one, sixteen) = (get("map-search"), get("map-search-16"));
        assert!((one.scores.map - 2.0 / 3.0).abs() < 1e-9, "{}", one.scores.map);
        let expected = (51.0 + 50.0 * 2.0 / 3.0) / 101.0;
        assert!((sixteen.scores.map - expected).abs() < 1e-9, "{}", sixteen.scores.map);
        assert!(one.hindsight && sixteen.hindsight);
    }
}
