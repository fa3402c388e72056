//! A design panel run end to end: every variant on every design with the hardware fixed, and
//! the report's paired sections.
#![allow(clippy::unwrap_used)] // a failed unwrap is a failed test

mod common;
use common::{TINY_RUN, cli, stderr, stdout};

const PANEL: &str = r#"
title = "controllers on a panel"
label_header = "Controller"
scenarios = ["calibrated"]

[panel]
designs = [{ id = "basler", camera = "basler" }]
from_runs = ["DONE"]

[[variant]]
id = "average"
label = "AverageAE"
run = { method = "tacos-average" }

[[variant]]
id = "neural"
label = "NeuralAE (DF-Grad)"
run = { method = "joca" }
"#;

#[test]
fn a_panel_compares_controllers_on_the_same_designs() {
    let dir = tempfile::tempdir().unwrap();
    // A finished run whose best design joins the panel (only best_design.json is read).
    let done = dir.path().join("done");
    std::fs::create_dir_all(&done).unwrap();
    std::fs::write(
        done.join("best_design.json"),
        r#"{"x_m": 1.2, "z_m": 1.5, "focal_length_mm": 6.0, "sensor": "IMX546",
            "sensor_mm": [5.6, 4.1], "pixel_pitch_um": 2.74, "optimised": true}"#,
    )
    .unwrap();
    let file = dir.path().join("panel.toml");
    std::fs::write(&file, PANEL.replace("DONE", done.to_str().unwrap())).unwrap();
    let cfg = dir.path().join("run.toml");
    // Four test episodes, one per light, for the per-light table.
    let run = TINY_RUN.replace("test_episodes = 1", "test_episodes = 4");
    std::fs::write(&cfg, run.replace("test_frames_per_episode = 2", "test_frames_per_episode = 1"))
        .unwrap();
    let exp = dir.path().join("exp");
    let o = cli!("experiment", file, "--config", cfg, "--seeds 2 --jobs 2 --out", exp);
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    // Every cell drove its panel design, not a searched one.
    for (cell, sensor) in [
        ("neural-calibrated-basler-s1", "AR0134"),
        ("average-calibrated-done-s0", "IMX546"),
        ("neural-calibrated-done-s1", "IMX546"),
    ] {
        let r: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(exp.join("cells").join(cell).join("results.json")).unwrap(),
        )
        .unwrap();
        assert_eq!(r["design"]["sensor"], sensor, "{cell}");
        assert_eq!(r["design"]["optimised"], false, "{cell}");
        assert_eq!(r["test_by_illumination"].as_object().unwrap().len(), 4, "{cell}");
    }
    let md = std::fs::read_to_string(exp.join("report.md")).unwrap();
    for part in [
        "## Over designs and seeds",
        "2 panel designs (basler, done)",
        "| Calibrated | NeuralAE (DF-Grad) − AverageAE | 2 designs × ≤ 2 seeds |",
        "### Paired, by illumination",
        "### Per design",
        "| Calibrated | done | IMX546, 6.00 mm, 2.74 µm | AverageAE | 2 |",
    ] {
        assert!(md.contains(part), "{part:?} not in\n{md}");
    }
}

#[test]
fn prepare_writes_every_cell_and_runs_none() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("panel.toml");
    // The panel without the finished run: the Basler camera, two controllers, two seeds.
    std::fs::write(&file, PANEL.replace("from_runs = [\"DONE\"]", "")).unwrap();
    let cfg = dir.path().join("run.toml");
    std::fs::write(&cfg, TINY_RUN).unwrap();
    let exp = dir.path().join("exp");
    let o = cli!("experiment", file, "--config", cfg, "--seeds 2 --prepare --out", exp);
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    assert!(stdout(&o).contains("0 done, 0 running, 0 partial, 4 missing of 4"), "{}", stdout(&o));
    assert!(exp.join("experiment.json").is_file());
    for cell in ["average-calibrated-basler-s0", "neural-calibrated-basler-s1"] {
        let c = exp.join("cells").join(cell);
        let toml = std::fs::read_to_string(c.join("cell.toml")).unwrap();
        assert!(toml.contains("sensor = \"AR0134\""), "{cell}: the Basler camera's sensor: {toml}");
        assert!(!c.join("checkpoint").exists() && !c.join("events.jsonl").exists(), "{cell}");
        assert!(!c.join("cell.log").exists(), "{cell}: no cell was started");
    }
    assert!(!exp.join("report.md").exists());
    // Refused beside --status, which writes nothing (and beside --slurm, which submits).
    let o = cli!("experiment", file, "--config", cfg, "--prepare --status --out", exp);
    assert!(!o.status.success() && stderr(&o).contains("cannot be used with"), "{}", stderr(&o));
}

/// A grid's cells run the code the grid started with: the `joca` a running experiment was
/// started from is replaced (as a rebuild replaces it) by a program that fails, and the
/// experiment's cell still runs and finishes, naming the commit its parent was built from.
#[cfg(target_os = "linux")]
#[test]
fn a_grid_runs_its_cells_with_its_own_code_when_the_program_is_rebuilt_under_it() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    // A copy beside the built program, where its run path finds libtorch as the original's does.
    let original = std::path::Path::new(env!("CARGO_BIN_EXE_joca"));
    let beside = tempfile::tempdir_in(original.parent().unwrap()).unwrap();
    let bin = beside.path().join("joca");
    std::fs::copy(original, &bin).unwrap();
    let (file, cfg, exp) =
        (dir.path().join("one.toml"), dir.path().join("run.toml"), dir.path().join("exp"));
    let one = "title = \"one\"\nlabel_header = \"Method\"\nscenarios = [\"calibrated\"]\n\n\
               [[variant]]\nid = \"tacos\"\nlabel = \"TaCOS\"\nrun = { method = \"tacos-average\" }\n";
    std::fs::write(&file, one).unwrap();
    std::fs::write(&cfg, TINY_RUN).unwrap();
    let child = std::process::Command::new(&bin)
        .arg("experiment")
        .arg(&file)
        .args(["--preset", "quick", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&exp)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // The rebuild: a new file at the program's path (the running image stays as it was).
    std::fs::remove_file(&bin).unwrap();
    std::fs::write(&bin, "#!/bin/sh\necho 'the rebuilt program ran' >&2\nexit 3\n").unwrap();
    std::fs::set_permissions(&bin, std::fs::Permissions::from_mode(0o755)).unwrap();
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    assert!(stdout(&o).contains("done   tacos-calibrated"), "{}", stdout(&o));
    let log = std::fs::read_to_string(exp.join("cells/tacos-calibrated/cell.log")).unwrap();
    assert!(!log.contains("the rebuilt program ran"), "{log}");
    assert!(exp.join("cells/tacos-calibrated/results.json").is_file());
}
