//! Training targets and loss of the detector (CenterNet): a penalty-reduced focal loss on the
//! class heatmaps with Gaussian peaks at object centres, and L1 losses on the log box size and the
//! sub-cell centre offset at those centres.

use super::{DetectorOutput, STRIDE};
use joca_core::Annotation;
use serde::{Deserialize, Serialize};
use tch::{Device, Kind, Tensor};

/// Weight of the size loss; log sizes are O(1), so they weigh like the offsets.
const SIZE_WEIGHT: f64 = 1.0;
/// Weight of the offset loss.
const OFFSET_WEIGHT: f64 = 1.0;

/// Where the size and offset heads are trained.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Regression {
    /// At each object's centre cell only (CenterNet): one sample per object.
    #[default]
    Centre,
    /// At every cell of the object's heatmap Gaussian, weighted by the Gaussian's value there
    /// (TTFNet's idea, Liu et al. 2020, with CenterNet's size/offset parametrisation): a
    /// neighbour of the centre learns the same box, its offset reaching past its own cell, so a
    /// peak that lands one cell off still decodes the right box, and each object gives the
    /// regression heads several samples per frame instead of one. A cell inside several
    /// objects' Gaussians regresses the one with the larger Gaussian value there (the smaller
    /// object on a tie), so every centre cell keeps its own object.
    Gaussian,
}

/// Ground truth rendered into the detector's output grid.
#[derive(Debug)]
pub struct Targets {
    /// Gaussian-peaked heatmap `[n, classes, h, w]` (`n` images, 1 unless
    /// [`Targets::stack`]ed), exactly 1 at object centres.
    pub heatmap: Tensor,
    /// `[n, classes, h, w]`: 1 in the cells an ignore region of that class covers, where a
    /// firing detector is not punished; `None` when the frame has no ignore region.
    pub ignore: Option<Tensor>,
    /// Flat indices `image·h·w + y·w + x` of the regression samples `[m]` (the object centres
    /// with [`Regression::Centre`]).
    pub indices: Tensor,
    /// `log(width / STRIDE), log(height / STRIDE)` of each sample's object `[2, m]`.
    pub size: Tensor,
    /// Object centre relative to the sample's cell corner, in cells `[2, m]` (within `[0, 1)`
    /// at the centre cell).
    pub offset: Tensor,
    /// Weight of each sample in the size and offset losses `[1, m]`: its Gaussian value times
    /// its class weight (all 1 for centre samples without class weights).
    pub weights: Tensor,
    /// Number of objects.
    pub count: usize,
    /// Class index of each object.
    pub classes: Vec<usize>,
    /// Class index and Gaussian value of each regression sample.
    samples: Vec<(usize, f32)>,
    /// Per-class loss weights on the heatmap positives `[1, classes, 1, 1]`; `None`: every
    /// class weighs 1.
    pub class_weights: Option<Tensor>,
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

/// One regression sample before the tensors are built.
#[derive(Debug, Clone, Copy)]
struct Sample {
    gaussian: f32,
    area: f64,
    class: usize,
    size: [f32; 2],
    offset: [f32; 2],
}

impl Targets {
    /// Targets for `annotations` (and the `ignore` regions) on an output grid of
    /// `out_h × out_w` cells and `classes`, as CenterNet: sizes regressed at the centres,
    /// CenterNet's Gaussian radius.
    pub fn new(
        annotations: &[Annotation],
        ignore: &[Annotation],
        classes: i64,
        out_h: i64,
        out_w: i64,
        device: Device,
    ) -> Self {
        Self::with_style(
            annotations,
            ignore,
            classes,
            (out_h, out_w),
            Regression::Centre,
            0,
            device,
        )
    }

    /// Targets as [`Targets::new`], with the size and offset samples chosen by `regression`
    /// and every heatmap Gaussian at least `min_radius` cells in radius. CenterNet's radius (the
    /// corner shift that keeps IoU ≥ 0.7)
    /// is 0 for objects under about 3 cells (12 px at stride 4): the target is then a single
    /// positive cell between full-weight negatives, although the centre of a 10-px sign can fall
    /// on either side of a cell border. With radius 1 the 4 neighbours are penalty-reduced
    /// negatives (Gaussian value e^-2 = 0.14, weight (1 − 0.14)^4 = 0.56).
    pub fn with_style(
        annotations: &[Annotation],
        ignore: &[Annotation],
        classes: i64,
        (out_h, out_w): (i64, i64),
        regression: Regression,
        min_radius: i64,
        device: Device,
    ) -> Self {
        let (h, w) = (out_h as usize, out_w as usize);
        let mut heat = vec![0.0f32; classes as usize * h * w];
        let mut object_classes = Vec::new();
        // Centre samples in object order (duplicates allowed, as CenterNet); Gaussian samples
        // keyed by cell, in cell order.
        let mut samples: Vec<(usize, Sample)> = Vec::new();
        let mut claims: std::collections::BTreeMap<usize, Sample> = Default::default();
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
            let radius = (gaussian_radius(bh.ceil(), bw.ceil(), 0.7).max(0.0).floor() as i64)
                .max(min_radius);
            let sigma = (2 * radius + 1) as f64 / 6.0;
            let class = a.class.index();
            let plane = &mut heat[class * h * w..(class + 1) * h * w];
            let sample = |x: usize, y: usize, gaussian: f32| Sample {
                gaussian,
                area: bw * bh,
                class,
                size: [bw.ln() as f32, bh.ln() as f32],
                offset: [(cx - x as f64) as f32, (cy - y as f64) as f32],
            };
            for dy in -radius..=radius {
                for dx in -radius..=radius {
                    let (x, y) = (ix as i64 + dx, iy as i64 + dy);
                    if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
                        continue;
                    }
                    let (x, y) = (x as usize, y as usize);
                    // exp(−0) = 1 exactly at the centre, which is always on the grid.
                    let g = (-((dx * dx + dy * dy) as f64) / (2.0 * sigma * sigma)).exp() as f32;
                    let cell = &mut plane[y * w + x];
                    *cell = cell.max(g);
                    if regression == Regression::Gaussian {
                        let new = sample(x, y, g);
                        let claim = claims.entry(y * w + x).or_insert(new);
                        let better = new.gaussian.total_cmp(&claim.gaussian).then(
                            claim.area.total_cmp(&new.area), // the smaller object on a tie
                        );
                        if better.is_gt() {
                            *claim = new;
                        }
                    }
                }
            }
            if regression == Regression::Centre {
                samples.push((iy * w + ix, sample(ix, iy, 1.0)));
            }
            object_classes.push(class);
        }
        samples.extend(claims);
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
        let m = samples.len() as i64;
        let pair = |f: &dyn Fn(&Sample) -> [f32; 2]| {
            let (a, b): (Vec<f32>, Vec<f32>) = samples.iter().map(|(_, s)| f(s).into()).unzip();
            Tensor::from_slice(&[a, b].concat()).view([2, m]).to_device(device)
        };
        let indices: Vec<i64> = samples.iter().map(|(cell, _)| *cell as i64).collect();
        let mut targets = Self {
            heatmap: Tensor::from_slice(&heat).view([1, classes, out_h, out_w]).to_device(device),
            ignore,
            indices: Tensor::from_slice(&indices).to_device(device),
            size: pair(&|s| s.size),
            offset: pair(&|s| s.offset),
            weights: Tensor::zeros([1, m], (Kind::Float, device)),
            count: object_classes.len(),
            classes: object_classes,
            samples: samples.iter().map(|(_, s)| (s.class, s.gaussian)).collect(),
            class_weights: None,
        };
        targets.weigh(&vec![1.0; classes as usize]);
        targets
    }

    /// The targets of a batch: `parts[i]` for image `i` (all on the same grid and classes).
    /// The heatmap loss is then normalised by the batch's object count and the regression
    /// losses averaged over all its samples, as CenterNet trains with batches, so a batch of
    /// one is the image's own targets.
    pub fn stack(parts: Vec<Targets>) -> Self {
        assert!(!parts.is_empty(), "a batch needs at least one image");
        let s = parts[0].heatmap.size();
        let cells = s[2] * s[3];
        let ignore = parts.iter().any(|t| t.ignore.is_some()).then(|| {
            let planes: Vec<Tensor> = parts
                .iter()
                .map(|t| {
                    t.ignore.as_ref().map_or_else(|| t.heatmap.zeros_like(), Tensor::shallow_clone)
                })
                .collect();
            Tensor::cat(&planes, 0)
        });
        let indices: Vec<Tensor> =
            parts.iter().enumerate().map(|(b, t)| &t.indices + b as i64 * cells).collect();
        let cat = |f: &dyn Fn(&Targets) -> &Tensor, dim: i64| {
            Tensor::cat(&parts.iter().map(f).collect::<Vec<_>>(), dim)
        };
        Self {
            heatmap: cat(&|t| &t.heatmap, 0),
            ignore,
            indices: Tensor::cat(&indices, 0),
            size: cat(&|t| &t.size, 1),
            offset: cat(&|t| &t.offset, 1),
            weights: cat(&|t| &t.weights, 1),
            count: parts.iter().map(|t| t.count).sum(),
            classes: parts.iter().flat_map(|t| t.classes.iter().copied()).collect(),
            samples: parts.iter().flat_map(|t| t.samples.iter().copied()).collect(),
            class_weights: parts[0].class_weights.as_ref().map(Tensor::shallow_clone),
        }
    }

    /// Sample weights: Gaussian value × class weight.
    fn weigh(&mut self, class_weights: &[f64]) {
        let weights: Vec<f32> =
            self.samples.iter().map(|&(c, g)| g * class_weights[c] as f32).collect();
        self.weights = Tensor::from_slice(&weights)
            .view([1, weights.len() as i64])
            .to_device(self.heatmap.device());
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
        self.class_weights = Some(
            Tensor::from_slice(&planes).view([1, weights.len() as i64, 1, 1]).to_device(device),
        );
        self.weigh(weights);
        self
    }
}

/// The detector's loss for one image or a batch ([`Targets::stack`]), with its parts for
/// logging.
#[derive(Debug)]
pub struct DetectionLoss {
    /// Weighted sum, differentiable.
    pub total: Tensor,
    /// Focal heatmap loss.
    pub heatmap: f64,
    /// The heatmap loss's background term: its share from the cells away from every object's
    /// peak (confidence where nothing is, penalised down to the Gaussian's falloff), per object.
    pub background: f64,
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
            Some(planes) => peaks * planes,
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
        let background = -&neg_loss / num_pos;
        let heatmap = -(pos_loss + neg_loss) / num_pos;
        let (size, offset) = if targets.count == 0 {
            (logits.zeros_like().sum(Kind::Float), logits.zeros_like().sum(Kind::Float))
        } else {
            // [n, 2, h, w] → [2, n·h·w], indexed by `image·h·w + y·w + x`.
            let at = |map: &Tensor| {
                let s = map.size();
                map.transpose(0, 1)
                    .reshape([2, s[0] * s[2] * s[3]])
                    .index_select(1, &targets.indices)
            };
            // Weighted mean over the samples and both coordinates.
            let w = &targets.weights;
            let l1 = |map: &Tensor, target: &Tensor| {
                ((at(map) - target).abs() * w).sum(Kind::Float) / (w.sum(Kind::Float) * 2.0)
            };
            (l1(&output.size, &targets.size), l1(&output.offset, &targets.offset))
        };
        let total = &heatmap + &size * SIZE_WEIGHT + &offset * OFFSET_WEIGHT;
        Self {
            heatmap: heatmap.double_value(&[]),
            background: background.double_value(&[]),
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
