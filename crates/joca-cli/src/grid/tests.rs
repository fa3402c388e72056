//! Resolving grids: built-in experiments, seeds and design panels.

use super::*;
use joca_train::Method;
use std::path::Path;

#[test]
fn every_built_in_experiment_resolves_with_every_preset() {
    for (name, _) in EXPERIMENTS {
        for (preset, _) in config::PRESETS {
            let result = resolve(name, preset, None, 1);
            if name == "real" {
                // Needs a recording; without one it is refused.
                assert!(result.unwrap_err().to_string().contains("runs on recorded frames"));
                continue;
            }
            let exp = result.unwrap_or_else(|e| panic!("{name} / {preset}: {e:#}"));
            assert!(!exp.cells.is_empty());
            let ids: std::collections::HashSet<_> = exp.cells.iter().map(|c| &c.spec.id).collect();
            assert_eq!(ids.len(), exp.cells.len(), "{name}: duplicate cell ids");
        }
    }
    let table1 = resolve("table1", "quick", None, 1).unwrap();
    assert_eq!(table1.cells.len(), 20);
    assert_eq!(table1.cells[0].spec.id, "flir-calibrated");
    assert_eq!(table1.cells[0].config.method, Method::FixedNeural);
    // Issue 41's grids reach the run: the thin lens with and without the aperture gene, fog.
    let aperture = resolve("aperture", "quick", None, 1).unwrap();
    let lenses: Vec<_> =
        aperture.cells.iter().map(|c| (c.config.lens, c.config.f_number)).collect();
    assert!(lenses.iter().all(|(l, _)| *l == joca_camera::LensModel::Thin));
    assert!(lenses.iter().any(|(_, f)| f.min == 1.4 && f.max == 16.0));
    assert!(lenses.iter().any(|(_, f)| f.is_calibration()));
    let dynamic = aperture.cells.iter().filter(|c| !c.config.aperture.is_fixed()).count();
    assert_eq!((aperture.cells.len(), dynamic), (6, 2));
    let fog = resolve("fog", "quick", None, 1).unwrap();
    let foggy = fog.cells.iter().filter(|c| c.config.weather.to_string() == "fog:300").count();
    assert_eq!((fog.cells.len(), foggy), (4, 2));
}

#[test]
fn seeds_repeat_every_cell_with_consecutive_seeds() {
    let one = resolve("ablation", "quick", None, 1).unwrap();
    let three = resolve("ablation", "quick", None, 3).unwrap();
    assert_eq!(three.cells.len(), 3 * one.cells.len());
    assert_eq!(three.manifest.seeds, 3);
    let base = one.cells[0].config.seed;
    for (k, cell) in three.cells[..3].iter().enumerate() {
        assert_eq!(cell.spec.id, format!("{}-s{k}", one.cells[0].spec.id));
        assert_eq!(cell.config.seed, base + k as u64);
        assert_eq!(cell.spec.seed, base + k as u64);
        // Only the seed differs from the one-seed cell.
        let c = RunConfig { seed: base, ..cell.config.clone() };
        assert_eq!(c, one.cells[0].config);
    }
    for bad in [0, MAX_SEEDS + 1] {
        let e = resolve("ablation", "quick", None, bad).unwrap_err().to_string();
        assert!(e.contains("--seeds") && e.contains("1 to 100"), "{e}");
    }
}

const PANEL: &str = r#"
title = "panel"
label_header = "Controller"
scenarios = ["calibrated"]

[panel]
designs = [
  { id = "flir", camera = "flir" },
  { id = "wide", sensor = "IMX546", focal_length_mm = 4.0, x_m = 0.5, z_m = 1.6 },
]
FROM

[[variant]]
id = "neural"
label = "NeuralAE (DF-Grad)"
run = { method = "joca" }

[[variant]]
id = "average"
label = "AverageAE"
run = { method = "tacos-average" }
"#;

/// Resolves `PANEL` with `from` in place of `FROM`, in a temporary folder holding a finished
/// run `done/` (its best design an IMX172 at 6 mm) and an unfinished one `busy/`.
fn panel(from: &str, edit: impl Fn(String) -> String) -> Result<Experiment> {
    let dir = tempfile::tempdir()?;
    let done = dir.path().join("done");
    std::fs::create_dir_all(&done)?;
    std::fs::create_dir_all(dir.path().join("busy"))?;
    std::fs::write(
        done.join("best_design.json"),
        r#"{"x_m": 1.0, "z_m": 1.5, "focal_length_mm": 6.0, "sensor": "IMX172",
            "sensor_mm": [6.17, 4.55], "pixel_pitch_um": 1.55, "optimised": true}"#,
    )?;
    let from = from.replace("DIR", &dir.path().display().to_string());
    let file = dir.path().join("panel.toml");
    std::fs::write(&file, edit(PANEL.replace("FROM", &from)))?;
    resolve(&file.display().to_string(), "quick", None, 2)
}

#[test]
fn a_panel_runs_every_variant_on_every_design_with_the_hardware_fixed() {
    let exp = panel(r#"from_runs = ["DIR/done", "DIR/done"]"#, |s| s).unwrap();
    // 2 variants × 3 designs (the run's design once) × 2 seeds.
    assert_eq!(exp.cells.len(), 12);
    let ids: Vec<&str> = exp.cells.iter().map(|c| c.spec.id.as_str()).collect();
    assert_eq!(
        ids[..6],
        [
            "neural-calibrated-flir-s0",
            "neural-calibrated-flir-s1",
            "neural-calibrated-wide-s0",
            "neural-calibrated-wide-s1",
            "neural-calibrated-done-s0",
            "neural-calibrated-done-s1",
        ]
    );
    let done = &exp.cells[4];
    assert_eq!(done.spec.design, "done");
    let spec = done.config.design.clone().unwrap();
    assert_eq!((spec.sensor.as_str(), spec.focal_length_mm, spec.x_m), ("IMX172", 6.0, 1.0));
    assert!(!done.config.hardware_search() && done.config.method == Method::Joca);
    let flir = exp.cells[0].config.fixed_design().unwrap();
    assert_eq!(flir, joca_train::FixedCamera::Flir.design());
    // The same design and seed for both variants: what the report pairs.
    assert_eq!(exp.cells[4].config.design, exp.cells[10].config.design);
    assert_eq!(exp.cells[4].config.seed, exp.cells[10].config.seed);
}

#[test]
fn a_bad_panel_names_the_entry_the_field_and_the_file() {
    let err = |from: &str, edit: &dyn Fn(String) -> String| {
        format!("{:#}", panel(from, edit).unwrap_err())
    };
    let same = |s: String| s;
    let e = err("", &|s| s.replace("\"IMX546\"", "\"IMX999\""));
    assert!(e.contains("panel.toml: [panel] design \"wide\"") && e.contains("IMX999"), "{e}");
    assert!(e.contains("IMX546"), "lists the valid sensors: {e}");
    let e = err("", &|s| s.replace("focal_length_mm = 4.0", "focal_length_mm = 50.0"));
    assert!(
        e.contains("design \"wide\"") && e.contains("focal_length_mm") && e.contains("10"),
        "{e}"
    );
    let e = err("", &|s| s.replace("x_m = 0.5,", ""));
    assert!(e.contains("design \"wide\"") && e.contains("x_m"), "{e}");
    let e = err(r#"from_runs = ["DIR/busy"]"#, &same);
    assert!(e.contains("from_runs") && e.contains("busy") && e.contains("best_design.json"), "{e}");
    let e = err(r#"from_runs = ["DIR/nowhere"]"#, &same);
    assert!(e.contains("nowhere") && e.contains("best_design.json"), "{e}");
    let e = err("", &|s| {
        let start = s.find("designs = [").unwrap();
        let end = s[start..].find("]\n").unwrap() + start + 2;
        format!("{}designs = []\n{}", &s[..start], &s[end..])
    });
    assert!(e.contains("panel.toml: [panel] holds no design"), "{e}");
    let e = err("", &|s| {
        s.replace("{ method = \"joca\" }", "{ method = \"joca\", design = { sensor = \"IMX172\", focal_length_mm = 3.6, x_m = 0.43, z_m = 1.65 } }")
    });
    assert!(e.contains("variant \"neural\" sets `design`"), "{e}");
    let e = err("", &|s| s.replace("id = \"wide\"", "id = \"flir\""));
    assert!(e.contains("id \"flir\" names two different designs"), "{e}");
    // One design under two ids, a scenario twice, two cells composed to one id, and an
    // f-number the pinhole cannot have: each refused naming what to change.
    let e = err("", &|s| {
        s.replace(
            "  { id = \"wide\"",
            "  { id = \"flir2\", camera = \"flir\" },\n  { id = \"wide\"",
        )
    });
    assert!(e.contains("design \"flir2\": the same design as \"flir\""), "{e}");
    let e =
        err("", &|s| s.replace("[\"calibrated\"]", "[\"calibrated\", \"blur4\", \"calibrated\"]"));
    assert!(e.contains("scenarios: \"calibrated\" is listed twice"), "{e}");
    let e = err("", &|s| {
        s.replace("[\"calibrated\"]", "[\"calibrated\", \"blur4\"]")
            .replace("id = \"wide\"", "id = \"blur4-flir\"")
            .replace("id = \"average\"", "id = \"neural-calibrated\"")
    });
    assert!(
        e.contains("two cells would be named \"neural-calibrated-blur4-flir-s0\"")
            && e.contains("the variant labelled \"AverageAE\" (tacos-average), scenario blur4")
            && e.contains("rename a variant or a panel design"),
        "{e}"
    );
    let e = err("", &|s| s.replace("z_m = 1.6 }", "z_m = 1.6, f_number = 2.8 }"));
    assert!(
        e.contains("panel design \"wide\"")
            && e.contains("design.f_number")
            && e.contains("lens = \"thin\""),
        "{e}"
    );
}

/// A prepared cell is checked against the grid in the fields its method reads: an AverageAE cell
/// made when the presets scored the perturbation search by AP50 is still the grid's (AverageAE
/// searches no perturbations), a NeuralAE cell made so is refused, naming the field.
#[test]
fn a_prepared_cell_must_match_the_grid_in_what_its_method_reads() {
    let exp = resolve("controllers", "quick", None, 1).unwrap();
    let dir = tempfile::tempdir().unwrap();
    prepare(&exp, dir.path()).unwrap();
    let as_ap50 = |id: &str| {
        let path = dir.path().join("cells").join(id).join("cell.toml");
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.contains("perturbation_score = \"loss\""), "{id}: {text}");
        std::fs::write(&path, text.replace("\"loss\"", "\"ap50\"")).unwrap();
    };
    as_ap50("average-calibrated-flir");
    prepare(&exp, dir.path()).unwrap();
    as_ap50("neural-calibrated-flir");
    let e = format!("{:#}", prepare(&exp, dir.path()).unwrap_err());
    assert!(e.contains("neural-calibrated-flir") && e.contains("perturbation_score"), "{e}");
}

#[test]
fn cells_named_first_run_first_in_the_order_named_and_the_rest_keep_theirs() {
    let exp = resolve("table1", "quick", None, 2).unwrap();
    let ids = |cells: &[&Cell]| cells.iter().map(|c| c.spec.id.clone()).collect::<Vec<_>>();
    let mut by_seed: Vec<&Cell> = exp.cells.iter().collect();
    order_cells(&mut by_seed, &exp, "seed", &[]);
    let first = vec![by_seed[7].spec.id.clone(), by_seed[2].spec.id.clone()];
    let mut todo: Vec<&Cell> = exp.cells.iter().collect();
    order_cells(&mut todo, &exp, "seed", &first);
    let all = ids(&todo);
    let (named, rest) = all.split_at(2);
    assert_eq!(named, first.as_slice());
    let expect: Vec<String> = ids(&by_seed).into_iter().filter(|i| !first.contains(i)).collect();
    assert_eq!(rest, expect.as_slice());
    // Seed order: every seed-0 cell before any seed-1 cell.
    assert!(by_seed.windows(2).all(|w| w[0].spec.seed <= w[1].spec.seed));
    // An id the grid lacks is refused, naming it and the cells there are.
    let e = format!("{:#}", check_first(&exp, &["flir-fog".to_owned()]).unwrap_err());
    assert!(
        e.contains("--first: unknown cell \"flir-fog\"") && e.contains("flir-calibrated-s0"),
        "{e}"
    );
    assert!(check_first(&exp, &first).is_ok());
}

/// Every experiment file in the repository's experiments/ folder (built in or not) resolves with
/// every preset, so a committed grid cannot fail only when a user starts it.
#[test]
fn every_experiment_file_in_the_repository_resolves() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../experiments");
    let files = crate::io::files_with_extension(&dir, "toml").unwrap();
    for path in &files {
        for (preset, _) in config::PRESETS {
            let result = resolve(path.to_str().unwrap(), preset, None, 1);
            if path.file_stem().is_some_and(|s| s == "real") {
                assert!(result.unwrap_err().to_string().contains("runs on recorded frames"));
                continue;
            }
            let exp = result.unwrap_or_else(|e| panic!("{} / {preset}: {e:#}", path.display()));
            assert!(!exp.cells.is_empty(), "{}", path.display());
        }
    }
    assert!(files.len() > EXPERIMENTS.len(), "only {} files in {}", files.len(), dir.display());
}
