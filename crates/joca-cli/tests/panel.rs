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
