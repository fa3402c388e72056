//! The sections of an experiment report above its table of every cell: over seeds and designs
//! on each town, pooled over towns, how the controllers set the camera, the controller swap,
//! where the wall time went and the starting detector.

use crate::ReportError;
use crate::data::RunData;
use crate::experiment::CellSpec;
use crate::seeds::titled_table;
use crate::table::Row;
use std::path::Path;

/// The note of the table pooled over towns.
const POOLED_TOWNS: &str = "Ours − baseline per seed (in a panel, per design) averaged over the \
    test town and every follow-up town, then the 95 % t interval over the seeds (designs) tested \
    on all of them: a cell's towns share its training, so each cell counts once. ✱ marks an \
    interval that excludes 0, read at full precision.";

/// The controls section's title and note.
const CONTROLS: &str = "How the controllers set the camera";
const CONTROLS_NOTE: &str = "Closed-loop test, mean over each variant's cells ± 95 % t interval \
    (the spread between designs and seeds): exposure E and gain G by day and by night, day's \
    exposure × linear gain relative to night's, day's mean frame level, and the share of the \
    training's perturbation searches whose best score was shared by two or more members (then the \
    tie-break or the GA's order chose).";

/// The sections above the table of every cell: over seeds (and designs) on the test town and each
/// follow-up town, how the controllers set the camera, the controller swap and the starting
/// detector; Markdown and HTML.
pub(crate) fn summary_sections(
    exp_dir: &Path,
    rows: &[Row],
    runs: &[(CellSpec, RunData)],
) -> Result<(String, String), ReportError> {
    let (mut md, mut html) = crate::seeds::seeds_sections(rows);
    let towns = crate::retests::town_rows(exp_dir, runs)?;
    for (town, rows) in &towns {
        let (town_md, town_html) = crate::seeds::town_sections(*town, rows);
        md.push_str(&town_md);
        html.push_str(&town_html);
    }
    let pooled = crate::seeds::pooled_towns_table(rows, &towns);
    if !pooled.is_empty() {
        titled_table(&mut md, &mut html, 2, "Pooled over towns", POOLED_TOWNS, &pooled);
        md.push('\n');
    }
    let controls = crate::controls::controls_table(rows);
    if !controls.is_empty() {
        titled_table(&mut md, &mut html, 2, CONTROLS, CONTROLS_NOTE, &controls);
        md.push('\n');
    }
    let swaps = crate::retests::swap_cells(exp_dir, runs)?;
    if !swaps.is_empty() {
        let paired = crate::swap::swap_table(&swaps);
        titled_table(&mut md, &mut html, 2, crate::swap::SWAP, crate::swap::SWAP_NOTE, &paired);
        md.push('\n');
        let behaviour = crate::swap::behaviour_table(&swaps);
        let (title, note) = ("What the controllers did", crate::swap::BEHAVIOUR_NOTE);
        titled_table(&mut md, &mut html, 3, title, note, &behaviour);
        md.push('\n');
        crate::steadiness::sections(&mut md, &mut html, &swaps);
    }
    let wall = crate::walltime::table(rows, runs);
    if !wall.is_empty() {
        let (title, note) = (crate::walltime::TITLE, crate::walltime::NOTE);
        titled_table(&mut md, &mut html, 2, title, note, &wall);
        md.push('\n');
    }
    let start = crate::detector_start::detector_start_table(exp_dir, runs)?;
    if !start.is_empty() {
        let (title, note) = (crate::detector_start::TITLE, crate::detector_start::NOTE);
        titled_table(&mut md, &mut html, 2, title, note, &start);
        md.push('\n');
    }
    Ok((md, html))
}
