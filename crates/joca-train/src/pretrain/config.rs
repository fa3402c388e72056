//! The settings of a pre-training run (`[pretrain]` in a preset or config file), checked field
//! by field, and the learning-rate schedule.

use crate::TrainError;
use joca_camera::DetectorInput;
use joca_nn::detector::{DetectorConfig, Precision, Regression};
use joca_nn::device::DeviceChoice;
use serde::{Deserialize, Serialize};

/// Settings of a pre-training run (the `[pretrain]` presets in `presets/`): the run itself at
/// the top, then one table each for the optimiser, the training data, the evaluations, and the
/// options that were measured and are not used by any preset.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PretrainConfig {
    /// Run seed.
    pub seed: u64,
    /// libtorch and rayon threads.
    pub threads: usize,
    /// What the detector trains and is evaluated on: `cpu` (the default), `cuda`, `cuda:N` or
    /// `auto` (as `[run] device`).
    #[serde(default, skip_serializing_if = "DeviceChoice::is_cpu")]
    pub device: DeviceChoice,
    /// Training frames (`steps / batch` gradient steps). `optimizer.warmup_steps` and
    /// `eval.every` count frames too.
    pub steps: usize,
    /// Frames per gradient step (default 1, as the paper): frames of one design, each from
    /// its own episode (a "lane" of the design's frames), so that they have one size and
    /// are not near-copies of one scene. Must divide `data.frames_per_design` and `steps`.
    #[serde(default = "one_frame")]
    pub batch: usize,
    /// Floating-point type of the training steps: `"fp32"` (default) or `"bf16"` (bfloat16
    /// convolutions with float32 weights, optimiser and loss; evaluation stays float32).
    #[serde(default)]
    pub precision: Precision,
    /// The detector's input (`input = { short_px, long_max_px, resampler }`), of the training
    /// frames and of every evaluation: each random design's frames are rendered at this size
    /// with its own field of view and the noise of its native grid carried through the resize.
    pub input: DetectorInput,
    /// Detector size.
    pub detector: DetectorConfig,
    /// Write a checkpoint every this many designs; the designs between two checkpoints have
    /// their frames interleaved.
    pub checkpoint_every_designs: usize,
    /// Learning rate, its schedule, weight decay, weight average.
    pub optimizer: OptimizerConfig,
    /// Which frames the detector trains on.
    pub data: DataConfig,
    /// The evaluations on the test town.
    pub eval: EvalConfig,
    /// Options measured and not used by any preset (docs/results, the pre-training log).
    #[serde(default)]
    pub experimental: ExperimentalConfig,
}

/// `[pretrain.optimizer]`: AdamW with linear warm-up and cosine decay, and the running weight
/// average that is evaluated and written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OptimizerConfig {
    /// Peak learning rate (AdamW).
    pub lr: f64,
    /// Learning rate at the end of the cosine decay.
    pub lr_final: f64,
    /// Linear warm-up, frames.
    pub warmup_steps: usize,
    /// AdamW weight decay.
    pub weight_decay: f64,
    /// Decay of the running weight average that is evaluated and written as the result
    /// (0: none, the last weights are the result). 0.999 averages over about the last 1000
    /// steps.
    pub ema_decay: f64,
}

/// `[pretrain.data]`: the random designs' drives through the training towns.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DataConfig {
    /// Frames per random camera design (45 in the paper).
    pub frames_per_design: usize,
    /// Consecutive frames per episode: a design's frames come from several episodes (each in a
    /// random training town, with its own drive, time and light), because 45 consecutive frames
    /// at 10 frames/s are nearly the same scene.
    pub frames_per_episode: usize,
    /// Spread of the training frames' exposure × gain around AverageAE's: each frame's total
    /// is AverageAE's times a factor log-uniform in `[1/s, s]`, split at random between
    /// exposure and gain (clamped to their ranges). 1 (default): AverageAE's frames only; a
    /// spread shows the detector under- and over-exposed frames, as other controllers make.
    #[serde(default = "one")]
    pub exposure_spread: f64,
    /// Number of training towns to draw episodes from.
    pub train_maps: u64,
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
}

/// `[pretrain.eval]`: evaluations on the test town (reference camera, AverageAE, by day and by
/// night, 10 scored frames per episode).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EvalConfig {
    /// Evaluate every this many frames (0: only at the end).
    pub every: usize,
    /// Test episodes per illumination in each periodic evaluation.
    pub episodes: u64,
    /// Test episodes per illumination of the final evaluation, the one in `results.json`
    /// (default: `episodes`). The test town's rarer classes need many: in 100 day frames
    /// there may be no traffic sign at all and a dozen walkers.
    #[serde(default)]
    pub final_episodes: Option<u64>,
}

/// `[pretrain.experimental]`: options that were measured and are not used by any preset; each
/// default leaves pre-training as the paper's (docs/results, the pre-training log).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ExperimentalConfig {
    /// Loss weight of each class's objects (vehicle, walker, traffic sign): a class-balanced
    /// loss for the rarer classes. The background term is not weighted.
    pub class_weights: [f64; 3],
    /// Where the size and offset heads learn: `"centre"` (CenterNet: each object's centre cell)
    /// or `"gaussian"` (every cell of its heatmap Gaussian, weighted by it).
    pub regression: Regression,
    /// Smallest radius of an object's heatmap Gaussian, cells (0: CenterNet's radius, which is
    /// 0 for objects under ~12 px such as most traffic signs).
    pub min_radius: u32,
    /// Smallest box width and height, pixels, that is a training object in the training towns
    /// (the simulator's rule, and the test's, is 8); smaller objects in view stay ignore
    /// regions.
    pub min_box_px: f64,
    /// Extra times a training frame is trained on when it holds an object of each class
    /// (vehicle, walker, traffic sign; the largest applies), in its design's next batches:
    /// repeat-factor sampling (Gupta et al., LVIS 2019) for the rare classes, within a block so
    /// that a resumed run repeats the same frames. The repeats are extra gradient samples, not
    /// frames of `steps`.
    pub repeats: [u32; 3],
    /// Make each batch's frames in a thread of their own while the detector trains on the
    /// previous batch: `threads / 2` threads make frames, the rest train (libtorch); every
    /// evaluation uses all `threads`. The frames are the same as without it; the weights are
    /// those of a run without it on `threads − threads / 2` threads. Needs `threads` ≥ 2.
    pub pipeline: bool,
}

impl Default for ExperimentalConfig {
    fn default() -> Self {
        Self {
            class_weights: [1.0; 3],
            regression: Regression::default(),
            min_radius: 0,
            min_box_px: f64::from(joca_core::TRAINING_MIN_BOX_PX),
            repeats: [0; 3],
            pipeline: false,
        }
    }
}

fn one() -> f64 {
    1.0
}

fn one_frame() -> usize {
    1
}

/// A `pretrain.<field>` error naming the value and what is allowed.
fn bad(field: &str, value: String, allowed: &str) -> Result<(), TrainError> {
    Err(TrainError::Config {
        field: format!("pretrain.{field}"),
        value,
        allowed: allowed.to_owned(),
    })
}

impl PretrainConfig {
    /// Test episodes per illumination of the final evaluation.
    pub fn final_episodes(&self) -> u64 {
        self.eval.final_episodes.unwrap_or(self.eval.episodes)
    }

    /// libtorch threads of the gradient steps (with [`ExperimentalConfig::pipeline`], the
    /// threads that do not make frames).
    pub fn trainer_threads(&self) -> usize {
        if self.experimental.pipeline { self.threads - self.threads / 2 } else { self.threads }
    }

    /// Checks every field; the error names the field and what is allowed.
    pub fn validate(&self) -> Result<(), TrainError> {
        if !(1..=64).contains(&self.threads) {
            return bad("threads", self.threads.to_string(), "1 to 64");
        }
        if !(1..=10_000_000).contains(&self.steps) {
            return bad("steps", self.steps.to_string(), "1 to 10000000");
        }
        if self.data.frames_per_design == 0 || self.data.frames_per_design > 400 {
            return bad(
                "data.frames_per_design",
                self.data.frames_per_design.to_string(),
                "1 to 400 (episodes last 60 s at 10 frames/s)",
            );
        }
        if !(1..=64).contains(&self.batch)
            || !self.data.frames_per_design.is_multiple_of(self.batch)
            || !self.steps.is_multiple_of(self.batch)
        {
            return bad(
                "batch",
                self.batch.to_string(),
                "1 to 64, dividing data.frames_per_design and steps",
            );
        }
        if self.data.frames_per_episode == 0
            || self.data.frames_per_episode > self.data.frames_per_design
        {
            return bad(
                "data.frames_per_episode",
                self.data.frames_per_episode.to_string(),
                "1 to data.frames_per_design",
            );
        }
        crate::run::check_input(&self.input, "pretrain")?;
        if !(1.0..=100.0).contains(&self.data.exposure_spread) {
            return bad("data.exposure_spread", self.data.exposure_spread.to_string(), "1 to 100");
        }
        if self.data.train_maps == 0 {
            return bad("data.train_maps", "0".into(), "at least 1");
        }
        self.validate_optimizer()?;
        crate::run::check_detector(&self.detector, "pretrain")?;
        if !(1..=10_000).contains(&self.eval.episodes) {
            return bad("eval.episodes", self.eval.episodes.to_string(), "1 to 10000");
        }
        if let Some(n) = self.eval.final_episodes.filter(|n| !(1..=10_000).contains(n)) {
            return bad("eval.final_episodes", n.to_string(), "1 to 10000");
        }
        let frames = [
            ("optimizer.warmup_steps", self.optimizer.warmup_steps),
            ("eval.every", self.eval.every),
        ];
        for (name, v) in frames {
            if v > 10_000_000 {
                return bad(name, v.to_string(), "0 to 10000000");
            }
        }
        if !(1..=100).contains(&self.checkpoint_every_designs) {
            let value = self.checkpoint_every_designs.to_string();
            return bad("checkpoint_every_designs", value, "1 to 100");
        }
        if !(0.0..=crate::MAX_SPEED_MPS).contains(&self.data.max_speed_mps) {
            let allowed = format!("0 to {}", crate::MAX_SPEED_MPS);
            return bad("data.max_speed_mps", self.data.max_speed_mps.to_string(), &allowed);
        }
        if !(self.data.walker_density >= 0.0 && self.data.walker_density <= 8.0) {
            return bad("data.walker_density", self.data.walker_density.to_string(), "0 to 8");
        }
        if !(self.data.sign_density >= 0.0 && self.data.sign_density <= 8.0) {
            return bad("data.sign_density", self.data.sign_density.to_string(), "0 to 8");
        }
        self.validate_experimental()
    }

    fn validate_optimizer(&self) -> Result<(), TrainError> {
        for (name, v) in
            [("optimizer.lr", self.optimizer.lr), ("optimizer.lr_final", self.optimizer.lr_final)]
        {
            if !(v > 0.0 && v < 1.0) {
                return bad(name, v.to_string(), "between 0 and 1");
            }
        }
        if !(self.optimizer.ema_decay >= 0.0 && self.optimizer.ema_decay < 1.0) {
            return bad(
                "optimizer.ema_decay",
                self.optimizer.ema_decay.to_string(),
                "0 (off) up to below 1",
            );
        }
        if !(self.optimizer.weight_decay >= 0.0 && self.optimizer.weight_decay < 1.0) {
            return bad(
                "optimizer.weight_decay",
                self.optimizer.weight_decay.to_string(),
                "0 to 1",
            );
        }
        Ok(())
    }

    fn validate_experimental(&self) -> Result<(), TrainError> {
        if !(self.experimental.min_box_px >= 1.0 && self.experimental.min_box_px <= 64.0) {
            return bad(
                "experimental.min_box_px",
                self.experimental.min_box_px.to_string(),
                "1 to 64 pixels",
            );
        }
        if self.experimental.pipeline && self.threads < 2 {
            return bad(
                "threads",
                self.threads.to_string(),
                "at least 2 with experimental.pipeline = true (one makes frames, one trains)",
            );
        }
        if self.experimental.repeats.iter().any(|&r| r > 8) {
            return bad(
                "experimental.repeats",
                format!("{:?}", self.experimental.repeats),
                "each 0 to 8",
            );
        }
        if self.experimental.min_radius > 4 {
            return bad(
                "experimental.min_radius",
                self.experimental.min_radius.to_string(),
                "0 to 4 cells",
            );
        }
        if !self.experimental.class_weights.iter().all(|w| *w > 0.0 && *w <= 100.0) {
            return bad(
                "experimental.class_weights",
                format!("{:?}", self.experimental.class_weights),
                "each above 0, at most 100",
            );
        }
        Ok(())
    }

    /// Learning rate at `step`: linear warm-up, then cosine decay to `lr_final`.
    pub fn lr_at(&self, step: usize) -> f64 {
        if step < self.optimizer.warmup_steps {
            return self.optimizer.lr * (step + 1) as f64 / self.optimizer.warmup_steps as f64;
        }
        let span = (self.steps - self.optimizer.warmup_steps.min(self.steps)).max(1) as f64;
        let progress = ((step - self.optimizer.warmup_steps) as f64 / span).min(1.0);
        self.optimizer.lr_final
            + 0.5
                * (self.optimizer.lr - self.optimizer.lr_final)
                * (1.0 + (std::f64::consts::PI * progress).cos())
    }
}
