//! What training the detector in the loop changed: each cell that trained its detector, tested
//! again with the detector weights it started from on its own design and controller
//! (`results-detector-start[-town<K>].json`, `[follow_up] starting_detector`). Beside the
//! frozen-detector variant of the same design and seed this splits "ours − frozen detector" in
//! two: the detector's part (ours' controller with its trained against its starting detector) and
//! the controller's part (the starting detector with ours' controller against the controller
//! trained beside the frozen detector).

use crate::ReportError;
use crate::data::RunData;
use crate::experiment::{CellSpec, Manifest};
use crate::paired::Comparison;
use crate::seeds::difference_cell;
use crate::table::Row;
use joca_record::{Method, Retest};
use std::path::Path;

/// The section's title and note.
pub(crate) const TITLE: &str = "What training the detector changed";
pub(crate) const NOTE: &str = "Each cell that trained its detector, tested again with the \
    detector weights it started from, on the same design, controller and test scenes \
    (`[follow_up] starting_detector`). Trained − starting detector: the detector's part of the \
    variant's result. Starting detector − frozen detector: the same starting detector driven by \
    the variant's controller against the controller trained beside the frozen detector (same \
    design and seed): the controller's part. Paired and aggregated as the tables above; ✱ \
    marks an interval that excludes 0, read at full precision.";

/// The rows of one town: each cell's test with its trained detector, with its starting
/// detector, and the frozen-detector cells' tests.
struct TownRows {
    town: u64,
    trained: Vec<Row>,
    start: Vec<Row>,
    frozen: Vec<Row>,
}

fn row(cell: &CellSpec, run: RunData) -> Row {
    Row {
        group: cell.group.clone(),
        label: cell.label.clone(),
        cell: cell.id.clone(),
        design: cell.design.clone(),
        results: run.results,
    }
}

/// The cell's test on `town`: its own results on the test town, else its town re-test.
fn own_test(dir: &Path, run: &RunData, town: u64) -> Result<Option<RunData>, ReportError> {
    if town == 0 { Ok(Some(run.clone())) } else { RunData::retest(dir, &Retest::town(town)) }
}

fn town_rows(
    exp_dir: &Path,
    runs: &[(CellSpec, RunData)],
    town: u64,
) -> Result<TownRows, ReportError> {
    let mut out = TownRows { town, trained: Vec::new(), start: Vec::new(), frozen: Vec::new() };
    for (spec, run) in runs {
        let dir = Manifest::cell_dir(exp_dir, spec);
        if run.results.method == Method::FrozenDetector {
            if let Some(own) = own_test(&dir, run, town)? {
                out.frozen.push(row(spec, own));
            }
            continue;
        }
        let Some(start) = RunData::retest(&dir, &Retest::start_detector(town))? else { continue };
        if let Some(own) = own_test(&dir, run, town)? {
            out.trained.push(row(spec, own));
            out.start.push(row(spec, start));
        }
    }
    Ok(out)
}

/// The table (header first); empty when no cell was tested with its starting detector.
pub(crate) fn detector_start_table(
    exp_dir: &Path,
    runs: &[(CellSpec, RunData)],
) -> Result<Vec<Vec<String>>, ReportError> {
    let mut towns: Vec<u64> =
        std::iter::once(0).chain(runs.iter().flat_map(|(c, _)| c.towns.iter().copied())).collect();
    towns.sort_unstable();
    towns.dedup();
    let mut table = vec![
        [
            "scenario",
            "variant",
            "town",
            "paired on",
            "Δ mAP trained − starting detector",
            "Δ mAP starting detector − frozen detector",
        ]
        .map(str::to_owned)
        .to_vec(),
    ];
    for town in towns {
        let rows = town_rows(exp_dir, runs, town)?;
        table.extend(town_table(&rows));
    }
    Ok(if table.len() < 2 { Vec::new() } else { table })
}

fn town_table(rows: &TownRows) -> Vec<Vec<String>> {
    let mut variants: Vec<(&str, &str)> = Vec::new();
    for r in &rows.trained {
        if !variants.contains(&(r.group.as_str(), r.label.as_str())) {
            variants.push((&r.group, &r.label));
        }
    }
    let map = |r: &Row| Some(r.results.test.map);
    let mut out = Vec::new();
    for (group, label) in variants {
        let of = |r: &&Row| r.group == group && r.label == label;
        let detector = Comparison {
            group: group.to_owned(),
            ours: label.to_owned(),
            other: "starting detector".to_owned(),
            pairs: rows.trained.iter().zip(&rows.start).filter(|(a, _)| of(a)).collect(),
        };
        let controller = Comparison {
            group: group.to_owned(),
            ours: label.to_owned(),
            other: "frozen detector".to_owned(),
            pairs: rows
                .start
                .iter()
                .filter(of)
                .filter_map(|a| {
                    let same = |b: &&Row| {
                        b.group == a.group
                            && b.design == a.design
                            && b.results.seed == a.results.seed
                    };
                    rows.frozen.iter().find(same).map(|b| (a, b))
                })
                .collect(),
        };
        let town = if rows.town == 0 { "test".to_owned() } else { rows.town.to_string() };
        out.push(vec![
            group.to_owned(),
            label.to_owned(),
            town,
            detector.describe(),
            difference_cell(detector.difference(map)),
            if controller.pairs.is_empty() {
                "–".to_owned()
            } else {
                difference_cell(controller.difference(map))
            },
        ]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(label: &str, design: &str, seed: u64, method: Method, map: f64) -> Row {
        crate::table::tests::row(label, method, design, seed, map)
    }

    #[test]
    fn the_split_pairs_each_cell_with_its_swap_and_the_frozen_cell_of_its_design_and_seed() {
        let ours = |d: &str, s: u64, map: f64| row("Ours", d, s, Method::Joca, map);
        let frozen = |d: &str, s: u64, map: f64| row("Frozen", d, s, Method::FrozenDetector, map);
        // Design a: two seeds, design b: one. Trained − start per cell: a 0.02, 0.04; b 0.09.
        // Start − frozen: a 0.10 − 0.12, 0.12 − 0.11; b 0.06 − 0.095.
        let rows = TownRows {
            town: 2,
            trained: vec![ours("a", 0, 0.12), ours("a", 1, 0.16), ours("b", 0, 0.15)],
            start: vec![ours("a", 0, 0.10), ours("a", 1, 0.12), ours("b", 0, 0.06)],
            frozen: vec![frozen("b", 0, 0.095), frozen("a", 1, 0.11), frozen("a", 0, 0.12)],
        };
        let table = town_table(&rows);
        assert_eq!(table.len(), 1);
        // Per design the mean over its seeds, then the t interval over the designs (df = 1,
        // t = 12.706): detector's part a 0.03, b 0.09 → 0.06 ± 12.706 · 0.03 = 0.381;
        // controller's part a (−0.02 + 0.01) / 2 = −0.005, b −0.035 → −0.02 ± 12.706 · 0.015.
        assert_eq!(table[0][..4], ["Calibrated", "Ours", "2", "2 designs × ≤ 2 seeds"]);
        assert_eq!(table[0][4], "0.060 ± 0.381");
        assert_eq!(table[0][5], "-0.020 ± 0.191");
    }
}
