//! What an experiment's cells were re-tested on after their run, read for the report: their
//! follow-up towns (`results-town<K>.json`) and the AverageAE re-test of each NeuralAE cell
//! (`results-average-127.5[-town<K>].json`).

use crate::ReportError;
use crate::data::RunData;
use crate::experiment::{CellSpec, Manifest};
use crate::table::Row;
use joca_record::Retest;
use std::path::Path;

/// Per follow-up town (ascending), the rows of the cells tested there (`results-town<K>.json`).
pub(crate) fn town_rows(
    exp_dir: &Path,
    runs: &[(CellSpec, RunData)],
) -> Result<Vec<(u64, Vec<Row>)>, ReportError> {
    let mut towns: Vec<u64> = runs.iter().flat_map(|(c, _)| c.towns.iter().copied()).collect();
    towns.sort_unstable();
    towns.dedup();
    let mut out = Vec::new();
    for town in towns {
        let mut rows = Vec::new();
        for (cell, _) in runs {
            let dir = Manifest::cell_dir(exp_dir, cell);
            if let Some(retest) = RunData::retest(&dir, &Retest::town(town))? {
                rows.push(Row {
                    group: cell.group.clone(),
                    label: cell.label.clone(),
                    cell: cell.id.clone(),
                    design: cell.design.clone(),
                    results: retest.results,
                });
            }
        }
        out.push((town, rows));
    }
    Ok(out)
}

/// The finished NeuralAE cells that carry an AverageAE re-test, with it.
pub(crate) fn swap_cells<'a>(
    exp_dir: &Path,
    runs: &'a [(CellSpec, RunData)],
) -> Result<Vec<crate::swap::SwapCell<'a>>, ReportError> {
    let mut out = Vec::new();
    for (cell, run) in runs {
        let dir = Manifest::cell_dir(exp_dir, cell);
        let mut push = |town: u64, neural: RunData, average: Option<RunData>| {
            if let Some(average) = average {
                out.push(crate::swap::SwapCell {
                    group: &cell.group,
                    label: &cell.label,
                    design: &cell.design,
                    town,
                    neural,
                    average,
                });
            }
        };
        push(0, run.clone(), RunData::retest(&dir, &Retest::average_swap(0))?);
        for &t in &cell.towns {
            if let Some(neural) = RunData::retest(&dir, &Retest::town(t))? {
                push(t, neural, RunData::retest(&dir, &Retest::average_swap(t))?);
            }
        }
    }
    Ok(out)
}
