//! A run stopped anywhere (killed, a failed checkpoint write, a NaN loss) resumes to the results
//! of one never stopped, or stops cleanly with its last checkpoint intact.

use super::{SERIAL, go, tiny};
use crate::common::{poison_first_tensor, snapshot};
use joca_camera::{DetectorInput, Resampler};
use joca_train::{EvalOptions, Method, RunConfig, RunEvent, TestController, TrainError, run};
use std::ops::ControlFlow;

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
    let (e, test_dir) =
        joca_train::evaluate_run(&dir.path().join("a"), &EvalOptions::default()).unwrap();
    assert_eq!(e, a);
    // Into its own files: the run's `results.json` and `test/` stay the run's.
    assert_eq!(test_dir, dir.path().join("a").join("test-eval"));
    assert!(dir.path().join("a/results-eval.json").is_file());
    // Another controller on the same trained design: its own files, the run's left alone.
    let before = std::fs::read(dir.path().join("a").join("results.json")).unwrap();
    let average = TestController::from_name("average:60").unwrap();
    let options = EvalOptions { controller: average, ..EvalOptions::default() };
    let (o, test_dir) = joca_train::evaluate_run(&dir.path().join("a"), &options).unwrap();
    assert_eq!(o.test_controller, Some(TestController::Average { target_dn: 60.0 }));
    assert_eq!((o.design.clone(), o.test.frames), (a.design.clone(), a.test.frames));
    assert_eq!(test_dir, dir.path().join("a").join("test-average-60"));
    assert!(test_dir.join("showcase.json").exists());
    let written = std::fs::read_to_string(dir.path().join("a").join("results-average-60.json"));
    assert!(written.unwrap().contains("\"test_controller\": \"average-60\""));
    assert_eq!(std::fs::read(dir.path().join("a").join("results.json")).unwrap(), before);
    // A fresh town of the test family: the same design on other scenes, recorded as such.
    let options = EvalOptions { town: 2, ..EvalOptions::default() };
    let (t, test_dir) = joca_train::evaluate_run(&dir.path().join("a"), &options).unwrap();
    assert_eq!((t.test_town, t.design.clone()), (Some(2), a.design.clone()));
    assert_ne!(t.test.class_objects, a.test.class_objects, "town 2 drove the test town's scenes");
    assert_eq!(test_dir, dir.path().join("a").join("test-town2"));
    // Its showcases too are town 2's (town 0's would repeat the run's own, byte for byte).
    let showcase = |d: &str| std::fs::read(dir.path().join("a").join(d).join("showcase.json"));
    assert_ne!(showcase("test-town2").unwrap(), showcase("test").unwrap());
    let written = std::fs::read_to_string(dir.path().join("a").join("results-town2.json"));
    assert!(written.unwrap().contains("\"test_town\": 2"));
    // The validation town chose among the designs: refused, naming the flag and the range.
    let options = EvalOptions { town: 1, ..EvalOptions::default() };
    let e = joca_train::evaluate_run(&dir.path().join("a"), &options).unwrap_err().to_string();
    assert!(e.contains("--town = 1 is invalid: 0 (the test town) or 2 to 9999"), "{e}");
    assert_eq!(std::fs::read(dir.path().join("a").join("results.json")).unwrap(), before);
    // The run's detector started from random weights: nothing to swap back to, refused.
    let options = EvalOptions { start_detector: true, ..EvalOptions::default() };
    let e = joca_train::evaluate_run(&dir.path().join("a"), &options).unwrap_err().to_string();
    assert!(e.contains("--detector = start is invalid") && e.contains("random detector"), "{e}");

    let mut other = cfg.clone();
    other.task_weight = 5.0;
    let e = run(&other, &b_dir, true, &mut go).unwrap_err().to_string();
    assert!(e.contains("task_weight (7.0 → 5.0)"), "{e}");
    // A run folder whose checkpoint another configuration wrote is not evaluated as its own.
    let config = b_dir.join("config.toml");
    let text = std::fs::read_to_string(&config).unwrap();
    std::fs::write(&config, text.replace("task_weight = 7.0", "task_weight = 5.0")).unwrap();
    let e = joca_train::evaluate_run(&b_dir, &EvalOptions::default()).unwrap_err().to_string();
    assert!(
        e.contains("state.json")
            && e.contains("another configuration")
            && e.contains("task_weight"),
        "{e}"
    );
    assert!(!b_dir.join("results-eval.json").exists());
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
    let ckpt = run_dir.join("checkpoint");
    // First, one bit flipped in the saved detector after the checkpoint was written: refused,
    // naming the file, before anything is loaded or written.
    let detector = ckpt.join("detector.safetensors");
    let good = std::fs::read(&detector).unwrap();
    let mut flipped = good.clone();
    let last = flipped.len() - 1;
    flipped[last] ^= 1;
    std::fs::write(&detector, &flipped).unwrap();
    let e = run(&cfg, &run_dir, true, &mut go).unwrap_err().to_string();
    assert!(e.contains("detector.safetensors") && e.contains("differ from the SHA-256"), "{e}");
    let e = joca_train::evaluate_run(&run_dir, &EvalOptions::default());
    assert!(e.unwrap_err().to_string().contains("detector.safetensors"));
    std::fs::write(&detector, &good).unwrap();
    // Without its digests (as a checkpoint of a joca before them) a checkpoint is taken as it
    // is: the changes below reach the loaders.
    std::fs::remove_file(ckpt.join("digests.json")).unwrap();
    // (A checkpoint written by a newer joca is refused, named, and left as it was.)
    let state_path = ckpt.join("state.json");
    let original = std::fs::read_to_string(&state_path).unwrap();
    assert!(original.starts_with("{\"format_version\":1,"), "{original}");
    std::fs::write(
        &state_path,
        original.replacen("\"format_version\":1", "\"format_version\":99", 1),
    )
    .unwrap();
    let e = run(&cfg, &run_dir, true, &mut go).unwrap_err().to_string();
    assert!(e.contains("state.json") && e.contains("format_version 99 is newer"), "{e}");
    std::fs::write(&state_path, &original).unwrap();
    // Divergence injected into the saved detector: the next step's loss is NaN.
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

/// Every file of a run's checkpoint, by name (the weights and optimiser states, `state.json`).
fn checkpoint_files(run_dir: &std::path::Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(run_dir.join("checkpoint"))
        .unwrap()
        .map(|e| {
            let path = e.unwrap().path();
            (
                path.file_name().unwrap().to_string_lossy().into_owned(),
                std::fs::read(&path).unwrap(),
            )
        })
        .collect();
    files.sort();
    files
}

/// A run stopped right after each of its checkpoints in turn — mid-generation, at the end of a
/// generation, and after the last candidate, before the test — and resumed, ends with the
/// `results.json` and checkpoint of a run never stopped, byte for byte.
#[test]
fn a_run_stopped_at_every_checkpoint_resumes_to_the_uninterrupted_run_byte_for_byte() {
    let _serial = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().unwrap();
    let input = DetectorInput { short_px: 240, long_max_px: 400, resampler: Resampler::Bilinear };
    let cfg = RunConfig { steps_per_candidate: 3, input, ..tiny(Method::Joca) };
    let whole = dir.path().join("whole");
    run(&cfg, &whole, false, &mut go).unwrap();
    let results = std::fs::read(whole.join("results.json")).unwrap();
    let checkpoint = checkpoint_files(&whole);
    let candidates = cfg.generations * cfg.population;
    for stop_after in 1..=candidates {
        let d = dir.path().join(format!("stopped-{stop_after}"));
        let mut stop = |e: &RunEvent| match e {
            RunEvent::Candidate { done, .. } if *done == stop_after => ControlFlow::Break(()),
            _ => ControlFlow::Continue(()),
        };
        assert!(matches!(run(&cfg, &d, false, &mut stop), Err(TrainError::Interrupted { .. })));
        run(&cfg, &d, true, &mut go).unwrap();
        assert!(
            std::fs::read(d.join("results.json")).unwrap() == results,
            "stopped after candidate {stop_after}: results.json differs"
        );
        assert!(
            checkpoint_files(&d) == checkpoint,
            "stopped after candidate {stop_after}: the checkpoint differs"
        );
    }
}
