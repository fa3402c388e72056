//! The cell cache (`joca experiment --reuse DIR`): a cell another experiment (or an export of
//! one, `joca export`) has already finished is taken instead of being run again, when its record
//! names this binary's commit and this cell's configuration — as DVC's run cache or Snakemake's
//! "only missing outputs" do. The key is `results.json`'s `provenance`: the commit (with its
//! dirty flag) and `config_sha256`, the SHA-256 of [`RunConfig::identity`]. The cell is copied
//! (files hard-linked where the file system allows), and `reused.json` in it says from where.

use super::{Cell, FollowUp};
use anyhow::{Context, Result};
use joca_core::output::{self, OutputKind};
use joca_report::{CellState, Manifest};
use joca_train::{RunConfig, RunResults};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The file a reused cell holds: where it came from.
pub const REUSED: &str = "reused.json";

/// `reused.json`.
#[derive(Debug, Serialize, Deserialize)]
pub struct Reused {
    /// The finished cell it was copied from.
    pub from: PathBuf,
    /// The commit that computed it (this binary's).
    pub commit: String,
    /// The configuration's key (`provenance.config_sha256`).
    pub config_sha256: String,
}

/// The key a cell's record carries once run here: the SHA-256 of its configuration's identity,
/// with the detector weights found as `joca cell` finds them.
pub fn key(config: &RunConfig) -> String {
    let mut c = config.clone();
    crate::commands::run::resolve_weights(&mut c);
    joca_record::config_sha256(&c.identity())
}

/// A finished run directory that may serve a cell.
struct Candidate {
    dir: PathBuf,
    results: RunResults,
}

/// Finished run directories under `roots`: an experiment's cells, a run directory, or the
/// experiments and runs one level below a folder (`runs/`). Folders inside `skip` (the
/// experiment being filled) are left out.
fn candidates(roots: &[PathBuf], skip: &Path) -> Result<Vec<Candidate>> {
    let skip = skip.canonicalize().unwrap_or_else(|_| skip.to_owned());
    let mut dirs = Vec::new();
    for root in roots {
        if !root.is_dir() {
            anyhow::bail!("--reuse {}: not a folder", root.display());
        }
        match output::marked_kind(root) {
            Some(OutputKind::Experiment) => dirs.extend(experiment_cells(root)?),
            Some(OutputKind::Run) => dirs.push(root.clone()),
            _ => {
                let entries = std::fs::read_dir(root)
                    .with_context(|| format!("cannot list {}", root.display()))?;
                let mut below: Vec<PathBuf> =
                    entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
                below.sort();
                for dir in below {
                    match output::marked_kind(&dir) {
                        Some(OutputKind::Experiment) => dirs.extend(experiment_cells(&dir)?),
                        Some(OutputKind::Run) => dirs.push(dir),
                        _ => {}
                    }
                }
            }
        }
    }
    let mut found = Vec::new();
    for dir in dirs {
        let real = dir.canonicalize().unwrap_or_else(|_| dir.clone());
        if real.starts_with(&skip) {
            continue;
        }
        let Ok(text) = std::fs::read_to_string(dir.join("results.json")) else { continue };
        // A record joca cannot read is not a candidate (it is not this build's either).
        let Ok(results) = serde_json::from_str::<RunResults>(&text) else { continue };
        found.push(Candidate { dir: real, results });
    }
    Ok(found)
}

fn experiment_cells(dir: &Path) -> Result<Vec<PathBuf>> {
    let manifest = Manifest::load(dir)
        .with_context(|| format!("--reuse {}: cannot read its manifest", dir.display()))?;
    Ok(manifest.cells.iter().map(|c| Manifest::cell_dir(dir, c)).collect())
}

/// Fills the cells of `cells` that have not started from finished cells under `roots` that
/// computed the same configuration with this binary's commit; returns the ids filled. A cell
/// whose configuration was found under another commit, or without the follow-up tests it needs
/// and no checkpoint to run them from, is run as usual and named on stdout.
pub fn reuse(exp_dir: &Path, cells: &[&Cell], roots: &[PathBuf]) -> Result<Vec<String>> {
    if roots.is_empty() {
        return Ok(Vec::new());
    }
    let found = candidates(roots, exp_dir)?;
    let mut filled = Vec::new();
    for cell in cells {
        if Manifest::state(exp_dir, &cell.spec) != CellState::Missing {
            continue;
        }
        let key = key(&cell.config);
        let same: Vec<&Candidate> = found
            .iter()
            .filter(|c| c.results.provenance.as_ref().is_some_and(|p| p.config_sha256 == key))
            .collect();
        let this_build = same.iter().find(|c| {
            c.results.provenance.as_ref().is_some_and(|p| p.is_this_build())
                && can_follow_up(&c.dir, &cell.follow_up, &cell.config)
        });
        let Some(from) = this_build else {
            for c in &same {
                println!(
                    "  not reused for {}: {} has its configuration but {}",
                    cell.spec.id,
                    c.dir.display(),
                    why_not(c)
                );
            }
            continue;
        };
        let to = Manifest::cell_dir(exp_dir, &cell.spec);
        copy_cell(&from.dir, &to)?;
        let record =
            Reused { from: from.dir.clone(), commit: this_commit_label(), config_sha256: key };
        joca_train::write_atomic(&to.join(REUSED), &serde_json::to_string_pretty(&record)?)?;
        println!("  reused {} from {}", cell.spec.id, from.dir.display());
        filled.push(cell.spec.id.clone());
    }
    Ok(filled)
}

/// Why a candidate with the cell's configuration was not taken.
fn why_not(c: &Candidate) -> String {
    match &c.results.provenance {
        Some(p) if !p.is_this_build() => format!(
            "was computed by commit {} (this joca: {})",
            p.commit_label(),
            this_commit_label()
        ),
        _ => "lacks follow-up tests and the checkpoint to run them".to_owned(),
    }
}

fn this_commit_label() -> String {
    joca_record::Provenance::of_this_build(&()).commit_label()
}

/// Whether a cell at `dir` has the follow-up tests `follow_up` asks for, or the checkpoint that
/// `joca cell` runs them from.
fn can_follow_up(dir: &Path, follow_up: &FollowUp, config: &RunConfig) -> bool {
    dir.join("checkpoint").is_dir()
        || follow_up.tests(config).iter().all(|t| dir.join(t.results_file()).is_file())
}

/// Copies run directory `from` into cell folder `to` (which holds only its `cell.toml` and
/// marker): every file but the lock and the cell's own configuration. Files in its folders
/// (checkpoint, test frames: written whole, never in place) are hard-linked where the file system
/// allows; the top-level records and logs, which a follow-up test appends to, are copied.
fn copy_cell(from: &Path, to: &Path) -> Result<()> {
    copy_tree(from, to, true)
}

fn copy_tree(from: &Path, to: &Path, top: bool) -> Result<()> {
    for entry in
        std::fs::read_dir(from).with_context(|| format!("cannot list {}", from.display()))?
    {
        let entry = entry?;
        let name = entry.file_name();
        let (src, dst) = (entry.path(), to.join(&name));
        let kind = entry.file_type()?;
        if name == output::LOCK_FILE || name == "cell.toml" || name == REUSED {
            continue;
        }
        if kind.is_dir() {
            std::fs::create_dir_all(&dst)
                .with_context(|| format!("cannot create {}", dst.display()))?;
            copy_tree(&src, &dst, false)?;
        } else if kind.is_file() {
            if dst.exists() {
                std::fs::remove_file(&dst)
                    .with_context(|| format!("cannot replace {}", dst.display()))?;
            }
            if top || std::fs::hard_link(&src, &dst).is_err() {
                std::fs::copy(&src, &dst).with_context(|| {
                    format!("cannot copy {} to {}", src.display(), dst.display())
                })?;
            }
        }
        // Links and other special files are not part of a run directory: left out.
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config(text: &str) -> RunConfig {
        #[derive(Deserialize)]
        struct File {
            run: RunConfig,
        }
        let base = crate::config::PRESETS.iter().find(|(n, _)| *n == "quick").unwrap().1;
        let mut table: toml::Table = toml::from_str(base).unwrap();
        let over: toml::Table = toml::from_str(text).unwrap();
        let run = table.get_mut("run").and_then(toml::Value::as_table_mut).unwrap();
        for (k, v) in over {
            run.insert(k, v);
        }
        toml::from_str::<File>(&toml::to_string(&table).unwrap()).unwrap().run
    }

    /// The key follows what the run computes: a changed field changes it, the order of a file's
    /// fields does not, nor a field the method does not read (AverageAE's warm start), and the
    /// detector weights count by content, not path.
    #[test]
    fn the_cache_key_changes_with_the_computation_only() {
        let a = key(&config("seed = 3\nmethod = \"joca\"\ntask_weight = 5.0"));
        assert_eq!(a.len(), 64);
        assert_eq!(a, key(&config("task_weight = 5.0\nmethod = \"joca\"\nseed = 3")));
        assert_ne!(a, key(&config("seed = 4\nmethod = \"joca\"\ntask_weight = 5.0")));
        assert_ne!(a, key(&config("seed = 3\nmethod = \"joca\"\ntask_weight = 6.0")));
        let average = |extra: &str| key(&config(&format!("method = \"tacos-average\"\n{extra}")));
        assert_eq!(average(""), average("warm_start = { frames = 0 }"));
        assert_ne!(average(""), average("generations = 2"));
        // The shipped weights by another path, and a copy of them changed by one byte.
        let dir = tempfile::tempdir().unwrap();
        let shipped =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../weights/detector.safetensors");
        let mut bytes = std::fs::read(&shipped).unwrap();
        let copy = dir.path().join("copy.safetensors");
        std::fs::write(&copy, &bytes).unwrap();
        let with = |p: &Path| {
            key(&config(&format!(
                "seed = 3\nmethod = \"joca\"\ntask_weight = 5.0\ndetector_weights = {:?}",
                p.display().to_string()
            )))
        };
        assert_eq!(with(&copy), a);
        let last = bytes.len() - 1;
        bytes[last] ^= 1;
        std::fs::write(&copy, &bytes).unwrap();
        assert_ne!(with(&copy), a);
    }
}
