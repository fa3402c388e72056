//! `joca experiment`: a grid file's bad entries named, and a grid run, skipped when finished and
//! resumed when killed.
#![allow(clippy::unwrap_used)] // a failed unwrap is a failed test

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;
use common::{TINY_RUN, cli, joca, stderr, stdout};

/// A grid small enough for a test: 2 variants × 2 scenarios of a 1-generation run.
const TINY_EXPERIMENT: &str = r#"
title = "tiny"
label_header = "Method"
scenarios = ["calibrated", "blur4"]

[follow_up]
towns = [2]
starting_detector = true

[[variant]]
id = "tacos"
label = "TaCOS + AverageAE"
run = { method = "tacos-average" }

[[variant]]
id = "joca"
label = "Ours"
run = { method = "joca" }
"#;

#[test]
fn experiment_files_with_unknown_methods_or_scenarios_name_them_and_the_valid_ones() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("mine.toml");
    std::fs::write(&file, TINY_EXPERIMENT.replace("tacos-average", "tacos-magic")).unwrap();
    let o = cli!("experiment", file, "--out /tmp/joca-never");
    let e = stderr(&o);
    assert!(
        e.contains("mine.toml")
            && e.contains("variant \"tacos\"")
            && e.contains("unknown method \"tacos-magic\"")
            && e.contains("tacos-average, fixed-neural"),
        "{e}"
    );
    std::fs::write(&file, TINY_EXPERIMENT.replace("\"blur4\"", "\"fog\"")).unwrap();
    let o = cli!("experiment", file, "--out /tmp/joca-never");
    let e = stderr(&o);
    assert!(
        e.contains("mine.toml: scenarios: unknown scenario \"fog\"") && e.contains("noise10"),
        "{e}"
    );
    for (towns, says) in [("[1]", "1 is the validation town"), ("[0]", "0 is the test town")] {
        std::fs::write(&file, TINY_EXPERIMENT.replace("towns = [2]", &format!("towns = {towns}")))
            .unwrap();
        let e = stderr(&cli!("experiment", file, "--out /tmp/joca-never"));
        assert!(e.contains("mine.toml: [follow_up] towns") && e.contains(says), "{e}");
    }
    let o = cli!("experiment table9 --out /tmp/joca-never");
    let e = stderr(&o);
    assert!(
        e.contains("unknown experiment \"table9\"") && e.contains("table1, ablation, sweep-weight"),
        "{e}"
    );
    // Slurm that is not there is said plainly (PATH without sbatch).
    let cfg = dir.path().join("tiny.toml");
    std::fs::write(&cfg, TINY_RUN).unwrap();
    std::fs::write(&file, TINY_EXPERIMENT).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_joca"))
        .args(["experiment", file.to_str().unwrap(), "--config", cfg.to_str().unwrap(), "--slurm"])
        .arg("--out")
        .arg(dir.path().join("exp"))
        .env("PATH", "/nonexistent")
        .output()
        .unwrap();
    assert!(
        stderr(&o).contains("Slurm is not reachable: `sbatch` is not on PATH"),
        "{}",
        stderr(&o)
    );
    // A cell to run first that the grid lacks: refused before anything is written.
    let out = dir.path().join("never");
    let o = cli!("experiment", file, "--first joca-fog --out", out);
    let e = stderr(&o);
    assert!(e.contains("--first: unknown cell \"joca-fog\"") && e.contains("joca-blur4"), "{e}");
    assert!(!out.exists());
}

/// The follow-up tests of the tiny grid's cells, and the report's tables of them.
fn follow_ups_are_tested_and_reported(exp: &Path, md: &str) {
    // Every NeuralAE cell is paired with its own AverageAE re-test (one unit per cell here).
    let map = |file: &str| -> f64 {
        let text = std::fs::read_to_string(exp.join("cells/joca-calibrated").join(file)).unwrap();
        serde_json::from_str::<serde_json::Value>(&text).unwrap()["test"]["map"].as_f64().unwrap()
    };
    let d = map("results.json") - map("results-average-127.5.json");
    let row = format!("| {} of 1 | {d:.3} |", usize::from(d > 0.0));
    assert!(md.contains("## The learned controller against AverageAE on its own detector"), "{md}");
    let line = |town: &str| md.lines().find(|l| l.contains(&format!("| Ours | {town} | 1 |")));
    assert!(line("test town").is_some_and(|l| l.contains(&row)), "{row}\n{md}");
    assert!(md.contains("| AverageAE mid-grey |"), "{md}");
    // The follow-up test on town 2: every cell tested there, a NeuralAE cell with AverageAE too.
    assert!(line("town 2").is_some(), "{md}");
    for f in ["tacos-blur4/results-town2.json", "joca-blur4/results-average-127.5-town2.json"] {
        assert!(exp.join("cells").join(f).is_file(), "{f}");
    }
    assert!(!exp.join("cells/tacos-blur4/results-average-127.5-town2.json").exists());
    // The starting detector swapped back in, on both towns; the report's difference is the
    // cell's own test minus that re-test (one seed: no interval; no frozen-detector variant).
    let d = map("results.json") - map("results-detector-start.json");
    let row = format!("| Calibrated | Ours | test | 1 seed | {d:.3} | – |");
    assert!(
        md.contains("## What training the detector changed") && md.contains(&row),
        "{row}\n{md}"
    );
    assert!(exp.join("cells/tacos-blur4/results-detector-start-town2.json").is_file());
}

/// The tiny grid and its run configuration written into `dir`, and the `joca experiment`
/// arguments that run it into `dir/exp`: (experiment folder, run configuration, arguments).
fn tiny_grid(dir: &Path) -> (PathBuf, PathBuf, Vec<String>) {
    let (file, cfg, exp) = (dir.join("tiny.toml"), dir.join("run.toml"), dir.join("exp"));
    std::fs::write(&file, TINY_EXPERIMENT).unwrap();
    std::fs::write(&cfg, TINY_RUN).unwrap();
    let path = |p: &Path| p.to_str().unwrap().to_owned();
    let args = vec![
        "experiment".to_owned(),
        path(&file),
        "--config".to_owned(),
        path(&cfg),
        "--out".to_owned(),
        path(&exp),
    ];
    (exp, cfg, args)
}

#[test]
fn an_experiment_runs_its_grid_skips_finished_cells_and_resumes_a_killed_one() {
    let dir = tempfile::tempdir().unwrap();
    let (exp, cfg, args) = tiny_grid(dir.path());
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = joca(&[&args[..], &["--jobs", "2"]].concat());
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    let csv = std::fs::read_to_string(exp.join("results.csv")).unwrap();
    assert_eq!(csv.lines().count(), 5, "{csv}");
    let md = std::fs::read_to_string(exp.join("report.md")).unwrap();
    assert!(
        md.contains("4 of 4 cells finished")
            && md.contains("| Motion blur×4 | TaCOS + AverageAE |"),
        "{md}"
    );
    for f in [
        "calibrated-settings.png",
        "calibrated-frames.png",
        "calibrated-fov.png",
        "motion-blur-4-tunnel.gif",
    ] {
        assert!(exp.join("figures").join(f).is_file(), "{f}");
    }
    let html = std::fs::read_to_string(exp.join("report.html")).unwrap();
    assert!(html.matches("src=\"").count() == html.matches("src=\"data:image/").count());
    follow_ups_are_tested_and_reported(&exp, &md);

    // A killed cell: results gone, checkpoint kept -> "partial", and the next invocation
    // resumes it (its checkpoint is newer than the first three cells' results) and reports all.
    let cell = exp.join("cells/joca-blur4");
    std::fs::remove_file(cell.join("results.json")).unwrap();
    // While a process holds the cell's lock, `--status` says it is running and by whom.
    let lock = std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(false)
        .open(cell.join(".joca-lock"))
        .unwrap();
    lock.lock().unwrap();
    let status = stdout(&joca(&[&args[..], &["--status"]].concat()));
    assert!(status.contains("running  joca-blur4") && status.contains("1 running"), "{status}");
    drop(lock);
    let status = joca(&[&args[..], &["--status"]].concat());
    assert!(stdout(&status).contains("partial  joca-blur4"), "{}", stdout(&status));
    let counts = "3 done, 0 running, 1 partial, 0 missing of 4";
    assert!(stdout(&status).contains(counts), "{}", stdout(&status));
    let before = std::fs::read_to_string(exp.join("cells/joca-calibrated/results.json")).unwrap();
    let o = joca(&args);
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    assert!(stdout(&o).contains("4 cells, 1 to run"), "{}", stdout(&o));
    assert!(cell.join("results.json").is_file());
    assert_eq!(
        std::fs::read_to_string(exp.join("cells/joca-calibrated/results.json")).unwrap(),
        before
    );
    assert_eq!(std::fs::read_to_string(exp.join("results.csv")).unwrap(), csv);

    // A cell restored from its compact results (docs/results/ keeps results.json and the
    // configuration only), first of its group: the report still has every figure, its row
    // of the frames figure empty.
    let compact = exp.join("cells/tacos-calibrated");
    for entry in std::fs::read_dir(&compact).unwrap() {
        let path = entry.unwrap().path();
        let keep = ["results.json", "config.toml", "cell.toml", "best_design.json"];
        if !keep.iter().any(|k| path.ends_with(k)) {
            if path.is_dir() {
                std::fs::remove_dir_all(&path).unwrap();
            } else {
                std::fs::remove_file(&path).unwrap();
            }
        }
    }
    std::fs::remove_dir_all(exp.join("figures")).unwrap();
    let o = joca(&["report", exp.to_str().unwrap()]);
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    assert!(exp.join("figures/calibrated-frames.png").is_file());

    // Every cell names the commit that computed it; a cell of another commit makes the table
    // refuse, naming both commits and their cells, unless told to mix them.
    let md = std::fs::read_to_string(exp.join("report.md")).unwrap();
    assert!(md.contains("joca commit "), "{md}");
    let path = exp.join("cells/joca-blur4/results.json");
    let mut r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(r["provenance"]["config_sha256"].as_str().unwrap().len(), 64);
    r["provenance"]["commit"] = "0123456789abcdef0123456789abcdef01234567".into();
    r["provenance"]["dirty"] = false.into();
    std::fs::write(&path, serde_json::to_string_pretty(&r).unwrap()).unwrap();
    let o = joca(&["report", exp.to_str().unwrap()]);
    let e = stderr(&o);
    assert!(
        !o.status.success()
            && e.contains("different joca commits")
            && e.contains("0123456789: joca-blur4"),
        "{e}"
    );
    let o = joca(&["report", exp.to_str().unwrap(), "--mixed-commits"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let md = std::fs::read_to_string(exp.join("report.md")).unwrap();
    assert!(md.contains("Cells of different joca commits, reported together"), "{md}");

    // The same directory with another configuration is refused, naming the field.
    std::fs::write(&cfg, TINY_RUN.replace("steps_per_candidate = 3", "steps_per_candidate = 4"))
        .unwrap();
    let o = joca(&args);
    assert!(
        stderr(&o).contains("another configuration") && stderr(&o).contains("steps_per_candidate"),
        "{}",
        stderr(&o)
    );
    // `--status` names the stale cells and the fields, and runs nothing.
    let status = stdout(&joca(&[&args[..], &["--status"]].concat()));
    assert!(
        status.contains("stale    joca-blur4") && status.contains("(4 stale: made with another"),
        "{status}"
    );
}

/// A prepared cell replaced by a link to a user's folder is refused, by `joca experiment` and by
/// `joca cell`, and the user's folder is left as it was.
#[test]
fn a_cell_that_is_a_symbolic_link_is_refused_and_its_target_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let (exp, _, args) = tiny_grid(dir.path());
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = joca(&[&args[..], &["--prepare"]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let mine = dir.path().join("mine");
    std::fs::create_dir(&mine).unwrap();
    std::fs::write(mine.join("report.md"), "my notes").unwrap();
    let cell = exp.join("cells/joca-blur4");
    std::fs::remove_dir_all(&cell).unwrap();
    std::os::unix::fs::symlink(&mine, &cell).unwrap();
    for o in [joca(&[&args[..], &["--prepare"]].concat()), joca(&["cell", cell.to_str().unwrap()])]
    {
        let e = stderr(&o);
        assert!(
            !o.status.success() && e.contains("is a symbolic link") && e.contains("joca-blur4"),
            "{e}"
        );
    }
    let left: Vec<_> = std::fs::read_dir(&mine).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(left, ["report.md"]);
    assert_eq!(std::fs::read_to_string(mine.join("report.md")).unwrap(), "my notes");
}

/// `joca report DIR --with OTHER`: OTHER's finished cells join DIR's report read from their own
/// directory, labelled ` (OTHER's name)`, with the numbers they have in OTHER's own report; a
/// `--with` that is not an experiment directory, or a run directory's report with `--with`, is
/// refused naming it.
fn another_experiments_cells_join_a_report(dir: &Path, other: &Path) {
    let path = |p: &Path| p.to_str().unwrap().to_owned();
    let o = joca(&["report", &path(dir), "--with", &path(other), "--no-figures"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert!(md.contains("8 of 8 cells finished") && md.contains("labelled `(exp)`"), "{md}");
    let csv = std::fs::read_to_string(dir.join("results.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv.lines().skip(1).map(|l| l.split(',').collect()).collect();
    let theirs: Vec<&Vec<&str>> = rows.iter().filter(|r| r[1].ends_with(" (exp)")).collect();
    assert_eq!((rows.len(), theirs.len()), (8, 4), "{csv}");
    for t in theirs {
        let label = t[1].trim_end_matches(" (exp)");
        let mine = rows.iter().find(|r| r[0] == t[0] && r[1] == label).unwrap();
        assert_eq!(mine[14..], t[14..], "{label}: the same cells, the same numbers");
    }
    let run = other.join("cells/joca-calibrated");
    let e = stderr(&joca(&["report", &path(dir), "--with", &path(&run)]));
    assert!(e.contains("--with") && e.contains("not an experiment directory"), "{e}");
    let e = stderr(&joca(&["report", &path(&run), "--with", &path(other)]));
    assert!(e.contains("apply to an experiment directory"), "{e}");
}

/// `joca export` keeps what the reports read (the export's report has the grid's table), and
/// `--reuse` fills another grid's cells from the export when the record names this commit and
/// the cell's configuration, names a cell computed by another commit, and leaves a cell of
/// another configuration to run.
#[test]
fn an_export_rebuilds_the_report_and_serves_another_grid_as_a_cache() {
    let dir = tempfile::tempdir().unwrap();
    let (exp, cfg, args) = tiny_grid(dir.path());
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = joca(&[&args[..], &["--jobs", "2"]].concat());
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    let csv = std::fs::read_to_string(exp.join("results.csv")).unwrap();
    // A cell killed between its results and its report is completed by the next invocation.
    std::fs::remove_file(exp.join("cells/tacos-calibrated/report.md")).unwrap();
    let o = joca(&args);
    assert!(stdout(&o).contains("wrote the missing report of tacos-calibrated"), "{}", stdout(&o));
    assert!(exp.join("cells/tacos-calibrated/report.md").is_file());

    let export = dir.path().join("export");
    let o = joca(&["export", exp.to_str().unwrap(), export.to_str().unwrap()]);
    assert!(
        o.status.success() && stdout(&o).contains("exported 4 finished run(s)"),
        "{}",
        stderr(&o)
    );
    let cell = export.join("cells/joca-blur4");
    assert!(
        cell.join("results-average-127.5-town2.json").is_file() && cell.join("cell.toml").is_file()
    );
    assert!(!cell.join("checkpoint").exists() && !cell.join("cell.log").exists());
    let show = std::fs::read_to_string(cell.join("test/showcase.json")).unwrap();
    assert!(show.contains("\"exposure_ms\"") && show.contains("\"boxes\":[]"), "{show}");
    // Rows from a follow-up town's records; a results file the cells lack is refused, named.
    let o = joca(&["report", export.to_str().unwrap(), "--results", "town2", "--no-figures"]);
    let md = std::fs::read_to_string(export.join("report.md")).unwrap();
    assert!(o.status.success() && md.contains("`results-town2.json`"), "{}", stderr(&o));
    let e = stderr(&joca(&["report", export.to_str().unwrap(), "--results", "town3"]));
    assert!(
        e.contains("has no results-town3.json (--results town3)") && e.contains("cell "),
        "{e}"
    );
    // Tables only, as records are committed: no figures, the same numbers.
    let o = joca(&["report", export.to_str().unwrap(), "--no-figures"]);
    assert!(o.status.success() && stdout(&o).contains("(no figures)"), "{}", stderr(&o));
    assert!(!export.join("figures").exists() && export.join("report.html").is_file());
    assert!(!std::fs::read_to_string(export.join("report.md")).unwrap().contains(".png"));
    assert_eq!(std::fs::read_to_string(export.join("results.csv")).unwrap(), csv);
    let o = joca(&["report", export.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(export.join("results.csv")).unwrap(), csv);
    another_experiments_cells_join_a_report(&export, &exp);
    // Exporting again replaces the export whole, but not over a file the export did not write;
    // into the grid itself, or into a run, refused.
    std::fs::write(export.join("notes.txt"), "mine").unwrap();
    let e = stderr(&joca(&["export", exp.to_str().unwrap(), export.to_str().unwrap()]));
    assert!(e.contains("files joca did not write (notes.txt)"), "{e}");
    assert_eq!(std::fs::read_to_string(export.join("notes.txt")).unwrap(), "mine");
    std::fs::remove_file(export.join("notes.txt")).unwrap();
    assert!(joca(&["export", exp.to_str().unwrap(), export.to_str().unwrap()]).status.success());
    let inside = exp.join("cells/x");
    let e = stderr(&joca(&["export", exp.to_str().unwrap(), inside.to_str().unwrap()]));
    assert!(e.contains("is inside"), "{e}");
    let run = exp.join("cells/joca-calibrated");
    let e = stderr(&joca(&[
        "export",
        run.to_str().unwrap(),
        exp.join("cells/tacos-blur4").to_str().unwrap(),
    ]));
    assert!(e.contains("not an export") && e.contains("tacos-blur4"), "{e}");

    // Another grid with the same cells takes all four from the export and runs none.
    let again = dir.path().join("again");
    let mut other = args.clone();
    let out = other.iter().position(|a| *a == "--out").unwrap() + 1;
    other[out] = again.to_str().unwrap();
    let o = joca(&[&other[..], &["--reuse", export.to_str().unwrap()]].concat());
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    assert!(
        stdout(&o).contains("4 cell(s) reused") && stdout(&o).contains("4 cells, 0 to run"),
        "{}",
        stdout(&o)
    );
    assert_eq!(std::fs::read_to_string(again.join("results.csv")).unwrap(), csv);
    let reused = std::fs::read_to_string(again.join("cells/tacos-blur4/reused.json")).unwrap();
    assert!(reused.contains("export/cells/tacos-blur4"), "{reused}");
    let status = stdout(&joca(&[&other[..], &["--status"]].concat()));
    assert!(status.contains("(reused: reused.json)"), "{status}");

    // A record of another commit is named and not taken.
    let path = export.join("cells/joca-calibrated/results.json");
    let mut r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    r["provenance"]["commit"] = "0123456789abcdef0123456789abcdef01234567".into();
    std::fs::write(&path, serde_json::to_string_pretty(&r).unwrap()).unwrap();
    let third = dir.path().join("third");
    other[out] = third.to_str().unwrap();
    let o = joca(&[&other[..], &["--reuse", export.to_str().unwrap(), "--prepare"]].concat());
    let s = stdout(&o);
    assert!(
        s.contains("3 cell(s) reused")
            && s.contains("not reused for joca-calibrated")
            && s.contains("computed by commit 0123456789"),
        "{s}"
    );
    // Another configuration finds nothing to take.
    std::fs::write(&cfg, TINY_RUN.replace("steps_per_candidate = 3", "steps_per_candidate = 4"))
        .unwrap();
    let fourth = dir.path().join("fourth");
    other[out] = fourth.to_str().unwrap();
    let o = joca(&[&other[..], &["--reuse", exp.to_str().unwrap(), "--prepare"]].concat());
    assert!(stdout(&o).contains("0 cell(s) reused"), "{}", stdout(&o));
}
