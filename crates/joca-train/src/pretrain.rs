//! Detector pre-training (`joca train-detector`): the detector alone, on simulator frames from
//! random camera designs of the synthetic design space, exposed by AverageAE — the paper's
//! "frozen detector" pre-training (15,750 frames from 350 random cameras, 45 frames each).
//!
//! Every random choice is drawn from a stream indexed by design or step, so the data of any step
//! can be regenerated: a resumed run continues exactly where the checkpoint left it.

use crate::TrainError;
use crate::checkpoint::{CheckpointDir, check_resume, read_json, write_atomic};
use crate::eval::{AverageControl, EvalSpec, evaluate};
use joca_camera::{
    AccRanges, AverageAe, Calibration, CameraDesign, DesignSpace, DynamicSettings, GenomeCodec,
    ImageFormation, SensorEncoding, sensor_by_name,
};
use joca_core::{Annotation, FrameRequest, FrameSource, PinholeCamera, Rgb8Image, SeedStreams};
use joca_metrics::TaskScores;
use joca_nn::detector::{
    DetectorConfig, DetectorModel, LossParts, Precision, Regression, TrainFrame, WeightAverage,
};
use joca_nn::{AdamConfig, Engine};
use joca_sim::{CityConfig, Illumination, SimConfig, Simulator, VisibilityRules, train_map_seed};
use rand::Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::io::Write;
use std::ops::ControlFlow;
use std::path::Path;

/// Settings of a pre-training run (the `[pretrain]` presets in `presets/`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PretrainConfig {
    /// Run seed.
    pub seed: u64,
    /// libtorch and rayon threads.
    pub threads: usize,
    /// Training frames (`steps / batch` gradient steps). `warmup_steps` and `eval_every`
    /// count frames too.
    pub steps: usize,
    /// Frames per gradient step (default 1, as the paper): frames of one design, each from
    /// its own episode (a "lane" of the design's frames), so that they have one size and
    /// are not near-copies of one scene. Must divide `frames_per_design` and `steps`.
    #[serde(default = "one_frame")]
    pub batch: usize,
    /// Floating-point type of the training steps: `"fp32"` (default) or `"bf16"` (bfloat16
    /// convolutions with float32 weights, optimiser and loss; evaluation stays float32).
    #[serde(default)]
    pub precision: Precision,
    /// Frames per random camera design (45 in the paper).
    pub frames_per_design: usize,
    /// Consecutive frames per episode: a design's frames come from several episodes (each in a
    /// random training town, with its own drive, time and light), because 45 consecutive frames
    /// at 10 frames/s are nearly the same scene.
    pub frames_per_episode: usize,
    /// Output resolution = sensor grid × this.
    pub render_scale: f64,
    /// Number of training towns to draw episodes from.
    pub train_maps: u64,
    /// Peak learning rate (AdamW).
    pub lr: f64,
    /// Learning rate at the end of the cosine decay.
    pub lr_final: f64,
    /// Linear warm-up steps.
    pub warmup_steps: usize,
    /// AdamW weight decay.
    pub weight_decay: f64,
    /// Decay of the running weight average that is evaluated and written as the result
    /// (0: none, the last weights are the result). 0.999 averages over about the last 1000
    /// steps.
    #[serde(default)]
    pub ema_decay: f64,
    /// Detector size.
    pub detector: DetectorConfig,
    /// Evaluate on the test town every this many steps (0: only at the end).
    pub eval_every: usize,
    /// Test episodes per illumination in each evaluation (10 scored frames each).
    pub eval_episodes: u64,
    /// Test episodes per illumination of the final evaluation, the one in `results.json`
    /// (default: `eval_episodes`). The test town's rarer classes need many: in 100 day frames
    /// there may be no traffic sign at all and a dozen walkers.
    #[serde(default)]
    pub final_eval_episodes: Option<u64>,
    /// Write a checkpoint every this many designs; the designs between two checkpoints have
    /// their frames interleaved.
    pub checkpoint_every_designs: usize,
    /// Ego top speed, m/s.
    pub max_speed_mps: f64,
    /// Walkers in the training towns, as a multiple of the simulator's density (the test town
    /// keeps 1): annotated walkers are about a tenth as frequent as vehicles, so more of them
    /// re-balances the classes with new examples rather than re-weighting the few there are.
    #[serde(default = "one")]
    pub walker_density: f64,
    /// Traffic signs in the training towns, as a multiple of the simulator's density (the test
    /// town keeps 1): up to ≈ 2.2 at more intersection approaches, beyond that along the blocks.
    #[serde(default = "one")]
    pub sign_density: f64,
    /// Loss weight of each class's objects (vehicle, walker, traffic sign): a class-balanced
    /// loss for the rarer classes. The background term is not weighted.
    #[serde(default = "ones")]
    pub class_weights: [f64; 3],
    /// Where the size and offset heads learn: `"centre"` (CenterNet: each object's centre cell)
    /// or `"gaussian"` (every cell of its heatmap Gaussian, weighted by it).
    #[serde(default)]
    pub regression: Regression,
    /// Smallest radius of an object's heatmap Gaussian, cells (0: CenterNet's radius, which is
    /// 0 for objects under ~12 px such as most traffic signs).
    #[serde(default)]
    pub min_radius: u32,
    /// Smallest box width and height, pixels, that is a training object in the training towns
    /// (the simulator's rule, and the test's, is 8); smaller objects in view stay ignore
    /// regions. With the small images of random designs at `render_scale` 0.08 (100–330 px
    /// wide) nearly every traffic sign and most walkers in view are under 8 px.
    #[serde(default = "eight")]
    pub min_box_px: f64,
    /// Extra times a training frame is trained on when it holds an object of each class
    /// (vehicle, walker, traffic sign; the largest applies), in its design's next batches:
    /// repeat-factor sampling (Gupta et al., LVIS 2019) for the rare classes, within a block so
    /// that a resumed run repeats the same frames. The repeats are extra gradient samples, not
    /// frames of `steps`.
    #[serde(default)]
    pub repeats: [u32; 3],
}

fn one() -> f64 {
    1.0
}

fn eight() -> f64 {
    f64::from(VisibilityRules::default().min_box_px)
}

fn one_frame() -> usize {
    1
}

fn ones() -> [f64; 3] {
    [1.0; 3]
}

impl PretrainConfig {
    /// Test episodes per illumination of the final evaluation.
    pub fn final_episodes(&self) -> u64 {
        self.final_eval_episodes.unwrap_or(self.eval_episodes)
    }

    /// Checks every field; the error names the field and what is allowed.
    pub fn validate(&self) -> Result<(), TrainError> {
        let bad = |field: &str, value: String, allowed: &str| {
            Err(TrainError::Config {
                field: format!("pretrain.{field}"),
                value,
                allowed: allowed.to_owned(),
            })
        };
        if !(1..=64).contains(&self.threads) {
            return bad("threads", self.threads.to_string(), "1 to 64");
        }
        if self.steps == 0 {
            return bad("steps", "0".into(), "at least 1");
        }
        if self.frames_per_design == 0 || self.frames_per_design > 400 {
            return bad(
                "frames_per_design",
                self.frames_per_design.to_string(),
                "1 to 400 (episodes last 60 s at 10 frames/s)",
            );
        }
        if !(1..=64).contains(&self.batch)
            || self.frames_per_design % self.batch != 0
            || self.steps % self.batch != 0
        {
            return bad(
                "batch",
                self.batch.to_string(),
                "1 to 64, dividing frames_per_design and steps",
            );
        }
        if self.frames_per_episode == 0 || self.frames_per_episode > self.frames_per_design {
            return bad(
                "frames_per_episode",
                self.frames_per_episode.to_string(),
                "1 to frames_per_design",
            );
        }
        if !(self.render_scale > 0.0 && self.render_scale <= 1.0) {
            return bad("render_scale", self.render_scale.to_string(), "above 0, at most 1");
        }
        if self.train_maps == 0 {
            return bad("train_maps", "0".into(), "at least 1");
        }
        for (name, v) in [("lr", self.lr), ("lr_final", self.lr_final)] {
            if !(v > 0.0 && v < 1.0) {
                return bad(name, v.to_string(), "between 0 and 1");
            }
        }
        if !(self.ema_decay >= 0.0 && self.ema_decay < 1.0) {
            return bad("ema_decay", self.ema_decay.to_string(), "0 (off) up to below 1");
        }
        if !(self.weight_decay >= 0.0 && self.weight_decay < 1.0) {
            return bad("weight_decay", self.weight_decay.to_string(), "0 to 1");
        }
        if !(4..=128).contains(&self.detector.width) {
            return bad("detector.width", self.detector.width.to_string(), "4 to 128");
        }
        if self.detector.classes != 3 {
            return bad(
                "detector.classes",
                self.detector.classes.to_string(),
                "3 (vehicle, walker, traffic sign)",
            );
        }
        if !(1..=10_000).contains(&self.eval_episodes) {
            return bad("eval_episodes", self.eval_episodes.to_string(), "1 to 10000");
        }
        if let Some(n) = self.final_eval_episodes.filter(|n| !(1..=10_000).contains(n)) {
            return bad("final_eval_episodes", n.to_string(), "1 to 10000");
        }
        if self.checkpoint_every_designs == 0 {
            return bad("checkpoint_every_designs", "0".into(), "at least 1");
        }
        if !(self.max_speed_mps >= 0.0 && self.max_speed_mps <= 40.0) {
            return bad("max_speed_mps", self.max_speed_mps.to_string(), "0 to 40");
        }
        if !(self.walker_density >= 0.0 && self.walker_density <= 8.0) {
            return bad("walker_density", self.walker_density.to_string(), "0 to 8");
        }
        if !(self.sign_density >= 0.0 && self.sign_density <= 8.0) {
            return bad("sign_density", self.sign_density.to_string(), "0 to 8");
        }
        if !(self.min_box_px >= 1.0 && self.min_box_px <= 64.0) {
            return bad("min_box_px", self.min_box_px.to_string(), "1 to 64 pixels");
        }
        if self.repeats.iter().any(|&r| r > 8) {
            return bad("repeats", format!("{:?}", self.repeats), "each 0 to 8");
        }
        if self.min_radius > 4 {
            return bad("min_radius", self.min_radius.to_string(), "0 to 4 cells");
        }
        if !self.class_weights.iter().all(|w| *w > 0.0 && *w <= 100.0) {
            return bad(
                "class_weights",
                format!("{:?}", self.class_weights),
                "each above 0, at most 100",
            );
        }
        Ok(())
    }

    /// Learning rate at `step`: linear warm-up, then cosine decay to `lr_final`.
    pub fn lr_at(&self, step: usize) -> f64 {
        if step < self.warmup_steps {
            return self.lr * (step + 1) as f64 / self.warmup_steps as f64;
        }
        let span = (self.steps - self.warmup_steps.min(self.steps)).max(1) as f64;
        let progress = ((step - self.warmup_steps) as f64 / span).min(1.0);
        self.lr_final
            + 0.5 * (self.lr - self.lr_final) * (1.0 + (std::f64::consts::PI * progress).cos())
    }
}

/// Progress reported to the caller.
#[derive(Debug, Clone)]
pub enum PretrainEvent {
    /// A training step finished.
    Step {
        /// Steps done.
        step: usize,
        /// Total steps.
        of: usize,
        /// Its loss.
        loss: LossParts,
    },
    /// A test-town evaluation finished.
    Eval(Box<EvalReport>),
    /// A checkpoint was written.
    Checkpoint {
        /// Steps covered.
        step: usize,
    },
}

/// Test-town scores under day and night light.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EvalReport {
    /// Steps trained.
    pub step: usize,
    /// Daylight.
    pub day: TaskScores,
    /// Night.
    pub night: TaskScores,
}

/// The fixed camera every pre-training evaluation uses: a FLIR-like IMX172 behind 3.6 mm at the
/// nuScenes-like mount (DESIGN.md's baseline camera).
pub fn reference_design() -> CameraDesign {
    let sensor_index = sensor_by_name("IMX172").map(|s| s.index).unwrap_or(19);
    CameraDesign { x_m: 0.43, z_m: 1.65, focal_length_mm: 3.6, sensor_index }
}

#[derive(Debug, Serialize, Deserialize)]
struct State {
    step: usize,
    config: PretrainConfig,
}

/// Runs (or resumes) pre-training into `run_dir` and writes the final weights to `weights_out`.
pub fn pretrain(
    config: &PretrainConfig,
    run_dir: &Path,
    weights_out: &Path,
    resume: bool,
    progress: &mut dyn FnMut(&PretrainEvent) -> ControlFlow<()>,
) -> Result<EvalReport, TrainError> {
    config.validate()?;
    std::fs::create_dir_all(run_dir).map_err(|e| TrainError::io(run_dir, e))?;
    let engine = Engine::cpu(config.threads);
    let streams = SeedStreams::new(config.seed);
    engine.seed(streams.stream("detector-init").random());
    let adam =
        AdamConfig { lr: config.lr, weight_decay: config.weight_decay, ..AdamConfig::DETECTOR };
    let mut model = DetectorModel::new(&engine, config.detector, adam);
    model.set_class_weights(&config.class_weights);
    model.set_regression(config.regression);
    model.set_precision(config.precision);
    model.set_min_radius(i64::from(config.min_radius));
    let ckpt = CheckpointDir::new(run_dir.join("checkpoint"));
    let mut start = 0;
    let mut average = None;
    let resumed_from = ckpt.existing().filter(|_| resume);
    if let Some(dir) = &resumed_from {
        let state: State = read_json(&dir.join("state.json"))?;
        check_resume(&state.config, config, run_dir)?;
        model.load_weights(&dir.join("detector.safetensors"))?;
        model.load_optimizer(&dir.join("optimizer.safetensors"))?;
        start = state.step;
    } else if !resume && ckpt.existing().is_some() {
        return Err(TrainError::Config {
            field: "run directory".into(),
            value: run_dir.display().to_string(),
            allowed: "a directory without a checkpoint (pass --resume to continue it)".into(),
        });
    }
    if config.ema_decay > 0.0 {
        let mut a = WeightAverage::new(&engine, &model, config.ema_decay);
        if let Some(dir) = &resumed_from {
            a.load(&dir.join(AVERAGE_FILE))?;
        }
        average = Some(a);
    }
    let log_path = run_dir.join("events.jsonl");
    let mut log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&log_path)
        .map_err(|e| TrainError::io(&log_path, e))?;

    let codec = GenomeCodec::new(DesignSpace::synthetic(), SensorEncoding::QuantisedContinuous)?;
    let world = World {
        config,
        streams: &streams,
        formation: ImageFormation::new(Calibration::DEFAULT)?,
        ae: AverageAe::new(AccRanges::PAPER),
        sim_config: SimConfig {
            max_speed_mps: config.max_speed_mps,
            city: CityConfig::default()
                .with_walker_density(config.walker_density as f32)
                .with_sign_density(config.sign_density as f32),
            visibility: VisibilityRules {
                min_box_px: config.min_box_px as f32,
                ..VisibilityRules::default()
            },
            ..SimConfig::default()
        },
    };
    let mut sims: HashMap<u64, Simulator> = HashMap::new();
    let mut step = start;
    let mut last_eval = None;
    let b = config.batch;
    // Whether `step` frames passed a multiple of `every` with the last batch.
    let crossed = |step: usize, every: usize| every > 0 && step / every > (step - b) / every;
    // Seconds this process spent making frames (render, formation, AverageAE) and in gradient
    // steps: where pre-training's time goes, logged with the loss.
    let (mut simulate_s, mut train_s) = (0.0_f64, 0.0_f64);
    while step < config.steps {
        let block = Block::containing(config, step);
        let mut runs = (block.first_design..block.first_design + block.designs)
            .flat_map(|d| (0..b).map(move |lane| (d, lane)))
            .map(|(d, lane)| DesignRun::new(d, lane, &codec, &world))
            .collect::<Result<Vec<_>, TrainError>>()?;
        let mut replays: Vec<Repeats<Shot>> =
            (0..block.designs).map(|_| Repeats::default()).collect();
        while step < block.end_step {
            let tick = (step - block.first_step) / b;
            let (d, j) = (tick % block.designs, tick / block.designs);
            let lanes = &mut runs[d * b..(d + 1) * b];
            let clock = std::time::Instant::now();
            for run in lanes.iter_mut() {
                if j % config.frames_per_episode == 0 {
                    run.start_episode(j / config.frames_per_episode, &world, &mut sims)?;
                }
                run.simulator(&world, &mut sims); // builds the lane's town if it is new
            }
            // The lanes' frames render side by side, each with AverageAE's settings for its
            // next frame: a small frame with few sub-frames keeps one core busy at most. Each
            // lane's noise stream is its own, so the frames are the same in any order.
            let made = lanes
                .par_iter()
                .enumerate()
                .map(|(lane, run)| {
                    let sim = &sims[&run.map_seed];
                    let request = FrameRequest {
                        episode: run.episode,
                        time_s: run.t0
                            + (j % config.frames_per_episode) as f64 * sim.frame_interval_s(),
                        exposure_s: run.settings.exposure_s,
                        motion_scale: 1.0,
                    };
                    let frame = sim.render(&run.camera, &request)?;
                    let image = world.formation.form(
                        &frame.hdr,
                        run.settings,
                        run.pitch_um,
                        &mut streams.indexed("pretrain-noise", (step + lane) as u64),
                    );
                    let next = world.ae.step(run.settings, &image);
                    Ok((Shot { image, truth: frame.boxes, ignore: frame.ignore }, next))
                })
                .collect::<Result<Vec<_>, TrainError>>()?;
            let (shots, next): (Vec<Shot>, Vec<DynamicSettings>) = made.into_iter().unzip();
            for (run, settings) in lanes.iter_mut().zip(next) {
                run.settings = settings;
            }
            simulate_s += clock.elapsed().as_secs_f64();
            let clock = std::time::Instant::now();
            model.set_lr(config.lr_at(step));
            let batch: Vec<TrainFrame<'_>> =
                shots.iter().chain(replays[d].due()).map(Shot::train_frame).collect();
            let loss = match model.train_batch(&batch) {
                Ok(loss) => loss,
                Err(e) => {
                    let _ = writeln!(
                        log,
                        "{}",
                        serde_json::json!({"step": step, "error": e.to_string()})
                    );
                    return Err(e.into());
                }
            };
            train_s += clock.elapsed().as_secs_f64();
            replays[d].advance(shots.into_iter().map(|shot| {
                let n = shot.truth.iter().map(|a| config.repeats[a.class.index()]).max();
                (shot, n.unwrap_or(0))
            }));
            step += b;
            if let Some(average) = &mut average {
                average.update((step / b) as u64);
            }
            if crossed(step, 10) || step == config.steps {
                let run = &lanes[0];
                let line = serde_json::json!({"step": step, "lr": config.lr_at(step - b), "loss": loss, "design_index": run.index, "design": run.design, "map_seed": run.map_seed, "episode": run.episode, "simulate_s": simulate_s, "train_s": train_s});
                writeln!(log, "{line}").map_err(|e| TrainError::io(&log_path, e))?;
            }
            if progress(&PretrainEvent::Step { step, of: config.steps, loss }).is_break() {
                return Err(TrainError::Interrupted { step });
            }
            if crossed(step, config.eval_every) && step < config.steps {
                let result = average.as_ref().map_or(&model, WeightAverage::model);
                let report =
                    evaluate_day_night(result, config, config.eval_episodes, &streams, step)?;
                writeln!(log, "{}", serde_json::json!({"eval": report}))
                    .map_err(|e| TrainError::io(&log_path, e))?;
                let _ = progress(&PretrainEvent::Eval(Box::new(report)));
                last_eval = Some(report);
            }
        }
        // Every design's state is rebuilt from the seed at a block's start, so a checkpoint at a
        // block's end is all a resumed run needs.
        ckpt.write(|dir| {
            model.save_weights(&dir.join("detector.safetensors"))?;
            model.save_optimizer(&dir.join("optimizer.safetensors"))?;
            if let Some(average) = &average {
                average.model().save_weights(&dir.join(AVERAGE_FILE))?;
            }
            let state = State { step, config: config.clone() };
            let text = serde_json::to_string_pretty(&state).map_err(|e| TrainError::Corrupt {
                path: "state.json".into(),
                reason: e.to_string(),
            })?;
            write_atomic(&dir.join("state.json"), &text)
        })?;
        let _ = progress(&PretrainEvent::Checkpoint { step });
    }
    let result = average.as_ref().map_or(&model, WeightAverage::model);
    let final_episodes = config.final_episodes();
    let report = match last_eval {
        Some(r) if r.step == step && final_episodes == config.eval_episodes => r,
        _ => {
            let r = evaluate_day_night(result, config, final_episodes, &streams, step)?;
            writeln!(log, "{}", serde_json::json!({"eval": r}))
                .map_err(|e| TrainError::io(&log_path, e))?;
            let _ = progress(&PretrainEvent::Eval(Box::new(r)));
            r
        }
    };
    result.save_weights(weights_out)?;
    write_atomic(
        &run_dir.join("results.json"),
        &serde_json::to_string_pretty(&report).unwrap_or_default(),
    )?;
    Ok(report)
}

/// A formed training frame with its ground truth (the HDR render is not kept).
#[derive(Debug)]
struct Shot {
    image: Rgb8Image,
    truth: Vec<Annotation>,
    ignore: Vec<Annotation>,
}

impl Shot {
    fn train_frame(&self) -> TrainFrame<'_> {
        TrainFrame { image: &self.image, truth: &self.truth, ignore: &self.ignore }
    }
}

/// The frames of one design waiting to be trained on again (`repeats`): each is due in as
/// many of the design's next batches as it has repeats.
#[derive(Debug)]
struct Repeats<T> {
    queue: Vec<(T, u32)>,
}

impl<T> Default for Repeats<T> {
    fn default() -> Self {
        Self { queue: Vec::new() }
    }
}

impl<T> Repeats<T> {
    /// The frames to add to the design's current batch, oldest first.
    fn due(&self) -> impl Iterator<Item = &T> {
        self.queue.iter().map(|(item, _)| item)
    }

    /// After a batch: each due frame has one repeat less, and `fresh` frames (with their
    /// repeats, 0 for none) join the queue.
    fn advance(&mut self, fresh: impl IntoIterator<Item = (T, u32)>) {
        self.queue.iter_mut().for_each(|(_, left)| *left -= 1);
        self.queue.retain(|(_, left)| *left > 0);
        self.queue.extend(fresh.into_iter().filter(|(_, n)| *n > 0));
    }
}

/// A run of consecutive steps over `designs` camera designs, `frames_per_design` frames each,
/// ending with a checkpoint. Within a block the designs' batches are interleaved (design 0's
/// batch 0, design 1's batch 0, …, design 0's batch 1, …): with small batches, 45 frames of one
/// camera in a row pull the detector towards that camera and scene, and the next design pulls
/// it away again. A design's batch holds one frame of each of its `batch` lanes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Block {
    first_design: usize,
    designs: usize,
    first_step: usize,
    end_step: usize,
}

impl Block {
    /// The block that `step` falls in. The last block may be cut short by `steps`; it then
    /// interleaves only as many designs as its steps need.
    fn containing(config: &PretrainConfig, step: usize) -> Self {
        let per_block = config.checkpoint_every_designs * config.frames_per_design;
        let b = step / per_block;
        let first_step = b * per_block;
        let end_step = (first_step + per_block).min(config.steps);
        Self {
            first_design: b * config.checkpoint_every_designs,
            designs: (end_step - first_step).div_ceil(config.frames_per_design),
            first_step,
            end_step,
        }
    }
}

/// What every design's frames are made with.
struct World<'a> {
    config: &'a PretrainConfig,
    streams: &'a SeedStreams,
    formation: ImageFormation,
    ae: AverageAe,
    sim_config: SimConfig,
}

/// The design's episode number of lane `lane`'s episode `e`: lanes own consecutive ranges, so
/// no two frames of a batch come from one episode.
fn design_episode(lane: usize, episodes_per_lane: usize, e: usize) -> u64 {
    (lane * episodes_per_lane + e) as u64
}

/// The running weight average in a checkpoint.
const AVERAGE_FILE: &str = "detector-average.safetensors";

/// AverageAE iterations on an episode's first view before its first training frame.
const AE_SETTLE_ITERATIONS: usize = 8;

/// One random camera design and the episode one of its lanes is currently driving.
struct DesignRun {
    index: usize,
    /// Lane of the design's frames (0 with batch size 1).
    lane: usize,
    /// Episodes per lane: lane `l`'s episode `e` is the design's episode
    /// `l · episodes_per_lane + e`.
    episodes_per_lane: usize,
    design: CameraDesign,
    camera: PinholeCamera,
    pitch_um: f64,
    settings: DynamicSettings,
    map_seed: u64,
    episode: u64,
    t0: f64,
}

impl DesignRun {
    /// Lane `lane` of design number `index`, drawn uniformly from the synthetic design space.
    fn new(
        index: usize,
        lane: usize,
        codec: &GenomeCodec,
        world: &World<'_>,
    ) -> Result<Self, TrainError> {
        let mut rng = world.streams.indexed("pretrain-design", index as u64);
        let genes: Vec<f64> =
            codec.genes().iter().map(|g| rng.random_range(g.bounds.min..=g.bounds.max)).collect();
        let design = codec.decode(&genes)?;
        let config = world.config;
        let lane_frames = config.frames_per_design / config.batch;
        Ok(Self {
            index,
            lane,
            episodes_per_lane: lane_frames.div_ceil(config.frames_per_episode),
            camera: design.pinhole(world.config.render_scale),
            pitch_um: design.sensor().pixel_pitch_um,
            design,
            settings: default_settings(),
            map_seed: 0,
            episode: 0,
            t0: 0.0,
        })
    }

    fn simulator<'s>(
        &self,
        world: &World<'_>,
        sims: &'s mut HashMap<u64, Simulator>,
    ) -> &'s Simulator {
        let map_seed = self.map_seed;
        sims.entry(map_seed)
            .or_insert_with(|| Simulator::new(SimConfig { map_seed, ..world.sim_config }))
    }

    /// Starts the lane's episode number `e`: a random training town, drive and start time,
    /// and AverageAE settled on a quarter-resolution view of the first frame (iterated on that
    /// one view, as a camera that had been driving there already would have converged), so that
    /// no training frame is one of the badly exposed frames of an AE start-up.
    fn start_episode(
        &mut self,
        e: usize,
        world: &World<'_>,
        sims: &mut HashMap<u64, Simulator>,
    ) -> Result<(), TrainError> {
        let id = (self.index as u64) << 16 | design_episode(self.lane, self.episodes_per_lane, e);
        let mut rng = world.streams.indexed("pretrain-episode", id);
        let config = world.config;
        self.map_seed = train_map_seed(rng.random_range(0..config.train_maps));
        self.episode = rng.random_range(0..1_000_000);
        let sim_config = &world.sim_config;
        let span = config.frames_per_episode as f64 * sim_config.frame_interval_s;
        self.t0 = rng.random_range(1.0..(sim_config.episode_s - 1.0 - span).max(1.0 + 1e-9));
        let probe = self.design.pinhole(config.render_scale / 4.0);
        let request = FrameRequest {
            episode: self.episode,
            time_s: self.t0,
            exposure_s: default_settings().exposure_s,
            motion_scale: 1.0,
        };
        let view = self.simulator(world, sims).render(&probe, &request)?;
        let mut noise = world.streams.indexed("pretrain-probe", id);
        let mut settings = default_settings();
        for _ in 0..AE_SETTLE_ITERATIONS {
            let image = world.formation.form(&view.hdr, settings, self.pitch_um, &mut noise);
            settings = world.ae.step(settings, &image);
        }
        self.settings = settings;
        Ok(())
    }
}

fn default_settings() -> DynamicSettings {
    DynamicSettings::new(Calibration::DEFAULT.exposure_s, Calibration::DEFAULT.gain_db)
}

/// Scores the detector weights in `weights` (architecture read from the file) exactly as a
/// pre-training run with `config` evaluates: reference camera, AverageAE, test town,
/// [`PretrainConfig::final_episodes`] day and night episodes, noise from `config.seed`. With the
/// config a run was trained with, this reproduces its `results.json`.
pub fn evaluate_weights(config: &PretrainConfig, weights: &Path) -> Result<EvalReport, TrainError> {
    config.validate()?;
    let engine = Engine::cpu(config.threads);
    let mut model =
        DetectorModel::new(&engine, DetectorConfig::of_weights(weights)?, AdamConfig::DETECTOR);
    model.load_weights(weights)?;
    evaluate_day_night(&model, config, config.final_episodes(), &SeedStreams::new(config.seed), 0)
}

fn evaluate_day_night(
    model: &DetectorModel,
    config: &PretrainConfig,
    episodes: u64,
    streams: &SeedStreams,
    step: usize,
) -> Result<EvalReport, TrainError> {
    let design = reference_design();
    let spec = |illumination| EvalSpec {
        illumination,
        episodes,
        frames_per_episode: 10,
        warmup_frames: 3,
        render_scale: config.render_scale,
        noise_scale: 1.0,
        motion_scale: 1.0,
    };
    let mut control = AverageControl(AverageAe::new(AccRanges::PAPER));
    let day = evaluate(model, &design, &mut control, &spec(Illumination::Day), streams)?;
    let night = evaluate(model, &design, &mut control, &spec(Illumination::Night), streams)?;
    Ok(EvalReport { step, day, night })
}

/// Top-level field names whose values differ between two configurations.
pub fn differing_fields<T: Serialize>(a: &T, b: &T) -> Vec<String> {
    let (Ok(serde_json::Value::Object(a)), Ok(serde_json::Value::Object(b))) =
        (serde_json::to_value(a), serde_json::to_value(b))
    else {
        return vec!["(unreadable)".into()];
    };
    let mut keys: Vec<&String> = a.keys().chain(b.keys()).collect();
    keys.sort();
    keys.dedup();
    keys.into_iter()
        .filter(|k| a.get(*k) != b.get(*k))
        .map(|k| {
            format!(
                "{k} ({} → {})",
                a.get(k).map_or("-".into(), |v| v.to_string()),
                b.get(k).map_or("-".into(), |v| v.to_string())
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_is_repeated_in_exactly_as_many_later_batches_as_asked() {
        let mut r = Repeats::default();
        let mut batches = Vec::new();
        // Batch 0 brings frames a (2 repeats), b (none), c (1); batch 1 brings d (3).
        let fresh: [&[(char, u32)]; 5] =
            [&[('a', 2), ('b', 0), ('c', 1)], &[('d', 3)], &[], &[], &[]];
        for frames in fresh {
            batches.push(r.due().copied().collect::<String>());
            r.advance(frames.iter().copied());
        }
        assert_eq!(batches, ["", "ac", "ad", "d", "d"]);
        assert_eq!(r.due().count(), 0);
    }

    #[test]
    fn the_frames_of_a_design_come_from_distinct_episodes_per_lane() {
        // 45 frames in batches of 5: 5 lanes of 9 frames, episodes of 5 frames → 2 per lane.
        let (fpd, fpe, batch): (usize, usize, usize) = (45, 5, 5);
        let per_lane = (fpd / batch).div_ceil(fpe);
        assert_eq!(per_lane, 2);
        let mut seen = std::collections::BTreeMap::new();
        for lane in 0..batch {
            for j in 0..fpd / batch {
                let e = design_episode(lane, per_lane, j / fpe);
                seen.entry(e).or_insert_with(Vec::new).push((lane, j % fpe));
            }
        }
        // Every episode belongs to one lane, and each (episode, frame) pair occurs once.
        for frames in seen.values() {
            assert!(frames.iter().all(|(l, _)| *l == frames[0].0));
            let mut k: Vec<usize> = frames.iter().map(|(_, f)| *f).collect();
            k.dedup();
            assert_eq!(k.len(), frames.len());
        }
        assert_eq!(seen.len(), 10);
        // Batch size 1: the design's episodes are numbered as they always were.
        assert_eq!(design_episode(0, 9, 4), 4);
    }
}
