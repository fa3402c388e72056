//! The joint optimisation loop of the paper (Sec. 5, docs/design.md's data flow), one loop for
//! every method: what differs between methods is which parts are optimised (hardware GA or a
//! fixed camera; NeuralAE or AverageAE; GA supervision, fixed perturbations or none; detector
//! trained or frozen).
//!
//! One idea per file: [`config`] (the `[run]` table and its validation), [`method`] (the fixed
//! cameras; methods and scenarios are `joca_record`'s), this file (the loop over generations and
//! candidates, then the test), [`state`] (the loop's checkpointed state and its steps: start or
//! resume, a generation's members, one candidate trained and checkpointed), [`stretches`] (which
//! scenes a candidate plays), [`rig`] (how a design captures), [`candidate`] (who learns: one
//! candidate's k steps of joint training), [`judge`] (who judges a candidate that learned from
//! scenes of its own), [`perturbation`] (DF-Grad's perturbation search), [`evaluate`] (choosing
//! the design by validation, testing it, `joca eval`), [`closed_loop`] (closed-loop driving: the
//! test, the validation, the showcases; [`driver`] one sequence's controller and captures),
//! [`scenes`] (where scenes come from: towns built once, or recordings), [`headroom`] (`joca
//! headroom`), [`results`] (what a run reports), [`timing`] (`joca bench step`).

mod aperture;
mod candidate;
mod closed_loop;
mod config;
mod driver;
mod evaluate;
mod hardware;
mod judge;
pub use hardware::HardwareMutation;
pub mod headroom;
mod method;
mod perturbation;
mod reference;
mod results;
mod rig;
mod scenes;
mod source;
mod state;
mod stretches;
mod timing;
mod warm_start;

use crate::TrainError;
use crate::checkpoint::{CheckpointDir, write_atomic};
use crate::control::TestController;
pub use closed_loop::{Showcase, ShowcaseFrame};
use config::ConfigFile;
pub use config::{
    AccOutput, FNumberRange, MAX_REFERENCE_RANGE_M, MAX_SPEED_MPS, PerturbationMutation,
    PerturbationScore, PerturbationSteps, RealConfig, ReferenceConfig, RunConfig, Source, TieBreak,
    TrainingScenes, WarmStart,
};
pub(crate) use config::{check_detector, check_input};
use driver::Driver;
pub use evaluate::{EvalOptions, MAX_TEST_TOWN, check_town, cpu_description, evaluate_run};
use evaluate::{best_design, test_design};
use joca_camera::{
    AccRanges, Calibration, CameraDesign, DesignSpace, GenomeCodec, ImageFormation, SensorEncoding,
};
use joca_core::SeedStreams;
use joca_core::output::{self, DirLock, OutputKind};
use joca_nn::Engine;
use joca_nn::joint::JointModel;
use joca_record::Event;
pub use joca_record::{Method, Scenario};
pub use method::{DesignSpec, FixedCamera};
use rand::Rng;
use results::summary;
pub use results::{DesignSummary, RunResults, SearchTies};
use rig::Rig;
pub(crate) use scenes::light_of;
use scenes::{RealSources, SceneSource};
use state::RunState;
use std::io::Write;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use timing::Stopwatch;
pub use timing::{CheckpointTiming, StepBreakdown, bench_checkpoint, bench_step};

/// Progress of a run.
#[derive(Debug, Clone)]
pub enum RunEvent {
    /// A candidate finished.
    Candidate {
        /// Generation (0-based).
        generation: usize,
        /// Candidate in the generation.
        candidate: usize,
        /// Its fitness.
        fitness: f64,
        /// Best so far.
        best: f64,
        /// Candidates done / total.
        done: usize,
        /// Total candidates.
        of: usize,
    },
    /// A training step finished (a run cannot be interrupted here: it stops between
    /// candidates, where it checkpoints).
    Step {
        /// Generation (0-based).
        generation: usize,
        /// Candidate in the generation (0-based).
        candidate: usize,
        /// Candidates per generation.
        candidates: usize,
        /// Steps of this candidate done.
        step: usize,
        /// Steps per candidate.
        of: usize,
        /// Best fitness so far (None before the first candidate finished).
        best: Option<f64>,
    },
    /// Testing started.
    Testing,
}
struct Context {
    config: RunConfig,
    streams: SeedStreams,
    codec: GenomeCodec,
    formation: ImageFormation,
    /// Where scenes come from: the towns built so far, or the recordings.
    scenes: SceneSource,
    ranges: AccRanges,
    /// What the closed-loop test drives: which controller, which town.
    test: TestDrive,
    /// What the run records as it goes: events, step timings, search ties.
    journal: Journal,
}

/// What a run records as it goes.
struct Journal {
    /// `events.jsonl` (a sink where nothing is logged).
    log: Box<dyn Write>,
    log_path: PathBuf,
    /// Where each step's time goes (only `joca bench step` reads it).
    watch: Stopwatch,
    /// The perturbation searches of the candidate in training, and their ties.
    ties: SearchTies,
}

/// What a closed-loop test drives the chosen design with, and where.
#[derive(Debug, Clone, Copy, Default)]
struct TestDrive {
    /// The controller (`joca eval --controller`; the run's own by default).
    controller: TestController,
    /// The test family's town (`joca eval --town`; 0: the test town).
    town: u64,
}

impl Context {
    /// How `design` captures in this run, driven at `frame_interval_s`.
    fn rig(&self, design: &CameraDesign, frame_interval_s: f64) -> Rig {
        Rig::new(&self.config, &self.formation, self.ranges, design, frame_interval_s)
    }

    /// A closed-loop sequence of `design` driven by `controller` (the run's own, or a swap).
    fn driver(
        &self,
        model: &mut JointModel,
        design: &CameraDesign,
        frame_interval_s: f64,
        controller: TestController,
    ) -> Driver {
        let rig = self.rig(design, frame_interval_s);
        let neural = self.config.method.neural();
        let control = crate::control::test_control(controller, neural, rig.sensor, self.ranges);
        Driver::new(rig, control, model)
    }

    /// Appends `event` to `events.jsonl`.
    fn log(&mut self, event: &Event) -> Result<(), TrainError> {
        let j = &mut self.journal;
        let line = serde_json::to_string(event).map_err(|e| TrainError::Corrupt {
            path: j.log_path.display().to_string(),
            reason: e.to_string(),
        })?;
        writeln!(j.log, "{line}").map_err(|e| TrainError::io(&j.log_path, e))
    }
}

/// Runs (or resumes) a joint optimisation into `run_dir`, then tests the best design.
pub fn run(
    config: &RunConfig,
    run_dir: &Path,
    resume: bool,
    progress: &mut dyn FnMut(&RunEvent) -> ControlFlow<()>,
) -> Result<RunResults, TrainError> {
    config.validate()?;
    let config = &config.clone().with_absolute_weights();
    output::claim(run_dir, OutputKind::Run)?;
    // One writer per run directory, for the whole run (released however the process ends).
    let _lock = DirLock::acquire(run_dir, "joca run")?;
    let log_path = run_dir.join("events.jsonl");
    let log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&log_path)
        .map_err(|e| TrainError::io(&log_path, e))?;
    let (mut cx, mut model) = setup(config, Box::new(log), log_path)?;
    let ckpt = CheckpointDir::new(run_dir.join("checkpoint"));
    let fresh = ckpt.existing().is_none();
    let mut state = RunState::start(&cx, &mut model, &ckpt, run_dir, resume)?;
    if fresh && config.method.neural() && !config.warm_start.is_off() {
        // NeuralAE's warm start on the first generation's designs, checkpointed so that a
        // resumed run does not repeat it.
        let members = state.members(&cx)?;
        let designs = members.iter().map(|g| cx.codec.decode(g)).collect::<Result<Vec<_>, _>>()?;
        warm_start::warm_start(&mut cx, &mut model, &designs)?;
        state.checkpoint(&model, &ckpt)?;
    }
    write_atomic(
        &run_dir.join("config.toml"),
        &toml::to_string(&ConfigFile { run: config.clone() }).unwrap_or_default(),
    )?;
    while state.generation < config.generations {
        let members = state.members(&cx)?;
        while state.candidate < members.len() {
            let fitness = state.train_candidate(&mut cx, &mut model, &members, &ckpt, progress)?;
            let done = state.generation * members.len() + state.candidate;
            let event = RunEvent::Candidate {
                generation: state.generation,
                candidate: state.candidate,
                fitness,
                best: state.best.as_ref().map_or(fitness, |b| b.1),
                done,
                // Every method trains on the same number of frames.
                of: config.generations * config.population,
            };
            if progress(&event).is_break() {
                return Err(TrainError::Interrupted { step: done });
            }
            if state.candidate == 0 {
                break;
            }
        }
    }
    let _ = progress(&RunEvent::Testing);
    let (design, validation) = best_design(&mut cx, &mut model, &state)?;
    write_atomic(
        &run_dir.join("best_design.json"),
        &serde_json::to_string_pretty(&summary(&design, config.hardware_search()))
            .unwrap_or_default(),
    )?;
    let out = run_dir.join("test");
    let results =
        test_design(&mut cx, &mut model, &state, (&design, validation.clone()), Some(&out))?;
    if config.method.neural() {
        // Does the learned controller earn its place? The same design, detector and test
        // scenes driven by AverageAE at mid-grey (what `joca eval --controller average` writes).
        let swap = joca_record::Retest::average_swap(0);
        cx.test.controller = swap.controller;
        let out = run_dir.join(format!("test-{swap}"));
        let mut r = test_design(&mut cx, &mut model, &state, (&design, validation), Some(&out))?;
        r.test_controller = Some(swap.controller);
        write_atomic(
            &run_dir.join(swap.results_file()),
            &serde_json::to_string_pretty(&r).unwrap_or_default(),
        )?;
        cx.test.controller = TestController::Trained;
    }
    write_atomic(
        &run_dir.join("results.json"),
        &serde_json::to_string_pretty(&results).unwrap_or_default(),
    )?;
    Ok(results)
}

/// Engine, model (with its starting detector weights) and loop context for `config`.
fn setup(
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
        formation,
        scenes: SceneSource::new(config, real),
        ranges,
        journal: Journal {
            log,
            log_path,
            watch: Stopwatch::default(),
            ties: SearchTies::default(),
        },
        test: TestDrive::default(),
    };
    Ok((cx, model))
}

fn ga_err(e: joca_evolve::GaError) -> TrainError {
    TrainError::Config { field: "ga".into(), value: String::new(), allowed: e.to_string() }
}
