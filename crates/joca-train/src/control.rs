//! Exposure control in closed loop: a controller sets the exposure and gain of frame t from
//! frame t − 1. NeuralAE (the paper's ACC, trained with DF-Grad) and AverageAE (TaCOS's
//! baseline) implement one interface, [`ExposureControl`], which the joint loop and the
//! closed-loop test drive alike.
//!
//! NeuralAE predicts settings for the calibration pixel pitch p0; [`for_sensor`] applies paper
//! Eq. 4 (`joca_camera::compensate_for_pixel_size`) and caps the exposure at what a frame can
//! have (`joca_camera::limit_exposure`) to turn them into what the sensor uses — the one place
//! this is done to plain numbers (the joint model differentiates a tensor twin of it, tested
//! equal). AverageAE works on the sensor's own settings.

use joca_camera::{
    AccRanges, AverageAe, Calibration, DynamicSettings, Iris, MID_GREY_DN,
    compensate_for_pixel_size, limit_exposure,
};
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

    /// The f-number of the frame last set (by [`Self::start`] or [`Self::next`]) where the
    /// controller moves the iris; `None`: the lens's own.
    fn f_number(&self) -> Option<f64> {
        None
    }
}

/// The sensor a controller drives: its pixel pitch and the longest exposure and highest gain it
/// can apply.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorLimits {
    /// Pixel pitch, µm.
    pub pixel_pitch_um: f64,
    /// The ACC range's maximum, or the frame interval if shorter, s.
    pub max_exposure_s: f64,
    /// The ACC range's maximum gain, dB.
    pub max_gain_db: f64,
    /// The lens's iris where the controller sets the aperture too (`[run] aperture =
    /// "dynamic"`).
    pub iris: Option<Iris>,
}

impl SensorLimits {
    /// A sensor of pitch `pixel_pitch_um` within `ranges`, taking a frame every
    /// `frame_interval_s`.
    pub fn new(pixel_pitch_um: f64, ranges: AccRanges, frame_interval_s: f64) -> Self {
        Self {
            pixel_pitch_um,
            max_exposure_s: ranges.exposure_s.max.min(frame_interval_s),
            max_gain_db: ranges.gain_db.max,
            iris: None,
        }
    }

    /// The same sensor behind a lens whose iris the controller sets.
    pub fn with_iris(self, iris: Option<Iris>) -> Self {
        Self { iris, ..self }
    }
}

/// Settings NeuralAE predicted for the calibration pitch, as `sensor` applies them: Eq. 4, then
/// the exposure capped with gain making up the rest.
pub fn for_sensor(predicted: DynamicSettings, sensor: &SensorLimits) -> DynamicSettings {
    let p0 = Calibration::DEFAULT.pixel_pitch_um;
    let applied = compensate_for_pixel_size(predicted, sensor.pixel_pitch_um, p0);
    limit_exposure(applied, sensor.max_exposure_s, sensor.max_gain_db)
}

/// The calibration camera's settings, where every sequence starts.
fn calibration_settings() -> DynamicSettings {
    let cal = Calibration::DEFAULT;
    DynamicSettings::new(cal.exposure_s, cal.gain_db)
}

/// NeuralAE driving one sensor.
#[derive(Debug, Clone, Copy)]
pub struct NeuralControl {
    sensor: SensorLimits,
    /// NeuralAE's last prediction (its input for the next frame).
    predicted: DynamicSettings,
    /// The settings the sensor last used.
    applied: DynamicSettings,
    /// The iris's last unit position, where NeuralAE sets it (a sequence starts at
    /// [`Iris::START_UNIT`]).
    iris: Option<f64>,
}

impl NeuralControl {
    /// NeuralAE driving `sensor`.
    pub fn new(sensor: SensorLimits) -> Self {
        let start = calibration_settings();
        Self {
            sensor,
            predicted: start,
            applied: start,
            iris: sensor.iris.map(|_| Iris::START_UNIT),
        }
    }
}

impl NeuralControl {
    /// NeuralAE driving `sensor` from a prediction of `predicted` (the settings of the
    /// sequence's first frame, for the calibration pitch) instead of the calibration's.
    pub fn starting_at(sensor: SensorLimits, predicted: DynamicSettings) -> Self {
        Self { predicted, applied: for_sensor(predicted, &sensor), ..Self::new(sensor) }
    }

    /// The settings the sensor last used.
    pub fn applied(&self) -> DynamicSettings {
        self.applied
    }

    /// NeuralAE's last prediction, for the calibration pitch.
    pub fn predicted(&self) -> DynamicSettings {
        self.predicted
    }
}

impl ExposureControl for NeuralControl {
    fn start(&mut self) -> DynamicSettings {
        *self = Self::new(self.sensor);
        self.applied
    }

    fn next(&mut self, model: &JointModel, last: &Rgb8Image) -> Decision {
        match model.predict(last, self.predicted, self.iris) {
            Some(p) => {
                self.predicted = p.settings();
                self.applied = for_sensor(self.predicted, &self.sensor);
                if self.sensor.iris.is_some() {
                    self.iris = p.iris();
                }
                Decision { applied: self.applied, prediction: Some(p) }
            }
            // No features of a previous frame yet: keep the settings.
            None => Decision { applied: self.applied, prediction: None },
        }
    }

    fn f_number(&self) -> Option<f64> {
        self.sensor.iris.zip(self.iris).map(|(iris, u)| iris.f_number(u))
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
        Self::with_target(ranges, MID_GREY_DN)
    }

    /// AverageAE within `ranges` holding the frame mean at `target_dn`.
    pub fn with_target(ranges: AccRanges, target_dn: f64) -> Self {
        Self { ae: AverageAe::with_target(ranges, target_dn), applied: calibration_settings() }
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

pub use joca_record::TestController;

/// The controller a closed-loop test drives a design of `sensor` with, for a run whose own
/// controller is NeuralAE if `neural`.
pub(crate) fn test_control(
    test: TestController,
    neural: bool,
    sensor: SensorLimits,
    ranges: AccRanges,
) -> Box<dyn ExposureControl> {
    match test {
        TestController::Trained => controller(neural, sensor, ranges),
        TestController::Average { target_dn } => {
            Box::new(AverageControl::with_target(ranges, target_dn))
        }
    }
}

/// The controller of a method: NeuralAE, or AverageAE for `tacos-average`.
pub(crate) fn controller(
    neural: bool,
    sensor: SensorLimits,
    ranges: AccRanges,
) -> Box<dyn ExposureControl> {
    if neural {
        Box::new(NeuralControl::new(sensor))
    } else {
        Box::new(AverageControl::new(ranges))
    }
}
