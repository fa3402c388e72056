//! The policies of a headroom measurement scored: every rung and closed-loop controller as
//! driven, and the choices made in hindsight from them — the best constant setting and the best
//! AverageAE target (overall, and chosen per light), and the per-frame oracle over the ladder.
//! Every policy's detections are pooled into one COCO evaluation, as the test pools its frames.

use super::Outcome;
use super::by_loss::{self, LossKey};
use super::by_map;
use crate::control::TestController;
use joca_camera::DynamicSettings;
use joca_metrics::{TaskMetrics, TaskScores};
use joca_record::{Light, PolicyLight, PolicyScores, Settings};
use std::collections::BTreeMap;

/// Scores every policy: the rungs (`rung-<i>`), the controllers, then `best-constant`,
/// `constant-by-light`, `best-target`, `target-by-light`, `oracle` and the mAP-scored search's
/// choices (`map-search`, `map-search-16`: [`by_map`]); where the ladder's captures carry their
/// task loss, the loss's choices ([`LossKey`]).
pub(super) fn score(
    rungs: &[DynamicSettings],
    ladder: &[Vec<Outcome>],
    controllers: &[(TestController, Vec<Outcome>)],
) -> Vec<PolicyScores> {
    let mut out = Vec::new();
    for (i, (rung, frames)) in rungs.iter().zip(ladder).enumerate() {
        let label = format!(
            "constant {:.3} ms at {:.1} dB (rung {i} of the ladder)",
            rung.exposure_s * 1e3,
            rung.gain_db
        );
        out.push(policy(format!("rung-{i}"), label, false, &refs(frames)));
    }
    for (c, frames) in controllers {
        let label = match c {
            TestController::Trained => "the run's own trained controller".to_owned(),
            TestController::Average { target_dn } => format!("AverageAE holding {target_dn} DN"),
        };
        out.push(policy(c.name(), label, false, &refs(frames)));
    }
    let rung_sets: Vec<&[Outcome]> = ladder.iter().map(Vec::as_slice).collect();
    if let Some((best, frames)) = best_overall(&rung_sets) {
        let label = format!("the best constant setting of the ladder (rung {best}), in hindsight");
        out.push(policy("best-constant".into(), label, true, &refs(frames)));
        let label = "the best constant setting for each light, in hindsight".to_owned();
        out.push(policy("constant-by-light".into(), label, true, &best_by_light(&rung_sets)));
    }
    let targets: Vec<(f64, &[Outcome])> = controllers
        .iter()
        .filter_map(|(c, o)| match c {
            TestController::Average { target_dn } => Some((*target_dn, o.as_slice())),
            TestController::Trained => None,
        })
        .collect();
    let target_sets: Vec<&[Outcome]> = targets.iter().map(|t| t.1).collect();
    if let Some((best, frames)) = best_overall(&target_sets) {
        let label = format!(
            "the best AverageAE target ({} DN), in hindsight",
            targets.get(best).map_or(f64::NAN, |t| t.0)
        );
        out.push(policy("best-target".into(), label, true, &refs(frames)));
        let label = "AverageAE with the best target for each light, in hindsight".to_owned();
        out.push(policy("target-by-light".into(), label, true, &best_by_light(&target_sets)));
    }
    if !ladder.is_empty() {
        let label = "per-frame oracle over the ladder: each frame's rung chosen in hindsight by \
                     coordinate ascent on its light's pooled mAP (a lower estimate of the optimum)"
            .to_owned();
        out.push(policy("oracle".into(), label, true, &oracle(&rung_sets)));
        for w in by_map::WINDOWS {
            let (name, label) = by_map::row(w);
            out.push(policy(name, label, true, &by_map::by_window(&rung_sets, w)));
        }
    }
    for key in [LossKey::Total, LossKey::Objects] {
        if ladder.is_empty() || !ladder.iter().flatten().all(|o| key.computed(o)) {
            continue;
        }
        let (name, label) = key.by_light_row();
        out.push(policy(name, label, true, &by_loss::by_light(&rung_sets, key)));
        let (name, label) = key.by_frame_row();
        out.push(policy(name, label, true, &by_loss::by_frame(&rung_sets, key)));
    }
    out
}

fn refs(o: &[Outcome]) -> Vec<&Outcome> {
    o.iter().collect()
}

/// The set of the highest pooled mAP (the first among equals), and its index.
fn best_overall<'a>(sets: &[&'a [Outcome]]) -> Option<(usize, &'a [Outcome])> {
    let maps: Vec<f64> = sets.iter().map(|s| metrics(s.iter()).compute().map).collect();
    let best = (0..sets.len()).reduce(|a, b| if maps[b] > maps[a] { b } else { a })?;
    Some((best, sets[best]))
}

/// For each light, the frames of the set whose frames of that light score the highest mAP.
fn best_by_light<'a>(sets: &[&'a [Outcome]]) -> Vec<&'a Outcome> {
    let Some(first) = sets.first() else { return Vec::new() };
    let lights: Vec<Light> = {
        let mut l: Vec<Light> = first.iter().map(|o| o.light).collect();
        l.sort();
        l.dedup();
        l
    };
    let mut chosen = vec![0usize; lights.len()];
    for (li, light) in lights.iter().enumerate() {
        let maps: Vec<f64> = sets
            .iter()
            .map(|s| metrics(s.iter().filter(|o| o.light == *light)).compute().map)
            .collect();
        chosen[li] =
            (0..sets.len()).reduce(|a, b| if maps[b] > maps[a] { b } else { a }).unwrap_or(0);
    }
    (0..first.len())
        .map(|f| {
            let li = lights.iter().position(|l| *l == first[f].light).unwrap_or(0);
            &sets[chosen[li]][f]
        })
        .collect()
}

/// The per-frame oracle over the ladder, light by light: each frame's rung chosen in hindsight
/// to raise the pooled mAP of its light's frames. COCO's mAP is not a sum over frames, so the
/// exact optimum is a search over rungs^frames; this is one pass of coordinate ascent on the
/// pooled mAP itself, started from the better of the light's best constant rung and each
/// frame's rung of the highest [`joca_metrics::frame_utility_of`]. It never scores below its
/// start, so it is at least the best constant per light, and at most the true optimum: a lower
/// estimate of the room a per-frame controller has.
fn oracle<'a>(rungs: &[&'a [Outcome]]) -> Vec<&'a Outcome> {
    let frames = rungs.first().map_or(0, |r| r.len());
    let mut choice = vec![0usize; frames];
    let mut lights: Vec<Light> = (0..frames).map(|f| rungs[0][f].light).collect();
    lights.sort();
    lights.dedup();
    for light in lights {
        let idx: Vec<usize> = (0..frames).filter(|&f| rungs[0][f].light == light).collect();
        let pooled =
            |c: &[usize]| metrics(idx.iter().zip(c).map(|(&f, &r)| &rungs[r][f])).compute().map;
        let constant: Vec<f64> = (0..rungs.len()).map(|r| pooled(&vec![r; idx.len()])).collect();
        let best_rung =
            (0..rungs.len()).reduce(|a, b| if constant[b] > constant[a] { b } else { a });
        let by_utility: Vec<usize> = idx
            .iter()
            .map(|&f| {
                (0..rungs.len())
                    .reduce(|a, b| if rungs[b][f].utility > rungs[a][f].utility { b } else { a })
                    .unwrap_or(0)
            })
            .collect();
        let mut c = vec![best_rung.unwrap_or(0); idx.len()];
        let mut best = constant.get(best_rung.unwrap_or(0)).copied().unwrap_or(0.0);
        let u = pooled(&by_utility);
        if u > best {
            (c, best) = (by_utility, u);
        }
        for i in 0..idx.len() {
            let f = idx[i];
            for r in 0..rungs.len() {
                let current = c[i];
                if r == current || rungs[r][f].detections == rungs[current][f].detections {
                    continue;
                }
                c[i] = r;
                let m = pooled(&c);
                if m > best {
                    best = m;
                } else {
                    c[i] = current;
                }
            }
        }
        for (i, &f) in idx.iter().enumerate() {
            choice[f] = c[i];
        }
    }
    (0..frames).map(|f| &rungs[choice[f]][f]).collect()
}

fn product(s: DynamicSettings) -> f64 {
    s.exposure_s * s.gain_linear()
}

fn metrics<'a>(frames: impl Iterator<Item = &'a Outcome>) -> TaskMetrics {
    let mut m = TaskMetrics::default();
    for o in frames {
        m.update(&o.truth, &o.ignore, &o.detections, o.visible_180);
    }
    m
}

/// A policy's record from the frames it chose.
fn policy(name: String, label: String, hindsight: bool, frames: &[&Outcome]) -> PolicyScores {
    let scores: TaskScores = metrics(frames.iter().copied()).compute();
    let mut by: BTreeMap<Light, Vec<&Outcome>> = BTreeMap::new();
    for o in frames {
        by.entry(o.light).or_default().push(o);
    }
    let by_light = by
        .into_iter()
        .map(|(light, f)| {
            let s = metrics(f.iter().copied()).compute();
            let n = f.len() as f64;
            let mean = |g: &dyn Fn(&Outcome) -> f64| f.iter().map(|o| g(o)).sum::<f64>() / n;
            let settings = Settings {
                exposure_ms: mean(&|o| o.settings.exposure_s * 1e3),
                gain_db: mean(&|o| o.settings.gain_db),
                f_number: None,
            };
            let record = PolicyLight {
                map: s.map,
                ap50: s.ap50,
                settings,
                exposure_gain_ms: mean(&|o| product(o.settings) * 1e3),
                mean_dn: mean(&|o| o.mean_dn),
                clipped_share: mean(&|o| o.clipped),
                task_loss: f.iter().map(|o| o.loss).sum::<Option<f64>>().map(|total| total / n),
                background_loss: f.iter().map(|o| o.background).sum::<Option<f64>>().map(|t| t / n),
                loss_slope: f.iter().map(|o| o.slope).sum::<Option<f64>>().map(|t| t / n),
                more_light_share: f
                    .iter()
                    .map(|o| o.slope.map(|s| f64::from(u8::from(s < 0.0))))
                    .sum::<Option<f64>>()
                    .map(|t| t / n),
                frames: f.len() as u64,
            };
            (light, record)
        })
        .collect();
    PolicyScores { policy: name, label, hindsight, scores, by_light }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use joca_core::{BBox, Class, Detection};

    /// A frame of `light` with one vehicle, detected exactly (score 0.9) or not at all.
    pub(in crate::run::headroom) fn frame(
        light: Light,
        detected: bool,
        exposure_ms: f64,
    ) -> Outcome {
        let bbox = BBox::new(10.0, 10.0, 50.0, 40.0);
        let detections = if detected {
            vec![Detection { bbox, class: Class::Vehicle, score: 0.9 }]
        } else {
            Vec::new()
        };
        Outcome {
            light,
            truth: vec![joca_core::Annotation::new(bbox, Class::Vehicle)],
            ignore: Vec::new(),
            visible_180: 1,
            utility: if detected { 0.9 } else { 0.0 },
            detections,
            settings: DynamicSettings::new(exposure_ms * 1e-3, 1.0),
            mean_dn: 100.0,
            clipped: 0.0,
            // The loss follows the detection: 1 where seen, 2 where missed.
            loss: Some(if detected { 1.0 } else { 2.0 }),
            background: None,
            slope: None,
        }
    }

    #[test]
    fn hindsight_choices_by_light_and_by_frame_find_what_each_rung_sees() {
        // Rung 0 sees the day frames, rung 1 the night frames; one night frame only rung 0
        // sees. Constant: each rung finds half the objects or less. By light: day from rung 0
        // (AP 1), night from rung 1 (2 of 3). The oracle takes every frame's seeing rung: AP 1.
        let (d, n) = (Light::Day, Light::Night);
        let rung0 = vec![
            frame(d, true, 1.0),
            frame(d, true, 1.0),
            frame(n, false, 1.0),
            frame(n, false, 1.0),
            frame(n, true, 1.0),
        ];
        let rung1 = vec![
            frame(d, false, 9.0),
            frame(d, false, 9.0),
            frame(n, true, 9.0),
            frame(n, true, 9.0),
            frame(n, false, 9.0),
        ];
        let rungs = [DynamicSettings::new(1e-3, 1.0), DynamicSettings::new(9e-3, 1.0)];
        let scored = score(&rungs, &[rung0, rung1], &[]);
        let get = |name: &str| scored.iter().find(|p| p.policy == name).unwrap();
        // pycocotools' 101-point AP of 3 hits among 5 objects, all at the same score: 0.6 is
        // reached at recall 0.6 → precision 1 at recall ≤ 0.6, 0 above: 61/101.
        assert!((get("best-constant").scores.map - 61.0 / 101.0).abs() < 1e-9);
        let by_light = get("constant-by-light");
        assert!((by_light.by_light[&d].map - 1.0).abs() < 1e-9);
        assert!((by_light.by_light[&n].map - 67.0 / 101.0).abs() < 1e-9);
        let oracle = get("oracle");
        assert!((oracle.scores.map - 1.0).abs() < 1e-9, "{}", oracle.scores.map);
        assert!(oracle.hindsight && by_light.hindsight && !get("rung-0").hindsight);
        // The oracle's night frames come from both rungs: mean exposure (9 + 9 + 1) / 3 ms.
        assert!((oracle.by_light[&n].settings.exposure_ms - 19.0 / 3.0).abs() < 1e-9);
        // Where the loss follows the detections, its choices are the mAP's: by light, day from
        // rung 0 (loss 1) and night from rung 1 (mean 4/3 against 5/3); by frame, the oracle's.
        let loss_by_light = get("loss-by-light");
        assert_eq!(loss_by_light.by_light, by_light.by_light);
        assert!((loss_by_light.by_light[&n].task_loss.unwrap() - 4.0 / 3.0).abs() < 1e-12);
        assert_eq!(get("loss-oracle").by_light, oracle.by_light);
        assert_eq!(get("loss-oracle").by_light[&d].task_loss, Some(1.0));
        // The rungs carry their mean loss per light: rung 0's night, (2 + 2 + 1) / 3.
        assert!((get("rung-0").by_light[&n].task_loss.unwrap() - 5.0 / 3.0).abs() < 1e-12);
    }
}
