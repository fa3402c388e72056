//! The choices per light made on other frames (`joca headroom --table … --chosen-on …`): for each
//! record, the AverageAE target and the ladder's rung that scored the highest mAP in a light on
//! another record of the same design and detector (another town's frames), scored in that light
//! on this record's frames, minus mid-grey. The hindsight rows choose on the frames they score,
//! so they hold the luck of the choice; these choose out of sample, as a controller that knew
//! the light and had learnt its level elsewhere would.

use crate::headroom::REFERENCE_POLICY;
use crate::seeds::{interval_text, mean_interval};
use joca_record::{HeadroomRecord, Light};
use std::fmt::Write as _;

/// The two families of policy a light's choice is made among: AverageAE's targets, the rungs.
const FAMILIES: [(&str, &str); 2] =
    [("average-", "target per light"), ("rung-", "constant setting per light")];

/// The policy of `prefix`'s family with the highest mAP in `light` on `record`, the first among
/// equals.
fn best_in_light<'a>(record: &'a HeadroomRecord, prefix: &str, light: Light) -> Option<&'a str> {
    let mut best: Option<(&str, f64)> = None;
    for p in record.policies.iter().filter(|p| p.policy.starts_with(prefix)) {
        let Some(map) = p.by_light.get(&light).map(|x| x.map) else { continue };
        if best.is_none_or(|(_, b)| map > b) {
            best = Some((&p.policy, map));
        }
    }
    best.map(|(name, _)| name)
}

/// Whether two records measured the same design and detector (of the same run, if any).
pub fn same_subject(a: &HeadroomRecord, b: &HeadroomRecord) -> bool {
    a.design == b.design && a.detector == b.detector && a.run == b.run
}

/// The table of choices made on `elsewhere` scored on `records`: per light, mean ± 95 % t over
/// the records of the chosen policy's mAP minus mid-grey's, and the records ahead. Each record
/// is paired with the first record of `elsewhere` of the same subject; one without a partner is
/// left out (the table says over how many records).
pub fn chosen_elsewhere_markdown(
    records: &[HeadroomRecord],
    elsewhere: &[HeadroomRecord],
) -> String {
    let mut s = String::new();
    let Some(first) = records.first() else {
        return String::new();
    };
    let lights = crate::headroom::lights(first);
    let pairs: Vec<(&HeadroomRecord, &HeadroomRecord)> = records
        .iter()
        .filter_map(|r| elsewhere.iter().find(|e| same_subject(r, e)).map(|e| (r, e)))
        .collect();
    let towns: Vec<String> = {
        let mut t: Vec<u64> = pairs.iter().map(|(_, e)| e.town).collect();
        t.sort_unstable();
        t.dedup();
        t.iter().map(u64::to_string).collect()
    };
    let _ = writeln!(
        s,
        "\nChosen on other frames: for each light, the AverageAE target and the ladder's rung of \
         the highest mAP in that light on town {}'s record of the same design and detector, \
         scored on these frames, minus mid-grey; mean ± 95 % Student t over {} records (ahead: \
         records above 0). Out of sample, unlike the rows marked †; per light only (the pooled \
         mAP over lights cannot be formed from per-light scores).\n",
        towns.join(", "),
        pairs.len()
    );
    let header: Vec<String> = lights.iter().map(|l| l.name().to_owned()).collect();
    let _ = writeln!(s, "| choice | {} |", header.join(" | "));
    let _ = writeln!(s, "|---|{}", "---|".repeat(lights.len()));
    for (prefix, label) in FAMILIES {
        let cells: Vec<String> = lights
            .iter()
            .map(|&light| {
                let diffs: Vec<f64> = pairs
                    .iter()
                    .filter_map(|(r, e)| {
                        let chosen = r.policy(best_in_light(e, prefix, light)?)?;
                        let reference = r.policy(REFERENCE_POLICY)?;
                        Some(chosen.by_light.get(&light)?.map - reference.by_light.get(&light)?.map)
                    })
                    .collect();
                let ahead = diffs.iter().filter(|d| **d > 0.0).count();
                format!("{} ({ahead}/{})", interval_text(mean_interval(&diffs), 3), diffs.len())
            })
            .collect();
        let _ =
            writeln!(s, "| {label}, chosen on town {} | {} |", towns.join(", "), cells.join(" | "));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use joca_record::{PolicyLight, PolicyScores};

    /// A record of `town` whose policies score `maps` (name, day mAP, night mAP), the rest of it
    /// a committed record's.
    fn record(town: u64, maps: &[(&str, f64, f64)]) -> HeadroomRecord {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../docs/results/2026-12-06-pooled-score-quick/headroom/town0/",
            "trained-map-16-calibrated-flir/headroom.json"
        ));
        let mut r: HeadroomRecord = serde_json::from_str(&text.unwrap()).unwrap();
        r.town = town;
        let template: PolicyLight = *r.policies[0].by_light.values().next().unwrap();
        r.policies = maps
            .iter()
            .map(|(name, day, night)| {
                let mut by_light = std::collections::BTreeMap::new();
                for (light, map) in [(Light::Day, *day), (Light::Night, *night)] {
                    by_light.insert(light, PolicyLight { map, ..template });
                }
                let mut p: PolicyScores = r.policies[0].clone();
                p.policy = (*name).to_owned();
                p.by_light = by_light;
                p
            })
            .collect();
        r
    }

    /// Town 2 picks target 40 by day and 210 by night; on town 0 those score 0.30 − 0.25 by day
    /// and 0.10 − 0.20 at night against mid-grey: +0.05 and −0.10, though town 0's own best
    /// (210 by day) would have been ahead in both.
    #[test]
    fn each_light_is_scored_by_the_choice_made_on_the_other_town() {
        let here = record(
            0,
            &[
                ("average-127.5", 0.25, 0.20),
                ("average-40", 0.30, 0.18),
                ("average-210", 0.35, 0.10),
            ],
        );
        let there = record(
            2,
            &[
                ("average-127.5", 0.20, 0.20),
                ("average-40", 0.40, 0.10),
                ("average-210", 0.10, 0.30),
            ],
        );
        let table = chosen_elsewhere_markdown(&[here], &[there]);
        let row = table.lines().find(|l| l.starts_with("| target per light")).unwrap();
        assert!(row.contains("0.050 (1/1)") && row.contains("-0.100 (0/1)"), "{table}");
        assert!(row.contains("(1/1)") && row.contains("(0/1)"), "{row}");
        assert!(table.contains("town 2"), "{table}");
    }
}
