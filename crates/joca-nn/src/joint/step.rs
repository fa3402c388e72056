//! What a joint step takes and gives: DF-Grad's loss weights, NeuralAE's prediction and the
//! GA's target, how a frame's exposure is set, and the step's report and timings.

use crate::detector::LossParts;
use joca_camera::DynamicSettings;
use joca_core::{Detection, Rgb8Image};
use tch::Tensor;

/// Loss weights of DF-Grad (the paper's 7 : 1, and no step cost).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DfGradWeights {
    /// Weight of the task loss in the ACC's loss.
    pub task: f64,
    /// Weight of the GA supervision loss.
    pub ga: f64,
    /// Weight of the step cost `l_step` (beyond the paper: 0 there), the cost of moving
    /// exposure and gain from the settings NeuralAE read.
    pub step: f64,
}

/// NeuralAE's prediction for the next frame ([`JointModel::predict`]): the settings for the
/// calibration pixel pitch, and the network outputs they came from, which a training step
/// ([`JointModel::step`] with [`Exposure::Predicted`]) differentiates through.
#[derive(Debug)]
pub struct Prediction {
    pub(super) settings: DynamicSettings,
    /// The settings NeuralAE read (the previous frame's, for the calibration pitch).
    pub(super) previous: DynamicSettings,
    pub(super) exposure_s: Tensor,
    pub(super) gain_db: Tensor,
    /// The iris's unit position, as a number and as the network's output.
    pub(super) iris: Option<(f64, Tensor)>,
}

impl Prediction {
    /// Predicted exposure and gain for the calibration pixel pitch (before Eq. 4).
    pub fn settings(&self) -> DynamicSettings {
        self.settings
    }

    /// The iris's predicted unit position (`joca_camera::Iris`), where NeuralAE sets it.
    pub fn iris(&self) -> Option<f64> {
        self.iris.as_ref().map(|(u, _)| *u)
    }
}

/// The best perturbation of a search, the target of `l_GA`: settings for the calibration pitch,
/// and the iris's unit position where NeuralAE sets it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaTarget {
    /// Exposure and gain.
    pub settings: DynamicSettings,
    /// The iris's unit position.
    pub iris: Option<f64>,
}

/// How a step's exposure and gain are set.
#[derive(Debug)]
pub enum Exposure {
    /// By NeuralAE (Eq. 4 applied for the sensor's pixel pitch); the ACC is trained.
    Predicted(Prediction),
    /// Fixed settings as applied to the sensor (AverageAE, the first frame of a sequence); no
    /// ACC gradient.
    Fixed(DynamicSettings),
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
    /// The step cost `l_step`, where NeuralAE set the frame and its weight is above 0.
    pub step_loss: Option<f64>,
    /// The task loss's pull on NeuralAE's exposure and gain outputs in l_GA's units
    /// (`w_task · ∂l_task/∂u`; negative: more light lowers the loss), where NeuralAE set the
    /// frame.
    pub task_gradient: Option<[f64; 2]>,
    /// Wall time of this step's parts, milliseconds.
    pub timings: StepTimings,
    /// Exposure and gain applied to the sensor.
    pub applied: DynamicSettings,
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
