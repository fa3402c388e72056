//! The joint loop end to end on a tiny configuration: determinism, kill-and-resume, refusals.
#![allow(clippy::unwrap_used)]

mod common;

use common::{poison_first_tensor, snapshot};
use joca_nn::detector::DetectorConfig;
use joca_train::{
    FixedCamera, Method, RealConfig, RunConfig, RunEvent, Scenario, Source, TrainError, run,
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
        method,
        scenario: Scenario::Blur2,
        camera: FixedCamera::Flir,
        generations: 2,
        population: 2,
        steps_per_candidate: 5,
        perturbation_population: 4,
        ga_every: 2,
        task_weight: 7.0,
        render_scale: 0.03,
        train_maps: 2,
        max_speed_mps: 15.0,
        detector: DetectorConfig { width: 8, classes: 3, deep: false, shared_head: false },
        detector_weights: String::new(),
        test_episodes: 1,
        test_frames_per_episode: 3,
        source: Source::Sim,
        test_source: Source::Sim,
        real: RealConfig::default(),
    }
}

fn go(_: &RunEvent) -> ControlFlow<()> {
    ControlFlow::Continue(())
}

#[test]
fn a_run_killed_mid_way_resumes_to_the_same_results_as_one_never_killed() {
    let _serial = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().unwrap();
    let cfg = tiny(Method::Joca);
    let a = run(&cfg, &dir.path().join("a"), false, &mut go).unwrap();
    // The same configuration again: identical results.
    let again = run(&cfg, &dir.path().join("again"), false, &mut go).unwrap();
    assert_eq!(a, again);
    assert_eq!(
        std::fs::read_to_string(dir.path().join("a/results.json")).unwrap(),
        std::fs::read_to_string(dir.path().join("again/results.json")).unwrap()
    );

    // Stopped after the third candidate (mid second generation), then resumed.
    let b_dir = dir.path().join("b");
    let mut stop = |e: &RunEvent| match e {
        RunEvent::Candidate { done: 3, .. } => ControlFlow::Break(()),
        _ => ControlFlow::Continue(()),
    };
    assert!(matches!(
        run(&cfg, &b_dir, false, &mut stop),
        Err(TrainError::Interrupted { step: 3 })
    ));
    let b = run(&cfg, &b_dir, true, &mut go).unwrap();
    assert_eq!(a, b);

    // `eval` re-tests the best design from the checkpoint and reproduces the test scores.
    let e = joca_train::evaluate_run(&dir.path().join("a"), None, None).unwrap();
    assert_eq!(e, a);

    let mut other = cfg.clone();
    other.task_weight = 5.0;
    let e = run(&other, &b_dir, true, &mut go).unwrap_err().to_string();
    assert!(e.contains("task_weight (7.0 → 5.0)"), "{e}");
}

#[test]
fn a_failing_checkpoint_write_keeps_the_previous_checkpoint_usable() {
    let _serial = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().unwrap();
    let cfg = tiny(Method::NoGaLoss);
    let reference = run(&cfg, &dir.path().join("ref"), false, &mut go).unwrap();
    let run_dir = dir.path().join("r");
    // After the first checkpoint, a file where the next checkpoint's temporary directory must
    // go makes every later write fail (as a full disk or a permission problem would).
    let blocker = run_dir.join("checkpoint.partial");
    let mut block = |e: &RunEvent| {
        if let RunEvent::Candidate { done: 1, .. } = e {
            std::fs::write(&blocker, "in the way").unwrap();
        }
        ControlFlow::Continue(())
    };
    let e = run(&cfg, &run_dir, false, &mut block).unwrap_err();
    assert!(matches!(e, TrainError::Io { .. }), "{e}");
    let state = std::fs::read_to_string(run_dir.join("checkpoint/state.json")).unwrap();
    assert!(state.contains("\"candidate\":1"), "{state}");
    // Once the obstacle is gone, --resume continues from that checkpoint to the same result.
    std::fs::remove_file(&blocker).unwrap();
    assert_eq!(run(&cfg, &run_dir, true, &mut go).unwrap(), reference);
}

#[test]
fn every_method_runs() {
    let _serial = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().unwrap();
    for method in
        [Method::TacosAverage, Method::FixedNeural, Method::NoGaLoss, Method::FixedPerturbation]
    {
        let mut cfg = tiny(method);
        cfg.generations = 1;
        let r = run(&cfg, &dir.path().join(method.name()), false, &mut go).unwrap();
        assert_eq!(r.method, method);
        assert_eq!(r.design.optimised, method != Method::FixedNeural);
        assert!(r.test.frames == 3);
    }
    // The frozen detector needs weights to freeze.
    let e = run(&tiny(Method::FrozenDetector), &dir.path().join("f"), false, &mut go)
        .unwrap_err()
        .to_string();
    assert!(e.contains("run.detector_weights"), "{e}");
    // With weights it trains NeuralAE only: the detector leaves the run exactly as it came in.
    let weights = dir.path().join("frozen.safetensors");
    let engine = joca_nn::Engine::cpu(1);
    joca_nn::detector::DetectorModel::new(
        &engine,
        DetectorConfig { width: 8, classes: 3, deep: false, shared_head: false },
        joca_nn::AdamConfig::DETECTOR,
    )
    .save_weights(&weights)
    .unwrap();
    let mut cfg = tiny(Method::FrozenDetector);
    cfg.generations = 1;
    cfg.detector_weights = weights.display().to_string();
    let r = run(&cfg, &dir.path().join("frozen"), false, &mut go).unwrap();
    assert_eq!(r.method, Method::FrozenDetector);
    assert_eq!(
        std::fs::read(dir.path().join("frozen/checkpoint/detector.safetensors")).unwrap(),
        std::fs::read(&weights).unwrap()
    );
}

#[test]
fn a_nan_loss_mid_run_stops_cleanly_and_leaves_the_last_checkpoint_intact() {
    let _serial = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().unwrap();
    let cfg = tiny(Method::Joca);
    let run_dir = dir.path().join("r");
    let mut stop = |e: &RunEvent| match e {
        RunEvent::Candidate { done: 1, .. } => ControlFlow::Break(()),
        _ => ControlFlow::Continue(()),
    };
    assert!(run(&cfg, &run_dir, false, &mut stop).is_err());
    // Divergence injected into the saved detector: the next step's loss is NaN.
    let ckpt = run_dir.join("checkpoint");
    poison_first_tensor(&ckpt.join("detector.safetensors"));
    let before = snapshot(&ckpt);
    let e = run(&cfg, &run_dir, true, &mut go).unwrap_err();
    assert!(matches!(e, TrainError::Diverged { generation: 0, candidate: 1, .. }), "{e}");
    let text = e.to_string();
    assert!(
        text.contains("training diverged in generation 0, candidate 1") && text.contains("NaN"),
        "{text}"
    );
    assert!(text.contains("after 1 candidate(s)) is intact"), "{text}");
    // Nothing was written over the last checkpoint, and no results were claimed.
    for (name, bytes) in &before {
        assert_eq!(&std::fs::read(ckpt.join(name)).unwrap(), bytes, "{name:?} changed");
    }
    assert!(!run_dir.join("results.json").exists());
    let state: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(ckpt.join("state.json")).unwrap()).unwrap();
    assert_eq!(state["candidate"], 1);
}
