//! The detector with its variables and optimiser, behind an interface free of tensor types, so
//! that training loops outside this crate never touch the framework.

use super::{
    DetectionLoss, Detector, DetectorConfig, DetectorOutput, Precision, Regression, Targets,
    batch_tensor, decode, image_tensor,
};
use crate::{Adam, AdamConfig, Engine, NnError, load_weights, save_weights};
use joca_core::{Annotation, Detection, Rgb8Image};
use serde::{Deserialize, Serialize};
use std::path::Path;
use tch::nn::VarStore;
use tch::{Device, Tensor};

/// Detections kept per image (COCO's maxDets).
pub const MAX_DETECTIONS: i64 = 100;
/// Detections below this score are dropped.
pub const MIN_SCORE: f64 = 0.01;

/// The parts of one training step's loss.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LossParts {
    /// Weighted total.
    pub total: f64,
    /// Focal heatmap loss.
    pub heatmap: f64,
    /// Log-size L1 loss.
    pub size: f64,
    /// Offset L1 loss.
    pub offset: f64,
}

/// One frame's task loss from [`DetectorModel::detect_with_loss`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameLoss {
    /// The loss the detector trains on (and DF-Grad's task term descends).
    pub total: f64,
    /// Its heatmap's background term ([`DetectionLoss::background`]): `total − background` is
    /// the loss on the objects alone (their peaks, sizes and offsets).
    pub background: f64,
}

/// Refuses an empty batch or one of frames of different sizes.
fn one_size(batch: &[TrainFrame<'_>]) -> Result<(), NnError> {
    let Some(first) = batch.first() else {
        return Err(NnError::Batch("no frames".into()));
    };
    let size = (first.image.width(), first.image.height());
    if let Some(f) = batch.iter().find(|f| (f.image.width(), f.image.height()) != size) {
        return Err(NnError::Batch(format!(
            "frames of {}×{} and {}×{}: a batch needs frames of one size",
            size.0,
            size.1,
            f.image.width(),
            f.image.height()
        )));
    }
    Ok(())
}

/// One training image with its ground truth and ignore regions.
#[derive(Debug, Clone, Copy)]
pub struct TrainFrame<'a> {
    /// The image.
    pub image: &'a Rgb8Image,
    /// Annotated objects.
    pub truth: &'a [Annotation],
    /// Regions where detections are neither rewarded nor punished.
    pub ignore: &'a [Annotation],
}

/// A trainable detector: network, variables, optimiser.
#[derive(Debug)]
pub struct DetectorModel {
    pub(crate) vs: VarStore,
    pub(crate) net: Detector,
    pub(crate) optimizer: Adam,
    device: Device,
    class_weights: Vec<f64>,
    regression: Regression,
    min_radius: i64,
    precision: Precision,
}

impl DetectorModel {
    /// A freshly initialised detector (initialisation follows libtorch's generator, seeded by
    /// [`Engine::seed`]).
    pub fn new(engine: &Engine, config: DetectorConfig, adam: AdamConfig) -> Self {
        let vs = VarStore::new(engine.device());
        let net = Detector::new(&vs.root(), config);
        let optimizer = Adam::new(&vs, adam);
        let class_weights = vec![1.0; config.classes as usize];
        let regression = Regression::Centre;
        let precision = Precision::Fp32;
        Self {
            vs,
            net,
            optimizer,
            device: engine.device(),
            class_weights,
            regression,
            min_radius: 0,
            precision,
        }
    }

    /// The device the network computes on.
    pub fn device(&self) -> Device {
        self.device
    }

    /// The network (for the NeuralAE, which reads its features).
    pub fn network(&self) -> &Detector {
        &self.net
    }

    /// Loads weights, checking every tensor.
    pub fn load_weights(&mut self, path: &Path) -> Result<(), NnError> {
        load_weights(&mut self.vs, path)
    }

    /// Saves weights atomically.
    pub fn save_weights(&self, path: &Path) -> Result<(), NnError> {
        save_weights(&self.vs, path)
    }

    /// Saves the optimiser state.
    pub fn save_optimizer(&self, path: &Path) -> Result<(), NnError> {
        self.optimizer.save(path)
    }

    /// Restores the optimiser state.
    pub fn load_optimizer(&mut self, path: &Path) -> Result<(), NnError> {
        self.optimizer.load(path)
    }

    /// Sets the learning rate.
    pub fn set_lr(&mut self, lr: f64) {
        self.optimizer.set_lr(lr);
    }

    /// Weights each class's objects in the training loss (see [`Targets::with_class_weights`]);
    /// all 1 by default. Panics unless there is one weight per class.
    pub fn set_class_weights(&mut self, weights: &[f64]) {
        assert_eq!(weights.len(), self.class_weights.len(), "one weight per class");
        self.class_weights = weights.to_vec();
    }

    /// Where [`DetectorModel::train_step`] trains the size and offset heads (the centres by
    /// default).
    pub fn set_regression(&mut self, regression: Regression) {
        self.regression = regression;
    }

    /// Freezes or unfreezes every weight (the "frozen detector" ablation).
    pub fn set_trainable(&mut self, trainable: bool) {
        if trainable { self.vs.unfreeze() } else { self.vs.freeze() }
    }

    /// The smallest heatmap Gaussian radius in training targets, cells (0 by default, as
    /// CenterNet; see [`Targets::with_style`]).
    pub fn set_min_radius(&mut self, cells: i64) {
        self.min_radius = cells;
    }

    /// The type [`DetectorModel::train_batch`] computes in (float32 by default; inference
    /// always runs in float32).
    pub fn set_precision(&mut self, precision: Precision) {
        self.precision = precision;
    }

    /// One gradient step on one frame with its ground truth and ignore regions. A non-finite
    /// loss is reported before any weight changes.
    pub fn train_step(
        &mut self,
        frame: &Rgb8Image,
        truth: &[Annotation],
        ignore: &[Annotation],
    ) -> Result<LossParts, NnError> {
        self.train_batch(&[TrainFrame { image: frame, truth, ignore }])
    }

    /// One gradient step on a batch of frames of one size (the loss normalised by the batch's
    /// object count, see [`Targets::stack`]). A non-finite loss is reported before any weight
    /// changes.
    pub fn train_batch(&mut self, batch: &[TrainFrame<'_>]) -> Result<LossParts, NnError> {
        one_size(batch)?;
        let images: Vec<&Rgb8Image> = batch.iter().map(|f| f.image).collect();
        let out = self.net.forward(&batch_tensor(&images, self.device, self.precision));
        let s = out.heatmap.size();
        let targets = Targets::stack(batch.iter().map(|f| self.targets(f, (s[2], s[3]))).collect());
        let loss = DetectionLoss::new(&out, &targets);
        let total = loss.total.double_value(&[]);
        if !total.is_finite() {
            return Err(NnError::NonFinite { what: "detector", value: total });
        }
        self.optimizer.zero_grad();
        loss.total.backward();
        self.optimizer.step();
        Ok(LossParts { total, heatmap: loss.heatmap, size: loss.size, offset: loss.offset })
    }

    /// The training targets of `frame` on an output grid of `grid` cells.
    fn targets(&self, frame: &TrainFrame<'_>, grid: (i64, i64)) -> Targets {
        Targets::with_style(
            frame.truth,
            frame.ignore,
            self.net.config().classes,
            grid,
            self.regression,
            self.min_radius,
            self.device,
        )
        .with_class_weights(&self.class_weights)
    }

    /// Each frame's task loss (the training loss's weighted total, normalised by the frame's own
    /// objects), without a gradient or an update, the convolutions in `precision`: a continuous
    /// score of how well the detector sees each frame's objects.
    pub fn losses_in(
        &self,
        batch: &[TrainFrame<'_>],
        precision: Precision,
    ) -> Result<Vec<f64>, NnError> {
        if batch.is_empty() {
            return Ok(Vec::new());
        }
        one_size(batch)?;
        let _guard = tch::no_grad_guard();
        let images: Vec<&Rgb8Image> = batch.iter().map(|f| f.image).collect();
        let out = self.net.forward(&batch_tensor(&images, self.device, precision));
        let s = out.heatmap.size();
        Ok(batch
            .iter()
            .enumerate()
            .map(|(i, f)| {
                let i = i as i64;
                let one = DetectorOutput {
                    heatmap: out.heatmap.narrow(0, i, 1),
                    size: out.size.narrow(0, i, 1),
                    offset: out.offset.narrow(0, i, 1),
                    features: out.features.narrow(0, i, 1),
                };
                DetectionLoss::new(&one, &self.targets(f, (s[2], s[3]))).total.double_value(&[])
            })
            .collect())
    }

    /// Detections in one frame, best first.
    pub fn detect(&self, frame: &Rgb8Image) -> Vec<Detection> {
        let _guard = tch::no_grad_guard();
        let out = self.net.forward(&image_tensor(frame, self.device));
        decode(&out, frame.width(), frame.height(), MAX_DETECTIONS, MIN_SCORE)
    }

    /// [`DetectorModel::detect`]'s detections in `frame.image` and the frame's task loss (as
    /// [`DetectorModel::losses_in`] in float32) from the same forward pass.
    pub fn detect_with_loss(&self, frame: TrainFrame<'_>) -> (Vec<Detection>, FrameLoss) {
        let _guard = tch::no_grad_guard();
        let out = self.net.forward(&image_tensor(frame.image, self.device));
        let s = out.heatmap.size();
        let parts = DetectionLoss::new(&out, &self.targets(&frame, (s[2], s[3])));
        let loss = FrameLoss { total: parts.total.double_value(&[]), background: parts.background };
        let (w, h) = (frame.image.width(), frame.image.height());
        (decode(&out, w, h, MAX_DETECTIONS, MIN_SCORE), loss)
    }

    /// Whether the network's outputs on `frame` hold NaN or infinite values: weights that are
    /// finite but overflow in the forward pass give no detection and no other sign.
    pub fn diverges_on(&self, frame: &Rgb8Image) -> bool {
        let _guard = tch::no_grad_guard();
        let out = self.net.forward(&image_tensor(frame, self.device));
        [&out.heatmap, &out.size, &out.offset]
            .iter()
            .any(|t| t.isfinite().all().int64_value(&[]) == 0)
    }

    /// Detections in each of several frames of one size, through the network as one batch (the
    /// normalisation is per frame, so each frame's detections do not depend on the others).
    /// Panics if the frames differ in size.
    pub fn detect_batch(&self, frames: &[&Rgb8Image]) -> Vec<Vec<Detection>> {
        self.detect_batch_in(frames, Precision::Fp32)
    }

    /// [`DetectorModel::detect_batch`] with the convolutions in `precision` (weights and
    /// outputs stay float32; see [`Precision`]).
    pub fn detect_batch_in(
        &self,
        frames: &[&Rgb8Image],
        precision: Precision,
    ) -> Vec<Vec<Detection>> {
        if frames.is_empty() {
            return Vec::new();
        }
        let _guard = tch::no_grad_guard();
        let out = self.net.forward(&batch_tensor(frames, self.device, precision));
        let (w, h) = (frames[0].width(), frames[0].height());
        (0..frames.len() as i64)
            .map(|i| {
                let one = DetectorOutput {
                    heatmap: out.heatmap.narrow(0, i, 1),
                    size: out.size.narrow(0, i, 1),
                    offset: out.offset.narrow(0, i, 1),
                    features: out.features.narrow(0, i, 1),
                };
                decode(&one, w, h, MAX_DETECTIONS, MIN_SCORE)
            })
            .collect()
    }

    /// Number of weights.
    pub fn parameter_count(&self) -> i64 {
        self.vs.trainable_variables().iter().map(Tensor::numel).map(|n| n as i64).sum()
    }
}

/// A running exponential average of a detector's weights (Polyak averaging), the network that
/// pre-training evaluates and ships. With batch size 1 and data that change block by block, the
/// trained weights follow the latest cameras and scenes; their average over the last ~1/(1−d)
/// steps does not. Group normalisation keeps no running statistics, so the weights are all
/// there is to average.
#[derive(Debug)]
pub struct WeightAverage {
    model: DetectorModel,
    /// `(average, source)` variable pairs, sharing storage with the two variable stores.
    pairs: Vec<(Tensor, Tensor)>,
    decay: f64,
}

impl WeightAverage {
    /// Starts the average at `source`'s current weights.
    pub fn new(engine: &Engine, source: &DetectorModel, decay: f64) -> Self {
        let model = DetectorModel::new(engine, source.net.config(), AdamConfig::DETECTOR);
        let theirs = source.vs.variables();
        let mut pairs: Vec<(Tensor, Tensor)> = model
            .vs
            .variables()
            .into_iter()
            .filter_map(|(name, mine)| theirs.get(&name).map(|t| (mine, t.shallow_clone())))
            .collect();
        let _guard = tch::no_grad_guard();
        for (mine, theirs) in &mut pairs {
            mine.copy_(theirs);
        }
        Self { model, pairs, decay }
    }

    /// Folds in the source's weights after its `updates`-th step: `avg ← d·avg + (1 − d)·w`
    /// with `d = min(decay, (1 + n)/(10 + n))`, so that the first steps' random weights do not
    /// linger (the ramp TensorFlow's ExponentialMovingAverage uses with `num_updates`).
    pub fn update(&mut self, updates: u64) {
        let n = updates as f64;
        let d = self.decay.min((1.0 + n) / (10.0 + n));
        let _guard = tch::no_grad_guard();
        for (mine, theirs) in &mut self.pairs {
            let _ = mine.lerp_(theirs, 1.0 - d);
        }
    }

    /// The averaged network.
    pub fn model(&self) -> &DetectorModel {
        &self.model
    }

    /// Loads averaged weights written by `model().save_weights`.
    pub fn load(&mut self, path: &Path) -> Result<(), NnError> {
        self.model.load_weights(path)
    }
}
