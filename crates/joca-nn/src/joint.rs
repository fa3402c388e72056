//! The joint model of the paper's training loop: detector, NeuralAE and the differentiable
//! formation between them, with one optimiser each (AdamW 1e-4 for the detector, Adam 1e-5 for
//! the ACC). The loop itself lives in `joca-train`; this type keeps every tensor on this side.
//!
//! A step: NeuralAE predicts `(E_pred, G_pred)` from the previous frame ([`JointModel::predict`]);
//! the caller renders `I0` with the exposure that Eq. 4 gives for the sensor; [`JointModel::step`]
//! applies Eq. 4 and Eq. 2–3 on tensors, runs the detector, and updates
//!
//! ```text
//! detector ← ∇ l_task          ACC ← ∇ (w_task · l_task + w_ga · l_GA)        (DF-Grad, Sec. 5)
//! l_GA = mean(|Ẽ* − E_pred|, |G̃* − G_pred|)  in normalised units (each range → [0, 1])
//! ```
//!
//! where `(Ẽ*, G̃*)` is the best perturbation the caller's GA found (given every i steps).
//! Beyond the paper, the ACC's loss may add `w_step · l_step`, a quadratic cost of each stop
//! NeuralAE moves exposure and gain from the settings it read (`equations::step_cost`): a
//! control-effort term that the task alone does not give a controller in steady light.
//!
//! With a moving iris NeuralAE also predicts the iris's unit position `u`; the light it lets
//! through, `(N0/N(u))²`, multiplies Eq. 2's signal as exposure does, so the task loss reaches
//! `u` through the frame's brightness and noise (its defocus, like the exposure's blur, only
//! through the perturbation search), and `l_GA` averages `|ũ* − u|` in as a third term.

mod equations;
mod learn;
mod step;

use crate::acc::{AccBounds, NeuralAe, histograms};
use crate::detector::{
    DetectorConfig, DetectorModel, MAX_DETECTIONS, MIN_SCORE, decode, image_tensor,
};
use crate::formation::ClipGradient;
use crate::{Adam, AdamConfig, Engine, NnError, load_weights, save_weights};
use joca_camera::{AccRanges, DynamicSettings, ImageFormation};
use joca_core::{Detection, Rgb8Image};
use std::path::Path;
use tch::nn::VarStore;
use tch::{Device, Tensor};

pub use step::{DfGradWeights, Exposure, GaTarget, Prediction, StepReport, StepTimings};

/// Detector + NeuralAE + their optimisers.
#[derive(Debug)]
pub struct JointModel {
    det: DetectorModel,
    acc_vs: VarStore,
    acc: NeuralAe,
    acc_opt: Adam,
    bounds: AccBounds,
    formation: ImageFormation,
    device: Device,
    /// The longest exposure and the highest gain the sensor can apply (Eq. 4's result is capped
    /// there, gain making up the exposure's excess), as `joca_camera::limit_exposure`.
    max_exposure_s: f64,
    max_gain_db: f64,
    /// The gradient of clipping in the differentiable formation.
    clip: ClipGradient,
    /// Detector features of the sequence's last frame: NeuralAE's input for the next one.
    features: Option<Tensor>,
    train_detector: bool,
}

impl JointModel {
    /// Fresh networks (initialised from libtorch's seeded generator); NeuralAE predicts within
    /// `ranges`.
    /// With `iris`, NeuralAE also sets the lens's iris (a third output).
    pub fn new(
        engine: &Engine,
        detector: DetectorConfig,
        ranges: AccRanges,
        formation: ImageFormation,
        iris: bool,
    ) -> Self {
        let bounds = AccBounds::new(ranges);
        let bounds = if iris { bounds.with_iris() } else { bounds };
        let det = DetectorModel::new(engine, detector, AdamConfig::DETECTOR);
        let acc_vs = VarStore::new(engine.device());
        let acc = NeuralAe::new(&acc_vs.root(), 2 * detector.width, bounds);
        let acc_opt = Adam::new(&acc_vs, AdamConfig::ACC);
        Self {
            det,
            acc_vs,
            acc,
            acc_opt,
            bounds,
            formation,
            device: engine.device(),
            max_exposure_s: ranges.exposure_s.max,
            max_gain_db: ranges.gain_db.max,
            clip: ClipGradient::default(),
            features: None,
            train_detector: true,
        }
    }

    /// The device the networks compute on.
    pub fn device(&self) -> Device {
        self.device
    }

    /// The longest exposure a frame can have (the ACC range's maximum by default; a shorter
    /// frame interval lowers it).
    pub fn set_max_exposure(&mut self, max_exposure_s: f64) {
        self.max_exposure_s = max_exposure_s;
    }

    /// NeuralAE's learning rate (the paper's 1e-5 by default).
    pub fn set_acc_lr(&mut self, lr: f64) {
        self.acc_opt.set_lr(lr);
    }

    /// How NeuralAE outputs exposure and gain (the paper's absolute settings by default); set
    /// before training or loading.
    pub fn set_acc_output(&mut self, form: crate::acc::AccOutputForm) {
        self.bounds = self.bounds.with_form(form);
        self.acc.set_form(form);
    }

    /// The detector's Adam learning rate during joint training (the paper's 1e-4 by default).
    pub fn set_detector_lr(&mut self, lr: f64) {
        self.det.set_lr(lr);
    }

    /// How the differentiable formation's clip passes gradients.
    pub fn set_clip_gradient(&mut self, clip: ClipGradient) {
        self.clip = clip;
    }

    /// Freezes the detector (the "frozen detector" ablation) or lets it train.
    pub fn set_detector_trainable(&mut self, trainable: bool) {
        self.train_detector = trainable;
        self.det.set_trainable(trainable);
    }

    /// Loads detector weights (e.g. from `joca train-detector`).
    pub fn load_detector(&mut self, path: &Path) -> Result<(), NnError> {
        self.det.load_weights(path)
    }

    /// Writes weights and optimiser states into `dir` (four safetensors files).
    pub fn save(&self, dir: &Path) -> Result<(), NnError> {
        self.det.save_weights(&dir.join("detector.safetensors"))?;
        save_weights(&self.acc_vs, &dir.join("acc.safetensors"))?;
        self.det.save_optimizer(&dir.join("detector_optimizer.safetensors"))?;
        self.acc_opt.save(&dir.join("acc_optimizer.safetensors"))
    }

    /// Restores what [`JointModel::save`] wrote.
    pub fn load(&mut self, dir: &Path) -> Result<(), NnError> {
        self.det.load_weights(&dir.join("detector.safetensors"))?;
        load_weights(&mut self.acc_vs, &dir.join("acc.safetensors"))?;
        self.det.load_optimizer(&dir.join("detector_optimizer.safetensors"))?;
        self.acc_opt.load(&dir.join("acc_optimizer.safetensors"))
    }

    /// Forgets the previous frame (start of a new sequence).
    pub fn reset_sequence(&mut self) {
        self.features = None;
    }

    /// Whether a previous frame is known (so [`JointModel::predict`] can run).
    pub fn has_previous(&self) -> bool {
        self.features.is_some()
    }

    /// NeuralAE's prediction for the next frame from the previous frame and the settings
    /// NeuralAE predicted for it (and the iris's unit position, where it sets the iris). Returns
    /// `None` at the start of a sequence (no features yet).
    pub fn predict(
        &self,
        previous_frame: &Rgb8Image,
        previous: DynamicSettings,
        previous_iris: Option<f64>,
    ) -> Option<Prediction> {
        let features = self.features.as_ref()?;
        let out = self.acc.forward(
            &histograms(previous_frame),
            features,
            &self.bounds.previous(previous.exposure_s, previous.gain_db, previous_iris),
            self.device,
        );
        let settings =
            DynamicSettings::new(out.exposure_s.double_value(&[0]), out.gain_db.double_value(&[0]));
        let iris = out.iris.map(|u| (u.double_value(&[0]), u));
        Some(Prediction {
            settings,
            previous,
            exposure_s: out.exposure_s,
            gain_db: out.gain_db,
            iris,
        })
    }

    /// Remembers the detector features of `frame` as "the previous frame" without training
    /// (evaluation and AverageAE methods).
    pub fn observe(&mut self, frame: &Rgb8Image) -> Vec<Detection> {
        let _guard = tch::no_grad_guard();
        let out = self.det.net.forward(&image_tensor(frame, self.device));
        self.features = Some(out.features.detach());
        decode(&out, frame.width(), frame.height(), MAX_DETECTIONS, MIN_SCORE)
    }

    /// Detections in a frame, without touching the sequence state.
    pub fn detect(&self, frame: &Rgb8Image) -> Vec<Detection> {
        self.det.detect(frame)
    }

    /// Detections in several frames of one size, as one batch, without touching the sequence
    /// state.
    pub fn detect_batch(&self, frames: &[&Rgb8Image]) -> Vec<Vec<Detection>> {
        self.det.detect_batch(frames)
    }

    /// [`JointModel::detect_batch`] with the detector's convolutions in `precision`.
    pub fn detect_batch_in(
        &self,
        frames: &[&Rgb8Image],
        precision: crate::detector::Precision,
    ) -> Vec<Vec<Detection>> {
        self.det.detect_batch_in(frames, precision)
    }

    /// Detections in a frame and its detector task loss from one forward pass, without touching
    /// the sequence state (see [`crate::detector::DetectorModel::detect_with_loss`]).
    pub fn detect_with_loss(
        &self,
        frame: crate::detector::TrainFrame<'_>,
    ) -> (Vec<Detection>, crate::detector::FrameLoss) {
        self.det.detect_with_loss(frame)
    }

    /// The task loss of the frame the differentiable formation makes of `scene` at `settings`
    /// (with this model's clip gradient), and its slope by the frame's light in stops,
    /// `∂l_task/∂s` for an exposure of `E·2^s` at `s = 0`: the local pull DF-Grad's task gradient
    /// puts on the light (negative: more light lowers the loss). Nothing is updated and no weight
    /// gradient is accumulated.
    pub fn loss_slope(
        &self,
        scene: &crate::formation::Scene<'_>,
        truth: &[joca_core::Annotation],
        ignore: &[joca_core::Annotation],
        settings: DynamicSettings,
    ) -> Result<(f64, f64), NnError> {
        let kind = (tch::Kind::Float, self.device);
        let stops = Tensor::zeros([1], kind).set_requires_grad(true);
        let exposure = (&stops * std::f64::consts::LN_2).exp() * settings.exposure_s;
        let gain = Tensor::from_slice(&[settings.gain_db as f32]).to_device(self.device);
        let frame = crate::formation::form(
            scene,
            &exposure,
            &gain,
            &self.formation,
            self.clip,
            self.device,
        );
        let out = self.det.net.forward(&crate::formation::to_detector_input(&frame));
        let sz = out.heatmap.size();
        let classes = self.det.net.config().classes;
        let targets =
            crate::detector::Targets::new(truth, ignore, classes, sz[2], sz[3], self.device);
        let loss = crate::detector::DetectionLoss::new(&out, &targets).total;
        let value = loss.double_value(&[]);
        if !value.is_finite() {
            return Err(NnError::NonFinite { what: "detector", value });
        }
        let grads = Tensor::run_backward(&[&loss], &[&stops], false, false);
        Ok((value, grads[0].double_value(&[0])))
    }

    /// Each frame's detector task loss, without a gradient or an update (see
    /// [`crate::detector::DetectorModel::losses_in`]).
    pub fn losses_in(
        &self,
        batch: &[crate::detector::TrainFrame<'_>],
        precision: crate::detector::Precision,
    ) -> Result<Vec<f64>, NnError> {
        self.det.losses_in(batch, precision)
    }
}

#[cfg(test)]
mod tests;
