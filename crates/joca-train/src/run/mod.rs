//! The joint optimisation loop of the paper (Sec. 5, DESIGN.md's data flow), one loop for every
//! method: what differs between methods is which parts are optimised (hardware GA or a fixed
//! camera; NeuralAE or AverageAE; GA supervision, fixed perturbations or none; detector trained
//! or frozen).
//!
//! One idea per file: [`config`] (the `[run]` table and its validation), [`method`] (the fixed
//! cameras; methods and scenarios are `joca_record`'s), this file (the hardware GA's loop over
//! candidates, checkpoints), [`candidate`] (one candidate's k steps of joint training on its
//! generation's scenes), [`perturbation`] (DF-Grad's perturbation search), [`evaluate`]
//! (choosing the design by validation, testing it, `joca eval`), [`closed_loop`] (closed-loop
//! driving: the test, the validation, the showcases), [`results`] (what a run reports),
//! [`timing`] (`joca bench step`).

mod candidate;
mod closed_loop;
mod config;
mod evaluate;
mod hardware;
pub use hardware::HardwareMutation;
mod method;
mod perturbation;
mod results;
mod source;
mod timing;

use crate::TrainError;
use crate::checkpoint::{CheckpointDir, check_resume, read_json, write_atomic};
use crate::control::TestController;
pub use closed_loop::{Showcase, ShowcaseFrame};
use config::ConfigFile;
pub use config::{
    MAX_REFERENCE_RANGE_M, MAX_SPEED_MPS, PerturbationMutation, PerturbationScore,
    PerturbationSteps, RealConfig, ReferenceConfig, RunConfig, Source, TieBreak,
};
pub(crate) use config::{check_detector, check_input};
use evaluate::{best_design, test_design};
pub use evaluate::{cpu_description, evaluate_run};
use joca_camera::{
    AccRanges, Calibration, DesignSpace, GenomeCodec, ImageFormation, SensorEncoding,
};
use joca_core::SeedStreams;
use joca_core::output::{self, DirLock, OutputKind};
use joca_data::folder::Recording;
use joca_evolve::Ga;
use joca_nn::Engine;
use joca_nn::joint::JointModel;
use joca_record::{CandidateRecord, Event, GenerationRecord};
pub use joca_record::{Method, Scenario};
use joca_sim::{Illumination, SimConfig, Simulator};
pub use method::{DesignSpec, FixedCamera};
use rand::Rng;
use results::summary;
pub use results::{DesignSummary, RunResults, SearchTies};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap};
use std::io::Write;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use timing::Stopwatch;
pub use timing::{StepBreakdown, bench_step};

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
#[derive(Debug, Serialize, Deserialize)]
struct RunState {
    config: RunConfig,
    generation: usize,
    candidate: usize,
    fitness: Vec<f64>,
    hardware: Ga,
    perturbation: Ga,
    best: Option<(Vec<f64>, f64)>,
    /// The best distinct designs of training, best first, with their fitness: the candidates
    /// the validation chooses among.
    #[serde(default)]
    top: Vec<(Vec<f64>, f64)>,
    /// The perturbation searches of the finished candidates, and their ties.
    #[serde(default)]
    ties: SearchTies,
}

/// How many of training's best designs the validation re-scores.
const TOP_DESIGNS: usize = 3;

impl RunState {
    /// Records a scored candidate among the top designs.
    fn rank(&mut self, genes: &[f64], fitness: f64) {
        match self.top.iter_mut().find(|(g, _)| g.as_slice() == genes) {
            Some(entry) => entry.1 = entry.1.max(fitness),
            None => self.top.push((genes.to_vec(), fitness)),
        }
        self.top.sort_by(|a, b| b.1.total_cmp(&a.1));
        self.top.truncate(TOP_DESIGNS);
    }
}

/// Simulators by town (map seed) and illumination.
type Sims = HashMap<(u64, Option<Illumination>), Arc<Simulator>>;

/// Training and test recordings of the real-image mode.
struct RealSources {
    train: Recording,
    /// `None`: the test plays the training recording (no `test_source`).
    held_out: Option<Recording>,
}

impl RealSources {
    /// The recording the test plays.
    fn test(&self) -> &Recording {
        self.held_out.as_ref().unwrap_or(&self.train)
    }
}

struct Context {
    config: RunConfig,
    streams: SeedStreams,
    codec: GenomeCodec,
    formation: ImageFormation,
    /// Training towns built so far.
    sims: Sims,
    /// The recorded sources of the real-image mode (None: the simulator).
    real: Option<Arc<RealSources>>,
    ranges: AccRanges,
    /// `events.jsonl` (a sink where nothing is logged).
    log: Box<dyn Write>,
    log_path: PathBuf,
    /// Where each step's time goes (only `joca bench step` reads it).
    watch: Stopwatch,
    /// The controller closed-loop tests drive the design with (`joca eval --controller`).
    test_controller: TestController,
    /// The perturbation searches of the candidate in training, and their ties.
    ties: SearchTies,
}

impl Context {
    /// Appends `event` to `events.jsonl`.
    fn log(&mut self, event: &Event) -> Result<(), TrainError> {
        let line = serde_json::to_string(event).map_err(|e| TrainError::Corrupt {
            path: self.log_path.display().to_string(),
            reason: e.to_string(),
        })?;
        writeln!(self.log, "{line}").map_err(|e| TrainError::io(&self.log_path, e))
    }
}

/// Runs (or resumes) a joint optimisation into `run_dir`, then tests the best design.
#[expect(
    clippy::too_many_lines,
    reason = "to be split into named steps with a byte-identical quick run (issue 42)"
)]
pub fn run(
    config: &RunConfig,
    run_dir: &Path,
    resume: bool,
    progress: &mut dyn FnMut(&RunEvent) -> ControlFlow<()>,
) -> Result<RunResults, TrainError> {
    config.validate()?;
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
    let streams = cx.streams;
    let codec = cx.codec.clone();
    let mut init_rng = streams.stream("hardware-init");
    let mut hardware = Ga::new(
        hardware::ga_config(config.hardware_mutation, config.population, &codec)?,
        &mut init_rng,
    );
    hardware.apply(|g| {
        let _ = codec.snap(g);
    });
    // Perturbations in normalised units: ±5 % of each range.
    let perturbation = perturbation::ga(config, &streams)?;
    let mut state = RunState {
        config: config.clone(),
        generation: 0,
        candidate: 0,
        fitness: Vec::new(),
        hardware,
        perturbation,
        best: None,
        top: Vec::new(),
        ties: SearchTies::default(),
    };

    let ckpt = CheckpointDir::new(run_dir.join("checkpoint"));
    if resume {
        if let Some(dir) = ckpt.existing() {
            let saved: RunState = read_json(&dir.join("state.json"))?;
            check_resume(&saved.config, config, run_dir)?;
            model.load(&dir)?;
            state = saved;
        }
    } else if ckpt.existing().is_some() {
        return Err(TrainError::Config {
            field: "run directory".into(),
            value: run_dir.display().to_string(),
            allowed: "a directory without a checkpoint (pass --resume to continue it)".into(),
        });
    }
    write_atomic(
        &run_dir.join("config.toml"),
        &toml::to_string(&ConfigFile { run: config.clone() }).unwrap_or_default(),
    )?;

    // Every method trains on the same number of frames: a fixed camera drives as many
    // candidates per generation (each on its own scenes) as the hardware GA evaluates.
    let total = config.generations * config.population;
    while state.generation < config.generations {
        let members: Vec<Vec<f64>> = if config.hardware_search() {
            state.hardware.ask().to_vec()
        } else {
            vec![cx.codec.encode(&config.fixed_design()?)?; config.population]
        };
        while state.candidate < members.len() {
            let design = cx.codec.decode(&members[state.candidate])?;
            let index = (state.generation * members.len() + state.candidate) as u64;
            let (generation, candidate, candidates) =
                (state.generation, state.candidate, members.len());
            let best = state.best.as_ref().map(|b| b.1);
            let mut on_step = |step: usize, of: usize| {
                let _ =
                    progress(&RunEvent::Step { generation, candidate, candidates, step, of, best });
            };
            let scores = match candidate::train(
                &mut cx,
                &mut model,
                &mut state.perturbation,
                &design,
                (index, state.generation as u64),
                &mut on_step,
            ) {
                Err(TrainError::Nn(source @ joca_nn::NnError::NonFinite { .. })) => {
                    let checkpoint = ckpt.existing().map_or_else(
                        || "none: no candidate had finished".to_owned(),
                        |d| format!("{}, after {index} candidate(s)", d.display()),
                    );
                    return Err(TrainError::Diverged { generation, candidate, checkpoint, source });
                }
                r => r?,
            };
            // A killed candidate is repeated from the checkpoint: count its searches once.
            state.ties.add(std::mem::take(&mut cx.ties));
            let fitness = scores.fitness();
            state.fitness.push(fitness);
            if state.best.as_ref().is_none_or(|(_, f)| fitness > *f) {
                state.best = Some((members[state.candidate].clone(), fitness));
            }
            state.rank(&members[state.candidate], fitness);
            cx.log(&Event::Candidate(CandidateRecord {
                generation: state.generation,
                candidate: state.candidate,
                design: summary(&design, config.hardware_search()),
                scores,
                fitness,
            }))?;
            state.candidate += 1;
            if state.candidate == members.len() {
                if config.hardware_search() {
                    let codec = cx.codec.clone();
                    let mut rng = cx.streams.indexed("hardware-ga", state.generation as u64);
                    state
                        .hardware
                        .tell(&state.fitness, &mut rng, |g| {
                            let _ = codec.snap(g);
                        })
                        .map_err(ga_err)?;
                }
                cx.log(&Event::Generation(GenerationRecord {
                    generation_done: state.generation,
                    fitness: state.fitness.clone(),
                }))?;
                state.fitness.clear();
                state.candidate = 0;
                state.generation += 1;
            }
            ckpt.write(|dir| {
                model.save(dir)?;
                let text = serde_json::to_string(&state).map_err(|e| TrainError::Corrupt {
                    path: "state.json".into(),
                    reason: e.to_string(),
                })?;
                write_atomic(&dir.join("state.json"), &text)
            })?;
            let done = state.generation * members.len() + state.candidate;
            let event = RunEvent::Candidate {
                generation: state.generation,
                candidate: state.candidate,
                fitness,
                best: state.best.as_ref().map_or(fitness, |b| b.1),
                done,
                of: total,
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
    let results = test_design(&mut cx, &mut model, &state, (&design, validation), Some(&out))?;
    write_atomic(
        &run_dir.join("results.json"),
        &serde_json::to_string_pretty(&results).unwrap_or_default(),
    )?;
    Ok(results)
}

/// Mean exposure (ms) and gain (dB) per illumination name.
type SettingsByLight = BTreeMap<String, (f64, f64)>;

/// Engine, model (with its starting detector weights) and loop context for `config`.
fn setup(
    config: &RunConfig,
    log: Box<dyn Write>,
    log_path: PathBuf,
) -> Result<(Context, JointModel), TrainError> {
    let engine = Engine::cpu(config.threads);
    let streams = SeedStreams::new(config.seed);
    engine.seed(streams.stream("init").random());
    let cal = Calibration::DEFAULT;
    let ranges = AccRanges::PAPER;
    let n = config.scenario.noise_scale();
    // Frames are rendered at the detector's input; each design's formation (`for_sensor`) gives
    // them the noise of its native grid carried through the configured resize.
    let formation =
        ImageFormation::new(cal)?.with_noise_scale(n)?.with_resampler(config.input.resampler);
    let mut model = JointModel::new(&engine, config.detector, ranges, formation);
    if !config.detector_weights.is_empty() {
        model.load_detector(Path::new(&config.detector_weights))?;
    }
    model.set_detector_trainable(config.method != Method::FrozenDetector);
    model.set_clip_gradient(config.clip_gradient);
    model.set_acc_lr(config.acc_lr);
    let (real, space) = match config.source.open(&config.real)? {
        None => (None, DesignSpace::synthetic()),
        Some(train) => {
            // Without a test source the test plays the training recording itself: opening it a
            // second time would read (and, for Waymo, hold) every frame twice.
            let held_out = config.test_source.open(&config.real)?;
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
        sims: HashMap::new(),
        real,
        ranges,
        log,
        log_path,
        watch: Stopwatch::default(),
        test_controller: TestController::Trained,
        ties: SearchTies::default(),
    };
    Ok((cx, model))
}

fn ga_err(e: joca_evolve::GaError) -> TrainError {
    TrainError::Config { field: "ga".into(), value: String::new(), allowed: e.to_string() }
}

/// The simulator of town `map_seed` under `illumination` (`None`: drawn per episode), built
/// once.
fn simulator(
    sims: &mut Sims,
    map_seed: u64,
    config: &RunConfig,
    illumination: Option<Illumination>,
) -> Arc<Simulator> {
    Arc::clone(sims.entry((map_seed, illumination)).or_insert_with(|| {
        Arc::new(Simulator::new(SimConfig {
            map_seed,
            max_speed_mps: config.max_speed_mps,
            illumination,
            visibility: config.reference.rules(),
            ..SimConfig::default()
        }))
    }))
}
