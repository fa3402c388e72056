//! One closed-loop sequence: a controller sets the exposure and gain of frame t from frame
//! t − 1 (its own output), the frame is captured and the detector runs on it, exactly as at
//! training time but without any update. The test, the validation, the showcases, a fresh-scenes
//! candidate's judging and `joca headroom` all drive their sequences through [`Driver`].

use super::rig::Rig;
use crate::TrainError;
use crate::control::ExposureControl;
use joca_camera::{Capture, DynamicSettings};
use joca_core::{Detection, Frame, FrameSource, Rgb8Image};
use joca_nn::joint::JointModel;
use joca_record::Settings;

/// Frames the controller runs before scoring starts (it starts at E0, G0).
pub(super) const WARMUP_FRAMES: usize = 3;

/// The controller state of one closed-loop sequence.
pub(super) struct Driver {
    control: Box<dyn ExposureControl>,
    /// Settings the sensor uses for the next frame.
    applied: DynamicSettings,
    previous: Option<Rgb8Image>,
    /// How the design captures.
    rig: Rig,
}

/// What one closed-loop frame produced.
pub(super) struct Step {
    pub(super) frame: Frame,
    pub(super) detections: Vec<Detection>,
    /// Exposure and gain, and the f-number where the controller sets the iris.
    pub(super) settings: Settings,
    /// Mean of the formed 8-bit frame, DN.
    pub(super) mean_dn: f64,
    /// Share of the frame's pixels with a channel at 255.
    pub(super) clipped: f64,
}

impl Driver {
    /// Starts a sequence of `rig`'s design driven by `control`.
    pub(super) fn new(
        rig: Rig,
        mut control: Box<dyn ExposureControl>,
        model: &mut JointModel,
    ) -> Self {
        rig.start_sequence(model);
        let applied = control.start();
        Self { control, applied, previous: None, rig }
    }

    /// The 8-bit frame last captured.
    pub(super) fn last_image(&self) -> Option<&Rgb8Image> {
        self.previous.as_ref()
    }

    /// The settings the last frame was captured with.
    pub(super) fn applied(&self) -> DynamicSettings {
        self.applied
    }

    /// Sets this frame's exposure and gain from the previous frame, captures the instant
    /// (`episode`, `time_s`) of `source` and detects.
    pub(super) fn step(
        &mut self,
        model: &mut JointModel,
        source: &dyn FrameSource,
        instant: (u64, f64),
        noise: &mut impl rand::Rng,
    ) -> Result<Step, TrainError> {
        if let Some(prev) = &self.previous {
            self.applied = self.control.next(model, prev).applied;
        }
        // Where the controller sets the iris, the frame is seen and formed at its f-number.
        let f_number = self.control.f_number();
        let Capture { frame, image } =
            self.rig.capture(source, instant, self.applied, f_number, noise)?;
        let detections = model.observe(&image);
        let (mean_dn, clipped) = levels(&image);
        self.previous = Some(image);
        let settings = Settings::from(self.applied).at(f_number);
        Ok(Step { frame, detections, settings, mean_dn, clipped })
    }
}

/// The frame's mean level, DN, and the share of its pixels with a channel at 255.
pub(super) fn levels(image: &Rgb8Image) -> (f64, f64) {
    let data = image.data();
    let mean = data.iter().map(|&v| f64::from(v)).sum::<f64>() / data.len().max(1) as f64;
    let pixels = data.len() / 3;
    let clipped = data.chunks_exact(3).filter(|p| p.contains(&255)).count();
    (mean, clipped as f64 / pixels.max(1) as f64)
}
