//! Testing a design: the best design of a run after training, and `joca eval`, which tests it
//! again from the checkpoint, optionally under another scenario or with more frames.

use super::closed_loop::{self, Plan};
use super::config::ConfigFile;
use super::context::{Context, setup};
use super::results::summary;
use super::{RunResults, RunState, Scenario, cpu_description};
use crate::TrainError;
use crate::checkpoint::{CheckpointDir, read_json, write_atomic};
use crate::control::TestController;
use joca_camera::CameraDesign;
use joca_core::output::{self, DirLock, OutputKind};
use joca_nn::detector::PrecisionExt;
use joca_nn::device::DeviceChoice;
use joca_nn::joint::JointModel;
use joca_record::{Provenance, Validated};
use std::path::{Path, PathBuf};

/// What `joca eval` changes about a run's test (the default: nothing — the same test again).
#[derive(Debug, Clone, Copy, Default)]
pub struct EvalOptions {
    /// Another scenario.
    pub scenario: Option<Scenario>,
    /// Another number of scored frames per episode.
    pub frames_per_episode: Option<usize>,
    /// Another number of episodes (stratified by light as the test's are).
    pub episodes: Option<u64>,
    /// Another town of the test family: fresh scenes of the same kind, never trained or validated
    /// on (0, the default, is the test town; 1 is the validation town and refused).
    pub town: u64,
    /// Another controller.
    pub controller: TestController,
    /// Test with the detector weights the run started from (its config's `detector_weights`) in
    /// place of its trained detector, on the design chosen with the trained one: what training
    /// the detector in the loop changed on that design and those scenes. NeuralAE keeps its
    /// trained weights; its semantic input is the detector's features, so it reads the swapped
    /// detector's.
    pub start_detector: bool,
    /// Another device for the networks (the run's `device` otherwise): a run trained on a GPU
    /// can be tested on a CPU and back; the numbers are the device's.
    pub device: Option<DeviceChoice>,
}

/// The largest `--town` index accepted.
pub const MAX_TEST_TOWN: u64 = 9_999;

impl EvalOptions {
    /// Refuses the validation town and an index past [`MAX_TEST_TOWN`].
    fn check(&self) -> Result<(), TrainError> {
        check_town(self.town)
    }
}

/// Refuses the validation town and an index past [`MAX_TEST_TOWN`] as a test town.
pub fn check_town(town: u64) -> Result<(), TrainError> {
    if town == 1 || town > MAX_TEST_TOWN {
        return Err(TrainError::Config {
            field: "--town".into(),
            value: town.to_string(),
            allowed: format!(
                "0 (the test town) or 2 to {MAX_TEST_TOWN} (fresh towns of the test family); \
                 1 is the validation town that chose among the designs"
            ),
        });
    }
    Ok(())
}

/// A finished (or interrupted) run directory opened: its configuration, its loop state and
/// checkpoint folder, and the directory's lock (held while the caller works, so it never reads a
/// checkpoint a run is writing): `joca eval`'s, which writes there, or with `reading` a reader's,
/// which other readers share.
pub(super) fn load_run(
    run_dir: &Path,
    reading: bool,
) -> Result<(super::RunConfig, RunState, PathBuf, DirLock), TrainError> {
    if output::check(run_dir, OutputKind::Run)? != Some(output::Claimed::Earlier) {
        return Err(TrainError::Corrupt {
            path: run_dir.display().to_string(),
            reason: "not a run directory of joca's (it does not exist or is empty)".into(),
        });
    }
    let lock = if reading {
        DirLock::acquire_shared(run_dir, "joca headroom")?
    } else {
        DirLock::acquire(run_dir, "joca eval")?
    };
    let config_path = run_dir.join("config.toml");
    let text =
        std::fs::read_to_string(&config_path).map_err(|e| TrainError::io(&config_path, e))?;
    let file: ConfigFile = toml::from_str(&text).map_err(|e| TrainError::Corrupt {
        path: config_path.display().to_string(),
        reason: e.to_string(),
    })?;
    let dir = CheckpointDir::new(run_dir.join("checkpoint")).existing().ok_or_else(|| {
        TrainError::Corrupt {
            path: run_dir.join("checkpoint").display().to_string(),
            reason: "no checkpoint: the run has not finished a single candidate".into(),
        }
    })?;
    crate::checkpoint::verify_checkpoint(&dir)?;
    let state_path = dir.join("state.json");
    let state: RunState = read_json(&state_path)?;
    // The checkpoint must be this run's: a folder holding another run's checkpoint would be
    // evaluated and written as this one's.
    let differing = crate::differing_fields(&state.config.identity(), &file.run.identity());
    if !differing.is_empty() {
        return Err(TrainError::Corrupt {
            path: state_path.display().to_string(),
            reason: format!(
                "the checkpoint was written by a run of another configuration than {} (fields \
                 differ: {})",
                config_path.display(),
                differing.join(", ")
            ),
        });
    }
    Ok((file.run, state, dir, lock))
}

/// Tests the best design of a finished (or interrupted) run again, from its checkpoint: the
/// trained detector and NeuralAE in closed loop, by default on the test town, with whatever
/// `options` change (another scenario, frame or episode count, town of the test family, or
/// controller: AverageAE at a chosen frame mean in place of the trained one; or detector: the
/// weights it started from; the design is still chosen with the run's own model). Never rewrites
/// the run's own `results.json`: writes `results-<tag>.json` (the tag names each change,
/// [`joca_record::Retest`]), its trace and showcases in the matching `test-<tag>` folder,
/// and returns the results and that folder. Holds the run directory's lock while it works, so it
/// never reads a checkpoint a run is writing.
pub fn evaluate_run(
    run_dir: &Path,
    options: &EvalOptions,
) -> Result<(RunResults, PathBuf), TrainError> {
    options.check()?;
    let EvalOptions {
        scenario,
        frames_per_episode,
        episodes,
        town,
        controller,
        start_detector,
        device,
    } = *options;
    let (mut config, state, dir, _lock) = load_run(run_dir, false)?;
    if let Some(d) = device {
        config.device = d;
    }
    if let Some(s) = scenario {
        config.scenario = s;
    }
    let (run_frames, run_episodes) = (config.test_frames_per_episode, config.test_episodes);
    if let Some(f) = frames_per_episode {
        config.test_frames_per_episode = f;
    }
    if let Some(n) = episodes {
        config.test_episodes = n;
    }
    config.validate()?;
    let config_path = run_dir.join("config.toml");
    let start_weights = if start_detector {
        Some(config.detector_weights.clone().ok_or_else(|| TrainError::Config {
            field: "--detector".into(),
            value: "start".into(),
            allowed: format!(
                "trained only: {} started from random detector weights (its config names no \
                 run.detector_weights)",
                config_path.display()
            ),
        })?)
    } else {
        None
    };
    let (mut cx, mut model) = setup(&config, Box::new(std::io::sink()), PathBuf::from("(none)"))?;
    if town != 0 && cx.scenes.recorded() {
        return Err(TrainError::Config {
            field: "--town".into(),
            value: town.to_string(),
            allowed: format!(
                "0 only: {} tests on recorded frames, which have no towns",
                run_dir.display()
            ),
        });
    }
    model.load(&dir)?;
    let (design, validation) = best_design(&mut cx, &mut model, &state)?;
    let retest = joca_record::Retest {
        scenario: scenario.filter(|s| *s != state.config.scenario),
        controller,
        start_detector: start_weights.is_some(),
        frames_per_episode: Some(config.test_frames_per_episode).filter(|f| *f != run_frames),
        episodes: Some(config.test_episodes).filter(|n| *n != run_episodes),
        town,
    };
    if let Some(weights) = &start_weights {
        // After the design is chosen: the swap tests the detector, not the choice.
        model.load_detector(weights)?;
    }
    let (name, test_dir) = (retest.results_file(), format!("test-{retest}"));
    let out = run_dir.join(test_dir);
    cx.test.controller = controller;
    cx.test.town = town;
    let mut results = test_design(&mut cx, &mut model, &state, (&design, validation), Some(&out))?;
    if controller != TestController::Trained {
        results.test_controller = Some(controller);
    }
    results.test_town = (town != 0).then_some(town);
    results.test_detector = start_weights.map(|w| w.display().to_string());
    write_atomic(&run_dir.join(name), &serde_json::to_string_pretty(&results).unwrap_or_default())?;
    Ok((results, out))
}

/// The design to test, and how the validation scored the candidates for it.
///
/// A candidate's training fitness rests on its own generation's scenes (one illumination, one
/// drive) and on the model of that moment, so the best of training is partly luck. The best
/// `TOP_DESIGNS` designs of training are therefore re-scored with the final model on the
/// validation town — another town than training's and the test's, one episode of each light —
/// and the best there is tested (ties keep the better training fitness). With a single design
/// (a fixed camera), or on recordings, there is nothing to choose and nothing is re-scored.
pub(super) fn best_design(
    cx: &mut Context,
    model: &mut JointModel,
    state: &RunState,
) -> Result<(CameraDesign, Vec<Validated>), TrainError> {
    let fallback =
        state.best.as_ref().map_or_else(|| state.hardware.ask()[0].clone(), |b| b.0.clone());
    if state.top.len() < 2 || cx.scenes.recorded() {
        return Ok((cx.codec.decode(&fallback)?, Vec::new()));
    }
    let optimised = cx.config.hardware_search();
    let mut scored = Vec::with_capacity(state.top.len());
    for (genes, fitness) in &state.top {
        let design = cx.codec.decode(genes)?;
        let validation = closed_loop::test(cx, model, &design, Plan::validation(), None)?.scores;
        scored.push((
            design,
            Validated {
                design: summary(&design, optimised),
                training_fitness: *fitness,
                validation,
            },
        ));
    }
    // Stable: among equal validation fitness the better training fitness (earlier) wins.
    scored.sort_by(|a, b| b.1.validation.fitness().total_cmp(&a.1.validation.fitness()));
    let design = scored[0].0;
    Ok((design, scored.into_iter().map(|(_, v)| v).collect()))
}

/// `design` tested in closed loop with the current model, as the run's results.
pub(super) fn test_design(
    cx: &mut Context,
    model: &mut JointModel,
    state: &RunState,
    (design, validation): (&CameraDesign, Vec<Validated>),
    out: Option<&Path>,
) -> Result<RunResults, TrainError> {
    let plan = Plan::test(&cx.config, cx.test.town);
    let tested = closed_loop::test(cx, model, design, plan, out)?;
    let config = &cx.config;
    let mut results = RunResults {
        format_version: 0,
        method: config.method,
        scenario: config.scenario,
        seed: config.seed,
        design: summary(design, config.hardware_search()),
        test: tested.scores,
        test_bands: tested.bands,
        by_illumination: tested.by_light,
        best_fitness: state.best.as_ref().map_or(0.0, |b| b.1),
        input: Some(config.input),
        render_scale: None,
        // Without a recording the test town is used, whatever `test_source` says.
        source: if config.source.is_recording() && config.test_source.is_recording() {
            config.test_source.clone()
        } else {
            config.source.clone()
        },
        scoring_precision: Some(config.scoring_precision.on_device(model.device())),
        cpu_kernels: Some(joca_nn::kernels::chosen()),
        denormals: Some(joca_nn::kernels::denormals()),
        cpu: cpu_description(),
        device: joca_nn::device::gpu_description(model.device()),
        test_controller: None,
        test_town: None,
        test_detector: None,
        perturbation_ties: (state.ties.searches > 0).then_some(state.ties),
        lens: config.lens,
        weather: config.weather,
        world: config.world(),
        aperture: config.aperture,
        validation,
        provenance: Some(Provenance::of_this_build(&config.identity())),
    };
    results.format_version = results.layout_version();
    Ok(results)
}
