//! Closed-loop evaluation on the test town: a camera design, an exposure controller and a
//! detector drive through test episodes; the frames are scored together (mAP, AP50, TP ratio).

use crate::TrainError;
use crate::control::{AverageControl, ExposureControl};
use joca_camera::{Calibration, CameraDesign, Capture, DetectorInput, ImageFormation};
use joca_core::{FrameRequest, FrameSource, SeedStreams};
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
    /// The detector's input.
    pub input: DetectorInput,
    /// Noise variance multiplier.
    pub noise_scale: f64,
    /// Motion blur multiplier.
    pub motion_scale: f64,
}

/// Scores `model` seeing through `design` with AverageAE (`control`) on the test town.
pub fn evaluate(
    model: &DetectorModel,
    design: &CameraDesign,
    control: &mut AverageControl,
    spec: &EvalSpec,
    streams: &SeedStreams,
) -> Result<TaskScores, TrainError> {
    let sim = Simulator::new(SimConfig {
        map_seed: test_map_seed(0),
        illumination: Some(spec.illumination),
        ..SimConfig::default()
    });
    let formation = ImageFormation::new(Calibration::DEFAULT)?
        .with_noise_scale(spec.noise_scale)?
        .with_resampler(spec.input.resampler)
        .for_sensor(design.sensor());
    let camera = design.pinhole(&spec.input);
    let pitch = design.sensor().pixel_pitch_um;
    let mut metrics = TaskMetrics::default();
    let dt = sim.frame_interval_s();
    for episode in 0..spec.episodes {
        let mut settings = control.start();
        for k in 0..spec.warmup_frames + spec.frames_per_episode {
            let request = FrameRequest {
                episode,
                time_s: 1.0 + k as f64 * dt,
                exposure_s: settings.exposure_s,
                motion_scale: spec.motion_scale,
            };
            let mut noise = streams.indexed("eval-noise", episode * 10_000 + k as u64);
            let Capture { frame, image } =
                formation.capture(&sim, &camera, &request, settings, pitch, &mut noise)?;
            if k >= spec.warmup_frames {
                metrics.update(
                    &frame.boxes,
                    &frame.ignore,
                    &model.detect(&image),
                    frame.visible_180,
                );
            }
            settings = control.step(&image);
        }
    }
    Ok(metrics.compute())
}
