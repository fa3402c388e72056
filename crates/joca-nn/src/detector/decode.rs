//! From network output to boxes: local maxima of the class heatmaps (3×3 max-pool peak
//! suppression, CenterNet's replacement for NMS), the best `max_detections` of them, each with its
//! predicted size and sub-cell offset.

use super::{DetectorOutput, STRIDE};
use joca_core::{BBox, Class, Detection};
use tch::{Kind, Tensor};

/// Detections of one image of `width × height` pixels, best first. NaN scores (a diverged
/// network) count as 0 and are dropped by `min_score > 0`.
pub fn decode(
    output: &DetectorOutput,
    width: usize,
    height: usize,
    max_detections: i64,
    min_score: f64,
) -> Vec<Detection> {
    let _guard = tch::no_grad_guard();
    let s = output.heatmap.size();
    let (classes, h, w) = (s[1], s[2], s[3]);
    let heat = output.heatmap.sigmoid().nan_to_num(0.0, 0.0, 0.0);
    let peaks = heat.max_pool2d([3, 3], [1, 1], [1, 1], [1, 1], false);
    let kept = &heat * peaks.eq_tensor(&heat).to_kind(Kind::Float);
    let k = max_detections.min(classes * h * w);
    let (scores, indices) = kept.reshape([-1]).topk(k, 0, true, true);
    let scores: Vec<f32> =
        Vec::try_from(scores.to_kind(Kind::Float).to_device(tch::Device::Cpu)).unwrap_or_default();
    let indices: Vec<i64> = Vec::try_from(indices.to_device(tch::Device::Cpu)).unwrap_or_default();
    let flat = |t: &Tensor| -> Vec<f32> {
        Vec::try_from(t.to_kind(Kind::Float).to_device(tch::Device::Cpu).reshape([-1]))
            .unwrap_or_default()
    };
    let size = flat(&output.size);
    let offset = flat(&output.offset);
    let plane = (h * w) as usize;
    let stride = STRIDE as f32;
    let mut out: Vec<Detection> = scores
        .iter()
        .zip(&indices)
        .filter(|&(&score, _)| f64::from(score) > min_score)
        .filter_map(|(&score, &index)| {
            let class = Class::ALL.get((index / (h * w)) as usize).copied()?;
            let cell = (index % (h * w)) as usize;
            let (y, x) = ((cell / w as usize) as f32, (cell % w as usize) as f32);
            let cx = (x + offset[cell]) * stride;
            let cy = (y + offset[plane + cell]) * stride;
            let bw = size[cell].clamp(-10.0, 10.0).exp() * stride;
            let bh = size[plane + cell].clamp(-10.0, 10.0).exp() * stride;
            let bbox = BBox::new(
                (cx - bw / 2.0).max(0.0),
                (cy - bh / 2.0).max(0.0),
                (cx + bw / 2.0).min(width as f32),
                (cy + bh / 2.0).min(height as f32),
            );
            (bbox.width() > 0.0 && bbox.height() > 0.0 && cx.is_finite() && cy.is_finite())
                .then_some(Detection { bbox, class, score })
        })
        .collect();
    out.sort_by(|a, b| b.score.total_cmp(&a.score));
    out
}
