//! The joint optimisation loop of the paper (Sec. 5, docs/design.md's data flow), one loop for
//! every method: what differs between methods is which parts are optimised (hardware GA or a
//! fixed camera; NeuralAE or AverageAE; GA supervision, fixed perturbations or none; detector
//! trained or frozen).
//!
//! One idea per file: [`config`] (the `[run]` table and its validation), [`method`] (the fixed
//! cameras; methods and scenarios are `joca_record`'s), this file (the loop over generations and
//! candidates, then the test), [`context`] (the parts every stage shares and how a run opens
//! them), [`journal`] (what a run records as it goes), [`state`] (the loop's checkpointed state
//! and its steps: start or resume, a generation's members, one candidate trained and
//! checkpointed), [`stretches`] (which scenes a candidate plays), [`rig`] (how a design
//! captures, and its closed-loop drivers), [`candidate`] (who learns: one candidate's k steps of
//! joint training), [`judge`] (who judges a candidate that learned from scenes of its own),
//! [`perturbation`] (DF-Grad's perturbation search), [`evaluate`] (choosing the design by
//! validation, testing it, `joca eval`), [`closed_loop`] (closed-loop driving: the test, the
//! validation, the showcases; [`driver`] one sequence's controller and captures), [`scenes`]
//! (where scenes come from: towns built once, or recordings), [`headroom`] (`joca headroom`),
//! [`results`] (what a run reports), [`timing`] (`joca bench step`).

mod aperture;
mod candidate;
mod closed_loop;
mod config;
mod context;
mod driver;
mod evaluate;
mod hardware;
mod journal;
mod judge;
mod machine;
pub use hardware::HardwareMutation;
pub mod headroom;
mod method;
mod perturbation;
mod pooled;
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
use context::{Context, setup};
pub use evaluate::{EvalOptions, MAX_TEST_TOWN, check_town, evaluate_run};
use evaluate::{best_design, test_design};
use joca_core::output::{self, DirLock, OutputKind};
use joca_record::{Event, PhaseRecord, RunPhase};
pub use joca_record::{Method, Scenario};
pub use machine::cpu_description;
pub use method::{DesignSpec, FixedCamera};
use results::summary;
pub use results::{DesignSummary, RunResults, SearchTies};
pub(crate) use scenes::light_of;
use state::RunState;
use std::ops::ControlFlow;
use std::path::Path;
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
    let mut clock = PhaseClock::start();
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
    clock.lap(&mut cx, RunPhase::Training)?;
    let _ = progress(&RunEvent::Testing);
    let (design, validation) = best_design(&mut cx, &mut model, &state)?;
    clock.lap(&mut cx, RunPhase::Selection)?;
    write_atomic(
        &run_dir.join("best_design.json"),
        &serde_json::to_string_pretty(&summary(&design, config.hardware_search()))
            .unwrap_or_default(),
    )?;
    let out = run_dir.join("test");
    let results =
        test_design(&mut cx, &mut model, &state, (&design, validation.clone()), Some(&out))?;
    clock.lap(&mut cx, RunPhase::Test)?;
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
        clock.lap(&mut cx, RunPhase::AverageRetest)?;
    }
    write_atomic(
        &run_dir.join("results.json"),
        &serde_json::to_string_pretty(&results).unwrap_or_default(),
    )?;
    Ok(results)
}

/// Wall time from one part of a run to the next, each lap logged to `events.jsonl`.
struct PhaseClock(std::time::Instant);

impl PhaseClock {
    fn start() -> Self {
        Self(std::time::Instant::now())
    }

    /// Logs the time since the last lap as `phase`'s and starts the next.
    fn lap(&mut self, cx: &mut Context, phase: RunPhase) -> Result<(), TrainError> {
        let wall_s = self.0.elapsed().as_secs_f64();
        self.0 = std::time::Instant::now();
        cx.journal.log(&Event::Phase(PhaseRecord { phase, wall_s }))
    }
}

fn ga_err(e: joca_evolve::GaError) -> TrainError {
    TrainError::Config { field: "ga".into(), value: String::new(), allowed: e.to_string() }
}
