//! Does each variant's learned controller earn its place? Every NeuralAE cell ends with AverageAE
//! (mid-grey) driving its own design, detector and test scenes (`results-average-127.5.json`,
//! `test-average-127.5/`), so the controller's effect is measured with the detector held fixed:
//! per cell NeuralAE − AverageAE, averaged over a design's seeds, then a 95 % t interval over the
//! designs (over the seeds outside a panel). Beside it what each controller did: the tunnel
//! exit's fall of exposure × gain within 1 s, night's exposure × gain over day's, its moves in
//! steady light, and day's frame level and clipped share.

use crate::data::RunData;
use crate::paired::LIGHTS;
use crate::seeds::{difference_text, interval_text, mean_interval};
use joca_record::{Light, RunResults};

/// One NeuralAE cell and its AverageAE re-test.
pub struct SwapCell<'a> {
    /// Scenario (group).
    pub group: &'a str,
    /// Variant label.
    pub label: &'a str,
    /// Panel design id (empty outside a panel).
    pub design: &'a str,
    /// The test family's town (0: the test town).
    pub town: u64,
    /// The cell's test there.
    pub neural: RunData,
    /// Its re-test with AverageAE at mid-grey.
    pub average: RunData,
}

/// `f` of NeuralAE − `f` of AverageAE, averaged over each design's cells: one value per unit.
fn units(cells: &[&SwapCell<'_>], f: impl Fn(&RunResults) -> Option<f64>) -> Vec<f64> {
    let mut designs: Vec<(&str, Vec<f64>)> = Vec::new();
    for c in cells {
        let Some(d) = f(&c.neural.results).zip(f(&c.average.results)).map(|(a, b)| a - b) else {
            continue;
        };
        // Outside a panel each cell (seed) is its own unit.
        let key = if c.design.is_empty() { "" } else { c.design };
        match designs.iter_mut().find(|(k, _)| !k.is_empty() && *k == key) {
            Some((_, v)) => v.push(d),
            None => designs.push((key, vec![d])),
        }
    }
    designs.into_iter().map(|(_, v)| v.iter().sum::<f64>() / v.len() as f64).collect()
}

fn light_of(
    r: &RunResults,
    l: Light,
    f: fn(&joca_record::LightResults) -> Option<f64>,
) -> Option<f64> {
    r.by_illumination.light(l).and_then(f)
}

/// Night's exposure × gain over day's.
pub(crate) fn night_over_day(r: &RunResults) -> Option<f64> {
    Some(
        light_of(r, Light::Night, |l| l.exposure_gain_ms)?
            / light_of(r, Light::Day, |l| l.exposure_gain_ms)?,
    )
}

/// The tunnel exit's fall of exposure × gain within 1 s (the largest ≥ 10× light step).
fn tunnel_fall(run: &RunData) -> Option<f64> {
    run.showcases.iter().find_map(|s| s.light_step(10.0, 1.0)).map(|s| s.fall)
}

/// Mean ± interval of differences `values` at 3 decimals, marked where it excludes 0.
fn difference(values: &[f64]) -> String {
    difference_text(mean_interval(values), 3)
}

/// Mean ± interval of `values` at `digits` ("–" for none).
fn text(values: &[f64], digits: usize) -> String {
    interval_text(mean_interval(values), digits)
}

/// The town's name in a table.
pub(crate) fn town_name(town: u64) -> String {
    if town == 0 { "test town".to_owned() } else { format!("town {town}") }
}

/// The groups, labels and towns of `cells`, in order (towns ascending within a variant).
fn variants<'a>(cells: &'a [SwapCell<'a>]) -> Vec<(&'a str, &'a str, u64, Vec<&'a SwapCell<'a>>)> {
    let mut out: Vec<(&str, &str, u64, Vec<&SwapCell<'_>>)> = Vec::new();
    for c in cells {
        match out.iter_mut().find(|(g, l, t, _)| *g == c.group && *l == c.label && *t == c.town) {
            Some(v) => v.3.push(c),
            None => out.push((c.group, c.label, c.town, vec![c])),
        }
    }
    out.sort_by_key(|(g, l, t, _)| {
        (cells.iter().position(|c| c.group == *g && c.label == *l).unwrap_or(usize::MAX), *t)
    });
    out
}

/// The paired table: per scenario and variant, NeuralAE − AverageAE in mAP overall and per light,
/// with the units it rests on and on how many NeuralAE was ahead.
pub fn swap_table(cells: &[SwapCell<'_>]) -> Vec<Vec<String>> {
    let mut table = vec![
        ["scenario", "variant", "test on", "units", "NeuralAE ahead"]
            .iter()
            .map(|s| (*s).to_owned())
            .chain(std::iter::once("mAP".to_owned()))
            .chain(LIGHTS.iter().map(|l| l.name().to_owned()))
            .collect::<Vec<_>>(),
    ];
    for (group, label, town, members) in variants(cells) {
        let overall = units(&members, |r| Some(r.test.map));
        let ahead = overall.iter().filter(|d| **d > 0.0).count();
        let mut row = vec![
            group.to_owned(),
            label.to_owned(),
            town_name(town),
            overall.len().to_string(),
            format!("{ahead} of {}", overall.len()),
            difference(&overall),
        ];
        for l in LIGHTS {
            row.push(difference(&units(&members, |r| {
                light_of(r, l, |x| x.scores.as_ref().map(|s| s.map))
            })));
        }
        table.push(row);
    }
    table
}

/// What the two controllers did: per scenario and variant, mean ± interval over the cells.
pub fn behaviour_table(cells: &[SwapCell<'_>]) -> Vec<Vec<String>> {
    let mut table = vec![
        [
            "scenario",
            "variant",
            "test on",
            "controller",
            "tunnel exit: E × G fall in 1 s",
            "night / day E × G",
            "steady light: E × G moves (stops a frame)",
            "day frame (DN)",
            "day clipped (%)",
            "night frame (DN)",
        ]
        .map(str::to_owned)
        .to_vec(),
    ];
    for (group, label, town, members) in variants(cells) {
        for (name, average) in [("NeuralAE", false), ("AverageAE mid-grey", true)] {
            let runs: Vec<&RunData> =
                members.iter().map(|c| if average { &c.average } else { &c.neural }).collect();
            let of = |f: &dyn Fn(&RunData) -> Option<f64>| -> Vec<f64> {
                runs.iter().filter_map(|r| f(r)).collect()
            };
            table.push(vec![
                group.to_owned(),
                label.to_owned(),
                town_name(town),
                name.to_owned(),
                text(&of(&tunnel_fall), 1),
                text(&of(&|r| night_over_day(&r.results)), 1),
                text(&of(&|r| crate::sections::steady_mean(&r.showcases)), 2),
                text(&of(&|r| light_of(&r.results, Light::Day, |l| l.mean_dn)), 0),
                text(
                    &of(&|r| {
                        light_of(&r.results, Light::Day, |l| l.clipped_share.map(|c| 100.0 * c))
                    }),
                    1,
                ),
                text(&of(&|r| light_of(&r.results, Light::Night, |l| l.mean_dn)), 0),
            ]);
        }
    }
    table
}

/// The section's title and notes.
pub const SWAP: &str = "The learned controller against AverageAE on its own detector";
/// The paired table's note.
pub const SWAP_NOTE: &str = "Each NeuralAE cell re-tested with AverageAE (mid-grey) on the same \
    design, detector and test scenes: NeuralAE − AverageAE in mAP@[.5:.95], per design the mean \
    over its seeds, then mean ± 95 % t interval over the designs (outside a panel, over the \
    cells); ✱ marks an interval that excludes 0, read at full precision. The detector is held \
    fixed, so this is the controller's effect alone.";
/// The behaviour table's note.
pub const BEHAVIOUR_NOTE: &str = "What each controller did in the same test, mean ± 95 % t \
    interval over the cells: how far exposure × linear gain fell within 1 s of the tunnel exit \
    (ambient light × several hundred), night's exposure × gain over day's (the light differs \
    ~1000×), how far exposure × gain moved from frame to frame where the showcases' light held \
    still (from 0.5 s after it last changed: a zig-zag shows here), day's mean frame level, share \
    of day pixels clipped, and night's frame level.";
