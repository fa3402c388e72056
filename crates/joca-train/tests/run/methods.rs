//! Every method runs on the same training budget, a design panel's cell holds its design, the
//! aperture (a gene or set frame by frame) and the weather are recorded, and the frozen detector
//! leaves the run as it came in (and `eval --detector start` of it repeats its test).

use super::{SERIAL, events, go, tiny};
use joca_camera::{ApertureControl, LensModel};
use joca_nn::detector::DetectorConfig;
use joca_sim::Weather;
use joca_train::{DesignSpec, EvalOptions, FNumberRange, Method, evaluate_run, run};

#[test]
fn every_method_runs_on_the_same_training_budget() {
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
        let events = events(&dir.path().join(method.name()));
        let candidates = events.iter().filter(|v| v.get("candidate").is_some()).count();
        assert_eq!(candidates, cfg.generations * cfg.population, "{}", method.name());
    }
}

/// A design panel's cell: ours with the hardware held to a given design.
#[test]
fn a_panel_cell_trains_ours_on_the_given_design() {
    let _serial = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().unwrap();
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
    let designs: Vec<serde_json::Value> = events(&dir.path().join("panel"))
        .into_iter()
        .filter(|v| v.get("candidate").is_some())
        .map(|v| v["design"].clone())
        .collect();
    assert_eq!(designs.len(), cfg.population);
    assert!(
        designs.iter().all(|d| d["sensor"] == "IMX546" && d["focal_length_mm"] == 5.0),
        "{designs:?}"
    );
}

/// The aperture as a gene, through a thin lens: each candidate's f-number within the range, and
/// the chosen one recorded (f/16 alone is left out of the records).
#[test]
fn the_aperture_gene_stays_in_its_range_and_lens_and_weather_are_recorded() {
    let _serial = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().unwrap();
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
    let apertures: Vec<f64> = events(&dir.path().join("aperture"))
        .into_iter()
        .filter(|v| v.get("candidate").is_some())
        .map(|v| v["design"]["f_number"].as_f64().unwrap())
        .collect();
    assert_eq!(apertures.len(), cfg.population);
    assert!(apertures.iter().all(|n| (1.4..=8.0).contains(n)), "{apertures:?}");
}

/// The aperture set frame by frame: NeuralAE's iris moves between the lens's f/2 and f/16, every
/// training step and test light records its f-number, and the layout says so.
#[test]
fn a_dynamic_aperture_is_recorded_per_step_and_repeats() {
    let _serial = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().unwrap();
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
    let stops: Vec<f64> = events(&dir.path().join("iris"))
        .into_iter()
        .filter(|v| v.get("step").is_some() && v.get("loss").is_some())
        .map(|v| v["f_number"].as_f64().expect("every step records its f-number"))
        .collect();
    assert!(!stops.is_empty() && stops.iter().all(|n| (2.0..=16.0).contains(n)), "{stops:?}");
    // The same run again: the same numbers.
    let again = run(&cfg, &dir.path().join("iris2"), false, &mut go).unwrap();
    assert_eq!(again.test, r.test);
    assert_eq!(again.by_illumination, r.by_illumination);
}

#[test]
fn the_frozen_detector_needs_weights_and_leaves_them_unchanged() {
    let _serial = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().unwrap();
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
    // Tested with the weights it started from, it is tested with its own detector: the same
    // scores, written to their own file naming the weights.
    let options = EvalOptions { start_detector: true, ..EvalOptions::default() };
    let (e, test_dir) = evaluate_run(&dir.path().join("frozen"), &options).unwrap();
    assert_eq!((e.test, e.design), (r.test, r.design));
    assert_eq!(e.test_detector.as_deref(), Some(weights.display().to_string().as_str()));
    assert_eq!(test_dir, dir.path().join("frozen/test-detector-start"));
    assert!(dir.path().join("frozen/results-detector-start.json").is_file());
}
