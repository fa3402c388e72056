//! A pre-training run's checkpoints: starting or resuming the detector, writing a block's
//! checkpoint, and naming the checkpoint a diverged run would resume from.

use super::{PretrainConfig, State};
use crate::TrainError;
use crate::checkpoint::{CheckpointDir, check_resume, read_json, write_atomic};
use joca_nn::detector::{DetectorModel, PrecisionExt, WeightAverage};
use joca_nn::{AdamConfig, Engine};
use std::path::Path;

/// The detector (and its weight average) to train from: new, or the checkpoint's when
/// resuming; and the step it starts at. A directory with a checkpoint is refused without
/// `resume`.
pub(super) fn start_or_resume(
    config: &PretrainConfig,
    engine: &Engine,
    ckpt: &CheckpointDir,
    run_dir: &Path,
    resume: bool,
) -> Result<(DetectorModel, Option<WeightAverage>, usize), TrainError> {
    let adam = AdamConfig {
        lr: config.optimizer.lr,
        weight_decay: config.optimizer.weight_decay,
        ..AdamConfig::DETECTOR
    };
    let mut model = DetectorModel::new(engine, config.detector, adam);
    model.set_class_weights(&config.experimental.class_weights);
    model.set_regression(config.experimental.regression);
    // bfloat16 only where the CPU has it (emulated, it is many times slower than float32) or on
    // a GPU.
    let precision = config.precision.on_device(engine.device());
    model.set_precision(precision);
    model.set_min_radius(i64::from(config.experimental.min_radius));
    let mut start = 0;
    let mut average = None;
    let resumed_from = ckpt.existing().filter(|_| resume);
    if let Some(dir) = &resumed_from {
        crate::checkpoint::verify_checkpoint(dir)?;
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
    if config.optimizer.ema_decay > 0.0 {
        let mut a = WeightAverage::new(engine, &model, config.optimizer.ema_decay);
        if let Some(dir) = &resumed_from {
            a.load(&dir.join(AVERAGE_FILE))?;
        }
        average = Some(a);
    }
    Ok((model, average, start))
}

/// A block's checkpoint: the detector, its optimiser, the weight average and the step.
pub(super) fn write_checkpoint(
    ckpt: &CheckpointDir,
    model: &DetectorModel,
    average: Option<&WeightAverage>,
    step: usize,
    config: &PretrainConfig,
) -> Result<(), TrainError> {
    ckpt.write(|dir| {
        model.save_weights(&dir.join("detector.safetensors"))?;
        model.save_optimizer(&dir.join("optimizer.safetensors"))?;
        if let Some(average) = average {
            average.model().save_weights(&dir.join(AVERAGE_FILE))?;
        }
        let state = State { step, config: config.clone() };
        let text = serde_json::to_string_pretty(&state).map_err(|e| TrainError::Corrupt {
            path: "state.json".into(),
            reason: e.to_string(),
        })?;
        write_atomic(&dir.join("state.json"), &text)
    })
}

/// The error of a failed gradient step at `step`: a non-finite loss names the frame and the
/// checkpoint a resumed run would start from. Checkpoints are written at block ends, so the last
/// one is the block's start (`block_start`); nothing of this block was written.
pub(super) fn failed_step(
    e: joca_nn::NnError,
    step: usize,
    ckpt: &CheckpointDir,
    block_start: usize,
) -> TrainError {
    match e {
        source @ joca_nn::NnError::NonFinite { .. } => TrainError::PretrainDiverged {
            frame: step,
            checkpoint: ckpt.existing().map_or_else(
                || "none yet: no block of designs had finished".to_owned(),
                |d| format!("{}, after {block_start} frames", d.display()),
            ),
            source,
        },
        e => e.into(),
    }
}

/// The running weight average in a checkpoint.
const AVERAGE_FILE: &str = "detector-average.safetensors";
