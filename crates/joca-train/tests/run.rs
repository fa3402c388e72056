//! The joint loop end to end on a tiny configuration: determinism, kill-and-resume, refusals.
#![allow(clippy::unwrap_used)]

mod common;

use common::{poison_first_tensor, snapshot};
use joca_camera::{ApertureControl, LensModel};
use joca_camera::{DetectorInput, Resampler};
use joca_nn::detector::{DetectorConfig, Precision};
use joca_sim::Weather;
use joca_train::{
    DesignSpec, FNumberRange, FixedCamera, Method, PerturbationMutation, PerturbationScore,
    PerturbationSteps, RealConfig, RunConfig, RunEvent, Scenario, Source, TestController,
    TrainError, run,
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
        design: None,
        generations: 2,
        population: 2,
        steps_per_candidate: 5,
        perturbation_population: 4,
        perturbation_mutation: PerturbationMutation::Additive,
        perturbation_tie_break: Default::default(),
        perturbation_score: Default::default(),
        perturbation_steps: Default::default(),
        // The run's default: bfloat16 scoring where native (float32 elsewhere).
        scoring_precision: Precision::Bf16,
        acc_lr: 1e-5,
        clip_gradient: Default::default(),
        ga_every: 2,
        task_weight: 7.0,
        // Small frames for a fast test: 120 × 90 for a 4:3 sensor.
        input: DetectorInput { short_px: 90, long_max_px: 160, resampler: Resampler::Bilinear },
        hardware_mutation: Default::default(),
        lens: Default::default(),
        f_number: Default::default(),
        aperture: Default::default(),
        weather: Default::default(),
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
    let (e, test_dir) =
        joca_train::evaluate_run(&dir.path().join("a"), None, None, TestController::Trained)
            .unwrap();
    assert_eq!(e, a);
    // Into its own files: the run's `results.json` and `test/` stay the run's.
    assert_eq!(test_dir, dir.path().join("a").join("test-eval"));
    assert!(dir.path().join("a/results-eval.json").is_file());
    // Another controller on the same trained design: its own files, the run's left alone.
    let before = std::fs::read(dir.path().join("a").join("results.json")).unwrap();
    let average = TestController::from_name("average:60").unwrap();
    let (o, test_dir) =
        joca_train::evaluate_run(&dir.path().join("a"), None, None, average).unwrap();
    assert_eq!(o.test_controller, Some(TestController::Average { target_dn: 60.0 }));
    assert_eq!((o.design.clone(), o.test.frames), (a.design.clone(), a.test.frames));
    assert_eq!(test_dir, dir.path().join("a").join("test-average-60"));
    assert!(test_dir.join("showcase.json").exists());
    let written = std::fs::read_to_string(dir.path().join("a").join("results-average-60.json"));
    assert!(written.unwrap().contains("\"test_controller\": \"average-60\""));
    assert_eq!(std::fs::read(dir.path().join("a").join("results.json")).unwrap(), before);

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
        // Nothing of layout 2 (lens, weather, f-number) used: written as layout 1.
        assert_eq!(r.format_version, 1);
        assert_eq!(r.design.optimised, method != Method::FixedNeural);
        assert!(r.test.frames == 3);
        // The same training budget for every method, the fixed camera included: population
        // candidates of k frames per generation.
        let events =
            std::fs::read_to_string(dir.path().join(method.name()).join("events.jsonl")).unwrap();
        let candidates = events.lines().filter(|l| l.contains("\"candidate\":")).count();
        assert_eq!(candidates, cfg.generations * cfg.population, "{}", method.name());
    }
    // A design panel's cell: ours with the hardware held to a given design.
    let mut cfg = tiny(Method::Joca);
    cfg.generations = 1;
    cfg.design = Some(DesignSpec {
        sensor: "IMX546".into(),
        focal_length_mm: 5.0,
        x_m: 1.0,
        z_m: 1.5,
        f_number: None,
    });
    let r = run(&cfg, &dir.path().join("panel"), false, &mut go).unwrap();
    assert_eq!((r.design.sensor.as_str(), r.design.focal_length_mm), ("IMX546", 5.0));
    assert!(!r.design.optimised);
    let events = std::fs::read_to_string(dir.path().join("panel/events.jsonl")).unwrap();
    let designs: Vec<serde_json::Value> = events
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|v| v.get("candidate").is_some())
        .map(|v| v["design"].clone())
        .collect();
    assert_eq!(designs.len(), cfg.population);
    assert!(
        designs.iter().all(|d| d["sensor"] == "IMX546" && d["focal_length_mm"] == 5.0),
        "{designs:?}"
    );
    // The aperture as a gene, through a thin lens: each candidate's f-number within the range,
    // and the chosen one recorded (f/16 alone is left out of the records).
    let mut cfg = tiny(Method::Joca);
    cfg.generations = 1;
    cfg.lens = LensModel::Thin;
    cfg.f_number = FNumberRange { min: 1.4, max: 8.0 };
    cfg.weather = Weather::Fog { visibility_m: 300.0 };
    let r = run(&cfg, &dir.path().join("aperture"), false, &mut go).unwrap();
    let n = r.design.f_number.expect("an f-number below 16 is recorded");
    assert!((1.4..=8.0).contains(&n), "f/{n}");
    // The lens and the weather are recorded, and a report can say them.
    assert_eq!((r.lens, r.weather, r.format_version), (LensModel::Thin, cfg.weather, 2));
    let text = std::fs::read_to_string(dir.path().join("aperture/results.json")).unwrap();
    assert!(
        text.contains("\"lens\": \"thin\"") && text.contains("\"weather\": \"fog:300\""),
        "{text}"
    );
    assert_eq!(
        r.conditions_note(),
        " through a thin lens (defocus and diffraction by depth), in fog:300"
    );
    let events = std::fs::read_to_string(dir.path().join("aperture/events.jsonl")).unwrap();
    let apertures: Vec<f64> = events
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|v| v.get("candidate").is_some())
        .map(|v| v["design"]["f_number"].as_f64().unwrap())
        .collect();
    assert_eq!(apertures.len(), cfg.population);
    assert!(apertures.iter().all(|n| (1.4..=8.0).contains(n)), "{apertures:?}");
    // The aperture set frame by frame: NeuralAE's iris moves between the lens's f/2 and f/16,
    // every training step and test light records its f-number, and the layout says so.
    let mut cfg = tiny(Method::Joca);
    cfg.generations = 1;
    cfg.lens = LensModel::Thin;
    cfg.f_number = FNumberRange { min: 2.0, max: 2.0 };
    cfg.aperture = ApertureControl::Dynamic;
    let r = run(&cfg, &dir.path().join("iris"), false, &mut go).unwrap();
    assert_eq!((r.aperture, r.format_version), (ApertureControl::Dynamic, 3));
    let stops: Vec<_> = r.by_illumination.f_numbers().collect();
    assert_eq!(stops.len(), r.by_illumination.settings().count());
    assert!(stops.iter().all(|(_, n)| (2.0..=16.0).contains(n)), "{stops:?}");
    let events = std::fs::read_to_string(dir.path().join("iris/events.jsonl")).unwrap();
    let stops: Vec<f64> = events
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|v| v.get("step").is_some() && v.get("loss").is_some())
        .map(|v| v["f_number"].as_f64().expect("every step records its f-number"))
        .collect();
    assert!(!stops.is_empty() && stops.iter().all(|n| (2.0..=16.0).contains(n)), "{stops:?}");
    // The same run again: the same numbers.
    let again = run(&cfg, &dir.path().join("iris2"), false, &mut go).unwrap();
    assert_eq!(again.test, r.test);
    assert_eq!(again.by_illumination, r.by_illumination);
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
    cfg.detector_weights = Some(weights.clone());
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
    let ckpt = run_dir.join("checkpoint");
    // (First, a checkpoint written by a newer joca is refused, named, and left as it was.)
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

/// Every numeric field of `[run]` has a finite range; a value outside it, NaN or infinite, is
/// refused before anything runs, naming the field and the range.
#[test]
fn out_of_range_run_fields_are_refused_naming_the_field_and_the_range() {
    type Edit = fn(&mut RunConfig);
    let cases: [(Edit, &str); 24] = [
        (
            |c| {
                c.design = Some(DesignSpec {
                    sensor: "IMX172".into(),
                    focal_length_mm: 30.0,
                    x_m: 0.4,
                    z_m: 1.6,
                    f_number: None,
                })
            },
            "run.design.focal_length_mm = 30 is invalid: 1 to 10 mm (the paper's design space)",
        ),
        (
            |c| {
                c.design = Some(DesignSpec {
                    sensor: "nope".into(),
                    focal_length_mm: 3.0,
                    x_m: 0.4,
                    z_m: 1.6,
                    f_number: None,
                })
            },
            "run.design.sensor = \"nope\" is invalid: a catalogue sensor: ",
        ),
        (|c| c.max_speed_mps = f64::NAN, "run.max_speed_mps = NaN is invalid: 0 to 40"),
        (
            |c| c.f_number = FNumberRange { min: 2.0, max: 16.0 },
            "run.f_number = { min = 2, max = 16 } is invalid: 16 to 16 with lens = \"pinhole\" \
             (the pinhole has the calibration's light); set lens = \"thin\" to search the \
             aperture",
        ),
        (
            |c| {
                c.lens = LensModel::Thin;
                c.f_number = FNumberRange { min: 0.5, max: 16.0 };
            },
            "run.f_number.min = 0.5 is invalid: 1 to 32, min at most max",
        ),
        (
            |c| {
                c.lens = LensModel::Thin;
                c.f_number = FNumberRange { min: 8.0, max: 4.0 };
            },
            "run.f_number.max = 4 is invalid: 1 to 32, min at most max",
        ),
        (
            |c| c.weather = Weather::Fog { visibility_m: -5.0 },
            "run.weather = \"fog:-5\" is invalid: fog visibility_m = -5: allowed 10 to 100000 m",
        ),
        (
            |c| {
                c.lens = LensModel::Thin;
                c.source = Source::Folder("/data/rec".into());
            },
            "run.lens = \"thin\" is invalid: \"pinhole\" with a recording (recorded frames have \
             no depth to defocus by)",
        ),
        (|c| c.max_speed_mps = -5.0, "run.max_speed_mps = -5 is invalid: 0 to 40"),
        (|c| c.detector.width = 0, "run.detector.width = 0 is invalid: 4 to 128"),
        (|c| c.detector.width = 100_000, "run.detector.width = 100000 is invalid: 4 to 128"),
        (
            |c| c.detector.classes = 0,
            "run.detector.classes = 0 is invalid: 3 (vehicle, walker, traffic sign)",
        ),
        (|c| c.population = 1_000_000_000, "run.population = 1000000000 is invalid: 2 to 1000"),
        (
            |c| c.perturbation_population = 100_000_000,
            "run.perturbation_population = 100000000 is invalid: 2 to 64",
        ),
        (
            |c| c.task_weight = f64::INFINITY,
            "run.task_weight = inf is invalid: above 0, at most 1000",
        ),
        (|c| c.task_weight = f64::NAN, "run.task_weight = NaN is invalid: above 0, at most 1000"),
        (|c| c.input.short_px = 0, "run.input.short_px = 0 is invalid: 16 to 1024 px"),
        (|c| c.input.short_px = 5000, "run.input.short_px = 5000 is invalid: 16 to 1024 px"),
        (|c| c.input.long_max_px = 60, "run.input.long_max_px = 60 is invalid: 90 to 2048 px"),
        (|c| c.input.long_max_px = 9999, "run.input.long_max_px = 9999 is invalid: 90 to 2048 px"),
        (|c| c.test_frames_per_episode = 0, "run.test_frames_per_episode = 0 is invalid: 1 to 500"),
        (|c| c.test_episodes = 0, "run.test_episodes = 0 is invalid: 1 to 10000"),
        (|c| c.generations = 0, "run.generations = 0 is invalid: 1 to 10000"),
        (|c| c.ga_every = 0, "run.ga_every = 0 is invalid: 1 to 400"),
    ];
    for (edit, message) in cases {
        let mut c = tiny(Method::Joca);
        edit(&mut c);
        let e = c.validate().unwrap_err().to_string();
        assert!(e == message || (message.ends_with(": ") && e.starts_with(message)), "{e}");
    }
    assert!(tiny(Method::Joca).validate().is_ok());
}

/// The test is stratified by illumination: four episodes are one day, one night, one tunnel and
/// one cycle episode, in that order, and the settings table has a row for each.
#[test]
fn the_test_gives_every_illumination_its_share_of_episodes() {
    let _serial = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().unwrap();
    let cfg = RunConfig {
        generations: 1,
        steps_per_candidate: 2,
        test_episodes: 4,
        test_frames_per_episode: 1,
        ..tiny(Method::TacosAverage)
    };
    let r = run(&cfg, dir.path(), false, &mut go).unwrap();
    let trace = std::fs::read_to_string(dir.path().join("test/trace.jsonl")).unwrap();
    let lights: Vec<String> = trace
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap()["illumination"].to_string())
        .collect();
    assert_eq!(lights, ["\"day\"", "\"night\"", "\"tunnel\"", "\"cycle\""]);
    assert_eq!(r.by_illumination.settings().count(), 4);
    // The same frames scored per light: one frame each.
    assert_eq!(r.by_illumination.scores().count(), 4);
    assert!(r.by_illumination.scores().all(|(_, s)| s.frames == 1));
}

/// Common random numbers: every candidate of a generation drives the same scenes, its k steps in
/// four stretches under day, night, tunnel and cycle (generation g starting at
/// `Illumination::ALL[g mod 4]`); the best designs of training are re-scored on the validation
/// town and the best there is the one tested.
#[test]
fn candidates_of_a_generation_share_their_scenes_and_the_validation_picks_the_design() {
    let _serial = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().unwrap();
    let cfg = RunConfig { steps_per_candidate: 8, ..tiny(Method::Joca) };
    let r = run(&cfg, dir.path(), false, &mut go).unwrap();
    let events = std::fs::read_to_string(dir.path().join("events.jsonl")).unwrap();
    let steps: Vec<serde_json::Value> = events
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|v| v.get("step").is_some())
        .collect();
    // Steps 0 and 5 of each candidate are logged (stretches of 2 steps: step 5 is in the third):
    // two candidates per generation, two generations.
    let lights: Vec<&str> = steps.iter().map(|v| v["illumination"].as_str().unwrap()).collect();
    let generation_0 = ["day", "tunnel"];
    let generation_1 = ["night", "cycle"];
    assert_eq!(lights, [generation_0, generation_0, generation_1, generation_1].concat());
    // Step 0 runs at the calibration camera's settings for every candidate.
    let first = steps.iter().step_by(2);
    assert!(first.clone().all(|v| (v["exposure_ms"].as_f64().unwrap() - 5.0).abs() < 1e-3));
    // Validation: up to three designs re-scored, the tested one first and best there.
    assert!(!r.validation.is_empty() && r.validation.len() <= 3);
    assert_eq!(r.validation[0].design, r.design);
    let best = r.validation[0].validation.fitness();
    assert!(r.validation.iter().all(|v| v.validation.fitness() <= best));
    assert!(r.validation.iter().all(|v| v.validation.frames == 40));
}

/// Every perturbation search is counted once (steps after a candidate's first, where NeuralAE
/// predicts), with how many a tie decided; the task loss scores members apart.
#[test]
fn the_results_count_the_perturbation_searches_and_their_ties() {
    let _serial = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().unwrap();
    let base = RunConfig { generations: 1, ..tiny(Method::Joca) };
    let searches = (base.population * (base.steps_per_candidate - 1)) as u64;
    let ap50 = run(&base, &dir.path().join("ap50"), false, &mut go).unwrap();
    let t = ap50.perturbation_ties.unwrap();
    assert_eq!(t.searches, searches);
    assert!(t.tied <= searches);
    let cfg = RunConfig {
        perturbation_score: PerturbationScore::Loss,
        perturbation_steps: PerturbationSteps::Relative,
        ..base.clone()
    };
    let loss = run(&cfg, &dir.path().join("loss"), false, &mut go).unwrap();
    // Members clamped to the same settings at a range's end still tie (1 of 8 on an AVX2
    // machine scoring in fp32, 0 with AVX-512 BF16): the issue's goal is under 20 %.
    let lt = loss.perturbation_ties.unwrap();
    assert_eq!(lt.searches, searches);
    assert!(lt.tied * 5 < searches, "{lt:?}");
    let avg = run(
        &RunConfig { generations: 1, ..tiny(Method::TacosAverage) },
        &dir.path().join("avg"),
        false,
        &mut go,
    )
    .unwrap();
    assert_eq!(avg.perturbation_ties, None);
}
