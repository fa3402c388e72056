//! What a report reads from a run's `events.jsonl`: the generations' fitness, the logged steps,
//! NeuralAE's warm start and the wall time of each part of the run, each line a
//! [`joca_record::Event`].

use joca_record::Event;
use std::collections::BTreeMap;

/// Best and mean hardware fitness of one generation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GenerationFitness {
    /// Generation, from 0.
    pub generation: u64,
    /// Best member.
    pub best: f64,
    /// Mean over members.
    pub mean: f64,
}

/// One logged training step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepLog {
    /// Global step.
    pub step: u64,
    /// Detector task loss.
    pub loss: f64,
    /// Exposure used, ms.
    pub exposure_ms: f64,
    /// Gain used, dB.
    pub gain_db: f64,
    /// The task loss's pull on NeuralAE's exposure and gain, in l_GA's units (where recorded).
    pub task_gradient: Option<[f64; 2]>,
    /// Whether l_GA applied at this step.
    pub ga: bool,
    /// The step's light (where recorded).
    pub light: Option<joca_record::Light>,
}

/// The warm-start record of an `events.jsonl`, if it has one (the last, should there be more).
pub(crate) fn warm_start_of(bytes: &[u8]) -> Option<joca_record::WarmStartRecord> {
    bytes.split(|&b| b == b'\n').rev().filter_map(|l| std::str::from_utf8(l).ok()).find_map(|l| {
        match serde_json::from_str(l) {
            Ok(Event::WarmStart(w)) => Some(w),
            _ => None,
        }
    })
}

/// The wall time of each part of a run in an `events.jsonl`, summed over its records (a resumed
/// run writes one a process; a process killed before a part ended wrote none for it), in the
/// order the parts first appear.
pub(crate) fn wall_of(bytes: &[u8]) -> Vec<(joca_record::RunPhase, f64)> {
    let mut wall: Vec<(joca_record::RunPhase, f64)> = Vec::new();
    for line in bytes.split(|&b| b == b'\n').filter_map(|l| std::str::from_utf8(l).ok()) {
        if let Ok(Event::Phase(p)) = serde_json::from_str(line) {
            match wall.iter_mut().find(|(phase, _)| *phase == p.phase) {
                Some((_, s)) => *s += p.wall_s,
                None => wall.push((p.phase, p.wall_s)),
            }
        }
    }
    wall
}

/// Generation and step records of `events.jsonl`, and the (1-based) numbers of the lines that
/// could not be read. A resumed run repeats the candidate it was killed in, so a later record of
/// the same step or generation replaces an earlier one; an unreadable line (one cut by a kill,
/// bytes that are not UTF-8, JSON of no known event) is left out and named, the rest kept.
pub(crate) fn parse_events(bytes: &[u8]) -> (Vec<GenerationFitness>, Vec<StepLog>, Vec<usize>) {
    let mut generations = BTreeMap::new();
    let mut steps = BTreeMap::new();
    let mut skipped = Vec::new();
    for (k, line) in bytes.split(|&b| b == b'\n').enumerate() {
        if line.iter().all(u8::is_ascii_whitespace) {
            continue;
        }
        let event: Option<Event> =
            std::str::from_utf8(line).ok().and_then(|l| serde_json::from_str(l).ok());
        if event.is_none() {
            skipped.push(k + 1);
        }
        match event {
            Some(Event::Generation(g)) if !g.fitness.is_empty() => {
                let f = &g.fitness;
                let best = f.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                let mean = f.iter().sum::<f64>() / f.len() as f64;
                let generation = g.generation_done as u64;
                generations.insert(generation, GenerationFitness { generation, best, mean });
            }
            Some(Event::Step(s)) => {
                steps.insert(
                    s.step,
                    StepLog {
                        step: s.step,
                        loss: s.loss.total,
                        exposure_ms: s.settings.exposure_ms,
                        gain_db: s.settings.gain_db,
                        task_gradient: s.task_gradient,
                        ga: s.ga_loss.is_some(),
                        light: s.illumination,
                    },
                );
            }
            _ => {}
        }
    }
    (generations.into_values().collect(), steps.into_values().collect(), skipped)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_keep_the_last_record_of_a_repeated_step() {
        let loss = |total: f64| {
            format!("\"loss\":{{\"total\":{total},\"heatmap\":0.0,\"size\":0.0,\"offset\":0.0}}")
        };
        let text = format!(
            "{{\"step\":0,{},\"exposure_ms\":5.0,\"gain_db\":1.0}}\n\
             {{\"step\":5,{},\"exposure_ms\":5.0,\"gain_db\":1.0}}\n\
             {{\"step\":5,\"loss\":{{\"tot\n\
             {{\"step\":5,{},\"exposure_ms\":4.0,\"gain_db\":2.0}}\n\
             {{\"generation_done\":0,\"fitness\":[0.2,0.4]}}\n",
            loss(2.0),
            loss(1.0),
            loss(0.5)
        );
        let (g, s, skipped) = parse_events(text.as_bytes());
        assert_eq!(
            g,
            vec![GenerationFitness { generation: 0, best: 0.4, mean: 0.30000000000000004 }]
        );
        assert_eq!(s.len(), 2);
        assert_eq!((s[1].step, s[1].loss, s[1].exposure_ms), (5, 0.5, 4.0));
        assert_eq!(skipped, vec![3]);
    }

    #[test]
    fn a_line_that_is_not_utf8_is_named_and_the_rest_kept() {
        let mut bytes = b"{\"generation_done\":0,\"fitness\":[0.2]}\n".to_vec();
        bytes.extend_from_slice(b"{\"step\":\xff\xfe}\n\n{\"surprise\":1}\n");
        bytes.extend_from_slice(b"{\"generation_done\":1,\"fitness\":[0.3]}");
        let (g, _, skipped) = parse_events(&bytes);
        assert_eq!(g.len(), 2);
        assert_eq!(skipped, vec![2, 4]);
    }

    /// A resumed run's parts are summed over its processes, in the order they first appear;
    /// other events and cut lines are passed over.
    #[test]
    fn a_resumed_runs_parts_are_summed() {
        let bytes = b"{\"phase\":\"training\",\"wall_s\":10.0}\n{\"phase\":\"tra\n\
            {\"phase\":\"training\",\"wall_s\":5.5}\n{\"phase\":\"test\",\"wall_s\":2.0}\n";
        let wall = wall_of(bytes);
        assert_eq!(
            wall,
            vec![(joca_record::RunPhase::Training, 15.5), (joca_record::RunPhase::Test, 2.0)]
        );
    }
}
