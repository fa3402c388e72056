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

fn cell(interval: (f64, f64)) -> String {
    interval_text(interval, 3)
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
            cell(c.difference(|r| Some(r.results.test.map))),
            cell(c.difference(|r| Some(r.results.test.ap50))),
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
        row.extend(LIGHTS.iter().map(|l| cell(c.difference(|r| light_map(r, *l)))));
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

/// "What the answer rests on": seeds, designs, test frames and objects per class, and which
/// paired differences these cells resolve.
fn rests_on(rows: &[Row]) -> String {
    let mut seeds: Vec<u64> = rows.iter().map(|r| r.results.seed).collect();
    seeds.sort_unstable();
    seeds.dedup();
    let mut designs: Vec<&str> =
        rows.iter().map(|r| r.design.as_str()).filter(|d| !d.is_empty()).collect();
    designs.sort_unstable();
    designs.dedup();
    let frames: Vec<u64> = rows.iter().map(|r| r.results.test.frames).collect();
    let range = |v: &[u64]| {
        let (lo, hi) = (v.iter().min().copied().unwrap_or(0), v.iter().max().copied().unwrap_or(0));
        if lo == hi { lo.to_string() } else { format!("{lo}–{hi}") }
    };
    let objects: Vec<String> = ["vehicle", "walker", "traffic sign"]
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let v: Vec<u64> = rows.iter().map(|r| r.results.test.class_objects[k]).collect();
            format!("{name} {}", range(&v))
        })
        .collect();
    let design_line = if designs.is_empty() {
        "each cell's own design (chosen by its hardware search, or its fixed camera)".to_owned()
    } else {
        format!("{} panel designs ({})", designs.len(), designs.join(", "))
    };
    let seed_list = seeds.iter().map(u64::to_string).collect::<Vec<_>>().join(", ");
    let mut md = format!(
        "**What the answer rests on.** {} cells; seeds {seed_list}; {design_line}; {} test \
         frames per cell, the same test scenes for every cell; reference objects per cell (summed \
         over frames): {}.",
        rows.len(),
        range(&frames),
        objects.join(", ")
    );
    let (mut resolved, mut open) = (Vec::new(), Vec::new());
    for c in comparisons(rows) {
        let (m, h) = c.difference(|r| Some(r.results.test.map));
        let spread = if h.is_finite() {
            format!(" ± {h:.3}")
        } else {
            ", one pair: no interval".to_owned()
        };
        let what = format!("{} − {} ({}, {m:+.3}{spread})", c.ours, c.other, c.group);
        if h.is_finite() && (m - h > 0.0 || m + h < 0.0) {
            resolved.push(what);
        } else {
            open.push(what);
        }
    }
    if !resolved.is_empty() || !open.is_empty() {
        let list = |v: &[String]| if v.is_empty() { "none".to_owned() } else { v.join("; ") };
        md.push_str(&format!(
            " Resolved (95 % interval of Δ mAP excludes 0): {}. Not resolved: {}.",
            list(&resolved),
            list(&open)
        ));
    }
    md.push_str("\n\n");
    md
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
    over designs. An interval that excludes 0 is a difference these cells resolve.";

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
    let lights = light_table(rows);
    if !lights.is_empty() {
        let note = "The same test frames split by the episode's light (episode e drives day, \
            night, tunnel, cycle for e mod 4); paired and aggregated as above.";
        section(&mut md, &mut html, "Paired, by illumination", note, &lights);
    }
    let designs = design_table(rows);
    if !designs.is_empty() {
        section(&mut md, &mut html, "Per design", "Each variant's mean over its seeds.", &designs);
    }
    md.push('\n');
    (md, html)
}

#[cfg(test)]
mod tests {
    use super::*;
    use joca_record::Method;

    #[test]
    fn the_t_interval_matches_a_hand_computation() {
        // 0.1, 0.2, 0.3: mean 0.2, s = 0.1, half-width t(0.975, 2)·0.1/√3 = 4.303·0.057735.
        let (m, h) = mean_interval(&[0.1, 0.2, 0.3]);
        assert!((m - 0.2).abs() < 1e-12);
        assert!((h - 4.302_653 * 0.1 / 3f64.sqrt()).abs() < 1e-7, "{h}");
        assert!(mean_interval(&[0.5]).1.is_nan());
        // Published quantiles (e.g. NIST/SEMATECH e-Handbook, Table of t, 1 − α/2 = 0.975).
        for (df, t) in [(1, 12.706_2), (2, 4.302_7), (5, 2.570_6), (10, 2.228_1), (30, 2.042_3)] {
            assert!((t_975(df) - t).abs() < 1e-4, "df {df}: {}", t_975(df));
        }
        assert!((t_975(100) - 1.984).abs() < 1e-3);
        assert!(t_975(0).is_nan());
    }

    #[test]
    fn variants_are_summarised_over_seeds_and_ours_is_paired_by_seed() {
        let row = |label: &str, method: Method, seed: u64, map: f64| {
            let mut results = crate::table::tests::results(map, 0.3, true);
            results.method = method;
            results.seed = seed;
            Row {
                group: "Calibrated".into(),
                label: label.into(),
                cell: format!("{label}-s{seed}"),
                design: String::new(),
                results,
            }
        };
        // Seeds listed out of order for the baseline: pairs are made by seed, not by position.
        let rows = vec![
            row("Ours", Method::Joca, 0, 0.30),
            row("Ours", Method::Joca, 1, 0.34),
            row("Ours", Method::Joca, 2, 0.32),
            row("FLIR", Method::FixedNeural, 2, 0.31),
            row("FLIR", Method::FixedNeural, 0, 0.25),
            row("FLIR", Method::FixedNeural, 1, 0.33),
        ];
        let (summary, paired) = tables(&rows);
        assert_eq!(summary.len(), 3);
        let h = t_975(2) * 0.02 / 3f64.sqrt();
        assert_eq!(summary[1][..3], ["Calibrated", "Ours", "3"]);
        assert_eq!(summary[1][3], format!("0.320 ± {h:.3}"));
        // Differences 0.05, 0.01, 0.01: mean 0.0233, s = 0.02309.
        assert_eq!(paired.len(), 2);
        assert_eq!(paired[1][1], "Ours − FLIR");
        let (m, hw) = mean_interval(&[0.05, 0.01, 0.01]);
        assert!((m - 0.07 / 3.0).abs() < 1e-12);
        assert_eq!(paired[1][3], format!("{m:.3} ± {hw:.3}"));
        assert_eq!(paired[1][5], "3 of 3 seeds");
        assert_eq!(paired[1][2], "3 seeds");
        let (md, html) = seeds_sections(&rows);
        assert!(md.contains("## Over seeds") && md.contains("Student's t"));
        assert!(html.contains("<th>Δ mAP</th>"));
        // One seed per variant: no section.
        assert_eq!(seeds_sections(&rows[..1]).0, "");
    }

    #[test]
    fn a_panel_pairs_on_design_and_seed_and_takes_the_interval_over_designs() {
        let row = |label: &str, method: Method, design: &str, seed: u64, map: f64, night: f64| {
            let mut results = crate::table::tests::results(map, 0.3, false);
            results.method = method;
            results.seed = seed;
            let mut n = results.test;
            n.map = night;
            results.by_illumination.entry(joca_record::Light::Night).or_default().scores = Some(n);
            Row {
                group: "Calibrated".into(),
                label: label.into(),
                cell: format!("{label}-{design}-s{seed}"),
                design: design.into(),
                results,
            }
        };
        let (o, a) = (Method::Joca, Method::TacosAverage);
        // Design "a": ours − AverageAE 0.02 and 0.04 (mean 0.03); "b": −0.01 (one seed); "c":
        // 0.05 and 0.03 (mean 0.04). A baseline cell on another design or seed has no pair.
        let rows = vec![
            row("Ours", o, "a", 0, 0.32, 0.10),
            row("Ours", o, "a", 1, 0.34, 0.12),
            row("Ours", o, "b", 0, 0.20, 0.05),
            row("Ours", o, "c", 0, 0.45, 0.20),
            row("Ours", o, "c", 1, 0.43, 0.20),
            row("AverageAE", a, "a", 1, 0.30, 0.10),
            row("AverageAE", a, "a", 0, 0.30, 0.09),
            row("AverageAE", a, "b", 0, 0.21, 0.06),
            row("AverageAE", a, "c", 0, 0.40, 0.15),
            row("AverageAE", a, "c", 1, 0.40, 0.14),
            row("AverageAE", a, "d", 0, 0.90, 0.90),
        ];
        let (_, paired) = tables(&rows);
        let (m, h) = mean_interval(&[0.03, -0.01, 0.04]);
        assert!((m - 0.02).abs() < 1e-12);
        assert_eq!(paired[1][2], "3 designs × ≤ 2 seeds");
        assert_eq!(paired[1][3], format!("{m:.3} ± {h:.3}"));
        assert_eq!(paired[1][5], "2 of 3 designs");
        // Night: a 0.015 (0.01, 0.02), b −0.01, c 0.055 (0.05, 0.06).
        let lights = light_table(&rows);
        let (m, h) = mean_interval(&[0.015, -0.01, 0.055]);
        assert_eq!(lights[1][3], format!("{m:.3} ± {h:.3}"));
        assert_eq!(lights[1][2], "–", "no day scores recorded: {:?}", lights[1]);
        let designs = design_table(&rows);
        assert_eq!(designs.len(), 1 + 7, "4 designs of AverageAE, 3 of ours");
        let (md, _) = seeds_sections(&rows);
        assert!(md.contains("## Over designs and seeds"), "{md}");
        assert!(md.contains("4 panel designs (a, b, c, d)"), "{md}");
        assert!(md.contains("Not resolved: Ours − AverageAE"), "{md}");
        // A second scenario with one pair (design b): its difference, no interval, counted in
        // the singular.
        let mut more = rows.clone();
        for i in [2, 7] {
            more.push(Row { group: "Blur".into(), ..rows[i].clone() });
        }
        let (_, paired) = tables(&more);
        assert_eq!(paired[2][2], "1 design × 1 seed");
        let (md, _) = seeds_sections(&more);
        assert!(md.contains("(Blur, -0.010, one pair: no interval)"), "{md}");
        assert!(!md.contains("NaN"), "{md}");
    }
}
