//! Pre-training end to end on a tiny configuration: determinism, kill-and-resume, refusals.
#![allow(clippy::unwrap_used)]

mod common;

use common::{poison_first_tensor, snapshot};
use joca_camera::{DetectorInput, Resampler};
use joca_nn::detector::{DetectorConfig, Precision, PrecisionExt, Regression};
use joca_train::{
    DataConfig, EvalConfig, ExperimentalConfig, OptimizerConfig, PretrainConfig, PretrainEvent,
    TrainError, evaluate_weights, pretrain,
};
use std::ops::ControlFlow;
use std::sync::Mutex;

/// libtorch's random generator and thread count are process-wide: tests that initialise
/// networks run one at a time so that each sees the seed it set.
static SERIAL: Mutex<()> = Mutex::new(());

fn tiny() -> PretrainConfig {
    PretrainConfig {
        seed: 7,
        threads: 1,
        device: Default::default(),
        steps: 12,
        batch: 1,
        precision: Precision::Fp32,
        // Small frames for a fast test: 120 × 90 for a 4:3 sensor.
        input: DetectorInput { short_px: 90, long_max_px: 160, resampler: Resampler::Bilinear },
        detector: DetectorConfig { width: 8, classes: 3, deep: false, shared_head: false },
        checkpoint_every_designs: 1,
        optimizer: OptimizerConfig {
            lr: 1e-3,
            lr_final: 1e-4,
            warmup_steps: 2,
            weight_decay: 1e-6,
            ema_decay: 0.9,
        },
        data: DataConfig {
            frames_per_design: 4,
            frames_per_episode: 2,
            exposure_spread: 4.0,
            train_maps: 2,
            max_speed_mps: 15.0,
            walker_density: 2.0,
            sign_density: 2.0,
        },
        eval: EvalConfig { every: 0, episodes: 1, final_episodes: Some(2) },
        experimental: ExperimentalConfig {
            class_weights: [1.0, 2.0, 1.0],
            regression: Regression::Gaussian,
            min_radius: 1,
            min_box_px: 6.0,
            repeats: [0, 1, 2],
            pipeline: false,
        },
    }
}

/// `tiny()` with `f` applied.
fn tiny_with(f: impl FnOnce(&mut PretrainConfig)) -> PretrainConfig {
    let mut c = tiny();
    f(&mut c);
    c
}

fn go(_: &PretrainEvent) -> ControlFlow<()> {
    ControlFlow::Continue(())
}

/// Interrupts a run once it reports `frames` trained frames (a kill).
fn stop_at(frames: usize) -> impl FnMut(&PretrainEvent) -> ControlFlow<()> {
    move |e| match e {
        PretrainEvent::Step { step, .. } if *step == frames => ControlFlow::Break(()),
        _ => ControlFlow::Continue(()),
    }
}

#[test]
fn a_killed_run_resumes_to_the_same_weights_as_an_uninterrupted_one() {
    let _serial = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().unwrap();
    let (a_dir, b_dir) = (dir.path().join("a.run"), dir.path().join("b.run"));
    let (a_w, b_w) = (dir.path().join("a.safetensors"), dir.path().join("b.safetensors"));
    let cfg = tiny();
    let report_a = pretrain(&cfg, &a_dir, &a_w, false, &mut go).unwrap();

    // Stop at step 10: the last checkpoint covers 8 steps; steps 9–10 are lost and redone.
    let mut stop = stop_at(10);
    assert!(matches!(
        pretrain(&cfg, &b_dir, &b_w, false, &mut stop),
        Err(TrainError::Interrupted { step: 10 })
    ));
    assert!(!b_w.exists());
    // Starting again without --resume is refused; with it, the run completes.
    assert!(
        pretrain(&cfg, &b_dir, &b_w, false, &mut go).unwrap_err().to_string().contains("--resume")
    );
    let report_b = pretrain(&cfg, &b_dir, &b_w, true, &mut go).unwrap();
    assert_eq!(std::fs::read(&a_w).unwrap(), std::fs::read(&b_w).unwrap());
    assert_eq!(report_a, report_b);
    // The final evaluation has its own size (2 episodes × 10 frames per light); scoring the
    // written weights again reproduces it.
    assert_eq!((report_a.day.frames, report_a.night.frames), (20, 20));
    let again = evaluate_weights(&cfg, &a_w).unwrap();
    assert_eq!((again.day, again.night), (report_a.day, report_a.night));

    // Resuming with another configuration names the differing field.
    let mut other = cfg.clone();
    other.optimizer.lr = 5e-4;
    let e = pretrain(&other, &b_dir, &b_w, true, &mut go).unwrap_err().to_string();
    assert!(e.contains("optimizer.lr (0.001 → 0.0005)"), "{e}");
}

#[test]
fn a_nan_loss_stops_pretraining_cleanly_and_leaves_the_last_checkpoint_intact() {
    let _serial = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().unwrap();
    let (run_dir, weights) = (dir.path().join("r.run"), dir.path().join("r.safetensors"));
    let cfg = tiny();
    // Killed in the second block of designs (4 frames each): the checkpoint covers 4 frames.
    assert!(matches!(
        pretrain(&cfg, &run_dir, &weights, false, &mut stop_at(6)),
        Err(TrainError::Interrupted { step: 6 })
    ));
    // Divergence injected into the saved detector: the resumed run's first loss is NaN.
    let ckpt = run_dir.join("checkpoint");
    poison_first_tensor(&ckpt.join("detector.safetensors"));
    // The checkpoint's digests see the change and refuse it, naming the file ...
    let e = pretrain(&cfg, &run_dir, &weights, true, &mut go).unwrap_err().to_string();
    assert!(e.contains("detector.safetensors") && e.contains("differ from the SHA-256"), "{e}");
    // ... and without them (a checkpoint of a joca before digests) the NaN surfaces in training.
    std::fs::remove_file(ckpt.join("digests.json")).unwrap();
    let before = snapshot(&ckpt);
    let e = pretrain(&cfg, &run_dir, &weights, true, &mut go).unwrap_err();
    assert!(matches!(e, TrainError::PretrainDiverged { frame: 4, .. }), "{e}");
    let text = e.to_string();
    assert!(
        text.contains("pre-training diverged in the batch after frame 4") && text.contains("NaN"),
        "{text}"
    );
    assert!(text.contains("after 4 frames) is intact") && text.contains("--resume"), "{text}");
    // Nothing was written over the checkpoint, and no weights or results were claimed.
    assert_eq!(snapshot(&ckpt), before);
    assert!(!weights.exists() && !run_dir.join("results.json").exists());
    let log = std::fs::read_to_string(run_dir.join("events.jsonl")).unwrap();
    assert!(log.lines().last().unwrap().contains("\"error\""), "{log}");
}

#[test]
fn a_batched_bfloat16_run_is_reproducible_across_kill_and_resume() {
    let _serial = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().unwrap();
    let (a_dir, b_dir) = (dir.path().join("a.run"), dir.path().join("b.run"));
    let (a_w, b_w) = (dir.path().join("a.safetensors"), dir.path().join("b.safetensors"));
    let cfg = PretrainConfig { batch: 2, precision: Precision::Bf16, ..tiny() };
    let mut steps = Vec::new();
    let mut record = |e: &PretrainEvent| {
        if let PretrainEvent::Step { step, .. } = e {
            steps.push(*step);
        }
        ControlFlow::Continue(())
    };
    let report_a = pretrain(&cfg, &a_dir, &a_w, false, &mut record).unwrap();
    // Six steps of two frames each.
    assert_eq!(steps, [2, 4, 6, 8, 10, 12]);
    let mut stop = stop_at(10);
    assert!(pretrain(&cfg, &b_dir, &b_w, false, &mut stop).is_err());
    let report_b = pretrain(&cfg, &b_dir, &b_w, true, &mut go).unwrap();
    assert_eq!(std::fs::read(&a_w).unwrap(), std::fs::read(&b_w).unwrap());
    assert_eq!(report_a, report_b);
    // bfloat16 where this CPU has it natively, float32 otherwise, and results.json says which.
    let want = if joca_nn::detector::native_bf16() { Precision::Bf16 } else { Precision::Fp32 };
    assert_eq!(report_a.training_precision, Some(want));
    let text = std::fs::read_to_string(a_dir.join("results.json")).unwrap();
    assert!(text.contains(&format!("\"training_precision\": \"{want:?}\"").to_lowercase()));
    assert_eq!(Precision::Fp32.on_this_cpu(), Precision::Fp32);
}

#[test]
fn a_pipelined_run_learns_what_a_serial_run_on_its_trainer_threads_learns() {
    let _serial = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().unwrap();
    let w = |name: &str| dir.path().join(format!("{name}.safetensors"));
    let run = |name: &str| dir.path().join(format!("{name}.run"));
    // Two threads: one makes the frames of the next batch while one trains on this batch.
    let piped = tiny_with(|c| (c.threads, c.experimental.pipeline, c.batch) = (2, true, 2));
    let mut serial = piped.clone();
    (serial.threads, serial.experimental.pipeline) = (1, false);
    assert_eq!(piped.trainer_threads(), 1);
    pretrain(&piped, &run("piped"), &w("piped"), false, &mut go).unwrap();
    pretrain(&serial, &run("serial"), &w("serial"), false, &mut go).unwrap();
    // The same frames in the same order, trained on one thread: the same weights, byte for byte.
    assert_eq!(std::fs::read(w("piped")).unwrap(), std::fs::read(w("serial")).unwrap());
    // Killed while the frame thread is a batch ahead, and resumed: still the same weights.
    assert!(matches!(
        pretrain(&piped, &run("killed"), &w("killed"), false, &mut stop_at(10)),
        Err(TrainError::Interrupted { step: 10 })
    ));
    pretrain(&piped, &run("killed"), &w("killed"), true, &mut go).unwrap();
    assert_eq!(std::fs::read(w("piped")).unwrap(), std::fs::read(w("killed")).unwrap());
    // Both logs tell where the time went.
    let log = std::fs::read_to_string(run("piped").join("events.jsonl")).unwrap();
    let last_step = log.lines().rfind(|l| l.contains("\"loss\"")).unwrap();
    let v: serde_json::Value = serde_json::from_str(last_step).unwrap();
    for key in ["simulate_s", "train_s", "wait_s"] {
        assert!(v[key].as_f64().unwrap() > 0.0, "{key} in {last_step}");
    }
}

#[test]
fn repeated_frames_change_what_is_learned() {
    let _serial = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().unwrap();
    let mut runs = 0;
    let mut weights = |repeats| {
        let cfg = tiny_with(|c| (c.experimental.repeats, c.steps) = (repeats, 8));
        runs += 1;
        let name = format!("run{runs}");
        let w = dir.path().join(format!("{name}.safetensors"));
        pretrain(&cfg, &dir.path().join(name), &w, false, &mut go).unwrap();
        std::fs::read(w).unwrap()
    };
    // Repeating every frame with an object once, in its design's next batch, trains on the
    // same frames plus repeats: other weights, and again the same ones on a second run.
    let none = weights([0, 0, 0]);
    let once = weights([1, 1, 1]);
    assert_ne!(none, once);
    assert_eq!(once, weights([1, 1, 1]));
}

/// The frame sizes a run's `events.jsonl` logged, and its final evaluation.
fn frame_sizes(run: &std::path::Path) -> (Vec<[usize; 2]>, serde_json::Value) {
    let log = std::fs::read_to_string(run.join("events.jsonl")).unwrap();
    let lines: Vec<serde_json::Value> =
        log.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    let sizes = lines
        .iter()
        .filter_map(|l| l.get("frame_px"))
        .map(|p| serde_json::from_value(p.clone()).unwrap())
        .collect();
    (sizes, lines.iter().rev().find_map(|l| l.get("eval")).unwrap().clone())
}

/// Every random design's training frames have the detector's input size — short side
/// `short_px` unless the long side's cap makes it shorter — whatever the sensor's pixel count;
/// twice the input doubles every frame. The test town's reference objects do not depend on the
/// input size.
#[test]
fn training_frames_have_the_input_size_and_the_test_counts_the_same_objects() {
    let _serial = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().unwrap();
    let run = |name: &str, cfg: &PretrainConfig| {
        let w = dir.path().join(format!("{name}.safetensors"));
        pretrain(cfg, &dir.path().join(name), &w, false, &mut go).unwrap();
        (frame_sizes(&dir.path().join(name)), std::fs::read(w).unwrap())
    };
    let coarse = tiny();
    let fine_input = DetectorInput { short_px: 180, long_max_px: 320, ..coarse.input };
    let fine = tiny_with(|c| c.input = fine_input);
    let ((coarse_px, coarse_eval), coarse_w) = run("coarse", &coarse);
    let ((fine_px, fine_eval), fine_w) = run("fine", &fine);
    assert_eq!(coarse_px.len(), fine_px.len());
    assert!(!coarse_px.is_empty());
    for (c, f) in coarse_px.iter().zip(&fine_px) {
        let (short, long) = (c[0].min(c[1]), c[0].max(c[1]));
        assert!(long <= 160 && (short == 90 || long == 160), "{c:?}");
        for k in 0..2 {
            assert!(f[k].abs_diff(2 * c[k]) <= 1, "{c:?} at 90 px, {f:?} at 180 px");
        }
    }
    // Other frames, other weights; the test town's reference objects are the same: an object
    // is counted whatever its size in pixels.
    assert_ne!(coarse_w, fine_w);
    for light in ["day", "night"] {
        assert_eq!(coarse_eval[light]["class_objects"], fine_eval[light]["class_objects"]);
    }
}

#[test]
fn invalid_configuration_names_the_field_and_the_range() {
    let _serial = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = tiny();
    cfg.input.short_px = 3;
    let e = pretrain(&cfg, dir.path(), &dir.path().join("w.safetensors"), false, &mut go)
        .unwrap_err()
        .to_string();
    assert_eq!(e, "pretrain.input.short_px = 3 is invalid: 16 to 1024 px");
    let mut cfg = tiny();
    cfg.experimental.class_weights = [1.0, 0.0, 1.0];
    let e = cfg.validate().unwrap_err().to_string();
    assert_eq!(
        e,
        "pretrain.experimental.class_weights = [1.0, 0.0, 1.0] is invalid: each above 0, at \
         most 100"
    );
    let cfg = PretrainConfig { batch: 3, ..tiny() };
    assert_eq!(
        cfg.validate().unwrap_err().to_string(),
        "pretrain.batch = 3 is invalid: 1 to 64, dividing data.frames_per_design and steps"
    );
    let mut cfg = tiny();
    cfg.data.sign_density = 9.0;
    assert_eq!(
        cfg.validate().unwrap_err().to_string(),
        "pretrain.data.sign_density = 9 is invalid: 0 to 8"
    );
    let cfg = tiny_with(|c| (c.experimental.pipeline, c.threads) = (true, 1));
    assert_eq!(
        cfg.validate().unwrap_err().to_string(),
        "pretrain.threads = 1 is invalid: at least 2 with experimental.pipeline = true (one makes \
         frames, one trains)"
    );
    let cfg = tiny_with(|c| c.data.exposure_spread = 0.5);
    assert_eq!(
        cfg.validate().unwrap_err().to_string(),
        "pretrain.data.exposure_spread = 0.5 is invalid: 1 to 100"
    );
    let cfg = tiny_with(|c| c.experimental.min_box_px = 0.5);
    assert_eq!(
        cfg.validate().unwrap_err().to_string(),
        "pretrain.experimental.min_box_px = 0.5 is invalid: 1 to 64 pixels"
    );
    let cfg = tiny_with(|c| c.experimental.repeats = [0, 9, 0]);
    assert_eq!(
        cfg.validate().unwrap_err().to_string(),
        "pretrain.experimental.repeats = [0, 9, 0] is invalid: each 0 to 8"
    );
}
