//! The order a grid's cells run in: `--order` and the cells named `--first`.

use super::{Cell, Experiment};
use anyhow::{Result, bail};

/// Refuses a `--first` id that names no cell of the experiment, listing the ones it has.
pub fn check_first(exp: &Experiment, first: &[String]) -> Result<()> {
    for id in first {
        if !exp.cells.iter().any(|c| c.spec.id == *id) {
            let ids: Vec<&str> = exp.cells.iter().map(|c| c.spec.id.as_str()).collect();
            bail!(
                "--first: unknown cell {id:?}: experiment {} has the cells {}",
                exp.manifest.name,
                ids.join(", ")
            );
        }
    }
    Ok(())
}

/// Puts `todo` in the order `order` names (`grid`: as resolved), the cells named in `first`
/// before all others in the order named. The sorts are stable, so cells that tie keep the
/// grid's order.
pub fn order_cells(todo: &mut [&Cell], exp: &Experiment, order: &str, first: &[String]) {
    // A panel design's place in the file (its first cell's position in the grid).
    let design_rank = |c: &Cell| {
        exp.cells.iter().position(|o| o.spec.design == c.spec.design).unwrap_or(usize::MAX)
    };
    match order {
        "design" => todo.sort_by_key(|c| (c.spec.seed, design_rank(c))),
        "seed" => todo.sort_by_key(|c| c.spec.seed),
        _ => {}
    }
    todo.sort_by_key(|c| first.iter().position(|f| *f == c.spec.id).unwrap_or(usize::MAX));
}
