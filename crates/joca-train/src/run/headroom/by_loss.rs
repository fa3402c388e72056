//! The ladder's rungs chosen in hindsight by the detector's task loss instead of by mAP: the
//! level the training loss asks for, per light and per frame. [`LossKey::Total`] ranks by the
//! loss DF-Grad's task term descends; [`LossKey::Objects`] by that loss less its heatmap's
//! background term (confidence where no object is), so that where the two disagree the part of
//! the loss that pulls the level away from mAP's can be read off.

use super::Outcome;
use joca_record::Light;
use std::collections::BTreeMap;

/// Which loss a choice ranks the rungs by.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum LossKey {
    /// The whole task loss.
    Total,
    /// The task loss less its background term: the objects' peaks, sizes and offsets.
    Objects,
}

impl LossKey {
    /// Whether `o` carries what this key ranks by.
    pub(super) fn computed(self, o: &Outcome) -> bool {
        match self {
            LossKey::Total => o.loss.is_some(),
            LossKey::Objects => o.loss.is_some() && o.background.is_some(),
        }
    }

    /// The loss of `o` by this key, a missing or non-finite one ranking last.
    fn of(self, o: &Outcome) -> f64 {
        let value = match self {
            LossKey::Total => o.loss,
            LossKey::Objects => o.loss.zip(o.background).map(|(l, b)| l - b),
        };
        value.filter(|l| l.is_finite()).unwrap_or(f64::INFINITY)
    }

    /// The name and label of the choice per light.
    pub(super) fn by_light_row(self) -> (String, String) {
        match self {
            LossKey::Total => (
                "loss-by-light".into(),
                "the constant setting of the lowest mean task loss for each light, in hindsight \
                 (the level the detector's training loss asks for)"
                    .into(),
            ),
            LossKey::Objects => (
                "objects-loss-by-light".into(),
                "the constant setting of the lowest mean task loss less its background term for \
                 each light, in hindsight (the level the loss on the objects alone asks for)"
                    .into(),
            ),
        }
    }

    /// The name and label of the choice per frame.
    pub(super) fn by_frame_row(self) -> (String, String) {
        match self {
            LossKey::Total => (
                "loss-oracle".into(),
                "each frame's rung of the lowest task loss, in hindsight".into(),
            ),
            LossKey::Objects => (
                "objects-loss-oracle".into(),
                "each frame's rung of the lowest task loss less its background term, in hindsight"
                    .into(),
            ),
        }
    }
}

/// The index of the lowest value (the first among equals).
fn argmin(values: &[f64]) -> usize {
    (0..values.len()).reduce(|a, b| if values[b] < values[a] { b } else { a }).unwrap_or(0)
}

/// For each light, the frames of the rung whose frames of that light have the lowest mean loss
/// by `key`.
pub(super) fn by_light<'a>(rungs: &[&'a [Outcome]], key: LossKey) -> Vec<&'a Outcome> {
    let Some(first) = rungs.first() else { return Vec::new() };
    let mut chosen: BTreeMap<Light, usize> = BTreeMap::new();
    for light in first.iter().map(|o| o.light) {
        chosen.entry(light).or_insert_with(|| {
            let sums: Vec<f64> = rungs
                .iter()
                .map(|r| r.iter().filter(|o| o.light == light).map(|o| key.of(o)).sum::<f64>())
                .collect();
            argmin(&sums)
        });
    }
    (0..first.len()).map(|f| &rungs[chosen[&first[f].light]][f]).collect()
}

/// Each frame from the rung of its lowest loss by `key`.
pub(super) fn by_frame<'a>(rungs: &[&'a [Outcome]], key: LossKey) -> Vec<&'a Outcome> {
    let frames = rungs.first().map_or(0, |r| r.len());
    (0..frames)
        .map(|f| {
            let losses: Vec<f64> = rungs.iter().map(|r| key.of(&r[f])).collect();
            &rungs[argmin(&losses)][f]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::super::policies::{score, tests::frame};
    use super::*;
    use joca_camera::DynamicSettings;

    /// Two rungs (1 and 9 ms) of one day frame and three night frames: the darker rung sees the
    /// day's object and one night object, the brighter rung two night objects.
    fn ladder(loss: impl Fn(&mut Outcome)) -> Vec<Vec<Outcome>> {
        let (d, n) = (Light::Day, Light::Night);
        let rung = |ms: f64, seen: [bool; 4]| -> Vec<Outcome> {
            [d, n, n, n]
                .into_iter()
                .zip(seen)
                .map(|(l, s)| {
                    let mut o = frame(l, s, ms);
                    loss(&mut o);
                    o
                })
                .collect()
        };
        vec![rung(1.0, [true, false, false, true]), rung(9.0, [false, true, true, false])]
    }

    const RUNGS: [DynamicSettings; 2] = [
        DynamicSettings { exposure_s: 1e-3, gain_db: 1.0 },
        DynamicSettings { exposure_s: 9e-3, gain_db: 1.0 },
    ];

    #[test]
    fn the_loss_choices_follow_the_loss_where_it_disagrees_with_the_detections() {
        // A loss that always prefers the darker rung (loss = exposure in ms): both loss choices
        // take rung 0 in every light, whatever it detects; night then finds 1 of 3 objects,
        // 34 of COCO's 101 recall points.
        let rungs = ladder(|o| o.loss = Some(o.settings.exposure_s * 1e3));
        let scored = score(&RUNGS, &rungs, &[]);
        let get = |name: &str| scored.iter().find(|p| p.policy == name).unwrap();
        for name in ["loss-by-light", "loss-oracle"] {
            let p = get(name);
            assert!(p.hindsight);
            assert!((p.by_light[&Light::Night].map - 34.0 / 101.0).abs() < 1e-9, "{name}");
            assert!((p.by_light[&Light::Night].settings.exposure_ms - 1.0).abs() < 1e-12);
            assert_eq!(p.by_light[&Light::Day].task_loss, Some(1.0), "{name}");
        }
        // Without the background term no objects' choice is made; without losses, no choice.
        assert!(scored.iter().all(|p| !p.policy.starts_with("objects-")));
        let mut bare = frame(Light::Day, true, 1.0);
        bare.loss = None;
        let scored = score(&RUNGS[..1], &[vec![bare]], &[]);
        assert!(scored.iter().all(|p| !p.policy.contains("loss-")));
        assert_eq!(scored[0].by_light[&Light::Day].task_loss, None);
    }

    #[test]
    fn the_objects_choices_drop_a_background_term_that_prefers_the_dark() {
        // The objects' loss follows the detections (1 seen, 2 missed); a background term of the
        // exposure in ms (the darker rung's false alarms fewer) makes the whole loss prefer the
        // darker rung in every light. The objects' choices take what mAP takes: by light, day
        // from rung 0 and night from rung 1 (2 of 3 objects, 67 recall points); by frame, every
        // frame's seeing rung (AP 1).
        let rungs = ladder(|o| {
            let background = o.settings.exposure_s * 1e3;
            let objects = if o.detections.is_empty() { 2.0 } else { 1.0 };
            o.background = Some(background);
            o.loss = Some(objects + background);
        });
        let scored = score(&RUNGS, &rungs, &[]);
        let get = |name: &str| scored.iter().find(|p| p.policy == name).unwrap();
        let night = |name: &str| get(name).by_light[&Light::Night];
        assert!((night("loss-by-light").settings.exposure_ms - 1.0).abs() < 1e-12);
        assert!((night("objects-loss-by-light").settings.exposure_ms - 9.0).abs() < 1e-12);
        assert!((night("objects-loss-by-light").map - 67.0 / 101.0).abs() < 1e-9);
        assert!((get("objects-loss-oracle").scores.map - 1.0).abs() < 1e-9);
        assert!(get("objects-loss-by-light").hindsight && get("objects-loss-oracle").hindsight);
        // Each rung carries its mean background term per light: rung 1's night, 9.
        let rung1 = night("rung-1");
        assert!((rung1.background_loss.unwrap() - 9.0).abs() < 1e-12);
        assert!((rung1.task_loss.unwrap() - ((2.0 + 1.0 + 1.0) / 3.0 + 9.0)).abs() < 1e-12);
    }
}
