//! Exposure control in closed loop: a controller sets the exposure and gain of frame t from
//! frame t − 1. NeuralAE (the paper's ACC, trained with DF-Grad) and AverageAE (TaCOS's
//! baseline) implement one interface, [`ExposureControl`], which the joint loop and the
//! closed-loop test drive alike.
//!
//! NeuralAE predicts settings for the calibration pixel pitch p0; [`NeuralControl`] applies
//! paper Eq. 4 (`joca_camera::compensate_for_pixel_size`) to turn them into what the sensor
//! uses — the one place Eq. 4 is applied to plain numbers (the joint model differentiates a
//! tensor twin of it, tested equal). AverageAE works on the sensor's own settings.

use joca_camera::{AccRanges, AverageAe, Calibration, DynamicSettings, compensate_for_pixel_size};
use joca_core::Rgb8Image;
use joca_nn::joint::{Exposure, JointModel, Prediction};

/// The settings of one frame, and NeuralAE's prediction behind them (which a training step
/// differentiates through).
#[derive(Debug)]
pub struct Decision {
    /// What the sensor uses.
    pub applied: DynamicSettings,
    /// NeuralAE's prediction (for the calibration pitch), if NeuralAE set `applied`.
    pub prediction: Option<Prediction>,
}

impl Decision {
    /// How the joint model's step is to set the frame's exposure.
    pub fn into_exposure(self) -> Exposure {
        match self.prediction {
            Some(p) => Exposure::Predicted(p),
            None => Exposure::Fixed(self.applied),
        }
    }
}

/// A closed-loop exposure controller.
pub trait ExposureControl {
    /// Starts a sequence: the settings of its first frame (the calibration camera's E0, G0).
    fn start(&mut self) -> DynamicSettings;

    /// The settings of the next frame, from the sequence's last 8-bit frame. NeuralAE also
    /// reads `model`'s detector features of that frame.
    fn next(&mut self, model: &JointModel, last: &Rgb8Image) -> Decision;
}

/// The calibration camera's settings, where every sequence starts.
fn calibration_settings() -> DynamicSettings {
    let cal = Calibration::DEFAULT;
    DynamicSettings::new(cal.exposure_s, cal.gain_db)
}

/// NeuralAE for a sensor of pitch `pixel_pitch_um`.
#[derive(Debug, Clone, Copy)]
pub struct NeuralControl {
    pixel_pitch_um: f64,
    /// NeuralAE's last prediction (its input for the next frame).
    predicted: DynamicSettings,
    /// The settings the sensor last used.
    applied: DynamicSettings,
}

impl NeuralControl {
    /// NeuralAE driving a sensor of pitch `pixel_pitch_um`.
    pub fn new(pixel_pitch_um: f64) -> Self {
        let start = calibration_settings();
        Self { pixel_pitch_um, predicted: start, applied: start }
    }
}

impl ExposureControl for NeuralControl {
    fn start(&mut self) -> DynamicSettings {
        *self = Self::new(self.pixel_pitch_um);
        self.applied
    }

    fn next(&mut self, model: &JointModel, last: &Rgb8Image) -> Decision {
        match model.predict(last, self.predicted) {
            Some(p) => {
                self.predicted = p.settings();
                self.applied = compensate_for_pixel_size(
                    self.predicted,
                    self.pixel_pitch_um,
                    Calibration::DEFAULT.pixel_pitch_um,
                );
                Decision { applied: self.applied, prediction: Some(p) }
            }
            // No features of a previous frame yet: keep the settings.
            None => Decision { applied: self.applied, prediction: None },
        }
    }
}

/// AverageAE (TaCOS's baseline): the sensor's settings scaled towards a mean of half the range.
#[derive(Debug, Clone, Copy)]
pub struct AverageControl {
    ae: AverageAe,
    applied: DynamicSettings,
}

impl AverageControl {
    /// AverageAE within `ranges`.
    pub fn new(ranges: AccRanges) -> Self {
        Self { ae: AverageAe::new(ranges), applied: calibration_settings() }
    }

    /// The settings after `last`, taken with the settings last returned.
    pub fn step(&mut self, last: &Rgb8Image) -> DynamicSettings {
        self.applied = self.ae.step(self.applied, last);
        self.applied
    }
}

impl ExposureControl for AverageControl {
    fn start(&mut self) -> DynamicSettings {
        self.applied = calibration_settings();
        self.applied
    }

    fn next(&mut self, _model: &JointModel, last: &Rgb8Image) -> Decision {
        Decision { applied: self.step(last), prediction: None }
    }
}

/// The controller of a method: NeuralAE, or AverageAE for `tacos-average`.
pub(crate) fn controller(
    neural: bool,
    pixel_pitch_um: f64,
    ranges: AccRanges,
) -> Box<dyn ExposureControl> {
    if neural {
        Box::new(NeuralControl::new(pixel_pitch_um))
    } else {
        Box::new(AverageControl::new(ranges))
    }
}
