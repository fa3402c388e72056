//! Training targets and loss of the detector (CenterNet): a penalty-reduced focal loss on the
//! class heatmaps with Gaussian peaks at object centres, and L1 losses on the log box size and the
//! sub-cell centre offset at those centres.

use super::{DetectorOutput, STRIDE};
use joca_core::Annotation;
use tch::{Device, Kind, Tensor};

/// Weight of the size loss; log sizes are O(1), so they weigh like the offsets.
const SIZE_WEIGHT: f64 = 1.0;
/// Weight of the offset loss.
const OFFSET_WEIGHT: f64 = 1.0;

/// Ground truth rendered into the detector's output grid.
#[derive(Debug)]
pub struct Targets {
    /// Gaussian-peaked heatmap `[1, classes, h, w]`, exactly 1 at object centres.
    pub heatmap: Tensor,
    /// `[1, classes, h, w]`: 1 in the cells an ignore region of that class covers, where a
    /// firing detector is not punished; `None` when the frame has no ignore region.
    pub ignore: Option<Tensor>,
    /// Flat indices `y·w + x` of the object centres `[n]`.
    pub indices: Tensor,
    /// `log(width / STRIDE), log(height / STRIDE)` per object `[2, n]`.
    pub size: Tensor,
    /// Centre position within its cell `[2, n]`.
    pub offset: Tensor,
    /// Number of objects.
    pub count: usize,
    /// Class index of each object.
    pub classes: Vec<usize>,
    /// Per-class loss weights (`[1, classes, 1, 1]` on the heatmap positives) and the same
    /// weights per object (`[1, n]`, on size and offset); `None`: every class weighs 1.
    pub class_weights: Option<(Tensor, Tensor)>,
}

/// CenterNet's Gaussian radius: the largest corner shift that keeps IoU ≥ `min_overlap`
/// (the formula as published in the CenterNet/CornerNet code).
fn gaussian_radius(h: f64, w: f64, min_overlap: f64) -> f64 {
    let o = min_overlap;
    let (b1, c1) = (h + w, w * h * (1.0 - o) / (1.0 + o));
    let r1 = (b1 + (b1 * b1 - 4.0 * c1).sqrt()) / 2.0;
    let (a2, b2, c2) = (4.0, 2.0 * (h + w), (1.0 - o) * w * h);
    let r2 = (b2 + (b2 * b2 - 4.0 * a2 * c2).sqrt()) / 2.0;
    let (a3, b3, c3) = (4.0 * o, -2.0 * o * (h + w), (o - 1.0) * w * h);
    let r3 = (b3 + (b3 * b3 - 4.0 * a3 * c3).sqrt()) / 2.0;
    r1.min(r2).min(r3)
}

impl Targets {
    /// Targets for `annotations` (and the `ignore` regions) on an output grid of
    /// `out_h × out_w` cells and `classes`.
    pub fn new(
        annotations: &[Annotation],
        ignore: &[Annotation],
        classes: i64,
        out_h: i64,
        out_w: i64,
        device: Device,
    ) -> Self {
        let (h, w) = (out_h as usize, out_w as usize);
        let mut heat = vec![0.0f32; classes as usize * h * w];
        let mut indices = Vec::new();
        let mut object_classes = Vec::new();
        let (mut size_w, mut size_h, mut off_x, mut off_y) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let s = STRIDE as f64;
        for a in annotations {
            let (bw, bh) = (f64::from(a.bbox.width()) / s, f64::from(a.bbox.height()) / s);
            if bw <= 0.0 || bh <= 0.0 {
                continue;
            }
            let cx = f64::from(a.bbox.x_min + a.bbox.x_max) / 2.0 / s;
            let cy = f64::from(a.bbox.y_min + a.bbox.y_max) / 2.0 / s;
            let (ix, iy) = (
                cx.floor().clamp(0.0, (w - 1) as f64) as usize,
                cy.floor().clamp(0.0, (h - 1) as f64) as usize,
            );
            let radius = gaussian_radius(bh.ceil(), bw.ceil(), 0.7).max(0.0).floor() as i64;
            let sigma = (2 * radius + 1) as f64 / 6.0;
            let plane = &mut heat[a.class.index() * h * w..(a.class.index() + 1) * h * w];
            for dy in -radius..=radius {
                for dx in -radius..=radius {
                    let (x, y) = (ix as i64 + dx, iy as i64 + dy);
                    if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
                        continue;
                    }
                    let g = (-((dx * dx + dy * dy) as f64) / (2.0 * sigma * sigma)).exp() as f32;
                    let cell = &mut plane[y as usize * w + x as usize];
                    *cell = cell.max(g);
                }
            }
            plane[iy * w + ix] = 1.0;
            indices.push((iy * w + ix) as i64);
            object_classes.push(a.class.index());
            size_w.push(bw.ln() as f32);
            size_h.push(bh.ln() as f32);
            off_x.push((cx - ix as f64) as f32);
            off_y.push((cy - iy as f64) as f32);
        }
        let ignore = (!ignore.is_empty()).then(|| {
            let mut mask = vec![0.0f32; classes as usize * h * w];
            for a in ignore {
                let cells = |lo: f32, hi: f32, n: usize| {
                    let lo = (f64::from(lo) / s).floor().max(0.0) as usize;
                    let hi = ((f64::from(hi) / s).ceil().max(0.0) as usize).min(n);
                    lo..hi
                };
                let plane = &mut mask[a.class.index() * h * w..(a.class.index() + 1) * h * w];
                for y in cells(a.bbox.y_min, a.bbox.y_max, h) {
                    plane[y * w..(y + 1) * w][cells(a.bbox.x_min, a.bbox.x_max, w)].fill(1.0);
                }
            }
            Tensor::from_slice(&mask).view([1, classes, out_h, out_w]).to_device(device)
        });
        let n = indices.len() as i64;
        let pair = |a: Vec<f32>, b: Vec<f32>| {
            Tensor::from_slice(&[a, b].concat()).view([2, n]).to_device(device)
        };
        Self {
            heatmap: Tensor::from_slice(&heat).view([1, classes, out_h, out_w]).to_device(device),
            ignore,
            indices: Tensor::from_slice(&indices).to_device(device),
            size: pair(size_w, size_h),
            offset: pair(off_x, off_y),
            count: indices.len(),
            classes: object_classes,
            class_weights: None,
        }
    }

    /// The same targets with each class's objects weighted by `weights[class]`, for class
    /// imbalance (class-balanced loss): a weighted class's heatmap peaks and its size and offset
    /// errors count `weight` times, while the background term and the normaliser (the number of
    /// objects) stay as they are, so a frame without that class trains exactly as before.
    pub fn with_class_weights(mut self, weights: &[f64]) -> Self {
        if weights.iter().all(|&w| w == 1.0) {
            return self;
        }
        let device = self.heatmap.device();
        let planes: Vec<f32> = weights.iter().map(|&w| w as f32).collect();
        let per_object: Vec<f32> = self.classes.iter().map(|&c| weights[c] as f32).collect();
        self.class_weights = Some((
            Tensor::from_slice(&planes).view([1, weights.len() as i64, 1, 1]).to_device(device),
            Tensor::from_slice(&per_object).view([1, self.count as i64]).to_device(device),
        ));
        self
    }
}

/// The detector's loss for one image, with its parts for logging.
#[derive(Debug)]
pub struct DetectionLoss {
    /// Weighted sum, differentiable.
    pub total: Tensor,
    /// Focal heatmap loss.
    pub heatmap: f64,
    /// Size L1 loss.
    pub size: f64,
    /// Offset L1 loss.
    pub offset: f64,
}

impl DetectionLoss {
    /// Computes the loss of `output` against `targets`.
    pub fn new(output: &DetectorOutput, targets: &Targets) -> Self {
        let logits = &output.heatmap;
        let t = &targets.heatmap;
        let p = logits.sigmoid();
        let peaks = t.eq(1.0).to_kind(Kind::Float);
        let not_pos: Tensor = 1.0 - &peaks;
        let pos = match &targets.class_weights {
            Some((planes, _)) => peaks * planes,
            None => peaks,
        };
        let neg: Tensor = match &targets.ignore {
            Some(ignore) => not_pos * (1.0 - ignore),
            None => not_pos,
        };
        // log p and log(1 − p) through log-sigmoid, stable for large logits.
        let one_minus_p: Tensor = 1.0 - &p;
        let pos_loss =
            (logits.log_sigmoid() * one_minus_p.pow_tensor_scalar(2.0) * &pos).sum(Kind::Float);
        let one_minus_t: Tensor = 1.0 - t;
        let neg_weight = one_minus_t.pow_tensor_scalar(4.0);
        let neg_loss = ((-logits).log_sigmoid() * p.pow_tensor_scalar(2.0) * neg_weight * neg)
            .sum(Kind::Float);
        let num_pos = (targets.count as f64).max(1.0);
        let heatmap = -(pos_loss + neg_loss) / num_pos;
        let (size, offset) = if targets.count == 0 {
            (logits.zeros_like().sum(Kind::Float), logits.zeros_like().sum(Kind::Float))
        } else {
            let at = |map: &Tensor| {
                let s = map.size();
                map.reshape([2, s[2] * s[3]]).index_select(1, &targets.indices)
            };
            let l1 = |map: &Tensor, target: &Tensor| {
                let error = (at(map) - target).abs();
                match &targets.class_weights {
                    Some((_, w)) => (error * w).sum(Kind::Float) / (w.sum(Kind::Float) * 2.0),
                    None => error.mean(Kind::Float),
                }
            };
            (l1(&output.size, &targets.size), l1(&output.offset, &targets.offset))
        };
        let total = &heatmap + &size * SIZE_WEIGHT + &offset * OFFSET_WEIGHT;
        Self {
            heatmap: heatmap.double_value(&[]),
            size: size.double_value(&[]),
            offset: offset.double_value(&[]),
            total,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaussian_radius_matches_centernet_values() {
        // CenterNet's published gaussian_radius((h, w), 0.7) evaluated with Python's math module:
        // (10, 10) → 2.733201, (40, 20) → 7.355851.
        assert!((gaussian_radius(10.0, 10.0, 0.7) - 2.733_201).abs() < 1e-5);
        assert!((gaussian_radius(40.0, 20.0, 0.7) - 7.355_851).abs() < 1e-5);
    }
}
