//! Closed-loop evaluation on the test town: a camera design, an exposure controller and a
//! detector drive through test episodes; the frames are scored together (mAP, AP50, TP ratio).

use crate::TrainError;
use joca_camera::{AverageAe, Calibration, CameraDesign, DynamicSettings, ImageFormation};
use joca_core::{FrameRequest, FrameSource, Rgb8Image, SeedStreams};
use joca_metrics::{TaskMetrics, TaskScores};
use joca_nn::detector::DetectorModel;
use joca_sim::{Illumination, SimConfig, Simulator, test_map_seed};

/// What the evaluation covers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EvalSpec {
    /// Illumination of every test episode.
    pub illumination: Illumination,
    /// Test episodes.
    pub episodes: u64,
    /// Scored frames per episode (consecutive, so the controller runs in closed loop).
    pub frames_per_episode: usize,
    /// Frames the controller runs before scoring starts (it starts at E0, G0).
    pub warmup_frames: usize,
    /// Output resolution factor.
    pub render_scale: f64,
    /// Noise variance multiplier.
    pub noise_scale: f64,
    /// Motion blur multiplier.
    pub motion_scale: f64,
}

/// A closed-loop exposure controller: settings for the next frame from the last frame.
pub trait ExposureControl {
    /// Settings for the first frame of an episode.
    fn start(&mut self) -> DynamicSettings;
    /// Settings for the next frame, given the last frame and the settings it was taken with.
    fn next(&mut self, previous: DynamicSettings, frame: &Rgb8Image) -> DynamicSettings;
}

/// AverageAE as an [`ExposureControl`], starting at the calibration settings.
#[derive(Debug, Clone, Copy)]
pub struct AverageControl(pub AverageAe);

impl ExposureControl for AverageControl {
    fn start(&mut self) -> DynamicSettings {
        DynamicSettings::new(Calibration::DEFAULT.exposure_s, Calibration::DEFAULT.gain_db)
    }

    fn next(&mut self, previous: DynamicSettings, frame: &Rgb8Image) -> DynamicSettings {
        self.0.step(previous, frame)
    }
}

/// Scores `model` seeing through `design` with `control` on the test town.
pub fn evaluate(
    model: &DetectorModel,
    design: &CameraDesign,
    control: &mut dyn ExposureControl,
    spec: &EvalSpec,
    streams: &SeedStreams,
) -> Result<TaskScores, TrainError> {
    let sim = Simulator::new(SimConfig {
        map_seed: test_map_seed(0),
        illumination: Some(spec.illumination),
        ..SimConfig::default()
    });
    let formation =
        ImageFormation::new(Calibration::DEFAULT)?.with_noise_scale(spec.noise_scale)?;
    let camera = design.pinhole(spec.render_scale);
    let pitch = design.sensor().pixel_pitch_um;
    let mut metrics = TaskMetrics::default();
    let dt = sim.frame_interval_s();
    for episode in 0..spec.episodes {
        let mut settings = control.start();
        for k in 0..spec.warmup_frames + spec.frames_per_episode {
            let t = 1.0 + k as f64 * dt;
            let request = FrameRequest {
                episode,
                time_s: t,
                exposure_s: settings.exposure_s,
                motion_scale: spec.motion_scale,
            };
            let frame = sim.render(&camera, &request)?;
            let image = formation.form(
                &frame.hdr,
                settings,
                pitch,
                &mut streams.indexed("eval-noise", episode * 10_000 + k as u64),
            );
            if k >= spec.warmup_frames {
                metrics.update(
                    &frame.boxes,
                    &frame.ignore,
                    &model.detect(&image),
                    frame.visible_180,
                );
            }
            settings = control.next(settings, &image);
        }
    }
    Ok(metrics.compute())
}
