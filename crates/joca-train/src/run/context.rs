//! The parts every stage of a run shares, each with one job, and how a run opens them: the
//! configuration, the seed streams, the genome's codec, how designs capture ([`Rigs`]), where
//! scenes come from ([`SceneSource`]), what the closed-loop test drives ([`TestDrive`]) and what
//! the run records ([`Journal`]). The stages themselves live in their own modules: who learns
//! (`candidate`), who judges (`judge`), the loop's state (`state`), choosing and testing the
//! design (`evaluate`).

use super::config::RunConfig;
use super::journal::Journal;
use super::method::FixedCamera;
use super::rig::Rigs;
use super::scenes::{RealSources, SceneSource};
use super::{Method, source};
use crate::TrainError;
use crate::control::TestController;
use joca_camera::SensorEncoding;
use joca_camera::{AccRanges, Calibration, DesignSpace, GenomeCodec, ImageFormation};
use joca_core::SeedStreams;
use joca_nn::Engine;
use joca_nn::joint::JointModel;
use rand::Rng;
use std::io::Write;
use std::path::PathBuf;
use std::sync::Arc;

/// The run's shared parts (see the module's documentation).
pub(super) struct Context {
    pub(super) config: RunConfig,
    pub(super) streams: SeedStreams,
    pub(super) codec: GenomeCodec,
    /// How each design captures: its rig, and closed-loop drivers.
    pub(super) rigs: Rigs,
    /// Where scenes come from: the towns built so far, or the recordings.
    pub(super) scenes: SceneSource,
    /// What the closed-loop test drives: which controller, which town.
    pub(super) test: TestDrive,
    /// What the run records as it goes: events, step timings, search ties.
    pub(super) journal: Journal,
}

/// What a closed-loop test drives the chosen design with, and where.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct TestDrive {
    /// The controller (`joca eval --controller`; the run's own by default).
    pub(super) controller: TestController,
    /// The test family's town (`joca eval --town`; 0: the test town).
    pub(super) town: u64,
}

/// Engine, model (with its starting detector weights) and loop context for `config`.
pub(super) fn setup(
    config: &RunConfig,
    log: Box<dyn Write>,
    log_path: PathBuf,
) -> Result<(Context, JointModel), TrainError> {
    let engine = Engine::open(config.device, config.threads)?;
    let streams = SeedStreams::new(config.seed);
    engine.seed(streams.stream("init").random());
    let cal = Calibration::DEFAULT;
    let ranges = AccRanges::PAPER;
    let n = config.scenario.noise_scale();
    // Frames are rendered at the detector's input; each design's formation (`for_sensor`) gives
    // them the noise of its native grid carried through the configured resize.
    let formation =
        ImageFormation::new(cal)?.with_noise_scale(n)?.with_resampler(config.input.resampler);
    let iris = config.aperture == joca_camera::ApertureControl::Dynamic;
    let mut model = JointModel::new(&engine, config.detector, ranges, formation, iris);
    if let Some(weights) = &config.detector_weights {
        model.load_detector(weights)?;
    }
    model.set_detector_trainable(config.method != Method::FrozenDetector);
    model.set_clip_gradient(config.clip_gradient);
    model.set_acc_lr(config.acc_lr);
    model.set_detector_lr(config.detector_lr);
    model.set_acc_output(config.acc_output.0);
    let (real, space) = match source::open(&config.source, &config.real)? {
        None => {
            let f = config.f_number;
            (None, DesignSpace::synthetic().with_f_numbers(f.min, f.max)?)
        }
        Some(train) => {
            // Without a test source the test plays the training recording itself: opening it a
            // second time would read (and, for Waymo, hold) every frame twice.
            let held_out = source::open(&config.test_source, &config.real)?;
            // The recording fixes mount and lens (the nuScenes-like values stand in for them in
            // the tables); only sensors whose pixel grid fits inside the recording are designed.
            let (w, h) = train.recording_size_px();
            let fixed = FixedCamera::Flir.design();
            let space = DesignSpace::synthetic()
                .with_fixed_mount(fixed.x_m, fixed.z_m, fixed.focal_length_mm)
                .restricted_to_recording(w as usize, h as usize)?;
            (Some(Arc::new(RealSources { train, held_out })), space)
        }
    };
    let cx = Context {
        config: config.clone(),
        streams,
        codec: GenomeCodec::new(space, SensorEncoding::QuantisedContinuous)?,
        rigs: Rigs::new(config, formation, ranges),
        scenes: SceneSource::new(config, real),
        journal: Journal::new(log, log_path),
        test: TestDrive::default(),
    };
    Ok((cx, model))
}
