//! Reading `[run]` fields whose file form differs from their type.
use super::RunConfig;
use std::path::PathBuf;

/// The `[run]` table of a TOML file, relative to the repository.
fn run_table(path: &str) -> toml::Table {
    let path = format!("{}/../../{path}", env!("CARGO_MANIFEST_DIR"));
    let mut table: toml::Table = toml::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    match table.remove("run") {
        Some(toml::Value::Table(run)) => run,
        other => panic!("no [run] table: {other:?}"),
    }
}

/// The quick preset's `[run]` with `detector_weights` set to `value` (or removed).
fn with_weights(value: Option<&str>) -> RunConfig {
    let mut run = run_table("presets/quick.toml");
    run.remove("detector_weights");
    if let Some(v) = value {
        run.insert("detector_weights".into(), v.into());
    }
    run.try_into().unwrap()
}

#[test]
fn detector_weights_are_a_path_or_none() {
    assert_eq!(with_weights(None).detector_weights, None);
    // Older files (and a user's override of a preset) write "none" as an empty string.
    assert_eq!(with_weights(Some("")).detector_weights, None);
    let some = with_weights(Some("w/d.safetensors"));
    assert_eq!(some.detector_weights, Some(PathBuf::from("w/d.safetensors")));
    // Written back, "none" leaves the field out and a path keeps it.
    assert!(!toml::to_string(&with_weights(Some(""))).unwrap().contains("detector_weights"));
    let text = toml::to_string(&some).unwrap();
    assert!(text.contains("detector_weights = \"w/d.safetensors\""), "{text}");
    assert_eq!(toml::from_str::<RunConfig>(&text).unwrap(), some);
}

#[test]
fn a_dynamic_aperture_needs_a_thin_lens_and_neural_ae() {
    use joca_camera::{ApertureControl, LensModel};
    let mut config = with_weights(None);
    config.aperture = ApertureControl::Dynamic;
    // The quick preset's pinhole has no iris.
    let e = config.validate().unwrap_err().to_string();
    assert!(e.contains("aperture") && e.contains("\"dynamic\"") && e.contains("thin"), "{e}");
    config.lens = LensModel::Thin;
    config.validate().unwrap();
    // AverageAE sets exposure and gain only.
    config.method = crate::Method::TacosAverage;
    let e = config.validate().unwrap_err().to_string();
    assert!(e.contains("aperture") && e.contains("NeuralAE"), "{e}");
    // Written back, the fixed default leaves the field out.
    assert!(!toml::to_string(&with_weights(None)).unwrap().contains("aperture"));
    let text = "aperture = \"dynamic\"";
    let mut table: toml::Table =
        toml::from_str(&toml::to_string(&with_weights(None)).unwrap()).unwrap();
    table.extend(toml::from_str::<toml::Table>(text).unwrap());
    let read: RunConfig = table.try_into().unwrap();
    assert_eq!(read.aperture, ApertureControl::Dynamic);
    let bad: Result<RunConfig, _> = toml::from_str(
        &toml::to_string(&with_weights(None))
            .unwrap()
            .replace("seed = 0", "seed = 0\naperture = \"iris\""),
    );
    let e = bad.unwrap_err().to_string();
    assert!(e.contains("iris") && e.contains("fixed") && e.contains("dynamic"), "{e}");
}

/// Every preset scores the perturbation search by the task loss; a saved configuration that does
/// not name the score (written before it was selectable, as the committed detector-input grid's
/// cells) reads as the paper's AP50, which is what it ran, so an experiment never mistakes such a
/// cell for one of today's.
#[test]
fn presets_score_by_the_loss_and_older_configurations_meant_ap50() {
    use super::PerturbationScore;
    for name in ["quick", "standard", "paper"] {
        let run: RunConfig = run_table(&format!("presets/{name}.toml")).try_into().unwrap();
        assert_eq!(run.perturbation_score, PerturbationScore::Loss, "{name}");
    }
    // A cell of issue 39's `standard` grid, run before the score was selectable.
    let old =
        "docs/results/2026-11-27-detector-input/standard/cells/basler-calibrated-s0/cell.toml";
    let table = run_table(old);
    assert!(!table.contains_key("perturbation_score"));
    let run: RunConfig = table.try_into().unwrap();
    assert_eq!(run.perturbation_score, PerturbationScore::Ap50);
}

/// NeuralAE's options mean nothing to AverageAE, nor the detector's rate to a frozen detector:
/// read as absent there, so a preset that sets them leaves such cells' configuration (and its
/// hash) as it was, and is not refused for them.
#[test]
fn controller_options_are_read_as_absent_where_the_method_has_no_use_for_them() {
    let mut run = run_table("presets/quick.toml");
    run.insert("acc_output".into(), "relative:3".into());
    run.insert("detector_lr".into(), 1e-5.into());
    let mut warm = toml::Table::new();
    warm.insert("frames".into(), 600.into());
    run.insert("warm_start".into(), warm.into());
    let with: RunConfig = run.try_into().unwrap();
    let average = RunConfig { method: joca_record::Method::TacosAverage, ..with.clone() };
    assert!(average.validate().is_ok());
    let plain = RunConfig {
        acc_output: Default::default(),
        warm_start: Default::default(),
        ..average.clone()
    };
    assert_eq!(average.as_read(), plain.as_read());
    let frozen = RunConfig { method: joca_record::Method::FrozenDetector, ..with.clone() };
    assert_eq!(frozen.as_read().detector_lr, 1e-4);
    assert_eq!((with.as_read().detector_lr, with.as_read().warm_start.frames), (1e-5, 600));
}

/// A window pools a score that ranks confidences (`ap50`, `map`) over 1 to 400 frames; zero
/// frames, too many, or a window over the loss (a sum, which a window cannot change the ranking
/// of) are refused naming the field and what is allowed. One frame is what an absent field
/// means, and is left out of a saved configuration, so earlier cells keep their identity.
#[test]
fn the_perturbation_window_pools_ranked_scores_within_its_range() {
    use super::PerturbationScore;
    let quick: RunConfig = run_table("presets/quick.toml").try_into().unwrap();
    assert_eq!(quick.perturbation_window, 1);
    assert!(!toml::to_string(&quick).unwrap().contains("perturbation_window"));
    let pooled =
        |score, w| RunConfig { perturbation_score: score, perturbation_window: w, ..quick.clone() };
    for score in [PerturbationScore::Map, PerturbationScore::Ap50] {
        assert!(pooled(score, 16).validate().is_ok());
        assert!(pooled(score, 400).validate().is_ok());
        let text = toml::to_string(&pooled(score, 16)).unwrap();
        assert!(text.contains("perturbation_window = 16"), "{text}");
    }
    for (score, w, allowed) in [
        (PerturbationScore::Map, 0, "1 (the perturbed frame alone) to 400"),
        (PerturbationScore::Ap50, 401, "1 (the perturbed frame alone) to 400"),
        (PerturbationScore::Loss, 16, "a window pools \"ap50\" or \"map\""),
    ] {
        let e = pooled(score, w).validate().unwrap_err().to_string();
        assert!(e.contains("run.perturbation_window") && e.contains(allowed), "{e}");
        assert!(e.contains(&w.to_string()), "{e}");
    }
    // AverageAE searches nothing: its window reads as absent.
    let average = RunConfig {
        method: joca_record::Method::TacosAverage,
        ..pooled(PerturbationScore::Map, 16)
    };
    assert_eq!(average.as_read().perturbation_window, 1);
}

/// `judge_frames` (with fresh scenes) takes 1 to 400 common frames and defaults to the steps a
/// candidate trains; zero, too many, or any with shared scenes (where a candidate is judged on
/// its training frames) are refused naming the field and what is allowed. An absent field is
/// left out of a saved configuration, so earlier cells keep their identity.
#[test]
fn judge_frames_counts_a_fresh_candidates_common_frames_within_its_range() {
    use super::TrainingScenes;
    let quick: RunConfig = run_table("presets/quick.toml").try_into().unwrap();
    let judged =
        |n, scenes| RunConfig { judge_frames: n, training_scenes: scenes, ..quick.clone() };
    let unset = judged(None, TrainingScenes::Fresh);
    assert!(unset.validate().is_ok());
    assert_eq!(unset.judge_frames(), unset.steps_per_candidate);
    assert!(!toml::to_string(&unset).unwrap().contains("judge_frames"));
    for n in [1, 12, 400] {
        let c = judged(Some(n), TrainingScenes::Fresh);
        assert!(c.validate().is_ok());
        assert_eq!(c.judge_frames(), n);
        assert!(toml::to_string(&c).unwrap().contains(&format!("judge_frames = {n}")));
    }
    for (n, scenes, allowed) in [
        (0, TrainingScenes::Fresh, "1 to 400"),
        (401, TrainingScenes::Fresh, "1 to 400"),
        (12, TrainingScenes::Shared, "unset with training_scenes = \"shared\""),
    ] {
        let e = judged(Some(n), scenes).validate().unwrap_err().to_string();
        assert!(e.contains("run.judge_frames") && e.contains(allowed), "{e}");
        assert!(e.contains(&n.to_string()), "{e}");
    }
}
