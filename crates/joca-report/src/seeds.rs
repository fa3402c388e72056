//! Results over seeds: each variant's mean with a 95 % interval, and ours paired with every
//! baseline of the same scenario on the same seeds.
//!
//! The interval is Student's t over seeds: mean ± t(0.975, n − 1) · s / √n, with s the sample
//! standard deviation of the n seeds' values. It covers the run-to-run variation that a seed
//! changes (initial designs, GA draws, training noise); every seed is tested on the same test
//! scenes, so the test scenes' own sampling variation is not in it. The paired comparison takes
//! per seed the difference ours − baseline (same seed, same test scenes) and gives its mean, its
//! t interval and on how many seeds ours was ahead.

use crate::table::{Row, escape};
use joca_record::Method;
use std::fmt::Write as _;

/// Two-sided 95 % quantiles of Student's t, t(0.975, df) for df = 1…30.
const T_975: [f64; 30] = [
    12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
    2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
    2.052, 2.048, 2.045, 2.042,
];

/// t(0.975, df); the normal quantile 1.960 beyond df = 30 (within 2 % of t there).
pub fn t_975(df: usize) -> f64 {
    match df {
        0 => f64::NAN,
        1..=30 => T_975[df - 1],
        _ => 1.960,
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

fn cell((mean, half): (f64, f64)) -> String {
    if half.is_nan() { format!("{mean:.3}") } else { format!("{mean:.3} ± {half:.3}") }
}

/// The variants of each group in order, each with its rows (one per seed).
fn variants(rows: &[Row]) -> Vec<(String, String, Vec<&Row>)> {
    let mut out: Vec<(String, String, Vec<&Row>)> = Vec::new();
    for r in rows {
        match out.iter_mut().find(|(g, l, _)| *g == r.group && *l == r.label) {
            Some(v) => v.2.push(r),
            None => out.push((r.group.clone(), r.label.clone(), vec![r])),
        }
    }
    out
}

/// The two tables as header and rows: over seeds, and paired.
fn tables(rows: &[Row]) -> (Vec<Vec<String>>, Vec<Vec<String>>) {
    let groups = variants(rows);
    let mut summary = vec![
        ["scenario", "variant", "seeds", "mAP@[.5:.95]", "AP50", "TP ratio"]
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
        ["scenario", "ours − baseline", "paired seeds", "Δ mAP", "Δ AP50", "ours ahead (mAP)"]
            .map(str::to_owned)
            .to_vec(),
    ];
    for (group, label, ours) in &groups {
        if !ours.iter().all(|r| r.results.method == Method::Joca) {
            continue;
        }
        for (g, other, theirs) in &groups {
            if g != group || other == label {
                continue;
            }
            let pairs: Vec<(&Row, &Row)> = ours
                .iter()
                .filter_map(|a| {
                    theirs.iter().find(|b| b.results.seed == a.results.seed).map(|b| (*a, *b))
                })
                .collect();
            if pairs.is_empty() {
                continue;
            }
            let diff = |f: fn(&Row) -> f64| {
                mean_interval(&pairs.iter().map(|(a, b)| f(a) - f(b)).collect::<Vec<_>>())
            };
            let ahead = pairs.iter().filter(|(a, b)| a.results.test.map > b.results.test.map);
            paired.push(vec![
                group.clone(),
                format!("{label} − {other}"),
                pairs.len().to_string(),
                cell(diff(|r| r.results.test.map)),
                cell(diff(|r| r.results.test.ap50)),
                format!("{} of {}", ahead.count(), pairs.len()),
            ]);
        }
    }
    (summary, paired)
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

const EXPLAIN: &str = "Mean ± 95 % interval, Student's t over seeds (test scenes fixed, so the \
    interval holds the run-to-run variation only). Paired: per seed ours − baseline on the same \
    seed and test scenes; an interval that excludes 0 is a difference these seeds resolve.";

/// The over-seeds section of an experiment report, Markdown and HTML; empty when no variant has
/// more than one seed.
pub fn seeds_sections(rows: &[Row]) -> (String, String) {
    if variants(rows).iter().all(|(_, _, m)| m.len() < 2) {
        return (String::new(), String::new());
    }
    let (summary, paired) = tables(rows);
    let mut md = format!("## Over seeds\n\n{EXPLAIN}\n\n");
    md.push_str(&markdown_table(&summary));
    let mut html = format!("<h2>Over seeds</h2>\n<p class=\"meta\">{}</p>\n", escape(EXPLAIN));
    html.push_str(&html_table(&summary));
    if paired.len() > 1 {
        md.push_str("\n### Ours paired with each baseline\n\n");
        md.push_str(&markdown_table(&paired));
        html.push_str("<h3>Ours paired with each baseline</h3>\n");
        html.push_str(&html_table(&paired));
    }
    md.push('\n');
    (md, html)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_t_interval_matches_a_hand_computation() {
        // 0.1, 0.2, 0.3: mean 0.2, s = 0.1, half-width t(0.975, 2)·0.1/√3 = 4.303·0.057735.
        let (m, h) = mean_interval(&[0.1, 0.2, 0.3]);
        assert!((m - 0.2).abs() < 1e-12);
        assert!((h - 4.303 * 0.1 / 3f64.sqrt()).abs() < 1e-12, "{h}");
        assert!(mean_interval(&[0.5]).1.is_nan());
        assert_eq!(t_975(100), 1.960);
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
        let h = 4.303 * 0.02 / 3f64.sqrt();
        assert_eq!(summary[1][..3], ["Calibrated", "Ours", "3"]);
        assert_eq!(summary[1][3], format!("0.320 ± {h:.3}"));
        // Differences 0.05, 0.01, 0.01: mean 0.0233, s = 0.02309.
        assert_eq!(paired.len(), 2);
        assert_eq!(paired[1][1], "Ours − FLIR");
        let (m, hw) = mean_interval(&[0.05, 0.01, 0.01]);
        assert!((m - 0.07 / 3.0).abs() < 1e-12);
        assert_eq!(paired[1][3], format!("{m:.3} ± {hw:.3}"));
        assert_eq!(paired[1][5], "3 of 3");
        let (md, html) = seeds_sections(&rows);
        assert!(md.contains("## Over seeds") && md.contains("Student's t"));
        assert!(html.contains("<th>Δ mAP</th>"));
        // One seed per variant: no section.
        assert_eq!(seeds_sections(&rows[..1]).0, "");
    }
}
