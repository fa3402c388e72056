//! How steadily each variant's NeuralAE held exposure × gain where the showcases' light held still
//! ([`crate::sections::steady_mean`]), per panel design and town, and each variant against the
//! scenario's first variant paired over the designs: a zig-zag is a property of a design's
//! trained controller, so the comparison that resolves it is the paired one.

use crate::seeds::{interval_text, mean_interval};
use crate::swap::{SwapCell, night_over_day, town_name};

/// One cell's steadiness: where it sits and NeuralAE's and its AverageAE re-test's stops a frame.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Steady<'a> {
    /// Scenario.
    pub group: &'a str,
    /// Variant label.
    pub label: &'a str,
    /// Panel design id.
    pub design: &'a str,
    /// The test family's town (0: the test town).
    pub town: u64,
    /// NeuralAE's mean move in steady light, stops a frame.
    pub neural: Option<f64>,
    /// AverageAE's (mid-grey) on the same design, detector and scenes.
    pub average: Option<f64>,
    /// NeuralAE's night ÷ day exposure × gain over the test: ~1 for a controller pinned in
    /// every light, whatever its steadiness.
    pub neural_span: Option<f64>,
    /// AverageAE's.
    pub average_span: Option<f64>,
}

impl<'a> Steady<'a> {
    fn of(c: &SwapCell<'a>) -> Self {
        Self {
            group: c.group,
            label: c.label,
            design: c.design,
            town: c.town,
            neural: crate::sections::steady_mean(&c.neural.showcases),
            average: crate::sections::steady_mean(&c.average.showcases),
            neural_span: night_over_day(&c.neural.results),
            average_span: night_over_day(&c.average.results),
        }
    }
}

/// The panel's steadiness per design and paired over designs, as level-3 sections of an
/// experiment's report, where a scenario has two variants.
pub(crate) fn sections(md: &mut String, html: &mut String, swaps: &[SwapCell<'_>]) {
    let (per_design, paired) = steadiness_tables(swaps);
    for (title, note, table) in
        [(PER_DESIGN, PER_DESIGN_NOTE, per_design), (PAIRED, PAIRED_NOTE, paired)]
    {
        if !table.is_empty() {
            crate::seeds::titled_table(md, html, 3, title, note, &table);
            md.push('\n');
        }
    }
}

/// Both tables of the panel cells among `cells` (empty where no scenario has a panel with two
/// variants).
fn steadiness_tables(cells: &[SwapCell<'_>]) -> (Vec<Vec<String>>, Vec<Vec<String>>) {
    let steady: Vec<Steady<'_>> =
        cells.iter().filter(|c| !c.design.is_empty()).map(Steady::of).collect();
    (per_design(&steady), paired(&steady))
}

/// The distinct values of `f` over `items`, in order of first appearance.
fn distinct<'a, T: PartialEq + Copy>(items: &[Steady<'a>], f: impl Fn(&Steady<'a>) -> T) -> Vec<T> {
    let mut out = Vec::new();
    for s in items {
        let v = f(s);
        if !out.contains(&v) {
            out.push(v);
        }
    }
    out
}

/// The mean over a design's seeds of `f` in `(group, label, design, town)`.
fn design_mean(
    items: &[Steady<'_>],
    (group, label, design, town): (&str, &str, &str, u64),
    f: impl Fn(&Steady<'_>) -> Option<f64>,
) -> Option<f64> {
    let v: Vec<f64> = items
        .iter()
        .filter(|s| s.group == group && s.label == label && s.design == design && s.town == town)
        .filter_map(f)
        .collect();
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// A scenario's variants, designs and towns (ascending).
struct Scenario<'a> {
    group: &'a str,
    labels: Vec<&'a str>,
    designs: Vec<&'a str>,
    towns: Vec<u64>,
}

/// Scenarios with at least two variants.
fn scenarios<'a>(items: &[Steady<'a>]) -> Vec<Scenario<'a>> {
    let mut out = Vec::new();
    for group in distinct(items, |s| s.group) {
        let members: Vec<Steady<'a>> = items.iter().filter(|s| s.group == group).cloned().collect();
        let labels = distinct(&members, |s| s.label);
        if labels.len() < 2 {
            continue;
        }
        let mut towns = distinct(&members, |s| s.town);
        towns.sort_unstable();
        out.push(Scenario { group, labels, designs: distinct(&members, |s| s.design), towns });
    }
    out
}

fn number(v: Option<f64>) -> String {
    v.map_or_else(|| "–".to_owned(), |x| format!("{x:.2}"))
}

/// Stops a frame, with the night ÷ day span in brackets where known.
fn steady_cell(stops: Option<f64>, span: Option<f64>) -> String {
    match (stops, span) {
        (Some(_), Some(x)) if x < 9.95 => format!("{} ({x:.1}×)", number(stops)),
        (Some(_), Some(x)) => format!("{} ({x:.0}×)", number(stops)),
        _ => number(stops),
    }
}

/// Per scenario, town and design: each variant's NeuralAE, and the first variant's AverageAE
/// re-test, in stops a frame.
fn per_design(items: &[Steady<'_>]) -> Vec<Vec<String>> {
    let mut table = Vec::new();
    for Scenario { group, labels, designs, towns } in scenarios(items) {
        if table.is_empty() {
            let mut header = vec!["scenario".to_owned(), "test on".into(), "design".into()];
            header.extend(labels.iter().map(|l| format!("NeuralAE: {l}")));
            header.push(format!("AverageAE mid-grey ({})", labels[0]));
            table.push(header);
        }
        for &town in &towns {
            for &design in &designs {
                let mut row = vec![group.to_owned(), town_name(town), design.to_owned()];
                for &label in &labels {
                    let at = (group, label, design, town);
                    row.push(steady_cell(
                        design_mean(items, at, |s| s.neural),
                        design_mean(items, at, |s| s.neural_span),
                    ));
                }
                let first = (group, labels[0], design, town);
                row.push(steady_cell(
                    design_mean(items, first, |s| s.average),
                    design_mean(items, first, |s| s.average_span),
                ));
                table.push(row);
            }
        }
    }
    table
}

/// Per scenario, town and later variant: its NeuralAE's stops a frame − the first variant's,
/// per design, mean ± 95 % t interval over the designs where both finished.
fn paired(items: &[Steady<'_>]) -> Vec<Vec<String>> {
    let mut table = Vec::new();
    for Scenario { group, labels, designs, towns } in scenarios(items) {
        if table.is_empty() {
            let header = ["scenario", "test on", "variant − first", "designs", "steadier on"];
            let mut header: Vec<String> = header.map(str::to_owned).to_vec();
            header.push("Δ stops a frame".into());
            table.push(header);
        }
        for &town in &towns {
            for &label in &labels[1..] {
                let d: Vec<f64> = designs
                    .iter()
                    .filter_map(|&design| {
                        let of = |l| design_mean(items, (group, l, design, town), |s| s.neural);
                        Some(of(label)? - of(labels[0])?)
                    })
                    .collect();
                let steadier = d.iter().filter(|x| **x < 0.0).count();
                table.push(vec![
                    group.to_owned(),
                    town_name(town),
                    format!("{label} − {}", labels[0]),
                    d.len().to_string(),
                    format!("{steadier} of {}", d.len()),
                    interval_text(mean_interval(&d), 2),
                ]);
            }
        }
    }
    table
}

/// The per-design table's title.
pub const PER_DESIGN: &str = "Steady light, per design";
/// The per-design table's note.
pub const PER_DESIGN_NOTE: &str = "How far exposure × linear gain moved from frame to frame where \
    the showcases' light held still (from 0.5 s after it last changed), stops a frame, each \
    design's mean over its seeds: NeuralAE of each variant, and AverageAE (mid-grey) re-tested \
    on the first variant's design, detector and scenes. In brackets, night ÷ day mean exposure × \
    gain over the test (the light differs ~1000×): a controller pinned in every light is steady \
    and near 1×.";
/// The paired table's title.
pub const PAIRED: &str = "Steady light, paired over designs";
/// The paired table's note.
pub const PAIRED_NOTE: &str = "Each variant's NeuralAE against the first variant's on the same \
    design and town: the difference in stops a frame moved in steady light (negative: steadier), \
    mean ± 95 % t interval over the designs where both finished.";

#[cfg(test)]
mod tests {
    use super::*;

    fn s<'a>(label: &'a str, design: &'a str, town: u64, neural: f64) -> Steady<'a> {
        Steady {
            group: "cal",
            label,
            design,
            town,
            neural: Some(neural),
            average: Some(0.02),
            neural_span: None,
            average_span: None,
        }
    }

    #[test]
    fn variants_are_paired_per_design_and_town() {
        let items = vec![
            s("none", "a", 0, 1.0),
            s("none", "b", 0, 0.5),
            s("none", "c", 0, 0.3),
            s("cost", "a", 0, 0.2),
            s("cost", "b", 0, 0.1),
            s("cost", "c", 0, 0.4),
            s("none", "a", 2, 0.6),
            s("cost", "a", 2, 0.1),
        ];
        let per = per_design(&items);
        assert_eq!(per[0][3..], ["NeuralAE: none", "NeuralAE: cost", "AverageAE mid-grey (none)"]);
        assert_eq!(per[1], ["cal", "test town", "a", "1.00", "0.20", "0.02"]);
        // Spans where recorded: a pinned controller's 1.0× beside mid-grey's 40×.
        let mut spanned = items.clone();
        spanned[0].neural_span = Some(1.04);
        spanned[0].average_span = Some(40.2);
        assert_eq!(per_design(&spanned)[1][3..], ["1.00 (1.0×)", "0.20", "0.02 (40×)"]);
        // Town 2 has design a only; b and c read "–".
        assert_eq!(per[5], ["cal", "town 2", "b", "–", "–", "–"]);
        let p = paired(&items);
        // Differences −0.8, −0.4, +0.1: mean −0.367, sd 0.451, t(2) = 4.303, half 1.120.
        assert_eq!(p[1], ["cal", "test town", "cost − none", "3", "2 of 3", "-0.37 ± 1.12"]);
        assert_eq!(p[2], ["cal", "town 2", "cost − none", "1", "1 of 1", "-0.50"]);
    }

    #[test]
    fn a_scenario_with_one_variant_has_no_rows() {
        let items = vec![s("none", "a", 0, 1.0), s("none", "b", 0, 0.5)];
        assert!(per_design(&items).is_empty() && paired(&items).is_empty());
    }
}
