//! Checks of an experiment file and its cells that name what to change: methods, scenarios,
//! composed cell ids, and cell folders that must be real folders inside the experiment.

use super::Cell;
use anyhow::{Result, anyhow, bail};
use joca_train::{Method, Scenario};
use std::path::Path;

/// Every scenario must be known and listed once.
pub fn check_scenarios(scenarios: &[String], source: &str) -> Result<()> {
    for (k, scenario) in scenarios.iter().enumerate() {
        Scenario::from_name(scenario).map_err(|e| anyhow!("{source}: scenarios: {e}"))?;
        if scenarios[..k].contains(scenario) {
            bail!("{source}: scenarios: {scenario:?} is listed twice; list each scenario once");
        }
    }
    Ok(())
}

/// Refuses two cells whose ids compose alike (variant `a-calibrated` × scenario `blur4` and
/// variant `a` × scenario `calibrated` × design `blur4`), naming both and what to rename.
pub fn check_unique_ids(cells: &[Cell], source: &str) -> Result<()> {
    let parts = |c: &Cell| {
        let design = if c.spec.design.is_empty() {
            String::new()
        } else {
            format!(", design {:?}", c.spec.design)
        };
        format!(
            "the variant labelled {:?} ({}), scenario {}{design}",
            c.spec.label,
            c.config.method.name(),
            c.config.scenario.name()
        )
    };
    for (k, cell) in cells.iter().enumerate() {
        if let Some(first) = cells[..k].iter().find(|c| c.spec.id == cell.spec.id) {
            bail!(
                "{source}: two cells would be named {:?}: {} and {}; rename a variant or a \
                 panel design so that `<variant>-<scenario>[-<design>]` differs",
                cell.spec.id,
                parts(first),
                parts(cell)
            );
        }
    }
    Ok(())
}

/// A `method` value in `table` must name a method; the error lists the valid ones.
pub fn check_method(table: &toml::Table, source: &str, what: &str) -> Result<()> {
    if let Some(m) = table.get("method") {
        let name =
            m.as_str().ok_or_else(|| anyhow!("{source}: {what}: method must be a string"))?;
        Method::from_name(name).map_err(|e| anyhow!("{source}: {what}: {e}"))?;
    }
    Ok(())
}

/// Refuses a cell folder that is, or sits below, a symbolic link inside the experiment
/// directory `exp`: joca would write through it into a folder that is not the experiment's.
pub fn real_cell_dir(exp: &Path, cell_dir: &Path) -> Result<()> {
    let inside = cell_dir.strip_prefix(exp).unwrap_or(cell_dir);
    let mut path = exp.to_path_buf();
    for part in inside.components() {
        path.push(part);
        if std::fs::symlink_metadata(&path).is_ok_and(|m| m.file_type().is_symlink()) {
            bail!(
                "{} is a symbolic link: an experiment's cells must be real folders inside it \
                 (joca would write through the link); remove the link to run the cell",
                path.display()
            );
        }
    }
    Ok(())
}
