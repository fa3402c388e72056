//! How the joint model learns: DF-Grad's training step (detector and NeuralAE together, see the
//! module documentation of [`super`]) and NeuralAE's imitation warm start.

use super::JointModel;
use super::equations::{
    eq4, ga_supervision_loss, iris_light_gradient, limit_exposure, step_cost, task_gradient_units,
    tensor_to_rgb8,
};
use super::step::{DfGradWeights, Exposure, GaTarget, Prediction, StepReport, StepTimings};
use crate::detector::{DetectionLoss, LossParts, MAX_DETECTIONS, MIN_SCORE, Targets, decode};
use crate::formation::{Scene, form, to_detector_input};
use crate::{Adam, AdamConfig, NnError};
use joca_camera::DynamicSettings;
use joca_core::Annotation;
use tch::Tensor;

impl JointModel {
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
        // they become ∇ (w_task·l_task + w_ga·l_GA + w_step·l_step).
        let extra = pred.map(|p| self.acc_terms(p, ga_target, weights)).transpose()?;
        let (ga_loss, step_loss) = extra.as_ref().map_or((None, None), |x| (x.ga, x.step));
        let objective = match extra.and_then(|x| x.loss) {
            Some(l) => &loss.total + l,
            None => loss.total.shallow_clone(),
        };
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
            step_loss,
            task_gradient,
            timings,
            applied: DynamicSettings::new(e_t.double_value(&[0]), g_t.double_value(&[0])),
        })
    }

    /// NeuralAE's loss terms beside the task's, divided by the task's weight (the ACC's
    /// gradients are multiplied by it after the backward): `w_ga·l_GA` where a GA target is
    /// given and `w_step·l_step` where its weight is above 0.
    fn acc_terms(
        &self,
        p: &Prediction,
        ga_target: Option<GaTarget>,
        weights: DfGradWeights,
    ) -> Result<AccTerms, NnError> {
        let finite = |t: &Tensor, what: &'static str| {
            let v = t.double_value(&[]);
            if v.is_finite() { Ok(v) } else { Err(NnError::NonFinite { what, value: v }) }
        };
        let mut terms = AccTerms { loss: None, ga: None, step: None };
        let mut add = |t: Tensor| {
            terms.loss = Some(match terms.loss.take() {
                Some(l) => l + t,
                None => t,
            })
        };
        if let Some(target) = ga_target {
            let iris = p.iris.as_ref().map(|(_, u)| u);
            let l_ga = ga_supervision_loss(&p.exposure_s, &p.gain_db, iris, target, &self.bounds);
            let v = finite(&l_ga, "GA supervision")?;
            add(l_ga * (weights.ga / weights.task));
            terms.ga = Some(v);
        }
        if weights.step > 0.0 {
            let l_step = step_cost(&p.exposure_s, &p.gain_db, p.previous);
            let v = finite(&l_step, "step cost")?;
            add(l_step * (weights.step / weights.task));
            terms.step = Some(v);
        }
        Ok(terms)
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
}

/// NeuralAE's loss terms beside the task's ([`JointModel::acc_terms`]): their weighted sum over
/// the task's weight, and each one's value.
struct AccTerms {
    loss: Option<Tensor>,
    ga: Option<f64>,
    step: Option<f64>,
}
