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
//!
//! With a moving iris NeuralAE also predicts the iris's unit position `u`; the light it lets
//! through, `(N0/N(u))²`, multiplies Eq. 2's signal as exposure does, so the task loss reaches
//! `u` through the frame's brightness and noise (its defocus, like the exposure's blur, only
//! through the perturbation search), and `l_GA` averages `|ũ* − u|` in as a third term.

mod equations;
mod step;

use crate::acc::{AccBounds, NeuralAe, histograms};
use crate::detector::{
    DetectionLoss, DetectorConfig, DetectorModel, LossParts, MAX_DETECTIONS, MIN_SCORE, Targets,
    decode, image_tensor,
};
use crate::formation::{ClipGradient, Scene, form, to_detector_input};
use crate::{Adam, AdamConfig, Engine, NnError, load_weights, save_weights};
use equations::{
    eq4, ga_supervision_loss, iris_light_gradient, limit_exposure, task_gradient_units,
    tensor_to_rgb8,
};
use joca_camera::{AccRanges, DynamicSettings, ImageFormation};
use joca_core::{Annotation, Detection, Rgb8Image};
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
        Some(Prediction { settings, exposure_s: out.exposure_s, gain_db: out.gain_db, iris })
    }

    /// One training step on a rendered frame (see the module documentation). `ga_target` is the
    /// best perturbation (for the calibration pitch) when the GA loss applies this step. The
    /// scene's `light_factor` is that of the frame's f-number; with a predicted iris,
    /// `scene.iris` is the lens's iris it moves in.
    pub fn step(
        &mut self,
        scene: &Scene<'_>,
        truth: &[Annotation],
        ignore: &[Annotation],
        exposure: Exposure,
        ga_target: Option<GaTarget>,
        weights: DfGradWeights,
    ) -> Result<StepReport, NnError> {
        let (e_t, g_t, pred) = match &exposure {
            Exposure::Predicted(p) => {
                let (e, g) = eq4(
                    &p.exposure_s,
                    &p.gain_db,
                    scene.pixel_pitch_um,
                    self.formation.calibration().pixel_pitch_um,
                );
                let (e, g) = limit_exposure(&e, &g, self.max_exposure_s, self.max_gain_db);
                (e, g, Some(p))
            }
            Exposure::Fixed(applied) => (
                Tensor::from_slice(&[applied.exposure_s as f32]).to_device(self.device),
                Tensor::from_slice(&[applied.gain_db as f32]).to_device(self.device),
                None,
            ),
        };
        // The iris's light enters Eq. 2 as exposure does: the frame is formed with the scene's
        // light factor (its f-number's), and the predicted iris's gradient rides on the exposure.
        let iris = pred.and_then(|p| p.iris.as_ref()).zip(scene.iris);
        let e_form = match iris {
            Some(((_, u), lens)) => &e_t * iris_light_gradient(u, lens),
            None => e_t.shallow_clone(),
        };
        let mut timings = StepTimings::default();
        let mut clock = std::time::Instant::now();
        let mut lap = |slot: &mut f64| {
            *slot = clock.elapsed().as_secs_f64() * 1e3;
            clock = std::time::Instant::now();
        };
        // Probes, zero in value: after the backward they hold the task loss's gradient by the
        // frame's exposure and gain (l_GA does not pass through the frame).
        let probes = pred.map(|_| {
            let zero =
                || Tensor::zeros([1], (tch::Kind::Float, self.device)).set_requires_grad(true);
            (zero(), zero())
        });
        let (e_in, g_in) = match &probes {
            Some((pe, pg)) => (&e_form + pe, &g_t + pg),
            None => (e_form.shallow_clone(), g_t.shallow_clone()),
        };
        let frame_dn = form(scene, &e_in, &g_in, &self.formation, self.clip, self.device);
        lap(&mut timings.formation_ms);
        let out = self.det.net.forward(&to_detector_input(&frame_dn));
        let s = out.heatmap.size();
        let classes = self.det.net.config().classes;
        let targets = Targets::new(truth, ignore, classes, s[2], s[3], self.device);
        let loss = DetectionLoss::new(&out, &targets);
        let task = loss.total.double_value(&[]);
        if !task.is_finite() {
            return Err(NnError::NonFinite { what: "detector", value: task });
        }
        // Backward once: detector gradients = ∇ l_task; ACC gradients are rescaled below so that
        // they become ∇ (w_task·l_task + w_ga·l_GA).
        let mut ga_loss = None;
        let mut objective = loss.total.shallow_clone();
        if let (Some(p), Some(target)) = (pred, ga_target) {
            let iris = p.iris.as_ref().map(|(_, u)| u);
            let l_ga = ga_supervision_loss(&p.exposure_s, &p.gain_db, iris, target, &self.bounds);
            let v = l_ga.double_value(&[]);
            if !v.is_finite() {
                return Err(NnError::NonFinite { what: "GA supervision", value: v });
            }
            ga_loss = Some(v);
            objective += l_ga * (weights.ga / weights.task);
        }
        self.det.optimizer.zero_grad();
        self.acc_opt.zero_grad();
        lap(&mut timings.detector_forward_ms);
        // With a frozen detector and no prediction (the first frame of a sequence runs at fixed
        // settings) nothing in the graph is trainable: there is nothing to back-propagate.
        if objective.requires_grad() {
            objective.backward();
        }
        lap(&mut timings.backward_ms);
        let task_gradient = probes.and_then(|(pe, pg)| {
            let (ge, gg) = (pe.grad(), pg.grad());
            (ge.defined() && gg.defined()).then(|| {
                task_gradient_units(
                    ge.double_value(&[0]),
                    gg.double_value(&[0]),
                    e_form.double_value(&[0]),
                    &self.bounds,
                    weights.task,
                )
            })
        });
        if self.train_detector {
            self.det.optimizer.step();
        }
        if pred.is_some() {
            let _guard = tch::no_grad_guard();
            for v in self.acc_vs.trainable_variables() {
                let mut g = v.grad();
                if g.defined() {
                    let _ = g.g_mul_scalar_(weights.task);
                }
            }
            self.acc_opt.step();
        }
        lap(&mut timings.update_ms);
        self.features = Some(out.features.detach());
        let frame = tensor_to_rgb8(&frame_dn);
        let detections = decode(&out, scene.width, scene.height, MAX_DETECTIONS, MIN_SCORE);
        lap(&mut timings.decode_ms);
        Ok(StepReport {
            frame,
            detections,
            loss: LossParts {
                total: task,
                heatmap: loss.heatmap,
                size: loss.size,
                offset: loss.offset,
            },
            ga_loss,
            task_gradient,
            timings,
            applied: DynamicSettings::new(e_t.double_value(&[0]), g_t.double_value(&[0])),
        })
    }

    /// One imitation step of NeuralAE alone (its warm start): `prediction` (made by
    /// [`JointModel::predict`]) is pulled towards `target` by `l_GA`'s L1 in normalised units,
    /// with learning rate `lr`; the detector does not change. Returns the loss before the step.
    pub fn imitate(
        &mut self,
        prediction: &Prediction,
        target: GaTarget,
        lr: f64,
    ) -> Result<f64, NnError> {
        let iris = prediction.iris.as_ref().map(|(_, u)| u);
        let loss = ga_supervision_loss(
            &prediction.exposure_s,
            &prediction.gain_db,
            iris,
            target,
            &self.bounds,
        );
        let v = loss.double_value(&[]);
        if !v.is_finite() {
            return Err(NnError::NonFinite { what: "imitation", value: v });
        }
        let trained_lr = self.acc_opt.config().lr;
        self.acc_opt.zero_grad();
        loss.backward();
        self.acc_opt.set_lr(lr);
        self.acc_opt.step();
        self.acc_opt.set_lr(trained_lr);
        Ok(v)
    }

    /// Starts NeuralAE's optimiser afresh (zero moments, step 0) at its learning rate: DF-Grad
    /// after a warm start begins as it would from initialised weights.
    pub fn restart_acc_optimizer(&mut self) {
        let lr = self.acc_opt.config().lr;
        self.acc_opt = Adam::new(&self.acc_vs, AdamConfig { lr, ..AdamConfig::ACC });
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
