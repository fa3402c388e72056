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

use crate::acc::{AccBounds, NeuralAe, histograms};
use crate::detector::{
    DetectionLoss, DetectorConfig, DetectorModel, LossParts, MAX_DETECTIONS, MIN_SCORE, Targets,
    decode, image_tensor,
};
use crate::formation::{Scene, form, to_detector_input};
use crate::{Adam, AdamConfig, Engine, NnError, load_weights, save_weights};
use joca_camera::ImageFormation;
use joca_core::{Annotation, Detection, Rgb8Image};
use std::path::Path;
use tch::nn::VarStore;
use tch::{Device, Kind, Tensor};

/// Loss weights of DF-Grad (the paper's 7 : 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DfGradWeights {
    /// Weight of the task loss in the ACC's loss.
    pub task: f64,
    /// Weight of the GA supervision loss.
    pub ga: f64,
}

/// Settings predicted by NeuralAE for the next frame, as plain numbers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    /// Predicted exposure (for the calibration pixel pitch), seconds.
    pub exposure_s: f64,
    /// Predicted gain, dB.
    pub gain_db: f64,
}

/// How a step's exposure and gain are set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Exposure {
    /// By the last [`JointModel::predict`] (after Eq. 4); the ACC is trained.
    Predicted,
    /// Fixed values (AverageAE, the first frame of a sequence); no ACC gradient.
    Fixed {
        /// Exposure actually applied, seconds.
        exposure_s: f64,
        /// Gain actually applied, dB.
        gain_db: f64,
    },
}

/// What one step produced.
#[derive(Debug, Clone)]
pub struct StepReport {
    /// The 8-bit frame the detector saw.
    pub frame: Rgb8Image,
    /// Its detections (from the training forward pass).
    pub detections: Vec<Detection>,
    /// Detector loss.
    pub loss: LossParts,
    /// GA supervision loss, when a target was given.
    pub ga_loss: Option<f64>,
    /// Wall time of this step's parts, milliseconds.
    pub timings: StepTimings,
    /// Exposure applied, seconds.
    pub exposure_s: f64,
    /// Gain applied, dB.
    pub gain_db: f64,
}

/// Where a training step's time goes, milliseconds.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepTimings {
    /// Differentiable formation (Eq. 4 and Eq. 2–3 on tensors).
    pub formation_ms: f64,
    /// Detector forward pass and loss.
    pub detector_forward_ms: f64,
    /// Backward pass through detector, formation and NeuralAE.
    pub backward_ms: f64,
    /// Optimiser updates of detector and NeuralAE.
    pub update_ms: f64,
    /// Decoding the detections.
    pub decode_ms: f64,
}

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
    pending: Option<(Tensor, Tensor)>,
    features: Option<Tensor>,
    train_detector: bool,
}

fn unit_tensor(value: &Tensor, range: (f64, f64)) -> Tensor {
    (value - range.0) / (range.1 - range.0)
}

impl JointModel {
    /// Fresh networks (initialised from libtorch's seeded generator).
    pub fn new(
        engine: &Engine,
        detector: DetectorConfig,
        bounds: AccBounds,
        formation: ImageFormation,
    ) -> Self {
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
            pending: None,
            features: None,
            train_detector: true,
        }
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
        self.pending = None;
        self.features = None;
    }

    /// Whether a previous frame is known (so [`JointModel::predict`] can run).
    pub fn has_previous(&self) -> bool {
        self.features.is_some()
    }

    /// NeuralAE's prediction for the next frame from the previous frame and its settings.
    /// Returns `None` at the start of a sequence.
    pub fn predict(
        &mut self,
        previous: &Rgb8Image,
        previous_exposure_s: f64,
        previous_gain_db: f64,
    ) -> Option<Prediction> {
        let features = self.features.as_ref()?;
        let out = self.acc.forward(
            &histograms(previous),
            features,
            self.bounds.unit(previous_exposure_s, previous_gain_db),
            self.device,
        );
        let p = Prediction {
            exposure_s: out.exposure_s.double_value(&[0]),
            gain_db: out.gain_db.double_value(&[0]),
        };
        self.pending = Some((out.exposure_s, out.gain_db));
        Some(p)
    }

    /// One training step on a rendered frame (see the module documentation). `ga_target` is the
    /// best perturbed `(exposure s, gain dB)` when the GA loss applies this step.
    pub fn step(
        &mut self,
        scene: &Scene<'_>,
        truth: &[Annotation],
        ignore: &[Annotation],
        exposure: Exposure,
        ga_target: Option<(f64, f64)>,
        weights: DfGradWeights,
    ) -> Result<StepReport, NnError> {
        let pending = if exposure == Exposure::Predicted { self.pending.take() } else { None };
        let (e_t, g_t, pred) = match (&pending, exposure) {
            (Some((e_pred, g_pred)), _) => {
                let (e, g) = eq4(
                    e_pred,
                    g_pred,
                    scene.pixel_pitch_um,
                    self.formation.calibration().pixel_pitch_um,
                );
                (e, g, Some((e_pred, g_pred)))
            }
            (None, Exposure::Fixed { exposure_s, gain_db }) => (
                Tensor::from_slice(&[exposure_s as f32]).to_device(self.device),
                Tensor::from_slice(&[gain_db as f32]).to_device(self.device),
                None,
            ),
            (None, Exposure::Predicted) => {
                return Err(NnError::Weights {
                    path: "(none)".into(),
                    reason: "step(Predicted) without a prediction".into(),
                });
            }
        };
        let mut timings = StepTimings::default();
        let mut clock = std::time::Instant::now();
        let mut lap = |slot: &mut f64| {
            *slot = clock.elapsed().as_secs_f64() * 1e3;
            clock = std::time::Instant::now();
        };
        let frame_dn = form(scene, &e_t, &g_t, &self.formation, self.device);
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
        if let (Some((e_pred, g_pred)), Some((e_star, g_star))) = (pred, ga_target) {
            let e_unit = unit_tensor(&e_pred.log(), self.bounds.log_exposure);
            let g_unit = unit_tensor(g_pred, self.bounds.gain_db);
            let e_star_unit = (e_star.ln() - self.bounds.log_exposure.0)
                / (self.bounds.log_exposure.1 - self.bounds.log_exposure.0);
            let g_star_unit =
                (g_star - self.bounds.gain_db.0) / (self.bounds.gain_db.1 - self.bounds.gain_db.0);
            let l_ga = ((e_unit - e_star_unit).abs() + (g_unit - g_star_unit).abs())
                .mean(Kind::Float)
                / 2.0;
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
            timings,
            exposure_s: e_t.double_value(&[0]),
            gain_db: g_t.double_value(&[0]),
        })
    }

    /// Remembers the detector features of `frame` as "the previous frame" without training
    /// (evaluation and AverageAE methods).
    pub fn observe(&mut self, frame: &Rgb8Image) -> Vec<Detection> {
        let _guard = tch::no_grad_guard();
        let out = self.det.net.forward(&image_tensor(frame, self.device));
        self.features = Some(out.features.detach());
        self.pending = None;
        decode(&out, frame.width(), frame.height(), MAX_DETECTIONS, MIN_SCORE)
    }

    /// Detections in a frame, without touching the sequence state.
    pub fn detect(&self, frame: &Rgb8Image) -> Vec<Detection> {
        self.det.detect(frame)
    }
}

/// Eq. 4 on tensors (linear gain inside, dB outside), as `joca_camera::compensate_for_pixel_size`.
fn eq4(
    e_pred: &Tensor,
    g_pred_db: &Tensor,
    pitch_um: f64,
    calibration_pitch_um: f64,
) -> (Tensor, Tensor) {
    let area = (pitch_um / calibration_pitch_um).powi(2);
    if area > 1.0 {
        let g_lin = (g_pred_db / 20.0 * std::f64::consts::LN_10).exp();
        let g_t = (&g_lin / area).clamp_min(1.0);
        let e_t = e_pred * &g_lin / (&g_t * area);
        (e_t, g_t.log10() * 20.0)
    } else {
        (e_pred / area, g_pred_db.shallow_clone())
    }
}

fn tensor_to_rgb8(frame_dn: &Tensor) -> Rgb8Image {
    let s = frame_dn.size();
    let (h, w) = (s[2] as usize, s[3] as usize);
    let bytes: Vec<u8> = Vec::try_from(
        frame_dn
            .detach()
            .squeeze_dim(0)
            .permute([1, 2, 0])
            .contiguous()
            .view([-1])
            .clamp(0.0, 255.0)
            .to_kind(Kind::Uint8),
    )
    .unwrap_or_else(|_| vec![0; w * h * 3]);
    Rgb8Image::from_vec(w, h, bytes).unwrap_or_else(|_| Rgb8Image::zeros(w, h))
}
