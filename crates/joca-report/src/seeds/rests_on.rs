//! "What the answer rests on": the block every experiment report opens its results with.

use crate::paired::comparisons;
use crate::table::Row;

/// "What the answer rests on": seeds, designs, test frames and objects per class, and which
/// paired differences these cells resolve.
pub(super) fn rests_on(rows: &[Row]) -> String {
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
