//! How the controller and the detector learn in `[run]`, beyond the paper's recipe: NeuralAE's
//! output form (`acc_output`), its warm start (`warm_start`) and the detector's learning rate
//! (`detector_lr`); the learning fields' part of [`RunConfig::validate`].

use super::RunConfig;
use crate::TrainError;
use joca_nn::acc::AccOutputForm;
use serde::{Deserialize, Serialize};

impl RunConfig {
    /// The learning fields' part of [`RunConfig::validate`]: the rates, the warm start, the
    /// loss weights and the smallest training box.
    pub(super) fn validate_learning(&self) -> Result<(), TrainError> {
        let bad = super::checks::refuse;
        if !(self.acc_lr > 0.0 && self.acc_lr <= 0.1) {
            return bad("acc_lr", self.acc_lr.to_string(), "above 0, at most 0.1");
        }
        self.warm_start.check()?;
        check_detector_lr(self.detector_lr)?;
        if !(self.task_weight > 0.0 && self.task_weight <= 1000.0) {
            return bad("task_weight", self.task_weight.to_string(), "above 0, at most 1000");
        }
        if !(0.0..=1000.0).contains(&self.step_weight) {
            let allowed = "0 (no step cost, the paper's) to 1000";
            return bad("step_weight", self.step_weight.to_string(), allowed);
        }
        if !(1.0..=64.0).contains(&self.min_box_px) {
            let allowed = "1 (every reference object) to 64";
            return bad("min_box_px", self.min_box_px.to_string(), allowed);
        }
        Ok(())
    }
}

/// The longest warm start, frames.
pub const MAX_WARM_START_FRAMES: usize = 100_000;

/// NeuralAE's warm start (`warm_start = { frames, lr }`): before DF-Grad, NeuralAE drives the
/// first generation's designs through the training towns and learns, frame by frame, the
/// settings AverageAE (mid-grey) would choose from where it stands (its previous prediction and
/// frame), so DF-Grad starts from a controller that follows the light. Off (0 frames) by default:
/// the paper starts DF-Grad from initialised weights.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WarmStart {
    /// Imitation frames (0: none).
    pub frames: usize,
    /// NeuralAE's Adam learning rate while it imitates.
    #[serde(default = "default_warm_start_lr")]
    pub lr: f64,
}

/// NeuralAE's imitation learning rate: at 1e-3 its outputs saturated at a range's end within a
/// few hundred frames; at 1e-4 it followed AverageAE (docs/results/2026-12-03-controller-training.md).
fn default_warm_start_lr() -> f64 {
    1e-4
}

impl Default for WarmStart {
    fn default() -> Self {
        Self { frames: 0, lr: default_warm_start_lr() }
    }
}

impl WarmStart {
    /// Whether there is none (the field is then left out of saved configurations).
    pub fn is_off(&self) -> bool {
        self.frames == 0
    }

    /// Checks the ranges, naming `run.warm_start.<field>`.
    pub(super) fn check(&self) -> Result<(), TrainError> {
        let bad = |field: &str, value: String, allowed: &str| {
            Err(TrainError::Config {
                field: format!("run.warm_start.{field}"),
                value,
                allowed: allowed.into(),
            })
        };
        if self.frames > MAX_WARM_START_FRAMES {
            return bad(
                "frames",
                self.frames.to_string(),
                &format!("0 to {MAX_WARM_START_FRAMES}"),
            );
        }
        if !(self.lr > 0.0 && self.lr <= 0.1) {
            return bad("lr", self.lr.to_string(), "above 0, at most 0.1");
        }
        Ok(())
    }
}

/// The default scoring precision: bfloat16 where the CPU has it natively (float32 elsewhere,
/// by [`joca_nn::detector::Precision::on_this_cpu`]).
pub(super) fn bf16_where_native() -> joca_nn::detector::Precision {
    joca_nn::detector::Precision::Bf16
}

pub(super) fn paper_acc_lr() -> f64 {
    joca_nn::AdamConfig::ACC.lr
}

/// The paper's detector learning rate in joint training (AdamW 1e-4).
pub(super) fn paper_detector_lr() -> f64 {
    joca_nn::AdamConfig::DETECTOR.lr
}

/// Whether `lr` is the paper's (the field is then left out of saved configurations).
pub(super) fn is_paper_detector_lr(lr: &f64) -> bool {
    *lr == paper_detector_lr()
}

/// Checks `run.detector_lr`: above 0 (a detector that must not learn is `frozen-detector`'s), at
/// most 0.1.
pub(super) fn check_detector_lr(lr: f64) -> Result<(), TrainError> {
    if lr > 0.0 && lr <= 0.1 {
        return Ok(());
    }
    Err(TrainError::Config {
        field: "run.detector_lr".into(),
        value: lr.to_string(),
        allowed: "above 0, at most 0.1 (method = \"frozen-detector\" keeps it fixed)".into(),
    })
}

/// Whether the step cost's weight is 0, the paper's loss (the field is then left out of saved
/// configurations).
pub(super) fn is_zero(w: &f64) -> bool {
    *w == 0.0
}

/// The smallest box side, px, the joint loop trains on by default (the pretraining's).
pub(super) fn training_min_box_px() -> f64 {
    f64::from(joca_core::TRAINING_MIN_BOX_PX)
}

/// Whether `min_box_px` is the default (the field is then left out of saved configurations).
pub(super) fn is_training_min_box_px(px: &f64) -> bool {
    *px == training_min_box_px()
}

/// The largest per-frame step `acc_output = "relative:S"` allows, stops.
pub const MAX_RELATIVE_STOPS: f64 = 8.0;

/// How NeuralAE outputs exposure and gain (`acc_output`): `"absolute"` (the paper's: settings
/// within the ranges) or `"relative:S"` (a step from the previous frame's settings, at most S
/// stops of each of exposure and gain a frame, S in (0, 8]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AccOutput(pub AccOutputForm);

impl AccOutput {
    /// Reads `absolute` or `relative:S`, naming what is allowed.
    pub fn parse(text: &str) -> Result<Self, String> {
        let allowed = format!(
            "\"absolute\" or \"relative:S\" with S the largest step a frame, above 0 and at most \
             {MAX_RELATIVE_STOPS} stops"
        );
        if text == "absolute" {
            return Ok(Self(AccOutputForm::Absolute));
        }
        let stops = text
            .strip_prefix("relative:")
            .and_then(|s| s.parse::<f64>().ok())
            .filter(|s| *s > 0.0 && *s <= MAX_RELATIVE_STOPS)
            .ok_or_else(|| format!("\"{text}\": expected {allowed}"))?;
        Ok(Self(AccOutputForm::Relative { max_stops: stops }))
    }

    /// Whether this is the paper's (the field is then left out of saved configurations).
    pub fn is_absolute(&self) -> bool {
        self.0 == AccOutputForm::Absolute
    }
}

impl std::fmt::Display for AccOutput {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.0 {
            AccOutputForm::Absolute => f.write_str("absolute"),
            AccOutputForm::Relative { max_stops } => write!(f, "relative:{max_stops}"),
        }
    }
}

joca_core::serde_as_text!(AccOutput, AccOutput::parse);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn acc_output_reads_both_forms_and_refuses_others_naming_the_range() {
        assert!(AccOutput::parse("absolute").unwrap().is_absolute());
        let r = AccOutput::parse("relative:3").unwrap();
        assert_eq!(r.0, AccOutputForm::Relative { max_stops: 3.0 });
        assert_eq!(r.to_string(), "relative:3");
        for bad in ["relative", "relative:0", "relative:9", "relative:x", "stops"] {
            let e = AccOutput::parse(bad).unwrap_err();
            assert!(e.contains("at most 8 stops") && e.contains(bad), "{e}");
        }
        assert!(WarmStart { frames: 10, lr: 1e-3 }.check().is_ok());
        let e = WarmStart { frames: 100_001, lr: 1e-3 }.check().unwrap_err().to_string();
        assert!(e.contains("run.warm_start.frames") && e.contains("0 to 100000"), "{e}");
        let e = WarmStart { frames: 10, lr: 0.0 }.check().unwrap_err().to_string();
        assert!(e.contains("run.warm_start.lr") && e.contains("at most 0.1"), "{e}");
        let e = check_detector_lr(0.0).unwrap_err().to_string();
        assert!(e.contains("run.detector_lr") && e.contains("frozen-detector"), "{e}");
    }
}
