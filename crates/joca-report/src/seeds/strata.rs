//! Ours − baseline split two more ways: by the distance band of the reference objects (mAP over
//! each band's objects, as every run's report lists them), and by the machine type each pair was
//! computed on (training repeats bit for bit on one machine type, not across types, so a grid
//! resumed on another CPU mixes two populations of runs).

use super::rests_on::machine;
use crate::paired::{Comparison, comparisons};
use crate::seeds::difference_cell;
use crate::table::Row;

/// The distance bands of the rows' tests (from the first row that has any), as (from, to) m.
fn bands(rows: &[Row]) -> Vec<(f64, f64)> {
    rows.iter()
        .find(|r| r.results.test_bands.iter().any(|b| b.class_objects.iter().sum::<u64>() > 0))
        .map(|r| r.results.test_bands.iter().map(|b| (b.from_m, b.to_m)).collect())
        .unwrap_or_default()
}

/// The mAP over band `band`'s objects in a row's test (`None`: the band had no objects).
fn band_map(r: &Row, (from, to): (f64, f64)) -> Option<f64> {
    r.results.test_bands.iter().find(|b| b.from_m == from && b.to_m == to)?.map
}

/// Δ mAP of ours against each baseline per distance band (header first); empty when the tests
/// recorded no band (recordings without depth).
pub(super) fn band_table(rows: &[Row]) -> Vec<Vec<String>> {
    let bands = bands(rows);
    if bands.is_empty() {
        return Vec::new();
    }
    let mut header = vec!["scenario".to_owned(), "ours − baseline".to_owned(), "paired on".into()];
    header.extend(bands.iter().map(|(from, to)| format!("Δ mAP {from:.0}–{to:.0} m")));
    let mut table = vec![header];
    for c in comparisons(rows) {
        let mut row = vec![c.group.clone(), format!("{} − {}", c.ours, c.other), c.describe()];
        row.extend(bands.iter().map(|b| difference_cell(c.difference(|r| band_map(r, *b)))));
        table.push(row);
    }
    if table.len() < 2 { Vec::new() } else { table }
}

/// The distinct machine types of `rows`, in order of appearance.
pub(crate) fn machines(rows: &[Row]) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for r in rows {
        let m = machine(r);
        if !out.contains(&m) {
            out.push(m);
        }
    }
    out
}

/// Where the rows' cells ran: each machine type and how many cells ran on it (header first), and
/// every comparison split by whether both members of a pair ran on one type (which) or on two.
/// Empty when every cell ran on one machine type.
pub(super) fn machine_tables(rows: &[Row]) -> (Vec<Vec<String>>, Vec<Vec<String>>) {
    let types = machines(rows);
    if types.len() < 2 {
        return (Vec::new(), Vec::new());
    }
    let mut counts = vec![vec!["machine type".to_owned(), "cells".to_owned()]];
    for t in &types {
        counts.push(vec![t.clone(), rows.iter().filter(|r| machine(r) == *t).count().to_string()]);
    }
    let mut split = vec![
        ["scenario", "ours − baseline", "pairs computed on", "paired on", "Δ mAP", "Δ AP50"]
            .map(str::to_owned)
            .to_vec(),
    ];
    let across = "two machine types".to_owned();
    for c in comparisons(rows) {
        for t in types.iter().chain(std::iter::once(&across)) {
            let pairs: Vec<(&Row, &Row)> = c
                .pairs
                .iter()
                .filter(|(a, b)| {
                    let (ma, mb) = (machine(a), machine(b));
                    if *t == across { ma != mb } else { ma == *t && mb == *t }
                })
                .copied()
                .collect();
            if pairs.is_empty() {
                continue;
            }
            let (group, ours, other) = (c.group.clone(), c.ours.clone(), c.other.clone());
            let of = Comparison { group, ours, other, pairs };
            split.push(vec![
                c.group.clone(),
                format!("{} − {}", c.ours, c.other),
                t.clone(),
                of.describe(),
                difference_cell(of.difference(|r| Some(r.results.test.map))),
                difference_cell(of.difference(|r| Some(r.results.test.ap50))),
            ]);
        }
    }
    (counts, split)
}
