//! The joint loop end to end on a tiny configuration: determinism, kill-and-resume, every method,
//! refusals of out-of-range fields, and the protocol (stratified test, shared scenes, counted
//! perturbation searches). One test binary; its parts by subject.
#![allow(clippy::unwrap_used)]

#[path = "../common/mod.rs"]
mod common;
mod methods;
mod protocol;
mod refusals;
mod resume;

use joca_camera::{DetectorInput, Resampler};
use joca_nn::detector::{DetectorConfig, Precision};
use joca_train::{
    FixedCamera, Method, PerturbationMutation, RealConfig, RunConfig, RunEvent, Scenario, Source,
};
use std::ops::ControlFlow;
use std::sync::Mutex;

/// libtorch's random generator and thread count are process-wide: tests that initialise
/// networks run one at a time so that each sees the seed it set.
static SERIAL: Mutex<()> = Mutex::new(());

fn tiny(method: Method) -> RunConfig {
    RunConfig {
        seed: 3,
        threads: 1,
        device: Default::default(),
        method,
        scenario: Scenario::Blur2,
        camera: FixedCamera::Flir,
        design: None,
        generations: 2,
        population: 2,
        steps_per_candidate: 5,
        perturbation_population: 4,
        perturbation_mutation: PerturbationMutation::Additive,
        perturbation_tie_break: Default::default(),
        perturbation_score: Default::default(),
        perturbation_window: 1,
        perturbation_steps: Default::default(),
        // The run's default: bfloat16 scoring where native (float32 elsewhere).
        scoring_precision: Precision::Bf16,
        acc_lr: 1e-5,
        acc_output: Default::default(),
        warm_start: Default::default(),
        detector_lr: 1e-4,
        clip_gradient: Default::default(),
        training_scenes: Default::default(),
        judge_frames: None,
        ga_every: 2,
        task_weight: 7.0,
        step_weight: 0.0,
        min_box_px: 8.0,
        // Small frames for a fast test: 120 × 90 for a 4:3 sensor.
        input: DetectorInput { short_px: 90, long_max_px: 160, resampler: Resampler::Bilinear },
        hardware_mutation: Default::default(),
        lens: Default::default(),
        f_number: Default::default(),
        aperture: Default::default(),
        weather: Default::default(),
        cast_shadows: false,
        sun_elevation: Default::default(),
        glare: Default::default(),
        sun_disc: false,
        dark_streets: false,
        tunnels: Default::default(),
        train_maps: 2,
        max_speed_mps: 15.0,
        detector: DetectorConfig { width: 8, classes: 3, deep: false, shared_head: false },
        detector_weights: None,
        test_episodes: 1,
        test_frames_per_episode: 3,
        source: Source::Sim,
        test_source: Source::Sim,
        real: RealConfig::default(),
        reference: Default::default(),
    }
}

/// Every event a run wrote to its `events.jsonl`, parsed.
fn events(run_dir: &std::path::Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(run_dir.join("events.jsonl"))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

fn go(_: &RunEvent) -> ControlFlow<()> {
    ControlFlow::Continue(())
}
