//! The joint optimisation loop of the paper (Sec. 5, DESIGN.md's data flow), one loop for every
//! method: what differs between methods is which parts are optimised (hardware GA or a fixed
//! camera; NeuralAE or AverageAE; GA supervision, fixed perturbations or none; detector trained
//! or frozen).

mod closed_loop;

use crate::TrainError;
use crate::checkpoint::{CheckpointDir, check_resume, read_json, write_atomic};
pub use closed_loop::{Showcase, ShowcaseFrame};
use joca_camera::{
    AccRanges, AverageAe, Calibration, CameraDesign, DesignSpace, DynamicSettings, GenomeCodec,
    ImageFormation, SensorEncoding, compensate_for_pixel_size, sensor_by_name,
};
use joca_core::{FrameRequest, FrameSource, SeedStreams};
use joca_data::blur::Linearize;
use joca_data::folder::{FolderConfig, OnBadFrame, Recording};
use joca_evolve::{Ga, GaConfig};
use joca_metrics::{TaskMetrics, TaskScores};
use joca_nn::Engine;
use joca_nn::acc::AccBounds;
use joca_nn::detector::DetectorConfig;
use joca_nn::formation::Scene;
use joca_nn::joint::{DfGradWeights, Exposure, JointModel};
use joca_sim::{Illumination, SimConfig, Simulator, train_map_seed};
use rand::Rng;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap};
use std::io::Write;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The methods of the paper's comparison and ablations.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Ours: hardware GA + NeuralAE trained with DF-Grad + detector.
    Joca,
    /// TaCOS: hardware GA + AverageAE + detector.
    TacosAverage,
    /// A fixed camera at the nuScenes-like mount with NeuralAE trained by the task loss only.
    FixedNeural,
    /// Ablation: hardware GA + NeuralAE by the task loss only.
    NoGaLoss,
    /// Ablation: hardware GA + NeuralAE supervised by four fixed perturbations (±2.5 %).
    FixedPerturbation,
    /// Ablation: ours with the pre-trained detector frozen.
    FrozenDetector,
}

impl Method {
    /// Every method.
    pub const ALL: [Method; 6] = [
        Method::Joca,
        Method::TacosAverage,
        Method::FixedNeural,
        Method::NoGaLoss,
        Method::FixedPerturbation,
        Method::FrozenDetector,
    ];

    /// The name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Method::Joca => "joca",
            Method::TacosAverage => "tacos-average",
            Method::FixedNeural => "fixed-neural",
            Method::NoGaLoss => "no-ga-loss",
            Method::FixedPerturbation => "fixed-perturbation",
            Method::FrozenDetector => "frozen-detector",
        }
    }

    /// Parses a name, listing the valid ones on failure.
    pub fn from_name(name: &str) -> Result<Self, String> {
        Self::ALL.into_iter().find(|m| m.name() == name).ok_or_else(|| {
            format!("unknown method {name:?}; valid: {}", Self::ALL.map(Method::name).join(", "))
        })
    }

    fn neural(self) -> bool {
        self != Method::TacosAverage
    }

    fn hardware_ga(self) -> bool {
        self != Method::FixedNeural
    }

    fn perturbations(self) -> bool {
        matches!(self, Method::Joca | Method::FixedPerturbation | Method::FrozenDetector)
    }
}

/// The scenarios of the paper's Table 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Scenario {
    /// Calibrated noise and motion.
    Calibrated,
    /// Noise variances × 10.
    Noise10,
    /// Noise variances × 20.
    Noise20,
    /// Motion during the shutter × 2.
    Blur2,
    /// Motion during the shutter × 4.
    Blur4,
}

impl Scenario {
    /// Every scenario.
    pub const ALL: [Scenario; 5] = [
        Scenario::Calibrated,
        Scenario::Noise10,
        Scenario::Noise20,
        Scenario::Blur2,
        Scenario::Blur4,
    ];

    /// The name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Scenario::Calibrated => "calibrated",
            Scenario::Noise10 => "noise10",
            Scenario::Noise20 => "noise20",
            Scenario::Blur2 => "blur2",
            Scenario::Blur4 => "blur4",
        }
    }

    /// Parses a name, listing the valid ones on failure.
    pub fn from_name(name: &str) -> Result<Self, String> {
        Self::ALL.into_iter().find(|s| s.name() == name).ok_or_else(|| {
            format!(
                "unknown scenario {name:?}; valid: {}",
                Self::ALL.map(Scenario::name).join(", ")
            )
        })
    }

    /// Multiplier of σp² and σr².
    pub fn noise_scale(self) -> f64 {
        match self {
            Scenario::Noise10 => 10.0,
            Scenario::Noise20 => 20.0,
            _ => 1.0,
        }
    }

    /// Multiplier of the motion during the shutter.
    pub fn motion_scale(self) -> f64 {
        match self {
            Scenario::Blur2 => 2.0,
            Scenario::Blur4 => 4.0,
            _ => 1.0,
        }
    }
}

/// The fixed cameras of the baselines, at the nuScenes-like mount (x 0.43 m, z 1.65 m, 3.6 mm).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FixedCamera {
    /// FLIR Flea3: IMX172.
    Flir,
    /// Basler Dart: AR0134.
    Basler,
}

impl FixedCamera {
    /// The design.
    pub fn design(self) -> CameraDesign {
        let name = match self {
            FixedCamera::Flir => "IMX172",
            FixedCamera::Basler => "AR0134",
        };
        CameraDesign {
            x_m: 0.43,
            z_m: 1.65,
            focal_length_mm: 3.6,
            sensor_index: sensor_by_name(name).map(|s| s.index).unwrap_or(0),
        }
    }
}

/// Settings of a run (the `[run]` table of a preset).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunConfig {
    /// Run seed.
    pub seed: u64,
    /// libtorch and rayon threads.
    pub threads: usize,
    /// Method.
    pub method: Method,
    /// Scenario.
    pub scenario: Scenario,
    /// Camera of `fixed-neural`.
    pub camera: FixedCamera,
    /// Hardware GA generations.
    pub generations: usize,
    /// Hardware GA population.
    pub population: usize,
    /// Steps (frames) per hardware candidate, k.
    pub steps_per_candidate: usize,
    /// Perturbation GA population, n.
    pub perturbation_population: usize,
    /// GA loss applied every i steps.
    pub ga_every: usize,
    /// Task-loss weight of the ACC loss (GA loss weight 1).
    pub task_weight: f64,
    /// Output resolution = sensor grid × this.
    pub render_scale: f64,
    /// Training towns.
    pub train_maps: u64,
    /// Ego top speed, m/s.
    pub max_speed_mps: f64,
    /// Detector size.
    pub detector: DetectorConfig,
    /// Detector weights to start from (relative paths are relative to the working directory);
    /// empty: train from scratch. `frozen-detector` requires them.
    pub detector_weights: String,
    /// Test episodes (illumination drawn per episode) on the test town.
    pub test_episodes: u64,
    /// Scored frames per test episode.
    pub test_frames_per_episode: usize,
    /// Frame source for training: empty (or `sim`) for the built-in simulator; `folder:DIR` (the
    /// folder format) or `waymo:DIR` (Waymo Open Dataset v2 parquet) for the real-image mode.
    #[serde(default)]
    pub source: String,
    /// Frame source for testing; empty: the test town (simulator) or, in real-image mode, the
    /// training folder itself (say so when you report it).
    #[serde(default)]
    pub test_source: String,
    /// How recorded frames are read (real-image mode only).
    #[serde(default)]
    pub real: RealConfig,
}

/// How the real-image mode reads recorded frames (`[run.real]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RealConfig {
    /// `srgb` (undo the sRGB curve of 8-bit frames) or `none` (frames are linear).
    pub linearize: String,
    /// Exposure of frames without `exposure_s`, ms; 0 refuses such frames.
    pub default_exposure_ms: f64,
    /// A frame that cannot be read: `stop` the run naming it, or `skip` it with a warning.
    pub on_bad_frame: String,
    /// Waymo camera to use (`key.camera_name`; FRONT_LEFT = 2, the paper's).
    pub waymo_camera: i64,
}

impl Default for RealConfig {
    fn default() -> Self {
        Self {
            linearize: "srgb".into(),
            default_exposure_ms: 0.0,
            on_bad_frame: "stop".into(),
            waymo_camera: joca_data::waymo::FRONT_LEFT,
        }
    }
}

impl RealConfig {
    fn folder_config(&self) -> Result<FolderConfig, TrainError> {
        let bad = |field: &str, value: String, allowed: &str| TrainError::Config {
            field: format!("run.real.{field}"),
            value,
            allowed: allowed.into(),
        };
        let cal = Calibration::DEFAULT;
        Ok(FolderConfig {
            linearize: Linearize::from_name(&self.linearize).map_err(|_| {
                bad("linearize", format!("{:?}", self.linearize), "\"srgb\" or \"none\"")
            })?,
            default_exposure_s: if self.default_exposure_ms > 0.0 {
                Some(self.default_exposure_ms * 1e-3)
            } else if self.default_exposure_ms == 0.0 {
                None
            } else {
                return Err(bad(
                    "default_exposure_ms",
                    self.default_exposure_ms.to_string(),
                    "0 (none) or above",
                ));
            },
            on_bad_frame: match self.on_bad_frame.as_str() {
                "stop" => OnBadFrame::Stop,
                "skip" => OnBadFrame::Skip,
                other => {
                    return Err(bad("on_bad_frame", format!("{other:?}"), "\"stop\" or \"skip\""));
                }
            },
            calibration_exposure_s: cal.exposure_s,
            calibration_gain_db: cal.gain_db,
            ..FolderConfig::default()
        })
    }
}

/// A recorded `source`: `folder:DIR` or `waymo:DIR`.
#[derive(Debug, Clone, PartialEq)]
enum Recorded {
    Folder(PathBuf),
    Waymo(PathBuf),
}

impl Recorded {
    fn open(&self, real: &RealConfig) -> Result<Recording, TrainError> {
        let folder = real.folder_config()?;
        Ok(match self {
            Recorded::Folder(dir) => Recording::open(dir, folder)?,
            Recorded::Waymo(dir) => Recording::open_waymo(dir, real.waymo_camera, folder)?,
        })
    }
}

/// A `source` value: a recording, or `None` for the simulator.
fn recording_of(source: &str, field: &str) -> Result<Option<Recorded>, TrainError> {
    match source {
        "" | "sim" => Ok(None),
        s if s.starts_with("folder:") && s.len() > 7 => Ok(Some(Recorded::Folder(PathBuf::from(&s[7..])))),
        s if s.starts_with("waymo:") && s.len() > 6 => Ok(Some(Recorded::Waymo(PathBuf::from(&s[6..])))),
        s => Err(TrainError::Config {
            field: format!("run.{field}"),
            value: format!("{s:?}"),
            allowed: "\"sim\" (the built-in simulator), \"folder:DIR\" (a recording in the folder format) or \"waymo:DIR\" (Waymo Open Dataset v2 parquet: DIR/camera_image, DIR/camera_box)".into(),
        }),
    }
}

impl RunConfig {
    /// Checks every field; the error names the field and what is allowed.
    pub fn validate(&self) -> Result<(), TrainError> {
        let bad = |field: &str, value: String, allowed: &str| {
            Err(TrainError::Config {
                field: format!("run.{field}"),
                value,
                allowed: allowed.into(),
            })
        };
        if !(1..=64).contains(&self.threads) {
            return bad("threads", self.threads.to_string(), "1 to 64");
        }
        if self.generations == 0 {
            return bad("generations", "0".into(), "at least 1");
        }
        if self.population < 2 {
            return bad("population", self.population.to_string(), "at least 2");
        }
        if self.steps_per_candidate < 2 || self.steps_per_candidate > 400 {
            return bad("steps_per_candidate", self.steps_per_candidate.to_string(), "2 to 400");
        }
        if self.perturbation_population < 2 {
            return bad(
                "perturbation_population",
                self.perturbation_population.to_string(),
                "at least 2",
            );
        }
        if self.ga_every == 0 {
            return bad("ga_every", "0".into(), "at least 1");
        }
        if self.task_weight.is_nan() || self.task_weight <= 0.0 {
            return bad("task_weight", self.task_weight.to_string(), "above 0");
        }
        if !(self.render_scale > 0.0 && self.render_scale <= 1.0) {
            return bad("render_scale", self.render_scale.to_string(), "above 0, at most 1");
        }
        if self.train_maps == 0 {
            return bad("train_maps", "0".into(), "at least 1");
        }
        if self.method == Method::FrozenDetector && self.detector_weights.is_empty() {
            return bad(
                "detector_weights",
                "\"\"".into(),
                "a weights file from `joca train-detector` (frozen-detector freezes it)",
            );
        }
        recording_of(&self.source, "source")?;
        recording_of(&self.test_source, "test_source")?;
        self.real.folder_config()?;
        if self.test_episodes == 0 || self.test_frames_per_episode == 0 {
            return bad(
                "test_episodes",
                self.test_episodes.to_string(),
                "at least 1 episode of at least 1 frame",
            );
        }
        Ok(())
    }
}

/// Test results of a run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunResults {
    /// Method.
    pub method: Method,
    /// Scenario.
    pub scenario: Scenario,
    /// The evaluated design.
    pub design: DesignSummary,
    /// Test-town scores.
    pub test: TaskScores,
    /// Mean exposure (ms) and gain (dB) by illumination during the test.
    pub settings_by_illumination: BTreeMap<String, (f64, f64)>,
    /// Best hardware fitness seen in training.
    pub best_fitness: f64,
    /// Output resolution factor.
    pub render_scale: f64,
    /// The test frames' source: `sim`, `folder:DIR` or `waymo:DIR`.
    #[serde(default)]
    pub source: String,
}

impl RunResults {
    /// Whether the run was tested on recorded frames (the real-image mode).
    pub fn real_images(&self) -> bool {
        matches!(recording_of(&self.source, "source"), Ok(Some(_)))
    }
}

/// A design as the result tables show it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DesignSummary {
    /// Forward position, m.
    pub x_m: f64,
    /// Height, m.
    pub z_m: f64,
    /// Focal length, mm.
    pub focal_length_mm: f64,
    /// Sensor name.
    pub sensor: String,
    /// Sensor width × height, mm.
    pub sensor_mm: (f64, f64),
    /// Pixel pitch, µm.
    pub pixel_pitch_um: f64,
    /// Whether the hardware was optimised (else fixed).
    pub optimised: bool,
}

impl DesignSummary {
    fn new(d: &CameraDesign, optimised: bool) -> Self {
        let s = d.sensor();
        Self {
            x_m: d.x_m,
            z_m: d.z_m,
            focal_length_mm: d.focal_length_mm,
            sensor: s.name.clone(),
            sensor_mm: (s.width_mm, s.height_mm),
            pixel_pitch_um: s.pixel_pitch_um,
            optimised,
        }
    }
}

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

/// Mean wall time per training step by part, milliseconds (`joca bench step`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct StepBreakdown {
    /// NeuralAE forward (histograms, features, prediction).
    pub acc_predict_ms: f64,
    /// Rendering the forward-mode frame (all its sub-frames).
    pub render_ms: f64,
    /// Perturbation mode: rendering the perturbed frames.
    pub perturbation_render_ms: f64,
    /// Perturbation mode: forming, detecting and scoring (AP50) the perturbed frames.
    pub perturbation_detect_ms: f64,
    /// Perturbation GA update.
    pub perturbation_ga_ms: f64,
    /// Drawing the noise sample.
    pub noise_ms: f64,
    /// Differentiable formation.
    pub formation_ms: f64,
    /// Detector forward and loss.
    pub detector_forward_ms: f64,
    /// Backward pass.
    pub backward_ms: f64,
    /// Optimiser updates.
    pub update_ms: f64,
    /// Decoding and metric bookkeeping.
    pub decode_ms: f64,
    /// Steps measured.
    pub steps: usize,
}

impl StepBreakdown {
    /// Sum of the parts, milliseconds.
    pub fn total_ms(&self) -> f64 {
        self.acc_predict_ms
            + self.render_ms
            + self.perturbation_render_ms
            + self.perturbation_detect_ms
            + self.perturbation_ga_ms
            + self.noise_ms
            + self.formation_ms
            + self.detector_forward_ms
            + self.backward_ms
            + self.update_ms
            + self.decode_ms
    }

    fn scaled(mut self, k: f64) -> Self {
        for v in [
            &mut self.acc_predict_ms,
            &mut self.render_ms,
            &mut self.perturbation_render_ms,
            &mut self.perturbation_detect_ms,
            &mut self.perturbation_ga_ms,
            &mut self.noise_ms,
            &mut self.formation_ms,
            &mut self.detector_forward_ms,
            &mut self.backward_ms,
            &mut self.update_ms,
            &mut self.decode_ms,
        ] {
            *v *= k;
        }
        self
    }
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
}

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
    sims: HashMap<u64, Simulator>,
    /// The recorded sources of the real-image mode (None: the simulator).
    real: Option<Arc<RealSources>>,
    ranges: AccRanges,
    log: Box<dyn Write>,
    log_path: PathBuf,
    timing: Option<StepBreakdown>,
}

/// Runs (or resumes) a joint optimisation into `run_dir`, then tests the best design.
pub fn run(
    config: &RunConfig,
    run_dir: &Path,
    resume: bool,
    progress: &mut dyn FnMut(&RunEvent) -> ControlFlow<()>,
) -> Result<RunResults, TrainError> {
    config.validate()?;
    std::fs::create_dir_all(run_dir).map_err(|e| TrainError::io(run_dir, e))?;
    let log_path = run_dir.join("events.jsonl");
    let log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&log_path)
        .map_err(|e| TrainError::io(&log_path, e))?;
    let (mut cx, mut model) = setup(config, Box::new(log), log_path)?;
    let streams = cx.streams;
    let codec = cx.codec.clone();
    let hw_bounds: Vec<(f64, f64)> =
        codec.genes().iter().map(|g| (g.bounds.min, g.bounds.max)).collect();
    let mut init_rng = streams.stream("hardware-init");
    let mut hardware = Ga::new(
        GaConfig::new(config.population, hw_bounds, (0.8, 1.2)).map_err(ga_err)?,
        &mut init_rng,
    );
    hardware.apply(|g| {
        let _ = codec.snap(g);
    });
    // Perturbations in normalised units: ±5 % of each range.
    let perturbation = perturbation_ga(config, &streams)?;
    let mut state = RunState {
        config: config.clone(),
        generation: 0,
        candidate: 0,
        fitness: Vec::new(),
        hardware,
        perturbation,
        best: None,
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

    let total =
        config.generations * if config.method.hardware_ga() { config.population } else { 1 };
    while state.generation < config.generations {
        let members: Vec<Vec<f64>> = if config.method.hardware_ga() {
            state.hardware.ask().to_vec()
        } else {
            vec![cx.codec.encode(&config.camera.design())?]
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
            let scores = match train_candidate(
                &mut cx,
                &mut model,
                &mut state.perturbation,
                &design,
                index,
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
            let fitness = scores.fitness();
            state.fitness.push(fitness);
            if state.best.as_ref().is_none_or(|(_, f)| fitness > *f) {
                state.best = Some((members[state.candidate].clone(), fitness));
            }
            let line = serde_json::json!({"generation": state.generation, "candidate": state.candidate, "design": DesignSummary::new(&design, config.method.hardware_ga()), "scores": scores, "fitness": fitness});
            writeln!(cx.log, "{line}").map_err(|e| TrainError::io(&cx.log_path, e))?;
            state.candidate += 1;
            if state.candidate == members.len() {
                if config.method.hardware_ga() {
                    let codec = cx.codec.clone();
                    let mut rng = cx.streams.indexed("hardware-ga", state.generation as u64);
                    state
                        .hardware
                        .tell(&state.fitness, &mut rng, |g| {
                            let _ = codec.snap(g);
                        })
                        .map_err(ga_err)?;
                }
                writeln!(cx.log, "{}", serde_json::json!({"generation_done": state.generation, "fitness": state.fitness})).map_err(|e| TrainError::io(&cx.log_path, e))?;
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
    let design = best_design(&cx, &state)?;
    write_atomic(
        &run_dir.join("best_design.json"),
        &serde_json::to_string_pretty(&DesignSummary::new(&design, config.method.hardware_ga()))
            .unwrap_or_default(),
    )?;
    let results = test_design(&mut cx, &mut model, &state, &design, Some(&run_dir.join("test")))?;
    write_atomic(
        &run_dir.join("results.json"),
        &serde_json::to_string_pretty(&results).unwrap_or_default(),
    )?;
    Ok(results)
}

/// Mean exposure (ms) and gain (dB) per illumination name.
type SettingsByLight = BTreeMap<String, (f64, f64)>;

/// The perturbation GA of DF-Grad: `(p_e, p_g)` in normalised units within ±5 % of each range,
/// mutation ×U(0.9, 1.1).
fn perturbation_ga(config: &RunConfig, streams: &SeedStreams) -> Result<Ga, TrainError> {
    let ga_config =
        GaConfig::new(config.perturbation_population, vec![(-0.05, 0.05); 2], (0.9, 1.1))
            .map_err(ga_err)?;
    Ok(Ga::new(ga_config, &mut streams.stream("perturbation-init")))
}

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
    let formation = ImageFormation::new(cal)?.with_noise_scale(n)?;
    let bounds = AccBounds::new(
        (ranges.exposure_s.min, ranges.exposure_s.max),
        (ranges.gain_db.min, ranges.gain_db.max),
    );
    let mut model = JointModel::new(&engine, config.detector, bounds, formation);
    if !config.detector_weights.is_empty() {
        model.load_detector(Path::new(&config.detector_weights))?;
    }
    model.set_detector_trainable(config.method != Method::FrozenDetector);
    let (real, space) = match recording_of(&config.source, "source")? {
        None => (None, DesignSpace::synthetic()),
        Some(recorded) => {
            let train = recorded.open(&config.real)?;
            // Without a test source the test plays the training recording itself: opening it a
            // second time would read (and, for Waymo, hold) every frame twice.
            let held_out = match recording_of(&config.test_source, "test_source")? {
                Some(test) => Some(test.open(&config.real)?),
                None => None,
            };
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
        timing: None,
    };
    Ok((cx, model))
}

/// Tests the best design of a finished (or interrupted) run again, from its checkpoint: the
/// trained detector and NeuralAE in closed loop on the test town, optionally under another
/// scenario or with another number of frames. Writes `results.json` (or, for another scenario,
/// `results-<scenario>.json`) and returns the results.
pub fn evaluate_run(
    run_dir: &Path,
    scenario: Option<Scenario>,
    frames_per_episode: Option<usize>,
) -> Result<RunResults, TrainError> {
    let config_path = run_dir.join("config.toml");
    let text =
        std::fs::read_to_string(&config_path).map_err(|e| TrainError::io(&config_path, e))?;
    let file: ConfigFile = toml::from_str(&text).map_err(|e| TrainError::Corrupt {
        path: config_path.display().to_string(),
        reason: e.to_string(),
    })?;
    let mut config = file.run;
    if let Some(s) = scenario {
        config.scenario = s;
    }
    if let Some(f) = frames_per_episode {
        config.test_frames_per_episode = f;
    }
    config.validate()?;
    let dir = CheckpointDir::new(run_dir.join("checkpoint")).existing().ok_or_else(|| {
        TrainError::Corrupt {
            path: run_dir.join("checkpoint").display().to_string(),
            reason: "no checkpoint: the run has not finished a single candidate".into(),
        }
    })?;
    let state: RunState = read_json(&dir.join("state.json"))?;
    let (mut cx, mut model) = setup(&config, Box::new(std::io::sink()), PathBuf::from("(none)"))?;
    model.load(&dir)?;
    let design = best_design(&cx, &state)?;
    let other = scenario.is_some_and(|s| s != state.config.scenario);
    let (name, test_dir) = if other {
        (
            format!("results-{}.json", config.scenario.name()),
            format!("test-{}", config.scenario.name()),
        )
    } else {
        ("results.json".to_owned(), "test".to_owned())
    };
    let results = test_design(&mut cx, &mut model, &state, &design, Some(&run_dir.join(test_dir)))?;
    write_atomic(&run_dir.join(name), &serde_json::to_string_pretty(&results).unwrap_or_default())?;
    Ok(results)
}

/// Times `steps` training steps of `config`'s method on `design` (one candidate after a warm-up
/// candidate), returning the mean time per step by part.
pub fn bench_step(
    config: &RunConfig,
    design: &CameraDesign,
    steps: usize,
) -> Result<StepBreakdown, TrainError> {
    let mut config = config.clone();
    config.steps_per_candidate = steps.max(2);
    config.validate()?;
    let (mut cx, mut model) = setup(&config, Box::new(std::io::sink()), PathBuf::from("(none)"))?;
    let mut perturbation = perturbation_ga(&config, &cx.streams)?;
    train_candidate(&mut cx, &mut model, &mut perturbation, design, 0, &mut |_, _| {})?; // warm-up
    cx.timing = Some(StepBreakdown::default());
    train_candidate(&mut cx, &mut model, &mut perturbation, design, 1, &mut |_, _| {})?;
    let t = cx.timing.unwrap_or_default();
    Ok(t.scaled(1.0 / t.steps.max(1) as f64))
}

/// `config.toml` of a run directory: the resolved `[run]` table.
#[derive(Serialize, Deserialize)]
struct ConfigFile {
    run: RunConfig,
}

fn ga_err(e: joca_evolve::GaError) -> TrainError {
    TrainError::Config { field: "ga".into(), value: String::new(), allowed: e.to_string() }
}

fn simulator(
    sims: &mut HashMap<u64, Simulator>,
    map_seed: u64,
    max_speed: f64,
    illumination: Option<Illumination>,
) -> &Simulator {
    sims.entry(map_seed).or_insert_with(|| {
        Simulator::new(SimConfig {
            map_seed,
            max_speed_mps: max_speed,
            illumination,
            ..SimConfig::default()
        })
    })
}

/// The illumination schedule of a training episode, as logged (`recorded` for real frames).
fn illumination_name(
    sims: &HashMap<u64, Simulator>,
    real: Option<&RealSources>,
    map_seed: u64,
    episode: u64,
) -> &'static str {
    match (real, sims.get(&map_seed)) {
        (None, Some(sim)) => sim.episode(episode).illumination.name(),
        _ => "recorded",
    }
}

/// One hardware candidate: k steps of joint training; its fitness scores the k frames together.
fn train_candidate(
    cx: &mut Context,
    model: &mut JointModel,
    perturbation: &mut Ga,
    design: &CameraDesign,
    index: u64,
    on_step: &mut dyn FnMut(usize, usize),
) -> Result<TaskScores, TrainError> {
    let c = cx.config.clone();
    let mut rng = cx.streams.indexed("candidate", index);
    let map_seed = train_map_seed(rng.random_range(0..c.train_maps));
    let episode: u64 = rng.random_range(0..1_000_000);
    let real = cx.real.clone();
    let t0: f64 = match &real {
        None => {
            let span = 59.0 - c.steps_per_candidate as f64 * 0.1;
            rng.random_range(1.0..span.max(1.5))
        }
        Some(r) => {
            // A window of k frames inside the recorded sequence (from its start if shorter).
            let room = r.train.duration_s(episode)
                - c.steps_per_candidate as f64 * r.train.frame_interval_s();
            if room > 0.0 { rng.random_range(0.0..room) } else { 0.0 }
        }
    };
    let camera = design.pinhole(c.render_scale);
    let pitch = design.sensor().pixel_pitch_um;
    let cal = Calibration::DEFAULT;
    let ae = AverageAe::new(cx.ranges);
    let motion = c.scenario.motion_scale();
    let weights = DfGradWeights { task: c.task_weight, ga: 1.0 };
    let mut metrics = TaskMetrics::default();
    model.reset_sequence();
    let mut applied = DynamicSettings::new(cal.exposure_s, cal.gain_db);
    let mut previous_pred = applied;
    let mut previous_frame = None;
    let mut clock = std::time::Instant::now();
    let mut lap = |timing: &mut Option<StepBreakdown>, part: fn(&mut StepBreakdown) -> &mut f64| {
        let ms = clock.elapsed().as_secs_f64() * 1e3;
        clock = std::time::Instant::now();
        if let Some(t) = timing.as_mut() {
            *part(t) += ms;
        }
    };
    for step in 0..c.steps_per_candidate {
        let global = index * c.steps_per_candidate as u64 + step as u64;
        lap(&mut None, |t| &mut t.decode_ms);
        let sim: &dyn FrameSource = match &real {
            Some(r) => &r.train,
            None => simulator(&mut cx.sims, map_seed, c.max_speed_mps, None),
        };
        let t = t0 + step as f64 * sim.frame_interval_s();
        // 1. Exposure and gain for this frame.
        let mut prediction = None;
        let exposure = match (&previous_frame, c.method.neural()) {
            (Some(prev), true) => {
                match model.predict(prev, previous_pred.exposure_s, previous_pred.gain_db) {
                    Some(p) => {
                        let pred = DynamicSettings::new(p.exposure_s, p.gain_db);
                        prediction = Some(pred);
                        applied = compensate_for_pixel_size(pred, pitch, cal.pixel_pitch_um);
                        Exposure::Predicted
                    }
                    None => {
                        Exposure::Fixed { exposure_s: applied.exposure_s, gain_db: applied.gain_db }
                    }
                }
            }
            (Some(prev), false) => {
                applied = ae.step(applied, prev);
                Exposure::Fixed { exposure_s: applied.exposure_s, gain_db: applied.gain_db }
            }
            (None, _) => {
                Exposure::Fixed { exposure_s: applied.exposure_s, gain_db: applied.gain_db }
            }
        };
        lap(&mut cx.timing, |t| &mut t.acc_predict_ms);
        let request = FrameRequest {
            episode,
            time_s: t,
            exposure_s: applied.exposure_s,
            motion_scale: motion,
        };
        let frame = sim.render(&camera, &request)?;
        lap(&mut cx.timing, |t| &mut t.render_ms);
        // 2. Perturbation mode: re-render with perturbed settings (new blur), score by AP50.
        let mut ga_target = None;
        if let (Some(pred), true) = (prediction, c.method.perturbations()) {
            let members: Vec<Vec<f64>> = if c.method == Method::FixedPerturbation {
                vec![
                    vec![0.025, 0.025],
                    vec![0.025, -0.025],
                    vec![-0.025, 0.025],
                    vec![-0.025, -0.025],
                ]
            } else {
                perturbation.ask().to_vec()
            };
            let mut fitness = Vec::with_capacity(members.len());
            let mut candidates = Vec::with_capacity(members.len());
            for (m, p) in members.iter().enumerate() {
                let perturbed = cx.ranges.clamp(DynamicSettings::new(
                    pred.exposure_s + p[0] * cx.ranges.exposure_s.span(),
                    pred.gain_db + p[1] * cx.ranges.gain_db.span(),
                ));
                let applied_p = compensate_for_pixel_size(perturbed, pitch, cal.pixel_pitch_um);
                let f = sim.render(
                    &camera,
                    &FrameRequest { exposure_s: applied_p.exposure_s, ..request },
                )?;
                lap(&mut cx.timing, |t| &mut t.perturbation_render_ms);
                let image = cx.formation.form(
                    &f.hdr,
                    applied_p,
                    pitch,
                    &mut cx.streams.indexed("perturbation-noise", global * 16 + m as u64),
                );
                let mut one = TaskMetrics::default();
                one.update(&f.boxes, &f.ignore, &model.detect(&image), f.visible_180);
                fitness.push(one.compute().ap50);
                candidates.push(perturbed);
                lap(&mut cx.timing, |t| &mut t.perturbation_detect_ms);
            }
            let best = (0..fitness.len())
                .max_by(|&a, &b| fitness[a].total_cmp(&fitness[b]).then(b.cmp(&a)))
                .unwrap_or(0);
            if c.method != Method::FixedPerturbation {
                perturbation
                    .tell(&fitness, &mut cx.streams.indexed("perturbation-ga", global), |_| {})
                    .map_err(ga_err)?;
            }
            if step % c.ga_every == 0 {
                ga_target = Some((candidates[best].exposure_s, candidates[best].gain_db));
            }
            lap(&mut cx.timing, |t| &mut t.perturbation_ga_ms);
        }
        // 3. Forward mode: differentiable formation, detector, DF-Grad update.
        let noise_seed: u64 = cx.streams.indexed("noise", global).random();
        let normals =
            ImageFormation::standard_normals(camera.width_px, camera.height_px, noise_seed);
        lap(&mut cx.timing, |t| &mut t.noise_ms);
        let scene = Scene {
            i0: frame.hdr.data(),
            normals: &normals,
            width: camera.width_px,
            height: camera.height_px,
            pixel_pitch_um: pitch,
        };
        let report =
            model.step(&scene, &frame.boxes, &frame.ignore, exposure, ga_target, weights)?;
        lap(&mut None, |t| &mut t.decode_ms);
        if let Some(t) = cx.timing.as_mut() {
            let r = report.timings;
            t.formation_ms += r.formation_ms;
            t.detector_forward_ms += r.detector_forward_ms;
            t.backward_ms += r.backward_ms;
            t.update_ms += r.update_ms;
            t.decode_ms += r.decode_ms;
            t.steps += 1;
        }
        metrics.update(&frame.boxes, &frame.ignore, &report.detections, frame.visible_180);
        if step % 5 == 0 {
            let line = serde_json::json!({"step": global, "loss": report.loss, "ga_loss": report.ga_loss, "exposure_ms": report.exposure_s * 1e3, "gain_db": report.gain_db, "illumination": illumination_name(&cx.sims, real.as_deref(), map_seed, episode)});
            writeln!(cx.log, "{line}").map_err(|e| TrainError::io(&cx.log_path, e))?;
        }
        previous_pred = prediction.unwrap_or(applied);
        previous_frame = Some(report.frame);
        on_step(step + 1, c.steps_per_candidate);
    }
    Ok(metrics.compute())
}

/// The best design of `state`: best fitness seen, or the first member if none was scored.
fn best_design(cx: &Context, state: &RunState) -> Result<CameraDesign, TrainError> {
    let genes =
        state.best.as_ref().map_or_else(|| state.hardware.ask()[0].clone(), |b| b.0.clone());
    Ok(cx.codec.decode(&genes)?)
}

/// `design` tested in closed loop with the current model, as the run's results.
fn test_design(
    cx: &mut Context,
    model: &mut JointModel,
    state: &RunState,
    design: &CameraDesign,
    out: Option<&Path>,
) -> Result<RunResults, TrainError> {
    let (test, settings) = closed_loop::test(cx, model, design, out)?;
    let config = &cx.config;
    Ok(RunResults {
        method: config.method,
        scenario: config.scenario,
        design: DesignSummary::new(design, config.method.hardware_ga()),
        test,
        settings_by_illumination: settings,
        best_fitness: state.best.as_ref().map_or(0.0, |b| b.1),
        render_scale: config.render_scale,
        source: if config.source.is_empty() || config.source == "sim" {
            "sim".into()
        } else if config.test_source.is_empty() {
            config.source.clone()
        } else {
            config.test_source.clone()
        },
    })
}
