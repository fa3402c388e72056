//! `joca headroom`: a fixed design with the shipped detector measured on a few test frames —
//! every policy scored on the same frames, the hindsight rows at least what they choose from —
//! the paired table over records, and bad ladders refused naming the field, range and file.
#![allow(clippy::unwrap_used)] // a failed unwrap is a failed test

mod common;
use common::{cli, stderr};

const DESIGN: &str = "--design IMX287:10:2.14:1.7 --preset quick";

#[test]
fn a_design_is_measured_and_tabulated() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("ladder.toml");
    // A short ladder keeps the test in seconds: 4 rungs, 2 stops apart, two targets.
    std::fs::write(&cfg, "[ladder]\nsteps = 4\nstep_stops = 2.0\ntop_exposure_gain_ms = 400.0\ntargets_dn = [60.0]\nslopes = true\n").unwrap();
    let out = dir.path().join("h");
    let o = cli!("headroom", DESIGN, "--episodes 4 --frames 2 --config", cfg, "--out", out);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(out.join("headroom.json")).unwrap();
    let r: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(r["frames"], 8);
    assert_eq!(r["ladder"].as_array().unwrap().len(), 4);
    let map = |name: &str| {
        let p = r["policies"].as_array().unwrap().iter().find(|p| p["policy"] == name).unwrap();
        (p["scores"]["map"].as_f64().unwrap(), p["hindsight"].as_bool().unwrap())
    };
    let rungs: Vec<f64> = (0..4).map(|i| map(&format!("rung-{i}")).0).collect();
    let best_rung = rungs.iter().copied().fold(f64::MIN, f64::max);
    assert_eq!(map("best-constant"), (best_rung, true));
    let targets = [map("average-127.5").0, map("average-60").0];
    assert_eq!(map("best-target").0, targets[0].max(targets[1]));
    assert!(!map("average-127.5").1 && map("oracle").1);
    // Chosen light by light among the same frames, the oracle starts from the best constant
    // of each light and never goes below it.
    assert!(map("oracle").0 >= map("constant-by-light").0 - 1e-12);
    // The mAP-scored search's choices over the rungs, the frame alone and pooled: hindsight rows.
    assert!(map("map-search").1 && map("map-search-16").1);
    // The task loss's own choices: the rungs carry their mean loss per light, and the loss's
    // choice per light holds, light by light, the least of them.
    assert!(map("loss-by-light").1 && map("loss-oracle").1);
    let policy = |name: &str| {
        r["policies"].as_array().unwrap().iter().find(|p| p["policy"] == name).unwrap().clone()
    };
    let chosen = policy("loss-by-light");
    for (light, x) in chosen["by_light"].as_object().unwrap() {
        let least = (0..4)
            .map(|i| policy(&format!("rung-{i}"))["by_light"][light]["task_loss"].as_f64().unwrap())
            .fold(f64::MAX, f64::min);
        assert_eq!(x["task_loss"].as_f64().unwrap(), least, "{light}");
    }
    // The objects' choice holds, light by light, the least loss less its background term, a
    // part of the loss (non-negative) that every rung carries beside it.
    let objects = |p: &serde_json::Value, light: &str| {
        let x = &p["by_light"][light];
        let background = x["background_loss"].as_f64().unwrap();
        assert!((0.0..=x["task_loss"].as_f64().unwrap()).contains(&background), "{x}");
        x["task_loss"].as_f64().unwrap() - background
    };
    assert!(map("objects-loss-by-light").1 && map("objects-loss-oracle").1);
    for light in policy("objects-loss-by-light")["by_light"].as_object().unwrap().keys() {
        let least =
            (0..4).map(|i| objects(&policy(&format!("rung-{i}")), light)).fold(f64::MAX, f64::min);
        assert_eq!(objects(&policy("objects-loss-by-light"), light), least, "{light}");
    }
    assert!(
        policy("average-127.5")["by_light"]
            .as_object()
            .unwrap()
            .values()
            .all(|x| x.get("task_loss").is_none())
    );
    // With `slopes`, each rung's lights carry the loss's slope and the share asking for light.
    for x in policy("rung-2")["by_light"].as_object().unwrap().values() {
        let share = x["more_light_share"].as_f64().unwrap();
        assert!(x["loss_slope"].as_f64().unwrap().is_finite() && (0.0..=1.0).contains(&share));
    }
    let md = std::fs::read_to_string(out.join("headroom.md")).unwrap();
    assert!(md.contains("## The ladder, light by light") && md.contains("| rung-3 |"), "{md}");
    assert!(r["provenance"]["commit"].as_str().unwrap().len() >= 7);
    // Two records tabulated: each difference paired.
    let o = cli!("headroom --table", out, out);
    let table = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(o.status.success() && table.contains("| oracle † |"), "{table}");
    assert!(table.contains("Frame level (DN)") && table.contains("| oracle | "), "{table}");
    assert!(table.contains("2/2") || table.contains("0/2"), "{table}");
}

#[test]
fn bad_ladders_and_subjects_are_refused_naming_field_range_and_file() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("mine.toml");
    let out = dir.path().join("never");
    for (ladder, words) in [
        ("steps = 0", vec!["ladder.steps", "1 to 64"]),
        ("step_stops = 0.0", vec!["ladder.step_stops", "above 0"]),
        ("step_stops = -1.0", vec!["ladder.step_stops", "above 0"]),
        ("top_exposure_gain_ms = 5000.0", vec!["ladder.top_exposure_gain_ms", "1581.1"]),
        ("steps = 30", vec!["ladder.steps", "under the ACC's"]),
        ("split = \"magic\"", vec!["unknown variant `magic`", "exposure-first"]),
        ("rungs = 3", vec!["unknown field `rungs`"]),
        ("targets_dn = [0.0]", vec!["ladder.targets_dn", "below 255"]),
    ] {
        std::fs::write(&cfg, format!("[ladder]\n{ladder}\n")).unwrap();
        let o = cli!("headroom", DESIGN, "--config", cfg, "--out", out);
        let e = stderr(&o);
        assert!(!o.status.success() && e.contains("mine.toml"), "{ladder}: {e}");
        for w in words {
            assert!(e.contains(w), "{ladder}: {e}");
        }
        assert!(!out.exists());
    }
    // An unknown clipping mode in [run] is refused by the run table's own reader.
    std::fs::write(&cfg, "[run]\nclip_gradient = \"soft\"\n").unwrap();
    let o = cli!("headroom", DESIGN, "--config", cfg, "--out", out);
    let e = stderr(&o);
    assert!(e.contains("mine.toml") && e.contains("unknown variant `soft`"), "{e}");
    // No design and no run directory; the validation town; a malformed design.
    let o = cli!("headroom --preset quick --out", out);
    assert!(stderr(&o).contains("run.design"), "{}", stderr(&o));
    let o = cli!("headroom", DESIGN, "--town 1 --out", out);
    assert!(stderr(&o).contains("--town = 1 is invalid"), "{}", stderr(&o));
    let o = cli!("headroom --design IMX287:ten:2:1.7 --out", out);
    assert!(stderr(&o).contains("focal length (mm) \"ten\""), "{}", stderr(&o));
    let o = cli!("headroom --table", out);
    assert!(stderr(&o).contains("cannot read"), "{}", stderr(&o));
}

#[test]
fn a_run_directory_adds_its_trained_controller() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("tiny.toml");
    std::fs::write(&cfg, common::TINY_RUN).unwrap();
    let run = dir.path().join("run");
    let o = cli!("run --config", cfg, "--out", run);
    assert!(o.status.success(), "{}", stderr(&o));
    let ladder = dir.path().join("ladder.toml");
    std::fs::write(&ladder, "[ladder]\nsteps = 2\nstep_stops = 4.0\ntargets_dn = []\n").unwrap();
    let o = cli!("headroom", run, "--episodes 4 --frames 1 --config", ladder);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = run.join("headroom-run-town0");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("headroom.json")).unwrap()).unwrap();
    let names: Vec<&str> =
        r["policies"].as_array().unwrap().iter().map(|p| p["policy"].as_str().unwrap()).collect();
    assert!(names.contains(&"trained") && names.contains(&"average-127.5"), "{names:?}");
    assert_eq!(r["detector"], "trained");
    assert!(r.get("tunnels").is_none(), "the run's own switch");
    // The same run tested with tunnels as places: the record says so (layout 5).
    let places = dir.path().join("places");
    let o = cli!(
        "headroom",
        run,
        "--episodes 4 --frames 1 --tunnels places --config",
        ladder,
        "--out",
        places
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(places.join("headroom.json")).unwrap())
            .unwrap();
    assert_eq!(
        (r["tunnels"]["kind"].as_str(), r["format_version"].as_u64()),
        (Some("places"), Some(5))
    );
    let o = cli!("headroom", run, "--tunnels roofs");
    assert!(stderr(&o).contains("switch, places"), "{}", stderr(&o));
    // A panel of trained runs: the run measured with its own detector and NeuralAE, in the
    // panel's tunnels, tabulated apart.
    let file = dir.path().join("trained.toml");
    let text = format!(
        "preset = \"quick\"\nscenarios = [\"calibrated\"]\ntowns = [0, 2]\nepisodes = 4\n\
         frames = 1\ntrained = [{run:?}]\n[run]\ntunnels = {{ kind = \"places\" }}\n[ladder]\n\
         steps = 2\nstep_stops = 4.0\ntargets_dn = []\n"
    );
    std::fs::write(&file, text).unwrap();
    let hp = dir.path().join("hp");
    // Two at a time, both of the one run (readers share its directory's lock).
    let o = cli!("headroom --jobs 2 --panel", file, "--out", hp);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(hp.join("calibrated/town2/trained-run/headroom.json").is_file());
    let record = hp.join("calibrated/town0/trained-run/headroom.json");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(record).unwrap()).unwrap();
    assert_eq!(
        (r["tunnels"]["kind"].as_str(), r["detector"].as_str()),
        (Some("places"), Some("trained"))
    );
    assert!(hp.join("calibrated-town0-trained.md").is_file());
    // With a run directory the file may hold only [ladder].
    std::fs::write(&ladder, "[run]\nseed = 3\n").unwrap();
    let o = cli!("headroom", run, "--config", ladder);
    assert!(stderr(&o).contains("only [ladder] is read"), "{}", stderr(&o));
}

/// A two-design panel in cast shadows: `tiny` with `frames` scored frames per episode.
fn tiny_panel(frames: usize, extra_run: &str) -> String {
    format!(
        "title = \"tiny\"\npreset = \"quick\"\nscenarios = [\"calibrated\"]\ntowns = [2]\n\
         episodes = 4\nframes = {frames}\n[run]\ncast_shadows = true\n{extra_run}\n[ladder]\n\
         steps = 2\nstep_stops = 4.0\ntargets_dn = []\n[panel]\ndesigns = [\n\
         {{ id = \"flir\", camera = \"flir\" }},\n\
         {{ id = \"imx287\", sensor = \"IMX287\", focal_length_mm = 10.0, x_m = 2.14, z_m = 1.7 }},\n]\n"
    )
}

#[test]
fn a_panel_is_measured_resumed_and_tabulated_in_its_own_world() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("panel.toml");
    std::fs::write(&file, tiny_panel(1, "")).unwrap();
    let out = dir.path().join("hp");
    let o = cli!("headroom --jobs 2 --panel", file, "--out", out);
    assert!(o.status.success(), "{}", stderr(&o));
    let table = std::fs::read_to_string(out.join("calibrated-town2.md")).unwrap();
    assert!(table.contains("2 records (paired; calibrated, town 2, cast shadows)"), "{table}");
    let record = out.join("calibrated/town2/imx287");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(record.join("headroom.json")).unwrap())
            .unwrap();
    assert_eq!((r["cast_shadows"].as_bool(), r["format_version"].as_u64()), (Some(true), Some(2)));
    assert_eq!((r["town"].as_u64(), r["frames"].as_u64()), (Some(2), Some(4)));
    assert!(out.join("calibrated/town2/flir.log").is_file());
    // Again: nothing left to run, the same table.
    let o = cli!("headroom --panel", file, "--out", out);
    assert!(String::from_utf8_lossy(&o.stdout).contains("0 to run"), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(out.join("calibrated-town2.md")).unwrap(), table);
    // Another panel into the same folder is refused; the records stay.
    std::fs::write(&file, tiny_panel(2, "")).unwrap();
    let o = cli!("headroom --panel", file, "--out", out);
    assert!(stderr(&o).contains("another panel"), "{}", stderr(&o));
    assert!(record.join("headroom.json").is_file());
    // A record in another world is not paired with these.
    let other = dir.path().join("default-light.json");
    let text = std::fs::read_to_string(record.join("headroom.json")).unwrap();
    std::fs::write(&other, text.replace("\"cast_shadows\": true,", "")).unwrap();
    let o = cli!("headroom --table", record, other);
    assert!(stderr(&o).contains("cast_shadows differs"), "{}", stderr(&o));
    // Dark streets: the records say so (layout 8), the table names the world, and a record of
    // lit streets is not paired with them.
    std::fs::write(&file, tiny_panel(1, "dark_streets = true")).unwrap();
    let dark = dir.path().join("dark");
    let o = cli!("headroom --jobs 2 --panel", file, "--out", dark);
    assert!(o.status.success(), "{}", stderr(&o));
    let table = std::fs::read_to_string(dark.join("calibrated-town2.md")).unwrap();
    assert!(table.contains("cast shadows, dark streets)"), "{table}");
    let dark = dark.join("calibrated/town2/imx287");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dark.join("headroom.json")).unwrap())
            .unwrap();
    assert_eq!((r["dark_streets"].as_bool(), r["format_version"].as_u64()), (Some(true), Some(8)));
    let o = cli!("headroom --table", record, dark);
    assert!(stderr(&o).contains("dark_streets differs"), "{}", stderr(&o));
}

#[test]
fn bad_panels_are_refused_naming_the_file_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("mine.toml");
    let out = dir.path().join("never");
    let good = tiny_panel(1, "");
    for (text, words) in [
        (good.replace("towns = [2]", "towns = [1]"), vec!["towns holds 1", "2 to 9999"]),
        (good.replace("towns = [2]", "towns = []"), vec!["towns = []"]),
        (good.replace("scenarios = [\"calibrated\"]", "scenarios = [\"fog\"]"), vec!["fog"]),
        (good.replace("episodes = 4", "episodes = 0"), vec!["episodes = 0"]),
        (good.replace("title", "titel"), vec!["unknown field `titel`"]),
        (tiny_panel(1, "threads = \"two\""), vec!["[run]", "threads"]),
        (tiny_panel(1, "design = 3"), vec!["[run] design is set by [panel]"]),
        (good.replace("steps = 2", "steps = 0"), vec!["ladder.steps", "1 to 64"]),
        (good.replace("camera = \"flir\"", "camera = \"nikon\""), vec!["nikon"]),
        (
            good.replace("[run]", "trained = [\"/no/run\"]\n[run]"),
            vec!["[run] cast_shadows would not reach the trained runs"],
        ),
        (
            good.replace("[run]\ncast_shadows = true", "trained = [\"/no/run\"]\n[run]"),
            vec!["trained holds /no/run, which is not a run directory"],
        ),
        (good[..good.find("[panel]").unwrap()].to_owned(), vec!["give [panel] designs, trained"]),
    ] {
        std::fs::write(&file, &text).unwrap();
        let o = cli!("headroom --panel", file, "--out", out);
        let e = stderr(&o);
        assert!(!o.status.success() && e.contains("mine.toml"), "{text}: {e}");
        for w in words {
            assert!(e.contains(w), "{text}: {e}");
        }
        assert!(!out.join("calibrated").exists(), "{text}: measured anyway");
    }
}

/// `--chosen-on`: the targets and rungs per light chosen on another town's records of the same
/// designs (the committed shipped-detector panel of 2026-12-03), scored on the tabulated town's;
/// records of another world, or without their design there, are refused naming why.
#[test]
fn choices_made_on_another_town_are_scored_out_of_sample() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/results");
    let panel = root.join("2026-12-03-headroom/calibrated");
    let designs = ["basler", "flir", "imx287-10mm"];
    let town = |t: &str| -> Vec<std::path::PathBuf> {
        designs.iter().map(|d| panel.join(t).join(d)).collect()
    };
    let (t0, t2) = (town("town0"), town("town2"));
    let o = cli!("headroom --table", t0[0], t0[1], t0[2], "--chosen-on", t2[0], t2[1], t2[2]);
    let table = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(table.contains("| oracle † |") && table.contains("over 3 records"), "{table}");
    for row in ["| target per light, chosen on town 2 |", "| constant setting per light, chosen"] {
        let line = table.lines().find(|l| l.starts_with(row)).unwrap_or_else(|| panic!("{table}"));
        assert_eq!(line.matches("/3)").count(), 4, "one cell per light: {line}");
    }
    // A design missing from the other town's records.
    let o = cli!("headroom --table", t0[0], t0[1], "--chosen-on", t2[0]);
    assert!(stderr(&o).contains("--chosen-on: no record of"), "{}", stderr(&o));
    // Another world: the shadows panel's town 2.
    let shadows = root.join("2026-12-05-headroom-shadows/calibrated/town2/basler");
    let o = cli!("headroom --table", t0[0], "--chosen-on", shadows);
    assert!(stderr(&o).contains("cast_shadows differs"), "{}", stderr(&o));
    // Only with --table.
    let o = cli!("headroom --chosen-on", t2[0]);
    assert!(!o.status.success() && stderr(&o).contains("--table"), "{}", stderr(&o));
    // A panel of two towns scores each town's choices on the other in each town's table.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("panel.toml");
    std::fs::write(&file, tiny_panel(1, "").replace("towns = [2]", "towns = [0, 2]")).unwrap();
    let out = dir.path().join("hp");
    let o = cli!("headroom --jobs 2 --panel", file, "--out", out);
    assert!(o.status.success(), "{}", stderr(&o));
    for (town, other) in [(0, 2), (2, 0)] {
        let table = std::fs::read_to_string(out.join(format!("calibrated-town{town}.md"))).unwrap();
        let row = format!("| target per light, chosen on town {other} |");
        assert!(table.contains(&row) && table.contains("over 2 records (ahead"), "{table}");
    }
}
