//! Where a training step's time goes (`joca bench step`).

use super::context::setup;
use super::{RunConfig, TrainError, candidate, perturbation};
use joca_camera::CameraDesign;
use joca_nn::detector::Precision;
use joca_nn::device::DeviceSync;
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// Mean wall time per training step by part, milliseconds (`joca bench step`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct StepBreakdown {
    /// NeuralAE forward (histograms, features, prediction).
    pub acc_predict_ms: f64,
    /// Rendering the forward-mode frame and the perturbed frames (one grid of sub-frames).
    pub render_ms: f64,
    /// Perturbation mode: forming the perturbed frames (8-bit, with noise).
    pub perturbation_render_ms: f64,
    /// Perturbation mode: detecting and scoring (`perturbation_score`) the perturbed frames.
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
    /// Sub-frames rendered for the step's grid (the longest shutter's count, which every other
    /// shutter's cells lie within).
    pub subframes: f64,
    /// Steps measured.
    pub steps: usize,
    /// Perturbation searches scored a second time in another precision (`bench_step`'s
    /// `check`).
    pub searches_checked: usize,
    /// Of those, the searches where both precisions chose the same member.
    pub searches_agreeing: usize,
    /// Over those searches, the sum of the other precision's fitness of its best member less
    /// its fitness of the member this precision chose (the regret, 0 where they agree).
    pub check_regret: f64,
    /// Over those searches, the sum of the spread of the other precision's fitness (best less
    /// worst member): the scale the regret compares with.
    pub check_spread: f64,
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
            &mut self.subframes,
        ] {
            *v *= k;
        }
        self
    }
}

/// A clock that attributes the time since its last lap to a part of [`StepBreakdown`], when
/// measuring (`joca bench step`); otherwise it only restarts.
#[derive(Debug)]
pub(super) struct Stopwatch {
    clock: Instant,
    /// The sums so far; `None` when not measuring.
    pub(super) breakdown: Option<StepBreakdown>,
    /// When measuring: also score each perturbation search in this precision (untimed) and
    /// count whether it chooses the same member.
    pub(super) check_precision: Option<Precision>,
    /// When measuring on a GPU: waits for its queued work before each lap.
    pub(super) sync: DeviceSync,
}

impl Default for Stopwatch {
    fn default() -> Self {
        Self {
            clock: Instant::now(),
            breakdown: None,
            check_precision: None,
            sync: DeviceSync::default(),
        }
    }
}

impl Stopwatch {
    /// A stopwatch that records.
    pub(super) fn measuring() -> Self {
        Self { breakdown: Some(StepBreakdown::default()), ..Self::default() }
    }

    /// Counts one checked perturbation search (whether both precisions chose the same member,
    /// the regret and the spread of the check's fitness), and restarts (the check is not
    /// timed).
    pub(super) fn count_check(&mut self, same: bool, regret: f64, spread: f64) {
        if let Some(t) = self.breakdown.as_mut() {
            t.searches_checked += 1;
            t.searches_agreeing += usize::from(same);
            t.check_regret += regret;
            t.check_spread += spread;
        }
        self.restart();
    }

    /// Adds the time since the last lap to `part`, and restarts.
    pub(super) fn lap(&mut self, part: fn(&mut StepBreakdown) -> &mut f64) {
        if self.breakdown.is_some() {
            self.sync.wait();
        }
        let ms = self.clock.elapsed().as_secs_f64() * 1e3;
        self.clock = Instant::now();
        if let Some(t) = self.breakdown.as_mut() {
            *part(t) += ms;
        }
    }

    /// Counts the sub-frames of a step's grid, when measuring.
    pub(super) fn count_subframes(&mut self, n: u32) {
        if let Some(t) = self.breakdown.as_mut() {
            t.subframes += f64::from(n);
        }
    }

    /// Restarts without attributing the time since the last lap.
    pub(super) fn restart(&mut self) {
        self.clock = Instant::now();
    }

    /// Adds the parts the joint model timed itself, and counts the step.
    pub(super) fn add_model_step(&mut self, r: &joca_nn::joint::StepTimings) {
        if let Some(t) = self.breakdown.as_mut() {
            t.formation_ms += r.formation_ms;
            t.detector_forward_ms += r.detector_forward_ms;
            t.backward_ms += r.backward_ms;
            t.update_ms += r.update_ms;
            t.decode_ms += r.decode_ms;
            t.steps += 1;
        }
    }
}

/// Times `steps` training steps of `config`'s method on `design` (one candidate after a warm-up
/// candidate), returning the mean time per step by part.
///
/// With `check`, every perturbation search is also scored in that precision (untimed), and the
/// breakdown counts how often both precisions choose the same member.
pub fn bench_step(
    config: &RunConfig,
    design: &CameraDesign,
    steps: usize,
    check: Option<Precision>,
) -> Result<StepBreakdown, TrainError> {
    let mut config = config.clone();
    config.steps_per_candidate = steps.max(2);
    config.validate()?;
    let (mut cx, mut model) = setup(&config, Box::new(std::io::sink()), PathBuf::from("(none)"))?;
    let mut perturbation = perturbation::ga(&config, &cx.streams)?;
    let train = candidate::train;
    train(&mut cx, &mut model, &mut perturbation, design, (0, 0), &mut |_, _| {})?; // warm-up
    let sync = DeviceSync::of(model.device());
    cx.journal.watch = Stopwatch { check_precision: check, sync, ..Stopwatch::measuring() };
    train(&mut cx, &mut model, &mut perturbation, design, (1, 1), &mut |_, _| {})?;
    let t = cx.journal.watch.breakdown.unwrap_or_default();
    Ok(t.scaled(1.0 / t.steps.max(1) as f64))
}

/// What a checkpoint costs to write and to prove (`joca bench checkpoint`), best of the
/// repetitions, milliseconds.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct CheckpointTiming {
    /// Bytes in the checkpoint (model, optimiser states, run state).
    pub bytes: u64,
    /// Writing its files (what `--resume` needs), without the digests.
    pub write_ms: f64,
    /// Hashing every file into `digests.json` (written last).
    pub digest_ms: f64,
    /// Checking every file against `digests.json` (what `--resume` and `eval` do first).
    pub verify_ms: f64,
}

/// Writes the run's model (detector, NeuralAE, both optimisers) as a checkpoint into `dir`
/// `repeats` times, timing the files, their digests and their verification apart.
pub fn bench_checkpoint(
    config: &RunConfig,
    dir: &std::path::Path,
    repeats: usize,
) -> Result<CheckpointTiming, TrainError> {
    config.validate()?;
    let (_cx, model) = setup(config, Box::new(std::io::sink()), PathBuf::from("(none)"))?;
    let mut best = CheckpointTiming {
        write_ms: f64::INFINITY,
        digest_ms: f64::INFINITY,
        verify_ms: f64::INFINITY,
        bytes: 0,
    };
    let ms = |t: Instant| t.elapsed().as_secs_f64() * 1e3;
    for _ in 0..repeats.max(1) + 1 {
        if dir.exists() {
            std::fs::remove_dir_all(dir).map_err(|e| TrainError::io(dir, e))?;
        }
        std::fs::create_dir_all(dir).map_err(|e| TrainError::io(dir, e))?;
        let t = Instant::now();
        model.save(dir)?;
        crate::checkpoint::write_atomic(&dir.join("state.json"), "{}")?;
        let write = ms(t);
        let t = Instant::now();
        crate::checkpoint::write_digests(dir)?;
        let digest = ms(t);
        let t = Instant::now();
        crate::checkpoint::verify_checkpoint(dir)?;
        let verify = ms(t);
        best.write_ms = best.write_ms.min(write);
        best.digest_ms = best.digest_ms.min(digest);
        best.verify_ms = best.verify_ms.min(verify);
    }
    best.bytes = std::fs::read_dir(dir)
        .map_err(|e| TrainError::io(dir, e))?
        .filter_map(|e| e.ok()?.metadata().ok())
        .map(|m| m.len())
        .sum();
    Ok(best)
}
