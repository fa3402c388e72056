//! Results over seeds: each variant's mean with a 95 % interval, and ours paired with every
//! baseline of the same scenario on the same seeds.
//!
//! The interval is Student's t over seeds: mean ± t(0.975, n − 1) · s / √n, with s the sample
//! standard deviation of the n seeds' values. It covers the run-to-run variation that a seed
//! changes (initial designs, GA draws, training noise); every seed is tested on the same test
//! scenes, so the test scenes' own sampling variation is not in it. The paired comparison takes
//! per seed the difference ours − baseline (same seed, same test scenes) and gives its mean, its
//! t interval and on how many seeds ours was ahead.

use crate::paired::{LIGHTS, comparisons, light_map, variants};
use crate::table::{Row, escape};
use std::fmt::Write as _;

mod pooled;
mod rests_on;
mod strata;
pub(crate) use pooled::pooled_towns_table;
use rests_on::rests_on;
pub(crate) use strata::machines;

/// t(0.975, df), the two-sided 95 % quantile of Student's t with `df` degrees of freedom (statrs'
/// inverse CDF); NaN for df = 0.
pub fn t_975(df: usize) -> f64 {
    use statrs::distribution::{ContinuousCDF, StudentsT};
    match StudentsT::new(0.0, 1.0, df as f64) {
        Ok(t) if df > 0 => t.inverse_cdf(0.975),
        _ => f64::NAN,
    }
}

/// Mean and 95 % t interval half-width of `values` (half-width NaN for fewer than two).
pub fn mean_interval(values: &[f64]) -> (f64, f64) {
    let n = values.len();
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    let mean = values.iter().sum::<f64>() / n as f64;
    if n < 2 {
        return (mean, f64::NAN);
    }
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    (mean, t_975(n - 1) * (var / n as f64).sqrt())
}

pub(crate) fn cell(interval: (f64, f64)) -> String {
    interval_text(interval, 3)
}

/// What marks a difference whose 95 % interval excludes 0.
pub(crate) const RESOLVED: &str = "✱";

/// A paired difference and its interval as [`cell`] writes them, marked [`RESOLVED`] where the
/// interval excludes 0 at full precision, which the rounded figures cannot always show.
pub(crate) fn difference_cell(interval: (f64, f64)) -> String {
    difference_text(interval, 3)
}

/// [`difference_cell`] at `digits` decimals.
pub(crate) fn difference_text(interval: (f64, f64), digits: usize) -> String {
    let text = interval_text(interval, digits);
    if resolved(interval) { format!("{text} {RESOLVED}") } else { text }
}

/// Whether a difference's 95 % interval (mean, half-width) excludes 0, at full precision; never
/// without a half-width.
pub(crate) fn resolved((mean, half): (f64, f64)) -> bool {
    half.is_finite() && mean.abs() > half
}

/// A mean and its interval half-width as text at `digits` decimals: "–" without a mean, the mean
/// alone without an interval.
pub(crate) fn interval_text((mean, half): (f64, f64), digits: usize) -> String {
    if mean.is_nan() {
        return "–".to_owned();
    }
    if half.is_nan() {
        format!("{mean:.digits$}")
    } else {
        format!("{mean:.digits$} ± {half:.digits$}")
    }
}

/// The two tables as header and rows: over seeds (and designs), and paired.
fn tables(rows: &[Row]) -> (Vec<Vec<String>>, Vec<Vec<String>>) {
    let groups = variants(rows);
    let mut summary = vec![
        ["scenario", "variant", "cells", "mAP@[.5:.95]", "AP50", "TP ratio"]
            .map(str::to_owned)
            .to_vec(),
    ];
    for (group, label, members) in &groups {
        let of =
            |f: fn(&Row) -> f64| mean_interval(&members.iter().map(|r| f(r)).collect::<Vec<_>>());
        summary.push(vec![
            group.clone(),
            label.clone(),
            members.len().to_string(),
            cell(of(|r| r.results.test.map)),
            cell(of(|r| r.results.test.ap50)),
            cell(of(|r| r.results.test.tp_ratio)),
        ]);
    }
    let mut paired = vec![
        ["scenario", "ours − baseline", "paired on", "Δ mAP", "Δ AP50", "ours ahead (mAP)"]
            .map(str::to_owned)
            .to_vec(),
    ];
    for c in comparisons(rows) {
        let (ahead, of) = c.ahead();
        paired.push(vec![
            c.group.clone(),
            format!("{} − {}", c.ours, c.other),
            c.describe(),
            difference_cell(c.difference(|r| Some(r.results.test.map))),
            difference_cell(c.difference(|r| Some(r.results.test.ap50))),
            format!("{ahead} of {of} {}", c.unit_name()),
        ]);
    }
    (summary, paired)
}

/// Δ mAP of ours against each baseline per illumination (empty when no pair recorded it).
fn light_table(rows: &[Row]) -> Vec<Vec<String>> {
    let mut header = vec!["scenario".to_owned(), "ours − baseline".to_owned()];
    header.extend(LIGHTS.iter().map(|l| format!("Δ mAP {l}")));
    let mut table = vec![header];
    for c in comparisons(rows) {
        if c.pairs.iter().all(|(a, _)| a.results.by_illumination.scores().next().is_none()) {
            continue;
        }
        let mut row = vec![c.group.clone(), format!("{} − {}", c.ours, c.other)];
        row.extend(LIGHTS.iter().map(|l| difference_cell(c.difference(|r| light_map(r, *l)))));
        table.push(row);
    }
    if table.len() == 1 { Vec::new() } else { table }
}

/// Per design (panel only): each variant's mean over its seeds.
fn design_table(rows: &[Row]) -> Vec<Vec<String>> {
    if rows.iter().all(|r| r.design.is_empty()) {
        return Vec::new();
    }
    let mut table = vec![
        ["scenario", "design", "sensor, f, pitch", "variant", "seeds", "mAP", "AP50"]
            .map(str::to_owned)
            .to_vec(),
    ];
    let mut keys: Vec<(&str, &str, &str)> = Vec::new();
    for r in rows {
        let k = (r.group.as_str(), r.design.as_str(), r.label.as_str());
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    keys.sort_by_key(|(g, d, _)| (rows.iter().position(|r| r.group == *g), *d));
    for (group, design, label) in keys {
        let of: Vec<&Row> = rows
            .iter()
            .filter(|r| r.group == group && r.design == design && r.label == label)
            .collect();
        let d = &of[0].results.design;
        let mean =
            |f: fn(&Row) -> f64| cell(mean_interval(&of.iter().map(|r| f(r)).collect::<Vec<_>>()));
        table.push(vec![
            group.to_owned(),
            design.to_owned(),
            format!("{}, {} mm, {} µm", d.sensor, d.lens_label(), d.pixel_pitch_um),
            label.to_owned(),
            of.len().to_string(),
            mean(|r| r.results.test.map),
            mean(|r| r.results.test.ap50),
        ]);
    }
    table
}

fn markdown_table(t: &[Vec<String>]) -> String {
    let mut md = String::new();
    for (i, row) in t.iter().enumerate() {
        let _ = writeln!(md, "| {} |", row.join(" | "));
        if i == 0 {
            let _ = writeln!(md, "|{}", "---|".repeat(row.len()));
        }
    }
    md
}

fn html_table(t: &[Vec<String>]) -> String {
    let mut h = String::from("<table>\n");
    for (i, row) in t.iter().enumerate() {
        let tag = if i == 0 { "th" } else { "td" };
        h.push_str("<tr>");
        for c in row {
            let _ = write!(h, "<{tag}>{}</{tag}>", escape(c));
        }
        h.push_str("</tr>\n");
    }
    h.push_str("</table>\n");
    h
}

const EXPLAIN: &str = "Mean ± 95 % interval, Student's t (statrs' quantile) over the cells of \
    a variant (test scenes fixed, so the interval holds the run-to-run variation and, in a panel, \
    the spread between designs). Paired: ours − baseline on the same seed and, in a panel, the \
    same design; over seeds, or in a panel per design the mean over its seeds and the t interval \
    over designs. An interval that excludes 0 is a difference these cells resolve; in the \
    paired tables ✱ marks one, read at full precision.";

/// A titled table in Markdown and HTML, a level-3 heading after a blank line.
fn section(md: &mut String, html: &mut String, title: &str, note: &str, table: &[Vec<String>]) {
    md.push('\n');
    titled_table(md, html, 3, title, note, table);
}

/// A table under a heading of `level` (Markdown `#`s, HTML `<hN>`) with an optional note.
pub(crate) fn titled_table(
    md: &mut String,
    html: &mut String,
    level: usize,
    title: &str,
    note: &str,
    table: &[Vec<String>],
) {
    md.push_str(&format!("{} {title}\n\n", "#".repeat(level)));
    html.push_str(&format!("<h{level}>{}</h{level}>\n", escape(title)));
    if !note.is_empty() {
        md.push_str(&format!("{note}\n\n"));
        html.push_str(&format!("<p class=\"meta\">{}</p>\n", escape(note)));
    }
    md.push_str(&markdown_table(table));
    html.push_str(&html_table(table));
}

const POOLED: &str = "Per seed (in a panel, per design) the mean over the scenarios of ours − \
    baseline, then the t interval over the seeds (designs) present in every one of them: each \
    counted once, however many scenarios it ran in.";

/// The over-seeds section of an experiment report, Markdown and HTML; empty when no variant has
/// more than one cell.
pub fn seeds_sections(rows: &[Row]) -> (String, String) {
    if variants(rows).iter().all(|(_, _, m)| m.len() < 2) {
        return (String::new(), String::new());
    }
    let (summary, paired) = tables(rows);
    let panel = rows.iter().any(|r| !r.design.is_empty());
    let title = if panel { "Over designs and seeds" } else { "Over seeds" };
    let rests = rests_on(rows);
    let mut md = format!("## {title}\n\n{rests}{EXPLAIN}\n\n");
    md.push_str(&markdown_table(&summary));
    let mut html = format!(
        "<h2>{title}</h2>\n<p>{}</p>\n<p class=\"meta\">{}</p>\n",
        escape(rests.trim().trim_start_matches("**What the answer rests on.**").trim()),
        escape(EXPLAIN)
    );
    html.push_str(&html_table(&summary));
    if paired.len() > 1 {
        section(&mut md, &mut html, "Ours paired with each baseline", "", &paired);
    }
    let pooled = pooled::pooled_table(rows);
    if !pooled.is_empty() {
        section(&mut md, &mut html, "Pooled over scenarios", POOLED, &pooled);
    }
    let lights = light_table(rows);
    if !lights.is_empty() {
        let note = "The same test frames split by the episode's light (episode e drives day, \
            night, tunnel, cycle for e mod 4); paired and aggregated as above.";
        section(&mut md, &mut html, "Paired, by illumination", note, &lights);
    }
    let bands = strata::band_table(rows);
    if !bands.is_empty() {
        section(&mut md, &mut html, "Paired, by distance band", BANDS, &bands);
    }
    let (machines, split) = strata::machine_tables(rows);
    if !machines.is_empty() {
        section(&mut md, &mut html, "Machine types", MACHINES, &machines);
        section(&mut md, &mut html, "Paired, by machine type", MACHINE_PAIRS, &split);
    }
    let designs = design_table(rows);
    if !designs.is_empty() {
        section(&mut md, &mut html, "Per design", "Each variant's mean over its seeds.", &designs);
    }
    md.push('\n');
    (md, html)
}

const BANDS: &str = "The same test frames scored per distance band of the reference objects \
    (mAP over a band's objects; false positives, having no distance, count in every band); paired \
    and aggregated as above. A band without objects in a pair's tests leaves the pair out.";

const MACHINES: &str = "The cells ran on more than one machine type. Training repeats bit for \
    bit on one machine type, not across types: a grid resumed on another CPU mixes two \
    populations of runs.";

const MACHINE_PAIRS: &str = "Each comparison restricted to the pairs whose two cells ran on one \
    machine type (per type), and to those that ran on two: a difference that holds within each \
    type is not a machine effect.";

/// The over-seeds section again for a follow-up town (`rows` built from each cell's
/// `results-town<K>.json`): the same cells on another sample of test scenes, paired as on the
/// test town. Empty when no variant has more than one cell there.
pub fn town_sections(town: u64, rows: &[Row]) -> (String, String) {
    if variants(rows).iter().all(|(_, _, m)| m.len() < 2) {
        return (String::new(), String::new());
    }
    let (summary, paired) = tables(rows);
    let title = format!("Town {town}: the same cells on another town of the test family");
    let note = format!(
        "Every cell tested again on town {town} (`[follow_up] towns`): the same designs, \
         detectors and controllers on other scenes; {} cells there. Intervals and pairing as \
         on the test town.",
        rows.len()
    );
    let mut md = format!("## {title}\n\n{note}\n\n");
    md.push_str(&markdown_table(&summary));
    let mut html =
        format!("<h2>{}</h2>\n<p class=\"meta\">{}</p>\n", escape(&title), escape(&note));
    html.push_str(&html_table(&summary));
    if paired.len() > 1 {
        section(
            &mut md,
            &mut html,
            &format!("Town {town}: ours paired with each baseline"),
            "",
            &paired,
        );
    }
    let pooled = pooled::pooled_table(rows);
    if !pooled.is_empty() {
        section(
            &mut md,
            &mut html,
            &format!("Town {town}: pooled over scenarios"),
            POOLED,
            &pooled,
        );
    }
    let lights = light_table(rows);
    if !lights.is_empty() {
        section(&mut md, &mut html, &format!("Town {town}: paired, by illumination"), "", &lights);
    }
    let designs = design_table(rows);
    if !designs.is_empty() {
        let title = format!("Town {town}: per design");
        section(&mut md, &mut html, &title, "Each variant's mean over its seeds.", &designs);
    }
    md.push('\n');
    (md, html)
}

#[cfg(test)]
mod tests;
