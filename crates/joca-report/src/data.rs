//! What a report reads from a run directory: `results.json`, `events.jsonl` and
//! `test/showcase.json` (DESIGN.md's run directory), in the record types `joca-train` writes
//! them with (`joca_record`).

use crate::ReportError;
use joca_record::{Event, RunResults, Showcase};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

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
}

/// Everything a report uses from one run directory.
#[derive(Debug, Clone)]
pub struct RunData {
    /// The run directory.
    pub dir: PathBuf,
    /// `results.json`.
    pub results: RunResults,
    /// Hardware GA fitness per generation.
    pub generations: Vec<GenerationFitness>,
    /// Training steps as logged (every fifth), in step order.
    pub steps: Vec<StepLog>,
    /// Showcase sequences (empty for runs made before they existed).
    pub showcases: Vec<Showcase>,
}

impl RunData {
    /// Reads a finished run directory.
    pub fn load(dir: &Path) -> Result<Self, ReportError> {
        let results_path = dir.join("results.json");
        let results: RunResults = parse(&results_path, &read(&results_path)?)?;
        let (generations, steps) = match std::fs::read_to_string(dir.join("events.jsonl")) {
            Ok(text) => parse_events(&text),
            Err(_) => (Vec::new(), Vec::new()),
        };
        let show_path = dir.join("test").join("showcase.json");
        let showcases =
            if show_path.exists() { parse(&show_path, &read(&show_path)?)? } else { Vec::new() };
        Ok(Self { dir: dir.to_owned(), results, generations, steps, showcases })
    }

    /// The showcase sequence called `name`.
    pub fn showcase(&self, name: &str) -> Option<&Showcase> {
        self.showcases.iter().find(|s| s.name == name)
    }

    /// Path of a saved showcase frame.
    pub fn frame_path(&self, image: &str) -> PathBuf {
        self.dir.join("test").join(image)
    }
}

pub(crate) fn read(path: &Path) -> Result<String, ReportError> {
    std::fs::read_to_string(path)
        .map_err(|source| ReportError::Io { path: path.display().to_string(), source })
}

pub(crate) fn parse<T: serde::de::DeserializeOwned>(
    path: &Path,
    text: &str,
) -> Result<T, ReportError> {
    serde_json::from_str(text).map_err(|e| ReportError::Format {
        path: path.display().to_string(),
        reason: e.to_string(),
    })
}

/// Generation and step records of `events.jsonl`. A resumed run repeats the candidate it was
/// killed in, so a later record of the same step or generation replaces an earlier one;
/// unparsable lines (a line cut by the kill) are skipped.
fn parse_events(text: &str) -> (Vec<GenerationFitness>, Vec<StepLog>) {
    let mut generations = BTreeMap::new();
    let mut steps = BTreeMap::new();
    for line in text.lines() {
        match serde_json::from_str::<Event>(line) {
            Ok(Event::Generation(g)) if !g.fitness.is_empty() => {
                let f = &g.fitness;
                let best = f.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                let mean = f.iter().sum::<f64>() / f.len() as f64;
                let generation = g.generation_done as u64;
                generations.insert(generation, GenerationFitness { generation, best, mean });
            }
            Ok(Event::Step(s)) => {
                steps.insert(
                    s.step,
                    StepLog {
                        step: s.step,
                        loss: s.loss.total,
                        exposure_ms: s.exposure_ms,
                        gain_db: s.gain_db,
                    },
                );
            }
            _ => {}
        }
    }
    (generations.into_values().collect(), steps.into_values().collect())
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
        let (g, s) = parse_events(&text);
        assert_eq!(
            g,
            vec![GenerationFitness { generation: 0, best: 0.4, mean: 0.30000000000000004 }]
        );
        assert_eq!(s.len(), 2);
        assert_eq!((s[1].step, s[1].loss, s[1].exposure_ms), (5, 0.5, 4.0));
    }
}
