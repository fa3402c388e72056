//! How each variant's controller set the camera in the closed-loop test, and how often its
//! perturbation search was decided by a tie: the mechanisms behind the scores (a controller that
//! lengthens the exposure the scenario punishes, a search whose score cannot tell its members
//! apart), one row per scenario and variant.

use crate::paired::variants;
use crate::seeds::{interval_text, mean_interval};
use crate::table::Row;
use joca_record::Light;

/// A mean over cells with its 95 % t interval, at `digits` decimals ("–" where no cell has it).
fn cell(values: &[f64], digits: usize) -> String {
    interval_text(mean_interval(values), digits)
}

/// The share of all the cells' perturbation searches whose best score was shared ("–" where no
/// cell ran a search).
fn tie_share(rows: &[&Row]) -> String {
    let (searches, tied) = rows
        .iter()
        .filter_map(|r| r.results.perturbation_ties)
        .fold((0, 0), |(s, t), ties| (s + ties.searches, t + ties.tied));
    if searches == 0 {
        "–".to_owned()
    } else {
        format!("{:.1} % of {searches}", 100.0 * tied as f64 / searches as f64)
    }
}

/// Per scenario and variant: the share of searches a tie decided, the mean test exposure and gain
/// by day and by night, day's exposure × gain relative to night's and day's mean frame level, each
/// a mean over the variant's cells (designs and seeds) with its 95 % t interval. Empty when no
/// cell recorded settings.
pub fn controls_table(rows: &[Row]) -> Vec<Vec<String>> {
    let mut table = vec![
        [
            "scenario",
            "variant",
            "cells",
            "searches a tie decided",
            "day E (ms)",
            "day G (dB)",
            "night E (ms)",
            "night G (dB)",
            "day / night E × G",
            "day frame (DN)",
        ]
        .map(str::to_owned)
        .to_vec(),
    ];
    for (group, label, members) in variants(rows) {
        let light = |l: Light, f: fn(&joca_record::LightResults) -> Option<f64>| -> Vec<f64> {
            members.iter().filter_map(|r| r.results.by_illumination.light(l).and_then(f)).collect()
        };
        let exposure = |l| light(l, |r| r.settings.map(|s| s.exposure_ms));
        let gain = |l| light(l, |r| r.settings.map(|s| s.gain_db));
        let ratio: Vec<f64> = members
            .iter()
            .filter_map(|r| {
                let of = |l| r.results.by_illumination.light(l)?.exposure_gain_ms;
                Some(of(Light::Day)? / of(Light::Night)?)
            })
            .collect();
        let (day, night) = (exposure(Light::Day), exposure(Light::Night));
        if day.is_empty() && night.is_empty() {
            continue;
        }
        table.push(vec![
            group,
            label,
            members.len().to_string(),
            tie_share(&members),
            cell(&day, 1),
            cell(&gain(Light::Day), 1),
            cell(&night, 1),
            cell(&gain(Light::Night), 1),
            cell(&ratio, 3),
            cell(&light(Light::Day, |r| r.mean_dn), 0),
        ]);
    }
    if table.len() == 1 { Vec::new() } else { table }
}

#[cfg(test)]
mod tests {
    use super::*;
    use joca_record::{LightResults, Method, SearchTies, Settings};

    fn row(
        label: &str,
        design: &str,
        day: (f64, f64),
        night: (f64, f64),
        ties: Option<(u64, u64)>,
    ) -> Row {
        let mut results = crate::table::tests::results(0.2, 0.3, false);
        results.method = if ties.is_some() { Method::Joca } else { Method::TacosAverage };
        results.perturbation_ties = ties.map(|(searches, tied)| SearchTies { searches, tied });
        for (light, (e, g)) in [(Light::Day, day), (Light::Night, night)] {
            let settings = Settings { exposure_ms: e, gain_db: g, f_number: None };
            let lr = LightResults {
                scores: None,
                settings: Some(settings),
                exposure_gain_ms: Some(e * 10f64.powf(g / 20.0)),
                mean_dn: Some(if light == Light::Day { 120.0 } else { 20.0 }),
                clipped_share: None,
            };
            results.by_illumination.insert(light, lr);
        }
        Row {
            group: "Calibrated".into(),
            label: label.into(),
            cell: format!("{label}-{design}"),
            design: design.into(),
            results,
        }
    }

    #[test]
    fn settings_and_tie_shares_are_summarised_per_variant() {
        let rows = vec![
            row("paper", "a", (40.0, 0.0), (50.0, 20.0), Some((100, 90))),
            row("paper", "b", (20.0, 0.0), (50.0, 20.0), Some((300, 210))),
            row("AverageAE", "a", (10.0, 0.0), (50.0, 20.0), None),
        ];
        let t = controls_table(&rows);
        assert_eq!(t.len(), 3, "{t:?}");
        let paper = &t[1];
        assert_eq!(paper[..3], ["Calibrated", "paper", "2"]);
        // Ties pooled over the cells' searches: (90 + 210) / 400.
        assert_eq!(paper[3], "75.0 % of 400");
        // Day exposures 40 and 20 ms: mean 30, s = 14.142, t(0.975, 1) = 12.706.
        let half = 12.706_2 * 14.142_136 / 2f64.sqrt();
        assert_eq!(paper[4], format!("30.0 ± {half:.1}"));
        assert_eq!(paper[6], "50.0 ± 0.0");
        // Day/night E × G: 40 / (50·10) = 0.08 and 20 / 500 = 0.04, mean 0.06.
        assert!(paper[8].starts_with("0.060 ± "), "{}", paper[8]);
        assert_eq!(paper[9], "120 ± 0");
        // No search: no share; one cell: no interval.
        assert_eq!(t[2][3], "–");
        assert_eq!(t[2][4], "10.0");
        assert_eq!(t[2][8], "0.020");
        // Cells without settings: no table.
        let mut bare = rows.clone();
        for r in &mut bare {
            r.results.by_illumination = Default::default();
        }
        assert!(controls_table(&bare).is_empty());
    }
}
