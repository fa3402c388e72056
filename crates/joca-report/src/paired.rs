//! Ours paired with each baseline of the same scenario: differences taken on the same seed and,
//! in a design panel, on the same design, with a 95 % interval.
//!
//! Outside a panel the unit is the seed: per seed ours − baseline (same seed, same test scenes),
//! mean ± t(0.975, n − 1)·s/√n over the n seeds. In a panel the unit is the design: per design
//! the mean difference over its seeds, then the t interval over the designs, so the interval
//! speaks for designs like these (design-to-design spread is the larger one) and a design with
//! more seeds does not weigh more.

use crate::seeds::mean_interval;
use crate::table::Row;
use joca_record::{Light, Method};

/// The illuminations of the test, in report order.
pub const LIGHTS: [Light; 4] = [Light::Day, Light::Night, Light::Tunnel, Light::Cycle];

/// Ours against one baseline of one scenario, on the (design, seed) units both finished.
#[derive(Debug)]
pub struct Comparison<'a> {
    /// Scenario (group).
    pub group: String,
    /// Ours' label.
    pub ours: String,
    /// The baseline's label.
    pub other: String,
    /// Pairs on the same design and seed.
    pub pairs: Vec<(&'a Row, &'a Row)>,
}

/// The variants of each group in order, each with its rows.
pub fn variants(rows: &[Row]) -> Vec<(String, String, Vec<&Row>)> {
    let mut out: Vec<(String, String, Vec<&Row>)> = Vec::new();
    for r in rows {
        match out.iter_mut().find(|(g, l, _)| *g == r.group && *l == r.label) {
            Some(v) => v.2.push(r),
            None => out.push((r.group.clone(), r.label.clone(), vec![r])),
        }
    }
    out
}

/// Every comparison of ours (variants whose every row is `Method::Joca`) with another variant of
/// the same group, paired on design and seed. Two variants of ours (e.g. two perturbation
/// scores) are compared once, the one listed first minus the later one.
pub fn comparisons(rows: &[Row]) -> Vec<Comparison<'_>> {
    let groups = variants(rows);
    let is_ours = |members: &[&Row]| members.iter().all(|r| r.results.method == Method::Joca);
    let mut out = Vec::new();
    for (i, (group, label, ours)) in groups.iter().enumerate() {
        if !is_ours(ours) {
            continue;
        }
        for (j, (g, other, theirs)) in groups.iter().enumerate() {
            if g != group || other == label || (j < i && is_ours(theirs)) {
                continue;
            }
            let pairs: Vec<(&Row, &Row)> = ours
                .iter()
                .filter_map(|a| {
                    theirs
                        .iter()
                        .find(|b| b.results.seed == a.results.seed && b.design == a.design)
                        .map(|b| (*a, *b))
                })
                .collect();
            if !pairs.is_empty() {
                out.push(Comparison {
                    group: group.clone(),
                    ours: label.clone(),
                    other: other.clone(),
                    pairs,
                });
            }
        }
    }
    out
}

impl Comparison<'_> {
    /// Whether the pairs come from a design panel.
    pub fn panel(&self) -> bool {
        self.pairs.iter().any(|(a, _)| !a.design.is_empty())
    }

    /// The distinct designs, in order.
    pub fn designs(&self) -> Vec<&str> {
        let mut d: Vec<&str> = Vec::new();
        for (a, _) in &self.pairs {
            if !d.contains(&a.design.as_str()) {
                d.push(&a.design);
            }
        }
        d
    }

    /// The differences the interval is over: per design the mean over its seeds (panel), else
    /// per seed. `f` reads a value of a row (`None`: not recorded, the pair is left out).
    pub fn units(&self, f: impl Fn(&Row) -> Option<f64>) -> Vec<f64> {
        let diffs: Vec<(&str, f64)> = self
            .pairs
            .iter()
            .filter_map(|(a, b)| Some((a.design.as_str(), f(a)? - f(b)?)))
            .collect();
        if !self.panel() {
            return diffs.into_iter().map(|(_, d)| d).collect();
        }
        self.designs()
            .into_iter()
            .filter_map(|design| {
                let of: Vec<f64> =
                    diffs.iter().filter(|(d, _)| *d == design).map(|(_, v)| *v).collect();
                (!of.is_empty()).then(|| of.iter().sum::<f64>() / of.len() as f64)
            })
            .collect()
    }

    /// Mean and 95 % half-width of the difference in `f` over the units.
    pub fn difference(&self, f: impl Fn(&Row) -> Option<f64>) -> (f64, f64) {
        mean_interval(&self.units(f))
    }

    /// What the pairs are: "3 seeds" or "6 designs × 3 seeds" (seeds per design at most).
    pub fn describe(&self) -> String {
        let count =
            |n: usize, one: &str, many: &str| format!("{n} {}", if n == 1 { one } else { many });
        if !self.panel() {
            return count(self.pairs.len(), "seed", "seeds");
        }
        let designs = self.designs();
        let most = designs
            .iter()
            .map(|d| self.pairs.iter().filter(|(a, _)| a.design == *d).count())
            .max()
            .unwrap_or(0);
        let seeds = if most == 1 { "1 seed".to_owned() } else { format!("≤ {most} seeds") };
        format!("{} × {seeds}", count(designs.len(), "design", "designs"))
    }

    /// On how many units ours scored the higher mAP, and of how many.
    pub fn ahead(&self) -> (usize, usize) {
        let units = self.units(|r| Some(r.results.test.map));
        (units.iter().filter(|d| **d > 0.0).count(), units.len())
    }

    /// The unit's name for "ours ahead on k of n …".
    pub fn unit_name(&self) -> &'static str {
        if self.panel() { "designs" } else { "seeds" }
    }
}

/// The mAP of `light` in a row's per-illumination test scores.
pub fn light_map(r: &Row, light: Light) -> Option<f64> {
    r.results.by_illumination.light(light)?.scores.as_ref().map(|s| s.map)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_variants_of_ours_are_compared_once_first_minus_later() {
        let row = |label: &str, method: Method, map: f64| {
            let mut results = crate::table::tests::results(map, 0.3, false);
            results.method = method;
            Row {
                group: "Calibrated".into(),
                label: label.into(),
                cell: label.into(),
                design: "a".into(),
                results,
            }
        };
        let rows = vec![
            row("loss", Method::Joca, 0.30),
            row("paper", Method::Joca, 0.25),
            row("AverageAE", Method::TacosAverage, 0.20),
        ];
        let names: Vec<(String, String, f64)> = comparisons(&rows)
            .iter()
            .map(|c| {
                (c.ours.clone(), c.other.clone(), c.difference(|r| Some(r.results.test.map)).0)
            })
            .collect();
        let expect =
            [("loss", "paper", 0.05), ("loss", "AverageAE", 0.1), ("paper", "AverageAE", 0.05)];
        assert_eq!(names.len(), expect.len(), "{names:?}");
        for ((a, b, d), (ea, eb, ed)) in names.iter().zip(expect) {
            assert_eq!((a.as_str(), b.as_str()), (ea, eb));
            assert!((d - ed).abs() < 1e-12);
        }
    }
}
