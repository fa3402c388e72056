//! Detector pre-training (`joca train-detector`): the detector alone, on simulator frames from
//! random camera designs of the synthetic design space, exposed by AverageAE — the paper's
//! "frozen detector" pre-training (15,750 frames from 350 random cameras, 45 frames each).
//!
//! Every random choice is drawn from a stream indexed by design or step, so the data of any step
//! can be regenerated: a resumed run continues exactly where the checkpoint left it.

mod config;
mod frames;
mod resume;
mod spread;

pub use config::{DataConfig, EvalConfig, ExperimentalConfig, OptimizerConfig, PretrainConfig};

use crate::TrainError;
use crate::checkpoint::{CheckpointDir, write_atomic};
use crate::control::AverageControl;
use crate::eval::{EvalSpec, evaluate};
use frames::{Batch, Block, FRAMES_AHEAD, FrameStream, Repeats, Shot, World, frame_pool};
use joca_camera::{
    AccRanges, AverageAe, Calibration, CameraDesign, DesignSpace, GenomeCodec, ImageFormation,
    SensorEncoding, sensor_by_name,
};
use joca_core::SeedStreams;
use joca_core::output::{self, DirLock, OutputKind};
use joca_metrics::TaskScores;
use joca_nn::detector::{
    DetectorConfig, DetectorModel, LossParts, Precision, PrecisionExt, TrainFrame, WeightAverage,
};
use joca_nn::{AdamConfig, Engine};
use joca_sim::{CityConfig, Illumination, SimConfig};
use rand::Rng;
use resume::{failed_step, start_or_resume, write_checkpoint};
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::ops::ControlFlow;
use std::path::Path;

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
    /// The precision the training steps ran in on this CPU (`precision` asks for bfloat16 only
    /// where the CPU has it natively); none for a weights file scored alone.
    #[serde(default)]
    pub training_precision: Option<Precision>,
}

/// The fixed camera every pre-training evaluation uses: a FLIR-like IMX172 behind 3.6 mm at the
/// nuScenes-like mount (docs/design.md's baseline camera).
pub fn reference_design() -> CameraDesign {
    let sensor_index = sensor_by_name("IMX172").map(|s| s.index).unwrap_or(19);
    CameraDesign {
        x_m: 0.43,
        z_m: 1.65,
        focal_length_mm: 3.6,
        sensor_index,
        f_number: joca_core::optics::CALIBRATION_F_NUMBER,
    }
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
    output::claim(run_dir, OutputKind::Pretrain)?;
    let _lock = DirLock::acquire(run_dir, "joca train-detector")?;
    let engine = Engine::open(config.device, config.trainer_threads())?;
    let streams = SeedStreams::new(config.seed);
    engine.seed(streams.stream("detector-init").random());
    let ckpt = CheckpointDir::new(run_dir.join("checkpoint"));
    let (mut model, mut average, start) = start_or_resume(config, &engine, &ckpt, run_dir, resume)?;
    let precision = config.precision.on_device(engine.device());
    let log_path = run_dir.join("events.jsonl");
    let mut log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&log_path)
        .map_err(|e| TrainError::io(&log_path, e))?;

    let codec = GenomeCodec::new(DesignSpace::synthetic(), SensorEncoding::QuantisedContinuous)?;
    let world = world(config, &streams)?;
    let mut step = start;
    let mut last_eval = None;
    let b = config.batch;
    // Whether `step` frames passed a multiple of `every` with the last batch.
    let crossed = |step: usize, every: usize| every > 0 && step / every > (step - b) / every;
    // Seconds spent making frames (render, formation, AverageAE; in the frame thread when
    // pipelined), in gradient steps, and waiting for frames: where pre-training's time goes,
    // logged with the loss.
    let (mut simulate_s, mut train_s, mut wait_s) = (0.0_f64, 0.0_f64, 0.0_f64);
    let frames = FrameStream::new(&world, &codec);
    std::thread::scope(|scope| -> Result<(), TrainError> {
        let mut next = batches(scope, config, start, frames)?;
        while step < config.steps {
            let block = Block::containing(config, step);
            let mut replays: Vec<Repeats<Shot>> =
                (0..block.designs).map(|_| Repeats::default()).collect();
            while step < block.end_step {
                let clock = std::time::Instant::now();
                let Batch { shots, design: d, about, seconds, .. } = next(step)?;
                wait_s += clock.elapsed().as_secs_f64();
                simulate_s += seconds;
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
                        return Err(failed_step(e, step, &ckpt, block.first_step));
                    }
                };
                train_s += clock.elapsed().as_secs_f64();
                replays[d].advance(shots.into_iter().map(|shot| {
                    let n = shot.repeats(&config.experimental.repeats);
                    (shot, n)
                }));
                step += b;
                if let Some(average) = &mut average {
                    average.update((step / b) as u64);
                }
                if crossed(step, 10) || step == config.steps {
                    let line = serde_json::json!({
                        "step": step, "lr": config.lr_at(step - b), "loss": loss,
                        "design_index": about.index, "design": about.design,
                        "map_seed": about.map_seed, "episode": about.episode,
                        "frame_px": about.frame_px,
                        "simulate_s": simulate_s, "train_s": train_s, "wait_s": wait_s,
                    });
                    log_line(&mut log, &log_path, &line)?;
                }
                if progress(&PretrainEvent::Step { step, of: config.steps, loss }).is_break() {
                    return Err(TrainError::Interrupted { step });
                }
                if crossed(step, config.eval.every) && step < config.steps {
                    let result = average.as_ref().map_or(&model, WeightAverage::model);
                    let report = engine.with_threads(config.threads, || {
                        evaluate_day_night(result, config, config.eval.episodes, &streams, step)
                    })?;
                    log_line(&mut log, &log_path, &serde_json::json!({"eval": report}))?;
                    let _ = progress(&PretrainEvent::Eval(Box::new(report)));
                    last_eval = Some(report);
                }
            }
            // Every design's state is rebuilt from the seed at a block's start, so a checkpoint
            // at a block's end is all a resumed run needs.
            write_checkpoint(&ckpt, &model, average.as_ref(), step, config)?;
            let _ = progress(&PretrainEvent::Checkpoint { step });
        }
        Ok(())
    })?;
    let result = average.as_ref().map_or(&model, WeightAverage::model);
    let final_episodes = config.final_episodes();
    let report = match last_eval {
        Some(r) if r.step == step && final_episodes == config.eval.episodes => r,
        _ => {
            let r = engine.with_threads(config.threads, || {
                evaluate_day_night(result, config, final_episodes, &streams, step)
            })?;
            log_line(&mut log, &log_path, &serde_json::json!({"eval": r}))?;
            let _ = progress(&PretrainEvent::Eval(Box::new(r)));
            r
        }
    };
    let report = EvalReport { training_precision: Some(precision), ..report };
    result.save_weights(weights_out)?;
    write_atomic(
        &run_dir.join("results.json"),
        &serde_json::to_string_pretty(&report).unwrap_or_default(),
    )?;
    Ok(report)
}

/// What every design's frames are made with: the configuration, the seed's streams, the
/// formation (each design's frames carry its native grid's noise, `DesignRun::formation`),
/// AverageAE and the training towns' simulator settings.
fn world<'a>(
    config: &'a PretrainConfig,
    streams: &'a SeedStreams,
) -> Result<World<'a>, TrainError> {
    Ok(World {
        config,
        streams,
        formation: ImageFormation::new(Calibration::DEFAULT)?
            .with_resampler(config.input.resampler),
        ae: AverageAe::new(AccRanges::PAPER),
        sim_config: SimConfig {
            max_speed_mps: config.data.max_speed_mps,
            city: CityConfig::default()
                .with_walker_density(config.data.walker_density as f32)
                .with_sign_density(config.data.sign_density as f32),
            ..SimConfig::default()
        },
    })
}

/// The batch of a step (steps asked in order).
type NextBatch<'a> = Box<dyn FnMut(usize) -> Result<Batch, TrainError> + 'a>;

/// The training loop's batches from `start` on. The frames do not depend on the detector, so
/// with `pipeline` they are made in a thread of their own (in `scope`), up to `FRAMES_AHEAD`
/// batches ahead, while the detector trains; otherwise each when it is asked for.
fn batches<'scope, 'env>(
    scope: &'scope std::thread::Scope<'scope, 'env>,
    config: &'env PretrainConfig,
    start: usize,
    mut frames: FrameStream<'env>,
) -> Result<NextBatch<'scope>, TrainError> {
    if !config.experimental.pipeline {
        return Ok(Box::new(move |step| frames.make(step)));
    }
    let (tx, rx) = std::sync::mpsc::sync_channel::<Result<Batch, TrainError>>(FRAMES_AHEAD);
    let pool = frame_pool(config)?;
    scope.spawn(move || {
        pool.install(|| {
            for step in (start..config.steps).step_by(config.batch) {
                let made = frames.make(step);
                let failed = made.is_err();
                // The trainer hung up (it stopped or failed): nothing more is needed.
                if tx.send(made).is_err() || failed {
                    break;
                }
            }
        });
    });
    Ok(Box::new(move |step| {
        let made = rx.recv().map_err(|_| TrainError::Thread {
            what: "frame thread".into(),
            reason: "it stopped without a frame or an error".into(),
        })??;
        debug_assert_eq!(made.step, step, "frames arrive in step order");
        Ok(made)
    }))
}

/// Appends one JSON line to the run's event log.
fn log_line(
    log: &mut std::fs::File,
    path: &Path,
    line: &serde_json::Value,
) -> Result<(), TrainError> {
    writeln!(log, "{line}").map_err(|e| TrainError::io(path, e))
}

/// Scores the detector weights in `weights` (architecture read from the file) exactly as a
/// pre-training run with `config` evaluates: reference camera, AverageAE, test town,
/// [`PretrainConfig::final_episodes`] day and night episodes, noise from `config.seed`. With the
/// config a run was trained with, this reproduces its `results.json`.
pub fn evaluate_weights(config: &PretrainConfig, weights: &Path) -> Result<EvalReport, TrainError> {
    config.validate()?;
    let engine = Engine::open(config.device, config.threads)?;
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
        input: config.input,
        noise_scale: 1.0,
        motion_scale: 1.0,
    };
    let mut control = AverageControl::new(AccRanges::PAPER);
    let day = evaluate(model, &design, &mut control, &spec(Illumination::Day), streams)?;
    let night = evaluate(model, &design, &mut control, &spec(Illumination::Night), streams)?;
    Ok(EvalReport { step, day, night, training_precision: None })
}

/// Top-level field names whose values differ between two configurations.
pub fn differing_fields<T: Serialize>(a: &T, b: &T) -> Vec<String> {
    let (Ok(a), Ok(b)) = (serde_json::to_value(a), serde_json::to_value(b)) else {
        return vec!["(unreadable)".into()];
    };
    let mut out = Vec::new();
    differing_at("", &a, &b, &mut out);
    out
}

/// The fields below `path` in which `a` and `b` differ, nested tables as dotted paths.
fn differing_at(path: &str, a: &serde_json::Value, b: &serde_json::Value, out: &mut Vec<String>) {
    use serde_json::Value;
    if let (Value::Object(a), Value::Object(b)) = (a, b) {
        let mut keys: Vec<&String> = a.keys().chain(b.keys()).collect();
        keys.sort();
        keys.dedup();
        for k in keys {
            let sub = if path.is_empty() { k.clone() } else { format!("{path}.{k}") };
            match (a.get(k), b.get(k)) {
                (Some(x), Some(y)) => differing_at(&sub, x, y, out),
                (x, y) => out.push(format!(
                    "{sub} ({} → {})",
                    x.map_or("-".into(), Value::to_string),
                    y.map_or("-".into(), Value::to_string)
                )),
            }
        }
    } else if a != b {
        out.push(format!("{path} ({a} → {b})"));
    }
}
