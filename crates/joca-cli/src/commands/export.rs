//! `joca export`: the compact records of a run or an experiment — what its reports are built
//! from, without checkpoints, frames, figures or logs — so a grid's results can be committed or
//! shared, `joca report` rebuilds its tables from them anywhere, and `joca experiment --reuse`
//! takes their cells into another grid.
//!
//! Kept per run: its configurations (`cell.toml`, `config.toml`), every `*.json` record
//! (`results*.json`, `best_design.json`, `reused.json`), `events.jsonl` without the training
//! steps (generations, candidates and the warm start stay), and each test's `showcase.json`
//! with the settings and light of every frame but no boxes, detections or frames. The export is
//! staged beside its destination and moved into place whole (`crate::io::StagedDir`: an earlier
//! export holding files it did not write is refused, naming them).

use crate::io::StagedDir;
use anyhow::{Context, Result, bail};
use joca_core::output::{self, OutputKind};
use joca_report::Manifest;
use joca_train::Showcase;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Arguments of `joca export`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// A finished run directory or an experiment directory.
    dir: PathBuf,
    /// The folder to write: new, empty, or an earlier export of the same kind (replaced whole,
    /// unless it holds files the export did not write).
    to: PathBuf,
}

/// The file an export holds at its top: what it is and where it came from.
pub const EXPORT_FILE: &str = "export.json";

/// `export.json`.
#[derive(Debug, Serialize, Deserialize)]
struct ExportRecord {
    /// The directory exported.
    from: PathBuf,
    /// The joca commit that exported it.
    exported_by: String,
    /// Runs exported (1 for a run directory).
    runs: usize,
    /// What an export leaves out.
    left_out: String,
}

const LEFT_OUT: &str = "checkpoints, test frames and traces, figures, report.html, logs, the \
    training steps of events.jsonl, and the boxes and detections of the showcases";

/// Runs `joca export`.
pub fn run(args: &Args) -> Result<()> {
    let (from, to) = (&args.dir, &args.to);
    let kind = match output::marked_kind(from) {
        Some(k @ (OutputKind::Run | OutputKind::Experiment)) => k,
        _ => bail!(
            "{} is neither a run directory nor an experiment directory of joca's (no {} marker \
             naming one): nothing to export",
            from.display(),
            output::MARKER
        ),
    };
    check_destination(from, to, kind)?;
    let staged = StagedDir::create(to, kind)?;
    let runs = match kind {
        OutputKind::Experiment => export_experiment(from, staged.path())?,
        _ => export_run(from, staged.path()).map(|()| 1)?,
    };
    let record = ExportRecord {
        from: from.canonicalize().unwrap_or_else(|_| from.clone()),
        exported_by: joca_record::Provenance::of_this_build(&()).commit_label(),
        runs,
        left_out: LEFT_OUT.to_owned(),
    };
    let text = serde_json::to_string_pretty(&record)?;
    joca_train::write_atomic(&staged.path().join(EXPORT_FILE), &text)?;
    staged.finish()?;
    println!(
        "exported {runs} finished run(s) of {} to {} ({} left out); `joca report {}` rebuilds its \
         tables",
        from.display(),
        to.display(),
        LEFT_OUT,
        to.display()
    );
    Ok(())
}

/// Refuses a destination inside the source, or one that holds anything but an earlier export
/// of the same kind.
fn check_destination(from: &Path, to: &Path, kind: OutputKind) -> Result<()> {
    let real_from =
        from.canonicalize().with_context(|| format!("cannot read {}", from.display()))?;
    let parent = to.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    if let Ok(real_parent) = parent.canonicalize()
        && real_parent.join(to.file_name().unwrap_or_default()).starts_with(&real_from)
    {
        bail!(
            "{} is inside {}: export to a folder outside the directory exported",
            to.display(),
            from.display()
        );
    }
    match output::check(to, kind)? {
        None => Ok(()),
        Some(_) if to.join(EXPORT_FILE).is_file() => Ok(()),
        Some(_) => bail!(
            "{} holds a joca {} output that is not an export (no {EXPORT_FILE}): an export would \
             replace its checkpoints and records; choose a new folder",
            to.display(),
            kind.name()
        ),
    }
}

/// Exports an experiment's manifest, tables and finished cells; returns the cells exported.
fn export_experiment(from: &Path, to: &Path) -> Result<usize> {
    output::mark(to, OutputKind::Experiment)?;
    let manifest = Manifest::load(from)
        .with_context(|| format!("cannot read the manifest of {}", from.display()))?;
    for name in [Manifest::FILE, "report.md", "results.csv"] {
        if from.join(name).is_file() {
            std::fs::copy(from.join(name), to.join(name))
                .with_context(|| format!("cannot copy {}", from.join(name).display()))?;
        }
    }
    let mut runs = 0;
    for cell in &manifest.cells {
        let dir = Manifest::cell_dir(from, cell);
        if dir.join("results.json").is_file() {
            export_run(&dir, &Manifest::cell_dir(to, cell))?;
            runs += 1;
        }
    }
    Ok(runs)
}

/// Exports one finished run's compact records (see the module doc).
fn export_run(from: &Path, to: &Path) -> Result<()> {
    if !from.join("results.json").is_file() {
        bail!("{} has not finished its test (no results.json): nothing to export", from.display());
    }
    output::mark(to, OutputKind::Run)?;
    let entries =
        std::fs::read_dir(from).with_context(|| format!("cannot list {}", from.display()))?;
    let mut paths: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    paths.sort();
    for path in paths {
        let name = path.file_name().unwrap_or_default().to_string_lossy().into_owned();
        let dst = to.join(&name);
        if path.is_dir() && name.starts_with("test") {
            let show = path.join("showcase.json");
            if show.is_file() {
                std::fs::create_dir_all(&dst)?;
                compact_showcase(&show, &dst.join("showcase.json"))?;
            }
        } else if path.is_file() && name == "events.jsonl" {
            let text = std::fs::read_to_string(&path)
                .with_context(|| format!("cannot read {}", path.display()))?;
            let kept: String =
                text.lines().filter(|l| !is_step_line(l)).flat_map(|l| [l, "\n"]).collect();
            joca_train::write_atomic(&dst, &kept)?;
        } else if path.is_file() && (name.ends_with(".json") || name.ends_with(".toml")) {
            std::fs::copy(&path, &dst)
                .with_context(|| format!("cannot copy {}", path.display()))?;
        }
    }
    Ok(())
}

/// Whether an `events.jsonl` line is a training step's record (the bulk of the file).
fn is_step_line(line: &str) -> bool {
    serde_json::from_str::<serde_json::Value>(line)
        .ok()
        .and_then(|v| v.as_object().map(|o| o.contains_key("step")))
        .unwrap_or(false)
}

/// Writes `from`'s showcases with every frame's settings and light but no boxes, detections or
/// frame files.
fn compact_showcase(from: &Path, to: &Path) -> Result<()> {
    let text =
        std::fs::read_to_string(from).with_context(|| format!("cannot read {}", from.display()))?;
    let mut shows: Vec<Showcase> =
        serde_json::from_str(&text).with_context(|| format!("invalid {}", from.display()))?;
    for frame in shows.iter_mut().flat_map(|s| s.frames.iter_mut()) {
        frame.boxes.clear();
        frame.detections.clear();
        frame.image = None;
    }
    joca_train::write_atomic(to, &serde_json::to_string(&shows)?)?;
    Ok(())
}
