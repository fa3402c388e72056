//! One image's matching (pycocotools' `evaluateImg`) and the accumulation of matched
//! detections into precision–recall curves (`accumulate`), step by step.

use super::*;

/// Matching result of one image and category at one area range.
pub(crate) struct ImageEval {
    pub(crate) scores: Vec<f64>,
    /// `[threshold][detection]`: matched to a ground truth.
    pub(crate) matched: Vec<Vec<bool>>,
    /// `[threshold][detection]`: ignored.
    pub(crate) ignored: Vec<Vec<bool>>,
    pub(crate) gt_ignored: Vec<bool>,
}

/// pycocotools' `evaluateImg` for one image and category (maxDets 100).
pub(crate) fn evaluate_image(
    gts: &[&GroundTruth],
    dts: &[&ScoredBox],
    range: (f64, f64),
    thresholds: &[f64],
    keep: &dyn Fn(&GroundTruth) -> bool,
) -> Option<ImageEval> {
    if gts.is_empty() && dts.is_empty() {
        return None;
    }
    let ignore = |g: &GroundTruth| g.crowd || g.area < range.0 || g.area > range.1 || !keep(g);
    // Non-ignored ground truth first (stable).
    let mut g_order: Vec<usize> = (0..gts.len()).collect();
    g_order.sort_by_key(|&i| ignore(gts[i]));
    let g: Vec<&GroundTruth> = g_order.iter().map(|&i| gts[i]).collect();
    let gt_ignored: Vec<bool> = g.iter().map(|x| ignore(x)).collect();
    // Best score first (stable), at most 100.
    let mut d_order: Vec<usize> = (0..dts.len()).collect();
    d_order.sort_by(|&a, &b| dts[b].score.total_cmp(&dts[a].score));
    d_order.truncate(100);
    let d: Vec<&ScoredBox> = d_order.iter().map(|&i| dts[i]).collect();
    let ious: Vec<Vec<f64>> = d
        .iter()
        .map(|dt| g.iter().map(|gt| iou_xywh(&dt.bbox, &gt.bbox, gt.crowd)).collect())
        .collect();
    let mut matched = vec![vec![false; d.len()]; thresholds.len()];
    let mut ignored = vec![vec![false; d.len()]; thresholds.len()];
    for (t, &threshold) in thresholds.iter().enumerate() {
        let mut gt_taken = vec![false; g.len()];
        for (di, row) in ious.iter().enumerate() {
            let mut best = threshold.min(1.0 - 1e-10);
            let mut m: Option<usize> = None;
            for (gi, &iou) in row.iter().enumerate() {
                if gt_taken[gi] && !g[gi].crowd {
                    continue;
                }
                if let Some(mm) = m
                    && !gt_ignored[mm]
                    && gt_ignored[gi]
                {
                    break;
                }
                if iou < best {
                    continue;
                }
                best = iou;
                m = Some(gi);
            }
            if let Some(mm) = m {
                ignored[t][di] = gt_ignored[mm];
                matched[t][di] = true;
                gt_taken[mm] = true;
            }
        }
    }
    for (di, dt) in d.iter().enumerate() {
        let area = dt.bbox[2] * dt.bbox[3];
        let outside = area < range.0 || area > range.1;
        for t in 0..thresholds.len() {
            if !matched[t][di] && outside {
                ignored[t][di] = true;
            }
        }
    }
    Some(ImageEval { scores: d.iter().map(|x| x.score).collect(), matched, ignored, gt_ignored })
}

/// Ground-truth objects not ignored, and true positives at IoU 0.5 among each image's first 100
/// detections (area "all").
pub(crate) fn counts_at_50(evals: &[ImageEval]) -> (usize, usize) {
    let ground_truths = evals.iter().flat_map(|e| &e.gt_ignored).filter(|&&i| !i).count();
    let true_positives = evals
        .iter()
        .map(|e| {
            e.matched[0].iter().zip(&e.ignored[0]).take(100).filter(|(m, i)| **m && !**i).count()
        })
        .sum::<usize>();
    (ground_truths, true_positives)
}

/// pycocotools' accumulate for one category, area range, detection cap and IoU threshold `t`:
/// the precision–recall curve over the merged detections (`(score, image, detection)`, by
/// score), its final recall, and its interpolated precision at each of `recall_points`.
pub(crate) fn accumulate(
    evals: &[ImageEval],
    merged: &[(f64, usize, usize)],
    t: usize,
    npig: usize,
    recall_points: &[f64],
) -> (f64, Vec<f64>) {
    let mut tp = 0.0f64;
    let mut fp = 0.0f64;
    let mut rc = Vec::with_capacity(merged.len());
    let mut pr = Vec::with_capacity(merged.len());
    for &(_, e, d) in merged {
        let (matched, ignored) = (evals[e].matched[t][d], evals[e].ignored[t][d]);
        // Ignored detections neither add nor cost, but, as numpy's cumsum
        // does, still emit a (repeated) point of the curve.
        if !ignored {
            if matched {
                tp += 1.0;
            } else {
                fp += 1.0;
            }
        }
        rc.push(tp / npig as f64);
        pr.push(tp / (fp + tp + f64::EPSILON));
    }
    let final_recall = rc.last().copied().unwrap_or(0.0);
    for i in (1..pr.len()).rev() {
        if pr[i] > pr[i - 1] {
            pr[i - 1] = pr[i];
        }
    }
    let mut precision = Vec::with_capacity(recall_points.len());
    for &threshold in recall_points {
        // searchsorted(rc, threshold, side="left"); recall points out of
        // reach keep precision 0, as in pycocotools.
        let pi = rc.partition_point(|&v| v < threshold);
        precision.push(pr.get(pi).copied().unwrap_or(0.0));
    }
    (final_recall, precision)
}
