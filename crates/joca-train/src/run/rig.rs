//! How a run captures: [`Rigs`] holds what every design of the run shares (the formation, the
//! controller's ranges, the detector's input, the lens model, the iris mode and the scenario's
//! motion) and makes one [`Rig`] per design: its view at the detector's input, its formation on
//! its native grid, the limits its controller works within (its pixel, the frame interval, the
//! iris where the controller sets the aperture). Training, judging, the warm start, the test and
//! `joca headroom` all see and form a design's frames through a [`Rig`], and drive closed-loop
//! sequences through [`Rigs::driver`], so they cannot disagree on how a design captures.

use super::RunConfig;
use super::driver::Driver;
use crate::TrainError;
use crate::control::{SensorLimits, TestController, test_control};
use joca_camera::{AccRanges, ApertureControl, CameraDesign, Capture, DetectorInput};
use joca_camera::{DynamicSettings, ImageFormation, Iris, LensModel};
use joca_core::optics::CALIBRATION_F_NUMBER;
use joca_core::{FrameRequest, FrameSource, PinholeCamera};
use joca_nn::joint::JointModel;

/// What every design of a run captures with (see the module's documentation).
#[derive(Debug, Clone)]
pub(super) struct Rigs {
    /// The run's formation (calibration, noise scale, resampler), before any design's grid.
    formation: ImageFormation,
    /// The controller's exposure and gain ranges.
    pub(super) ranges: AccRanges,
    input: DetectorInput,
    lens: LensModel,
    aperture: ApertureControl,
    /// The scenario's motion-blur scale.
    motion_scale: f64,
    /// Whether the run's own controller is NeuralAE.
    neural: bool,
}

impl Rigs {
    /// The capture setup of the run of `config`, forming with `formation` under `ranges`.
    pub(super) fn new(config: &RunConfig, formation: ImageFormation, ranges: AccRanges) -> Self {
        Self {
            formation,
            ranges,
            input: config.input,
            lens: config.lens,
            aperture: config.aperture,
            motion_scale: config.scenario.motion_scale(),
            neural: config.method.neural(),
        }
    }

    /// How `design` captures in this run, driven at `frame_interval_s`.
    pub(super) fn rig(&self, design: &CameraDesign, frame_interval_s: f64) -> Rig {
        // Eq. 4 compensates the pixel area; the aperture's light is the formation's (so the
        // controller's whole range stays the camera's at every f-number).
        let iris = (self.aperture == ApertureControl::Dynamic).then(|| iris_of(design));
        let sensor =
            SensorLimits::new(design.sensor().pixel_pitch_um, self.ranges, frame_interval_s)
                .with_iris(iris);
        Rig {
            camera: design.view(&self.input, self.lens),
            formation: self.formation.for_design(design),
            sensor,
            motion_scale: self.motion_scale,
        }
    }

    /// A closed-loop sequence of `design` driven by `controller` (the run's own, or a swap).
    pub(super) fn driver(
        &self,
        model: &mut JointModel,
        design: &CameraDesign,
        frame_interval_s: f64,
        controller: TestController,
    ) -> Driver {
        let rig = self.rig(design, frame_interval_s);
        let control = test_control(controller, self.neural, rig.sensor, self.ranges);
        Driver::new(rig, control, model)
    }
}

/// How the run captures with one design (see the module's documentation).
#[derive(Debug, Clone)]
pub(super) struct Rig {
    /// The design's pinhole view at the detector's input.
    pub(super) camera: PinholeCamera,
    /// The run's formation on the design's native grid.
    pub(super) formation: ImageFormation,
    /// What a controller may set on this design at this frame interval.
    pub(super) sensor: SensorLimits,
    /// The scenario's motion-blur scale.
    motion_scale: f64,
}

impl Rig {
    /// Starts a sequence of this design on `model`: no previous frame, and the design's longest
    /// exposure at this frame interval.
    pub(super) fn start_sequence(&self, model: &mut JointModel) {
        model.reset_sequence();
        model.set_max_exposure(self.sensor.max_exposure_s);
    }

    /// The design's pixel pitch, µm.
    pub(super) fn pitch_um(&self) -> f64 {
        self.sensor.pixel_pitch_um
    }

    /// The request for the instant (`episode`, `time_s`) with a shutter of `exposure_s`.
    pub(super) fn request(&self, episode: u64, time_s: f64, exposure_s: f64) -> FrameRequest {
        FrameRequest { episode, time_s, exposure_s, motion_scale: self.motion_scale }
    }

    /// The formation at `f_number` where the controller set the iris (`None`: the design's).
    pub(super) fn formation_at(&self, f_number: Option<f64>) -> Result<ImageFormation, TrainError> {
        Ok(match f_number {
            Some(n) => self.formation.with_f_number(n)?,
            None => self.formation,
        })
    }

    /// Renders the instant (`episode`, `time_s`) of `source` with `applied` at `f_number` and
    /// forms it on the design's grid with noise from `noise`.
    pub(super) fn capture(
        &self,
        source: &dyn FrameSource,
        (episode, time_s): (u64, f64),
        applied: DynamicSettings,
        f_number: Option<f64>,
        noise: &mut impl rand::Rng,
    ) -> Result<Capture, TrainError> {
        let request = self.request(episode, time_s, applied.exposure_s);
        Ok(self.formation_at(f_number)?.capture(
            source,
            &self.camera.stopped_to(f_number)?,
            &request,
            applied,
            self.pitch_um(),
            noise,
        )?)
    }
}

/// The iris NeuralAE moves on `design` where the run sets the aperture frame by frame: from the
/// design's f-number (the lens wide open) to the calibration's f/16.
fn iris_of(design: &CameraDesign) -> Iris {
    Iris::new(design.f_number, CALIBRATION_F_NUMBER)
}
