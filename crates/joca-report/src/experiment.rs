//! Experiment reports: an experiment directory holds `experiment.json` (a [`Manifest`]: which
//! cells exist and how the tables label them) and one normal run directory per cell. The report
//! covers the finished cells and lists the others, so it can be made while a grid still runs.

use crate::data::{RunData, parse, read};
use crate::table::{Row, Table, escape};
use crate::{
    Figure, ReportError, ReportOptions, figures_markdown, html, write_figures, write_text,
};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// One cell of an experiment grid: a run directory and how tables label it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CellSpec {
    /// Unique id, also the run directory's name.
    pub id: String,
    /// Row label (method or sweep value).
    pub label: String,
    /// Group label (scenario).
    pub group: String,
    /// Run directory, relative to the experiment directory.
    pub dir: String,
    /// The cell's `seed`.
    #[serde(default)]
    pub seed: u64,
    /// The panel design the cell's hardware is fixed to (its id); empty outside a panel.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub design: String,
    /// Towns of the test family the cell is also tested on after its run (`[follow_up] towns`):
    /// `results-town<K>.json`, and for a NeuralAE cell its AverageAE re-test there too.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub towns: Vec<u64>,
    /// The tags of every follow-up test the cell runs after its run (`results-<tag>.json`,
    /// [`joca_record::Retest`]); older manifests lack them and list only `towns`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub follow_ups: Vec<String>,
}

/// `experiment.json`: what an experiment directory contains.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Experiment name (`table1`, …).
    pub name: String,
    /// Title of the report.
    pub title: String,
    /// Preset the cells were run with.
    pub preset: String,
    /// Seeds per variant and scenario (cells with the same group and label).
    #[serde(default = "one")]
    pub seeds: u64,
    /// Header of the tables' label column.
    pub label_header: String,
    /// Cells in display order.
    pub cells: Vec<CellSpec>,
}

fn one() -> u64 {
    1
}

/// The runs a group's figures show: one per method, its lowest finished seed (among the cells
/// that kept their full run directory, if any did), in table order.
/// With several seeds a figure of every run repeats each legend entry once per seed and reuses
/// colours; the other seeds' figures are in their own cells' reports. Labels name the seed when
/// the experiment has more than one.
fn figure_members<'a, R>(
    runs: &'a [(CellSpec, R)],
    group: &str,
    full: impl Fn(&R) -> bool,
) -> Vec<(String, &'a R)> {
    let in_group: Vec<&(CellSpec, R)> = runs.iter().filter(|(c, _)| c.group == group).collect();
    let several = in_group
        .iter()
        .any(|(c, _)| in_group.iter().any(|(o, _)| o.label == c.label && o.seed != c.seed));
    let mut members: Vec<(String, &R)> = Vec::new();
    // Per method its lowest seed, preferring cells that kept their full run directory (a cell
    // restored from its compact results has no frames or training curves to draw).
    let mut shown: Vec<(&str, u64, bool)> = Vec::new();
    for (c, r) in &in_group {
        let f = full(r);
        match shown.iter_mut().find(|(l, _, _)| *l == c.label) {
            Some((_, seed, was_full)) => {
                if (f, std::cmp::Reverse(c.seed)) > (*was_full, std::cmp::Reverse(*seed)) {
                    (*seed, *was_full) = (c.seed, f);
                }
            }
            None => shown.push((&c.label, c.seed, f)),
        }
    }
    let shown: Vec<(&str, u64)> = shown.into_iter().map(|(l, s, _)| (l, s)).collect();
    for (label, seed) in shown {
        if let Some((c, r)) = in_group.iter().find(|(c, _)| c.label == label && c.seed == seed) {
            let name =
                if several { format!("{}, seed {}", c.label, c.seed) } else { c.label.clone() };
            members.push((name, r));
        }
    }
    members
}

/// Where a cell stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CellState {
    /// `results.json` exists: finished and tested.
    Done,
    /// A run directory with a checkpoint or log but no results: killed or still running.
    Partial,
    /// Nothing yet.
    Missing,
}

impl Manifest {
    /// File name inside an experiment directory.
    pub const FILE: &'static str = "experiment.json";

    /// Reads `dir/experiment.json`.
    pub fn load(dir: &Path) -> Result<Self, ReportError> {
        let path = dir.join(Self::FILE);
        parse(&path, &read(&path)?)
    }

    /// The run directory of `cell`.
    pub fn cell_dir(exp_dir: &Path, cell: &CellSpec) -> PathBuf {
        exp_dir.join(&cell.dir)
    }

    /// Where `cell` stands. `results.json` is written atomically after the test, so its presence
    /// means the cell is complete.
    pub fn state(exp_dir: &Path, cell: &CellSpec) -> CellState {
        let dir = Self::cell_dir(exp_dir, cell);
        let towns_done = cell
            .towns
            .iter()
            .map(|t| joca_record::Retest::town(*t).to_string())
            .chain(cell.follow_ups.iter().cloned())
            .all(|tag| dir.join(format!("results-{tag}.json")).is_file());
        if dir.join("results.json").is_file() && towns_done {
            CellState::Done
        } else if dir.join("checkpoint").exists() || dir.join("events.jsonl").exists() {
            CellState::Partial
        } else {
            CellState::Missing
        }
    }
}

/// Writes `report.md`, `report.html`, `results.csv` and `figures/` into the experiment
/// directory from its finished cells, and returns the Markdown.
pub fn write_experiment_report(exp_dir: &Path) -> Result<String, ReportError> {
    write_experiment_report_with(exp_dir, &ReportOptions::default())
}

/// The commit (with `-dirty`, or `unrecorded` for cells written before provenance existed) of
/// each finished cell, grouped: `commit: cell, cell; commit: cell`.
fn commits(rows: &[Row]) -> Vec<(String, Vec<String>)> {
    let mut by: Vec<(String, Vec<String>)> = Vec::new();
    for r in rows {
        let label = r.results.provenance.as_ref().map_or("unrecorded".into(), |p| p.commit_label());
        match by.iter_mut().find(|(c, _)| *c == label) {
            Some((_, cells)) => cells.push(r.cell.clone()),
            None => by.push((label, vec![r.cell.clone()])),
        }
    }
    by
}

/// [`write_experiment_report`] as `options` say: refusing cells of different joca commits unless
/// `mixed_commits` (then the report names each commit and its cells), without figures with
/// `no_figures`.
pub fn write_experiment_report_with(
    exp_dir: &Path,
    options: &ReportOptions,
) -> Result<String, ReportError> {
    let manifest = Manifest::load(exp_dir)?;
    let cells = cells_with(&manifest, &options.with)?;
    let mut rows = Vec::new();
    let mut runs = Vec::new();
    let mut pending = Vec::new();
    for cell in &cells {
        // A finished run is reported even where its follow-up tests are still to come.
        if !Manifest::cell_dir(exp_dir, cell).join("results.json").is_file() {
            pending.push(cell.id.clone());
            continue;
        }
        let dir = Manifest::cell_dir(exp_dir, cell);
        let run = match &options.results {
            None => RunData::load(&dir)?,
            Some(tag) => RunData::retest_tag(&dir, tag)?.ok_or_else(|| {
                let file = format!("results-{tag}.json");
                ReportError::MissingResults { cell: cell.id.clone(), file, tag: tag.clone() }
            })?,
        };
        rows.push(Row {
            group: cell.group.clone(),
            label: cell.label.clone(),
            cell: cell.id.clone(),
            design: cell.design.clone(),
            results: run.results.clone(),
        });
        runs.push((cell.clone(), run));
    }
    let commits = commits(&rows);
    let commit_text = commits
        .iter()
        .map(|(c, cells)| format!("{c}: {}", cells.join(", ")))
        .collect::<Vec<_>>()
        .join("; ");
    if commits.len() > 1 && !options.mixed_commits {
        return Err(ReportError::MixedCommits {
            experiment: exp_dir.display().to_string(),
            cells: commit_text,
        });
    }
    let table = Table { label_header: manifest.label_header.clone(), rows };
    let done = runs.len();
    let total = cells.len();
    let mut meta = format!(
        "Preset `{}`; {done} of {total} cells finished. Each cell is a full `joca run` directory \
            under `{}`; \
         test on the test town, closed loop. Camera parameters marked ● were optimised, ○ fixed; \
         best of each group in bold, second underlined.",
        manifest.preset,
        exp_dir.display()
    );
    if !pending.is_empty() {
        let _ = write!(meta, " Not finished: {}.", pending.join(", "));
    }
    if let Some(tag) = &options.results {
        let _ = write!(meta, " Every row read from the cell's `results-{tag}.json`.");
    }
    for other in &options.with {
        let name = other_name(other);
        let _ = write!(
            meta,
            " With the cells of `{}`, labelled `({name})`, paired with these on the same \
             scenario, design and seed.",
            other.display()
        );
    }
    if let [machine] = crate::seeds::machines(&table.rows).as_slice()
        && !table.rows[0].results.cpu.is_empty()
    {
        let _ = write!(meta, " Computed on {machine}.");
    }
    match commits.as_slice() {
        [] => {}
        [(c, _)] => {
            let _ = write!(meta, " joca commit {c}.");
        }
        _ => {
            let _ =
                write!(meta, " Cells of different joca commits, reported together: {commit_text}.");
        }
    }
    let mut md = format!("# {}\n\n{meta}\n\n", manifest.title);
    let (seeds_md, seeds_html) = crate::summary::summary_sections(exp_dir, &table.rows, &runs)?;
    md.push_str(&seeds_md);
    if !seeds_md.is_empty() {
        md.push_str("## Every cell\n\n");
    }
    md.push_str(&table.markdown());
    md.push_str("\nAll numbers, every seed, at full precision: `results.csv`.\n\n");
    let mut html_body = format!(
        "<p class=\"meta\">{}</p>\n{seeds_html}{}",
        escape(&meta.replace('`', "")),
        table.html()
    );
    let mut figures: Vec<Figure> = Vec::new();
    for group in table.groups().into_iter().filter(|_| !options.no_figures) {
        let members = figure_members(&runs, &group, |r: &RunData| !r.showcases.is_empty());
        let prefix = format!("{}-", slug(&group));
        let group_figures = write_figures(exp_dir, &prefix, &group, &members)?;
        let _ = writeln!(md, "## {group}\n");
        md.push_str(&figures_markdown(&group_figures).replacen("## Figures\n\n", "", 1));
        figures.extend(group_figures);
    }
    write_text(&exp_dir.join("results.csv"), &table.csv())?;
    write_text(&exp_dir.join("report.md"), &md)?;
    html_body.push_str(if options.no_figures {
        "<p class=\"meta\">All numbers, at full precision: results.csv.</p>\n"
    } else {
        "<p class=\"meta\">All numbers, at full precision: results.csv. Figures follow, by \
            scenario.</p>\n"
    });
    let page = html::page(&manifest.title, &html_body, exp_dir, &figures)?;
    write_text(&exp_dir.join("report.html"), &page)?;
    Ok(md)
}

/// The name that labels another experiment's cells: its directory's last component.
fn other_name(dir: &Path) -> String {
    dir.file_name().map_or_else(|| dir.display().to_string(), |n| n.to_string_lossy().into_owned())
}

/// `manifest`'s cells, then each of `with`'s: labelled and named ` (<directory name>)` and read
/// from their own directory (an absolute path, which [`Manifest::cell_dir`] keeps as it is).
fn cells_with(manifest: &Manifest, with: &[PathBuf]) -> Result<Vec<CellSpec>, ReportError> {
    let mut cells = manifest.cells.clone();
    for other in with {
        let name = other_name(other);
        let absolute = std::path::absolute(other)
            .map_err(|source| ReportError::Io { path: other.display().to_string(), source })?;
        for c in Manifest::load(other)?.cells {
            cells.push(CellSpec {
                id: format!("{} ({name})", c.id),
                label: format!("{} ({name})", c.label),
                dir: absolute.join(&c.dir).display().to_string(),
                ..c
            });
        }
    }
    Ok(cells)
}

/// A file-name-safe form of a label.
fn slug(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c.to_ascii_lowercase() } else { '-' })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cell(label: &str, group: &str, seed: u64) -> (CellSpec, u64) {
        let id = format!("{label}-{group}-s{seed}");
        let spec = CellSpec {
            id: id.clone(),
            label: label.into(),
            group: group.into(),
            dir: id,
            seed,
            design: String::new(),
            towns: Vec::new(),
            follow_ups: Vec::new(),
        };
        (spec, seed)
    }

    #[test]
    fn figures_show_each_method_once_at_its_lowest_finished_seed() {
        // Seed 0 of "b" has not finished; the calibrated group's figures show a/0 and b/1.
        let runs = vec![
            cell("a", "cal", 2),
            cell("a", "cal", 0),
            cell("b", "cal", 1),
            cell("b", "cal", 2),
            cell("a", "blur", 0),
        ];
        let shown: Vec<(String, u64)> =
            figure_members(&runs, "cal", |_| true).into_iter().map(|(l, r)| (l, *r)).collect();
        assert_eq!(shown, vec![("a, seed 0".to_owned(), 0), ("b, seed 1".to_owned(), 1)]);
        // One seed: labels as the table's.
        let one = vec![cell("a", "cal", 0), cell("b", "cal", 0)];
        let shown: Vec<String> =
            figure_members(&one, "cal", |_| true).into_iter().map(|(l, _)| l).collect();
        assert_eq!(shown, vec!["a".to_owned(), "b".to_owned()]);
        // Seeds 0 of "a" and 1 of "b" restored from compact results (here: even seeds are
        // full): each method is shown at its lowest full seed, a method without one at its
        // lowest seed.
        let shown: Vec<(String, u64)> = figure_members(&runs, "cal", |s| s % 2 == 0)
            .into_iter()
            .map(|(l, r)| (l, *r))
            .collect();
        assert_eq!(shown, vec![("a, seed 0".to_owned(), 0), ("b, seed 2".to_owned(), 2)]);
        let odd: Vec<(String, u64)> = figure_members(&runs, "cal", |s| s % 2 == 1)
            .into_iter()
            .map(|(l, r)| (l, *r))
            .collect();
        assert_eq!(odd, vec![("a, seed 0".to_owned(), 0), ("b, seed 1".to_owned(), 1)]);
    }
}
