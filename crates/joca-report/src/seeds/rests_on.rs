//! "What the answer rests on": the block every experiment report opens its results with.

use crate::paired::comparisons;
use crate::table::Row;
use joca_core::compute::{CpuKernels, Denormals};

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
    md.push_str(&machines(rows));
    let (mut resolved, mut open) = (Vec::new(), Vec::new());
    for c in comparisons(rows) {
        let (m, h) = c.difference(|r| Some(r.results.test.map));
        let spread = if h.is_finite() {
            format!(" ± {h:.3}")
        } else {
            ", one pair: no interval".to_owned()
        };
        let across = c.pairs.iter().filter(|(a, b)| machine(a) != machine(b)).count();
        let mixed = if across > 0 {
            format!("; {across} of {} pairs across machine types", c.pairs.len())
        } else {
            String::new()
        };
        let what = format!("{} − {} ({}, {m:+.3}{spread}{mixed})", c.ours, c.other, c.group);
        if crate::seeds::resolved((m, h)) {
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

/// The machine type a cell's numbers came from: everything the run report's machine line
/// ([`crate::sections::machine_line`]) names — CPU (model name, family and model numbers,
/// widest vector units), libtorch's kernels and subnormal handling, each named only where it
/// is not joca's default — and the precision its perturbed frames were scored in. Training
/// repeats bit for bit only within one.
pub(super) fn machine(r: &Row) -> String {
    let r = &r.results;
    let mut m = if r.cpu.is_empty() { "CPU not recorded".to_owned() } else { r.cpu.clone() };
    if let Some(gpu) = &r.device {
        m.push_str(&format!(", the networks on {gpu}"));
    }
    if r.cpu_kernels == Some(CpuKernels::Avx2) {
        m.push_str(", libtorch's avx2 kernels");
    }
    if r.denormals == Some(Denormals::Keep) {
        m.push_str(", subnormal floats kept");
    }
    if let Some(p) = r.scoring_precision {
        m.push_str(&format!(", scoring in {}", p.name()));
    }
    m
}

/// One sentence naming the machine types the cells ran on, with counts where there are several.
fn machines(rows: &[Row]) -> String {
    let mut kinds: Vec<(String, usize)> = Vec::new();
    for r in rows {
        let m = machine(r);
        match kinds.iter_mut().find(|(k, _)| *k == m) {
            Some((_, n)) => *n += 1,
            None => kinds.push((m, 1)),
        }
    }
    match kinds.as_slice() {
        [] => String::new(),
        [(only, _)] => format!(" Every cell ran on one machine type ({only})."),
        _ => {
            let list: Vec<String> = kinds
                .iter()
                .map(|(k, n)| format!("{k}: {n} cell{}", if *n == 1 { "" } else { "s" }))
                .collect();
            format!(
                " Cells ran on {} machine types ({}); a pair across types also differs by the \
                 machine's rounding (and scoring precision), not only by the method.",
                kinds.len(),
                list.join("; ")
            )
        }
    }
}
