//! Ours against a baseline pooled over the scenarios both ran in: per unit (a seed, or in a panel
//! a design) the mean over scenarios of ours − baseline, then the t interval over the units
//! present in every one of those scenarios — Table 1's "over the five scenarios" as one number
//! whose interval counts each seed (or design) once.

use crate::paired::{Comparison, comparisons};
use crate::seeds::{difference_cell, mean_interval};
use crate::table::Row;

/// The pooled table (header first); empty when no pair of variants meets in two scenarios.
pub fn pooled_table(rows: &[Row]) -> Vec<Vec<String>> {
    let all = comparisons(rows);
    let mut pairs: Vec<(&str, &str)> = Vec::new();
    for c in &all {
        if !pairs.contains(&(c.ours.as_str(), c.other.as_str())) {
            pairs.push((&c.ours, &c.other));
        }
    }
    let mut table = vec![
        ["ours − baseline", "scenarios", "pooled over", "Δ mAP", "Δ AP50", "ours ahead (mAP)"]
            .map(str::to_owned)
            .to_vec(),
    ];
    for (ours, other) in pairs {
        let of: Vec<&Comparison<'_>> =
            all.iter().filter(|c| c.ours == ours && c.other == other).collect();
        if of.len() < 2 {
            continue;
        }
        let map = pooled_units(&of, |r| r.results.test.map);
        if map.is_empty() {
            continue;
        }
        let ap50 = pooled_units(&of, |r| r.results.test.ap50);
        let unit = if of[0].panel() { "designs" } else { "seeds" };
        table.push(vec![
            format!("{ours} − {other}"),
            of.len().to_string(),
            format!("{} {unit}", map.len()),
            difference_cell(mean_interval(&map)),
            difference_cell(mean_interval(&ap50)),
            format!("{} of {} {unit}", map.iter().filter(|d| **d > 0.0).count(), map.len()),
        ]);
    }
    if table.len() < 2 { Vec::new() } else { table }
}

/// Per unit found in every comparison, the mean over the comparisons (scenarios) of that unit's
/// difference in `f`.
fn pooled_units(of: &[&Comparison<'_>], f: impl Fn(&Row) -> f64 + Copy) -> Vec<f64> {
    let keyed: Vec<Vec<(String, f64)>> = of.iter().map(|c| unit_differences(c, f)).collect();
    let Some(first) = keyed.first() else { return Vec::new() };
    first
        .iter()
        .filter_map(|(key, _)| {
            let values: Vec<f64> = keyed
                .iter()
                .map(|units| units.iter().find(|(k, _)| k == key).map(|(_, v)| *v))
                .collect::<Option<Vec<f64>>>()?;
            Some(values.iter().sum::<f64>() / values.len() as f64)
        })
        .collect()
}

/// A comparison's differences per unit: per seed, or in a panel per design (mean over seeds).
fn unit_differences(c: &Comparison<'_>, f: impl Fn(&Row) -> f64) -> Vec<(String, f64)> {
    let mut out: Vec<(String, Vec<f64>)> = Vec::new();
    for (a, b) in &c.pairs {
        let key = if c.panel() { a.design.clone() } else { a.results.seed.to_string() };
        let d = f(a) - f(b);
        match out.iter_mut().find(|(k, _)| *k == key) {
            Some((_, v)) => v.push(d),
            None => out.push((key, vec![d])),
        }
    }
    out.into_iter().map(|(k, v)| (k, v.iter().sum::<f64>() / v.len() as f64)).collect()
}

/// Ours against each baseline pooled over towns (header first): per unit (seed, or design in a
/// panel) the mean over the test town and every follow-up town of its difference, then the t
/// interval over the units present on all of them — a cell's towns share its training, so they
/// are not independent draws. Empty without follow-up towns.
pub fn pooled_towns_table(test: &[Row], towns: &[(u64, Vec<Row>)]) -> Vec<Vec<String>> {
    if towns.is_empty() {
        return Vec::new();
    }
    let on_towns: Vec<Vec<Comparison<'_>>> = towns.iter().map(|(_, r)| comparisons(r)).collect();
    let mut table = vec![
        [
            "scenario",
            "ours − baseline",
            "towns",
            "pooled over",
            "Δ mAP",
            "Δ AP50",
            "ours ahead (mAP)",
            "r, test town ~ first follow-up",
        ]
        .map(str::to_owned)
        .to_vec(),
    ];
    for c in comparisons(test) {
        let same =
            |o: &&Comparison<'_>| o.group == c.group && o.ours == c.ours && o.other == c.other;
        let mut of: Vec<&Comparison<'_>> = vec![&c];
        of.extend(on_towns.iter().filter_map(|cs| cs.iter().find(same)));
        if of.len() < 2 {
            continue;
        }
        let map = pooled_units(&of, |r| r.results.test.map);
        let ap50 = pooled_units(&of, |r| r.results.test.ap50);
        let unit = if c.panel() { "designs" } else { "seeds" };
        table.push(vec![
            c.group.clone(),
            format!("{} − {}", c.ours, c.other),
            of.len().to_string(),
            format!("{} {unit}", map.len()),
            difference_cell(mean_interval(&map)),
            difference_cell(mean_interval(&ap50)),
            format!("{} of {} {unit}", map.iter().filter(|d| **d > 0.0).count(), map.len()),
            correlation(of[0], of[1], |r| r.results.test.map)
                .map_or_else(|| "–".to_owned(), |r| format!("{r:.2}")),
        ]);
    }
    if table.len() < 2 { Vec::new() } else { table }
}

/// Pearson's r between two comparisons' per-unit differences in `f`, over the units both have
/// (do the same designs lead on both towns?); `None` with fewer than three units or no spread.
fn correlation(
    a: &Comparison<'_>,
    b: &Comparison<'_>,
    f: impl Fn(&Row) -> f64 + Copy,
) -> Option<f64> {
    let other = unit_differences(b, f);
    let pairs: Vec<(f64, f64)> = unit_differences(a, f)
        .into_iter()
        .filter_map(|(k, x)| other.iter().find(|(o, _)| *o == k).map(|(_, y)| (x, *y)))
        .collect();
    if pairs.len() < 3 {
        return None;
    }
    let n = pairs.len() as f64;
    let mx = pairs.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pairs.iter().map(|p| p.1).sum::<f64>() / n;
    let sxy: f64 = pairs.iter().map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = pairs.iter().map(|(x, _)| (x - mx).powi(2)).sum();
    let syy: f64 = pairs.iter().map(|(_, y)| (y - my).powi(2)).sum();
    (sxx > 0.0 && syy > 0.0).then(|| sxy / (sxx * syy).sqrt())
}
