//! What a run records as it goes: `events.jsonl` (each step, candidate, generation and the warm
//! start), where each step's time goes (`joca bench step`), and the perturbation searches' ties.

use super::SearchTies;
use super::timing::Stopwatch;
use crate::TrainError;
use joca_record::Event;
use std::io::Write;
use std::path::PathBuf;

/// What a run records as it goes.
pub(super) struct Journal {
    /// `events.jsonl` (a sink where nothing is logged).
    log: Box<dyn Write>,
    log_path: PathBuf,
    /// Where each step's time goes (only `joca bench step` reads it).
    pub(super) watch: Stopwatch,
    /// The perturbation searches of the candidate in training, and their ties.
    pub(super) ties: SearchTies,
}

impl Journal {
    /// A journal writing its events to `log` (named `log_path` in errors).
    pub(super) fn new(log: Box<dyn Write>, log_path: PathBuf) -> Self {
        Self { log, log_path, watch: Stopwatch::default(), ties: SearchTies::default() }
    }

    /// Appends `event` to `events.jsonl`.
    pub(super) fn log(&mut self, event: &Event) -> Result<(), TrainError> {
        let line = serde_json::to_string(event).map_err(|e| TrainError::Corrupt {
            path: self.log_path.display().to_string(),
            reason: e.to_string(),
        })?;
        writeln!(self.log, "{line}").map_err(|e| TrainError::io(&self.log_path, e))
    }
}
