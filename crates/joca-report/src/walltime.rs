//! Where a run's wall time went, from `events.jsonl`'s phase and warm-start records: one run's
//! sentence, and an experiment's table of each variant's mean over its cells. Wall time on
//! whatever else the machine ran: a record of where the time went, not a benchmark.

use crate::data::RunData;
use crate::experiment::CellSpec;
use crate::paired::variants;
use crate::seeds::{interval_text, mean_interval};
use crate::table::Row;
use joca_record::RunPhase;

/// The parts in report order.
const PHASES: [RunPhase; 4] =
    [RunPhase::Training, RunPhase::Selection, RunPhase::Test, RunPhase::AverageRetest];

/// The experiment section's title and note.
pub const TITLE: &str = "Where the wall time went";
/// See [`TITLE`].
pub const NOTE: &str = "Seconds of wall time by part of each cell's `joca run`, from its \
    `events.jsonl` (summed over the processes of a resumed run; a process killed mid-part \
    recorded none), mean ± 95 % t over the variant's cells that recorded it. Wall time on \
    whatever else the machine ran at the time: where the time went, not a benchmark. \
    Follow-up tests (`joca eval`) are not counted.";

/// A part's name in a report: its record's, but the re-test's says which controller.
fn name(p: RunPhase) -> &'static str {
    match p {
        RunPhase::AverageRetest => "AverageAE re-test",
        p => p.name(),
    }
}

/// A run's seconds in `phase`, if recorded.
fn seconds(run: &RunData, phase: RunPhase) -> Option<f64> {
    run.wall.iter().find(|(p, _)| *p == phase).map(|(_, s)| *s)
}

/// The run's total: its warm start and every recorded part.
fn total(run: &RunData) -> f64 {
    run.warm_start.as_ref().and_then(|w| w.warm_start_s).unwrap_or(0.0)
        + run.wall.iter().map(|(_, s)| s).sum::<f64>()
}

/// One run's sentence (`None` where it recorded no part).
pub fn run_sentence(run: &RunData) -> Option<String> {
    if run.wall.is_empty() {
        return None;
    }
    let mut parts: Vec<String> = Vec::new();
    if let Some(s) = run.warm_start.as_ref().and_then(|w| w.warm_start_s) {
        parts.push(format!("warm start {s:.0} s"));
    }
    for p in PHASES {
        if let Some(s) = seconds(run, p) {
            parts.push(format!("{} {s:.0} s", name(p)));
        }
    }
    Some(format!(
        "Wall time, on whatever else the machine ran: {} ({:.0} s in all).\n",
        parts.join(", "),
        total(run)
    ))
}

/// The experiment's table: one row per variant of `rows` whose cells (their runs in `runs`, by
/// cell id) recorded a part; empty where none did.
pub fn table(rows: &[Row], runs: &[(CellSpec, RunData)]) -> Vec<Vec<String>> {
    let mut out = vec![
        ["scenario", "variant", "cells", "warm start", "training", "selection", "test"]
            .map(str::to_owned)
            .to_vec(),
    ];
    out[0].extend(["AverageAE re-test", "in all"].map(str::to_owned));
    for (group, label, members) in variants(rows) {
        let recorded: Vec<&RunData> = members
            .iter()
            .filter_map(|m| runs.iter().find(|(spec, _)| spec.id == m.cell).map(|(_, r)| r))
            .filter(|r| !r.wall.is_empty())
            .collect();
        if recorded.is_empty() {
            continue;
        }
        let cell = |v: Vec<f64>| {
            if v.is_empty() { "–".to_owned() } else { interval_text(mean_interval(&v), 0) }
        };
        let mut row = vec![group, label, recorded.len().to_string()];
        row.push(cell(
            recorded.iter().filter_map(|r| r.warm_start.as_ref()?.warm_start_s).collect(),
        ));
        for p in PHASES {
            row.push(cell(recorded.iter().filter_map(|r| seconds(r, p)).collect()));
        }
        row.push(cell(recorded.iter().map(|r| total(r)).collect()));
        out.push(row);
    }
    if out.len() == 1 { Vec::new() } else { out }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    /// A committed `quick` cell (its warm start took 21.4 s), with `wall` as given.
    fn cell(wall: Vec<(RunPhase, f64)>) -> RunData {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../docs/results/2026-12-06-pooled-score-quick/cells/loss-calibrated-flir");
        let mut run = RunData::load(&dir).unwrap();
        run.wall = wall;
        run
    }

    /// Cell `id` of the variant "loss" in group "Calibrated", with `run`.
    fn experiment_cell(id: &str, run: RunData) -> (CellSpec, RunData) {
        let spec = CellSpec {
            id: id.into(),
            label: "loss".into(),
            group: "Calibrated".into(),
            dir: id.into(),
            seed: 0,
            design: String::new(),
            towns: Vec::new(),
            follow_ups: Vec::new(),
        };
        (spec, run)
    }

    /// The result table's rows of `cells`.
    fn table_rows(cells: &[(CellSpec, RunData)]) -> Vec<Row> {
        cells
            .iter()
            .map(|(spec, run)| Row {
                group: spec.group.clone(),
                label: spec.label.clone(),
                cell: spec.id.clone(),
                design: spec.design.clone(),
                results: run.results.clone(),
            })
            .collect()
    }

    #[test]
    fn a_run_says_where_its_time_went_and_a_variant_averages_its_cells() {
        // Made before parts were recorded: no sentence, no row.
        let old = cell(Vec::new());
        assert_eq!(run_sentence(&old), None);
        let a = cell(vec![(RunPhase::Training, 60.0), (RunPhase::Test, 9.6)]);
        let line = run_sentence(&a).unwrap();
        assert!(line.contains("warm start 21 s, training 60 s, test 10 s (91 s in all)"), "{line}");
        let b = cell(vec![(RunPhase::Training, 70.0), (RunPhase::Test, 10.4)]);
        let cells = vec![
            experiment_cell("old", old.clone()),
            experiment_cell("a", a),
            experiment_cell("b", b),
        ];
        let rows = table(&table_rows(&cells), &cells);
        assert_eq!(rows.len(), 2, "{rows:?}");
        // Two cells recorded: training 65 ± t(0.975, 1)·7.07/√2 = 65 ± 64; no selection part.
        assert_eq!(rows[1][2], "2");
        assert_eq!(rows[1][4], "65 ± 64");
        assert_eq!(rows[1][5], "–");
        let only_old = vec![experiment_cell("old", old)];
        assert!(table(&table_rows(&only_old), &only_old).is_empty());
    }
}
