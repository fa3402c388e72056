//! `joca run` refuses bad methods, scenarios, presets and configuration values, naming the
//! field, the allowed range and the file, and writes nothing.
#![allow(clippy::unwrap_used)] // a failed unwrap is a failed test

mod common;
use common::{cli, stderr};

#[test]
fn run_refuses_unknown_methods_scenarios_presets_and_config_fields() {
    let o = cli!("run --method magic --out /tmp/joca-never");
    assert!(
        stderr(&o).contains("unknown method \"magic\"")
            && stderr(&o).contains("tacos-average, fixed-neural"),
        "{}",
        stderr(&o)
    );
    let o = cli!("run --scenario fog --out /tmp/joca-never");
    assert!(
        stderr(&o).contains("unknown scenario \"fog\"") && stderr(&o).contains("noise10"),
        "{}",
        stderr(&o)
    );
    let o = cli!("run --preset huge --out /tmp/joca-never");
    assert!(
        stderr(&o).contains("unknown preset \"huge\"")
            && stderr(&o).contains("quick, standard, paper"),
        "{}",
        stderr(&o)
    );
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("mine.toml");
    std::fs::write(&cfg, "[run]\ngenerations = 2\npopulaton = 4\n").unwrap();
    let o = cli!("run --config", cfg, "--out /tmp/joca-never");
    assert!(
        stderr(&o).contains("mine.toml") && stderr(&o).contains("unknown field `populaton`"),
        "{}",
        stderr(&o)
    );
    // `joca experiment --seeds 0` is refused before anything is written.
    let exp_dir = dir.path().join("exp");
    let o = cli!("experiment ablation --seeds 0 --out", exp_dir);
    let e = stderr(&o);
    assert!(!o.status.success() && e.contains("--seeds = 0 is invalid: 1 to 100"), "{e}");
    assert!(!exp_dir.exists());
    // A misspelt table is refused, not ignored.
    std::fs::write(&cfg, "[runn]\ngenerations = 2\n").unwrap();
    let o = cli!("run --config", cfg, "--out /tmp/joca-never");
    assert!(
        !o.status.success()
            && stderr(&o).contains("mine.toml")
            && stderr(&o).contains("`runn`")
            && stderr(&o).contains("[run], [pretrain]"),
        "{}",
        stderr(&o)
    );
    // `--resume` where nothing ran is refused, and so is `--out` at a folder of other files,
    // which is left untouched.
    let empty = dir.path().join("empty");
    let o = cli!("run --resume --out", empty);
    assert!(stderr(&o).contains("nothing to resume"), "{}", stderr(&o));
    let other = dir.path().join("other");
    std::fs::create_dir_all(&other).unwrap();
    std::fs::write(other.join("notes.txt"), "mine").unwrap();
    let o = cli!("run --out", other);
    assert!(stderr(&o).contains("is not a joca run output"), "{}", stderr(&o));
    let left: Vec<_> = std::fs::read_dir(&other).unwrap().collect();
    assert_eq!(left.len(), 1);
    // A speed that is not a number is refused before anything runs.
    let o = cli!("render --max-speed-mps NaN --frames 1 --out /tmp/joca-never");
    assert!(stderr(&o).contains("--max-speed-mps = NaN is out of range"), "{}", stderr(&o));
}

#[test]
fn run_refuses_bad_config_values_naming_the_field_and_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("mine.toml");
    // The detector input: a size past its maximum, a long side below the short side, an unknown
    // resampler, hardware mutation or perturbation score or step, a fixed design outside the
    // catalogue or the design space, each named with what is allowed and the file; nothing is
    // written.
    let cases = [
        (
            "input = { short_px = 2000, long_max_px = 3000 }",
            "run.input.short_px = 2000 is invalid: 16 to 1024 px",
        ),
        (
            "input = { short_px = 0, long_max_px = 400 }",
            "run.input.short_px = 0 is invalid: 16 to 1024 px",
        ),
        (
            "input = { short_px = 240, long_max_px = 200 }",
            "run.input.long_max_px = 200 is invalid: 240 to 2048 px",
        ),
        (
            "input = { short_px = 240, long_max_px = 400, resampler = \"lanczos\" }",
            "unknown variant `lanczos`, expected `bilinear` or `area`",
        ),
        (
            "hardware_mutation = \"gaussian\"",
            "unknown variant `gaussian`, expected `tacos` or `paper`",
        ),
        (
            "perturbation_score = \"median\"",
            "unknown variant `median`, expected one of `ap50`, `loss`, `map`",
        ),
        (
            "perturbation_window = 0",
            "run.perturbation_window = 0 is invalid: 1 (the perturbed frame alone) to 400",
        ),
        (
            "perturbation_window = 16",
            "run.perturbation_window = 16 is invalid: 1 with perturbation_score = \"loss\"",
        ),
        (
            "perturbation_steps = \"log\"",
            "\"log\": expected \"linear\", \"relative\" or \"stops:S\"",
        ),
        ("perturbation_steps = \"stops:6\"", "above 0 and at most 4 stops"),
        (
            "sun_elevation = { min_deg = 5, max_deg = 20, daylight = \"dusk\" }",
            "unknown variant `dusk`, expected `constant` or `clear-sky`",
        ),
        (
            "design = { sensor = \"IMX999\", focal_length_mm = 4.0, x_m = 0.5, z_m = 1.5 }",
            "run.design.sensor = \"IMX999\" is invalid: a catalogue sensor: ",
        ),
        (
            "design = { sensor = \"IMX172\", focal_length_mm = 25.0, x_m = 0.5, z_m = 1.5 }",
            "run.design.focal_length_mm = 25 is invalid: 1 to 10 mm (the paper's design space)",
        ),
        (
            "design = { sensor = \"IMX172\", focal_length_mm = 4.0, x_m = 0.5 }",
            "missing field `z_m`",
        ),
        // The lens, its aperture range and the weather (issue 41).
        ("lens = \"fisheye\"", "unknown variant `fisheye`, expected `pinhole` or `thin`"),
        ("weather = \"snow\"", "unknown weather \"snow\"; allowed: \"clear\", \"fog:V\""),
        ("weather = \"fog:-3\"", "fog visibility_m = -3: allowed 10 to 100000 m"),
        (
            "lens = \"thin\"\nf_number = { min = 0.7, max = 16.0 }",
            "run.f_number.min = 0.7 is invalid: 1 to 32, min at most max",
        ),
        (
            "f_number = { min = 2.0, max = 16.0 }",
            "run.f_number = { min = 2, max = 16 } is invalid: 16 to 16 with lens = \"pinhole\"",
        ),
        ("aperture = \"iris\"", "unknown variant `iris`, expected `fixed` or `dynamic`"),
        // Cast shadows are on or off (issue 74).
        (
            "sun_elevation = { min_deg = 10, max_deg = 95 }",
            "run.sun_elevation = { min_deg = 10, max_deg = 95 } is invalid: 2 to 90 degrees",
        ),
        (
            "sun_elevation = { min = 10, max = 30 }",
            "expected one of `min_deg`, `max_deg`, `daylight`\nin `sun_elevation`",
        ),
        (
            "cast_shadows = \"yes\"",
            "invalid type: string \"yes\", expected a boolean\nin `cast_shadows`",
        ),
        (
            "aperture = \"dynamic\"",
            "run.aperture = \"dynamic\" is invalid: \"fixed\" unless lens = \"thin\"",
        ),
        (
            "lens = \"thin\"\naperture = \"dynamic\"\nmethod = \"tacos-average\"",
            "run.aperture = \"dynamic\" is invalid: \"fixed\" unless lens = \"thin\" and the method's",
        ),
    ];
    for (line, message) in cases {
        std::fs::write(&cfg, format!("[run]\n{line}\n")).unwrap();
        let out = dir.path().join("r");
        let o = cli!("run --config", cfg, "--out", out);
        assert!(!o.status.success());
        assert!(stderr(&o).contains(message) && stderr(&o).contains("mine.toml"), "{}", stderr(&o));
        assert!(!out.exists(), "{line}: the run directory was created");
    }
    // An unknown perturbation mutation names the field and the values it may take.
    std::fs::write(&cfg, "[run]\nperturbation_mutation = \"gaussian\"\n").unwrap();
    let o = cli!("run --config", cfg, "--out /tmp/joca-never");
    let e = stderr(&o);
    assert!(
        e.contains("perturbation_mutation") && e.contains("`paper`") && e.contains("`additive`"),
        "{e}"
    );
    // So does an unknown scoring precision.
    std::fs::write(&cfg, "[run]\nscoring_precision = \"fp16\"\n").unwrap();
    let o = cli!("run --config", cfg, "--out /tmp/joca-never");
    let e = stderr(&o);
    assert!(e.contains("scoring_precision") && e.contains("`fp32`") && e.contains("`bf16`"), "{e}");
    // A reference range of zero (or less) names the field, the allowed range and the file,
    // before a run directory exists; the other ranges of a partial table keep their defaults.
    std::fs::write(&cfg, "[run.reference]\nwalker_m = 0.0\n").unwrap();
    let never = dir.path().join("never");
    let o = cli!("run --config", cfg, "--out", never);
    let e = stderr(&o);
    assert!(
        !o.status.success()
            && e.contains("run.reference.walker_m = 0 is invalid: above 0 m, at most 200 m")
            && e.contains(cfg.to_str().unwrap()),
        "{e}"
    );
    assert!(!never.exists(), "a refused config left {}", never.display());
}

/// `joca bench step` and `bench checkpoint` read a configuration as `joca run` does (a world's
/// lights priced on the joint step): a bad value is refused naming the field, its range and the
/// file before anything is timed, and the other benches refuse `--config` naming it.
#[test]
fn bench_step_refuses_a_bad_config_naming_the_field_and_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("lights.toml");
    std::fs::write(&cfg, "[run]\nglare = { fraction = 1.5 }\n").unwrap();
    for target in ["step", "checkpoint"] {
        let o = cli!("bench", target, "--repeats 2 --config", cfg);
        let e = stderr(&o);
        assert!(!o.status.success() && e.contains("lights.toml"), "{target}: {e}");
        assert!(e.contains("glare.fraction") && e.contains("below 1"), "{target}: {e}");
    }
    let o = cli!("bench render --config", cfg);
    let e = stderr(&o);
    assert!(!o.status.success() && e.contains("--config") && e.contains("lights.toml"), "{e}");
    assert!(e.contains("`bench step` and `bench checkpoint`"), "{e}");
}
