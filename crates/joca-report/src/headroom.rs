//! Tables of `joca headroom`: one design's policies ([`headroom_markdown`]) and, over several
//! designs measured alike, each policy's difference to AverageAE at mid-grey paired by design
//! ([`headroom_summary_markdown`]), overall and per light, with a 95 % Student t interval.

use crate::seeds::{difference_text, interval_text, mean_interval};
use joca_record::{HeadroomRecord, Light, PolicyScores};
use std::fmt::Write as _;

/// The reference every difference is taken to: AverageAE holding mid-grey.
pub const REFERENCE_POLICY: &str = "average-127.5";

/// The policies the tables show, in order: the reference, the controllers, the choices in
/// hindsight (the ladder's rungs only through them).
fn shown(record: &HeadroomRecord) -> Vec<&PolicyScores> {
    let mut shown: Vec<&PolicyScores> =
        record.policies.iter().filter(|p| !p.policy.starts_with("rung-") && !p.hindsight).collect();
    shown.extend(record.policies.iter().filter(|p| p.hindsight));
    shown
}

/// The lights of a record's reference policy, in order.
pub(crate) fn lights(record: &HeadroomRecord) -> Vec<Light> {
    record.policy(REFERENCE_POLICY).map_or_else(Vec::new, |p| p.by_light.keys().copied().collect())
}

/// One design's headroom: each policy's mAP overall and by light, its difference to the
/// reference, and what it does to the frames (exposure × gain, level, clipped share) by light.
pub fn headroom_markdown(r: &HeadroomRecord) -> String {
    let mut s = String::new();
    let d = &r.design;
    let _ = writeln!(
        s,
        "# Headroom: {} behind {:.2} mm at x {:.2} m, z {:.2} m; {}, town {}{}, detector {}\n",
        d.sensor,
        d.focal_length_mm,
        d.x_m,
        d.z_m,
        r.scenario.name(),
        r.town,
        if r.layout_version() > 1 { format!(", {}", r.world()) } else { String::new() },
        r.detector
    );
    let _ = writeln!(
        s,
        "{} frames; ladder of {} rungs from {:.3} to {:.1} ms × gain; computed on {}, joca {} \
         ({}).\nRows marked † are chosen in hindsight from the test frames' scores: bounds on \
         what a controller could reach in this world, not controllers.\n",
        r.frames,
        r.ladder.len(),
        r.ladder.first().map_or(f64::NAN, |s| s.exposure_gain_ms()),
        r.ladder.last().map_or(f64::NAN, |s| s.exposure_gain_ms()),
        r.device.as_ref().map_or(r.cpu.clone(), |gpu| format!("{} and {gpu}", r.cpu)),
        r.provenance.joca_version,
        r.provenance.commit_label()
    );
    let lights = lights(r);
    let reference = r.policy(REFERENCE_POLICY);
    let header: Vec<String> = lights.iter().map(|l| format!("{} mAP", l.name())).collect();
    let _ = writeln!(s, "| policy | mAP | Δ mAP | {} |", header.join(" | "));
    let _ = writeln!(s, "|---|---|---|{}", "---|".repeat(lights.len()));
    for p in shown(r) {
        let delta = reference.map_or(f64::NAN, |q| p.scores.map - q.scores.map);
        let per: Vec<String> = lights
            .iter()
            .map(|l| p.by_light.get(l).map_or("–".into(), |x| format!("{:.3}", x.map)))
            .collect();
        let mark = if p.hindsight { " †" } else { "" };
        let _ = writeln!(
            s,
            "| {}{mark} | {:.3} | {:+.3} | {} |",
            p.label,
            p.scores.map,
            delta,
            per.join(" | ")
        );
    }
    ladder_by_light(&mut s, r, &lights);
    let _ = writeln!(s, "\n## What each policy does to the frames\n");
    let _ =
        writeln!(s, "| policy | light | E (ms) | G (dB) | E × gain (ms) | frame (DN) | clipped |");
    let _ = writeln!(s, "|---|---|---|---|---|---|---|");
    for p in shown(r) {
        for (l, x) in &p.by_light {
            let _ = writeln!(
                s,
                "| {} | {} | {:.2} | {:.1} | {:.2} | {:.0} | {:.1} % |",
                p.policy,
                l.name(),
                x.settings.exposure_ms,
                x.settings.gain_db,
                x.exposure_gain_ms,
                x.mean_dn,
                100.0 * x.clipped_share
            );
        }
    }
    s
}

/// The ladder's rungs light by light: each rung's mAP, the detector's mean task loss (where the
/// record has it) and the frame level, so that where the task loss is lowest can be read beside
/// where the mAP is highest.
fn ladder_by_light(s: &mut String, r: &HeadroomRecord, lights: &[Light]) {
    let rungs: Vec<&PolicyScores> =
        r.policies.iter().filter(|p| p.policy.starts_with("rung-")).collect();
    if rungs.is_empty() {
        return;
    }
    let _ = writeln!(
        s,
        "\n## The ladder, light by light: mAP · the detector's task loss · frame level (DN)\n"
    );
    if rungs.iter().any(|p| p.by_light.values().any(|x| x.background_loss.is_some())) {
        let _ = writeln!(
            s,
            "The loss is followed by its heatmap's background term in brackets (confidence where \
             no object is); the loss less it is the loss on the objects alone.\n"
        );
    }
    if rungs.iter().any(|p| p.by_light.values().any(|x| x.loss_slope.is_some())) {
        let _ = writeln!(
            s,
            "Then the loss's mean slope by the light per stop through the differentiable \
             formation (DF-Grad's task pull; negative: more light lowers the loss) and the share \
             of frames where it asks for more light.\n"
        );
    }
    let header: Vec<String> = lights.iter().map(|l| l.name().to_owned()).collect();
    let _ = writeln!(s, "| rung | E × gain (ms) | {} |", header.join(" | "));
    let _ = writeln!(s, "|---|---|{}", "---|".repeat(lights.len()));
    for (i, p) in rungs.iter().enumerate() {
        let per: Vec<String> = lights
            .iter()
            .map(|l| {
                p.by_light.get(l).map_or("–".into(), |x| {
                    let loss = match (x.task_loss, x.background_loss) {
                        (Some(v), Some(b)) => format!("{v:.3} ({b:.3})"),
                        (Some(v), None) => format!("{v:.3}"),
                        _ => "–".into(),
                    };
                    let slope = x.loss_slope.zip(x.more_light_share).map_or(String::new(), |v| {
                        format!(" · {:+.3} ({:.0} %)", v.0, 100.0 * v.1)
                    });
                    format!("{:.3} · {loss} · {:.0}{slope}", x.map, x.mean_dn)
                })
            })
            .collect();
        let product = r.ladder.get(i).map_or(f64::NAN, |x| x.exposure_gain_ms());
        let _ = writeln!(s, "| {} | {product:.3} | {} |", p.policy, per.join(" | "));
    }
}

/// Each policy minus the reference, paired by record (design, scenario and town measured alike),
/// mean ± 95 % t over records, overall and by light; with the number of records ahead.
pub fn headroom_summary_markdown(records: &[HeadroomRecord]) -> String {
    let mut s = String::new();
    let Some(first) = records.first() else {
        return "no headroom records\n".into();
    };
    let lights = lights(first);
    let mut names: Vec<&str> = Vec::new();
    for p in records.iter().flat_map(shown) {
        if p.policy != REFERENCE_POLICY && !names.contains(&p.policy.as_str()) {
            names.push(&p.policy);
        }
    }
    let _ = writeln!(
        s,
        "Each policy's mAP@[.5:.95] minus AverageAE at mid-grey on the same design, detector and \
         frames; mean ± 95 % Student t over {} records (paired; {}, town {}, {}); ahead: \
         records where the difference is above 0; ✱ the interval excludes 0, read at full \
         precision. † chosen in hindsight.\n",
        records.len(),
        first.scenario.name(),
        first.town,
        first.world()
    );
    let header: Vec<String> = lights.iter().map(|l| l.name().to_owned()).collect();
    let _ = writeln!(s, "| policy | overall | ahead | {} |", header.join(" | "));
    let _ = writeln!(s, "|---|---|---|{}", "---|".repeat(lights.len()));
    let reference_level: Vec<f64> =
        records.iter().filter_map(|r| r.policy(REFERENCE_POLICY).map(|p| p.scores.map)).collect();
    let _ = writeln!(
        s,
        "| AverageAE mid-grey (level, not a difference) | {} | – | {} |",
        interval_text(mean_interval(&reference_level), 3),
        lights
            .iter()
            .map(|l| {
                let v: Vec<f64> = records
                    .iter()
                    .filter_map(|r| r.policy(REFERENCE_POLICY)?.by_light.get(l).map(|x| x.map))
                    .collect();
                interval_text(mean_interval(&v), 3)
            })
            .collect::<Vec<_>>()
            .join(" | ")
    );
    for name in names.iter().copied() {
        let diffs = |light: Option<Light>| -> Vec<f64> {
            records
                .iter()
                .filter_map(|r| {
                    let (p, q) = (r.policy(name)?, r.policy(REFERENCE_POLICY)?);
                    match light {
                        None => Some(p.scores.map - q.scores.map),
                        Some(l) => Some(p.by_light.get(&l)?.map - q.by_light.get(&l)?.map),
                    }
                })
                .collect()
        };
        let overall = diffs(None);
        let ahead = overall.iter().filter(|d| **d > 0.0).count();
        let hindsight = records.iter().filter_map(|r| r.policy(name)).any(|p| p.hindsight);
        let label = format!("{name}{}", if hindsight { " †" } else { "" });
        let per: Vec<String> =
            lights.iter().map(|l| difference_text(mean_interval(&diffs(Some(*l))), 3)).collect();
        let _ = writeln!(
            s,
            "| {label} | {} | {ahead}/{} | {} |",
            difference_text(mean_interval(&overall), 3),
            overall.len(),
            per.join(" | ")
        );
    }
    levels_table(&mut s, records, &lights, &names);
    s
}

/// Each policy's frame level and clipped share by light, mean ± 95 % t over the records: where
/// in the light each policy puts its frames.
fn levels_table(s: &mut String, records: &[HeadroomRecord], lights: &[Light], names: &[&str]) {
    let _ = writeln!(
        s,
        "\nFrame level (DN) and share of pixels clipped by light, mean ± 95 % Student t over the \
         same records.\n"
    );
    let header: Vec<String> = lights.iter().map(|l| l.name().to_owned()).collect();
    let _ = writeln!(s, "| policy | {} |", header.join(" | "));
    let _ = writeln!(s, "|---|{}", "---|".repeat(lights.len()));
    for name in std::iter::once(REFERENCE_POLICY).chain(names.iter().copied()) {
        let per: Vec<String> = lights
            .iter()
            .map(|l| {
                let (dn, clipped): (Vec<f64>, Vec<f64>) = records
                    .iter()
                    .filter_map(|r| r.policy(name)?.by_light.get(l))
                    .map(|x| (x.mean_dn, 100.0 * x.clipped_share))
                    .unzip();
                format!(
                    "{} DN, {} %",
                    interval_text(mean_interval(&dn), 0),
                    interval_text(mean_interval(&clipped), 0)
                )
            })
            .collect();
        let _ = writeln!(s, "| {name} | {} |", per.join(" | "));
    }
}
