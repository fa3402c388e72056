//! The lines of a run's `events.jsonl` and `test/trace.jsonl`: one JSON object per line.

use crate::{DesignSummary, Light, Settings};
use joca_metrics::TaskScores;
use serde::{Deserialize, Serialize};

/// One line of `events.jsonl`. A resumed run repeats the candidate it was killed in, so a
/// reader keeps the last record of a repeated step or generation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Event {
    /// A logged training step (every 5th).
    Step(StepRecord),
    /// A finished hardware candidate (boxed: its design and scores dwarf a step's record).
    Candidate(Box<CandidateRecord>),
    /// A finished generation.
    Generation(GenerationRecord),
    /// NeuralAE's warm start, before the first generation.
    WarmStart(WarmStartRecord),
    /// A part of the run finished, with its wall time in this process.
    Phase(PhaseRecord),
}

joca_core::named_enum! {
    /// The parts of a run whose wall time `events.jsonl` records (the warm start has its own
    /// record).
    pub enum RunPhase("run phase") {
        /// The generations trained in one process (a resumed run writes one record a process).
        Training = "training",
        /// Choosing the design to test: the best candidates re-scored on the validation towns.
        Selection = "selection",
        /// The test in closed loop with the run's own controller.
        Test = "test",
        /// The same test with AverageAE at mid-grey (NeuralAE methods).
        AverageRetest = "average-retest",
    }
}

/// The wall time of one part of a run, seconds, on whatever else the machine ran: a record of
/// where the time went, not a benchmark.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PhaseRecord {
    /// Which part.
    pub phase: RunPhase,
    /// Its wall time, seconds.
    pub wall_s: f64,
}

/// NeuralAE's warm start: how closely it imitated AverageAE, at the start and at the end.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WarmStartRecord {
    /// Imitation frames.
    pub warm_start_frames: usize,
    /// Mean imitation loss (L1 in normalised units, as l_GA) over the first quarter of them.
    pub imitation_loss_first: f64,
    /// The same over the last quarter.
    pub imitation_loss_last: f64,
    /// Its wall time, seconds (absent in older runs).
    #[serde(default)]
    pub warm_start_s: Option<f64>,
}

/// A training step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StepRecord {
    /// Global step index (candidate index × k + step).
    pub step: u64,
    /// The detector's task loss.
    pub loss: LossRecord,
    /// DF-Grad's GA supervision loss, on the steps it applies.
    #[serde(default)]
    pub ga_loss: Option<f64>,
    /// NeuralAE's step cost `l_step` (mean square stops moved), where its weight is above 0;
    /// absent otherwise and in older runs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub step_loss: Option<f64>,
    /// Exposure (ms) and gain (dB) applied, written as two fields.
    #[serde(flatten)]
    pub settings: Settings,
    /// The task loss's pull on NeuralAE's exposure and gain outputs, in l_GA's units
    /// (`w_task · ∂l_task/∂u`, u each setting's unit position in its range; negative: more
    /// light lowers the loss); absent where NeuralAE did not set the frame and in older runs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub task_gradient: Option<[f64; 2]>,
    /// The episode's illumination schedule (`recorded` for real frames; absent in older runs).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub illumination: Option<Light>,
}

/// The parts of the detector's task loss.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LossRecord {
    /// Weighted total.
    pub total: f64,
    /// Focal heatmap loss.
    pub heatmap: f64,
    /// Log-size L1 loss.
    pub size: f64,
    /// Offset L1 loss.
    pub offset: f64,
}

/// A hardware candidate's training result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CandidateRecord {
    /// Generation, from 0.
    pub generation: usize,
    /// Candidate in the generation, from 0.
    pub candidate: usize,
    /// Its design.
    pub design: DesignSummary,
    /// Its k frames scored together.
    pub scores: TaskScores,
    /// The hardware GA's fitness, mAP + 1.1 · TP ratio.
    pub fitness: f64,
}

/// A finished generation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GenerationRecord {
    /// Generation, from 0.
    pub generation_done: usize,
    /// Every member's fitness, in order.
    pub fitness: Vec<f64>,
}

/// One scored test frame (`test/trace.jsonl`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TraceRecord {
    /// Test episode.
    pub episode: u64,
    /// Scored frame in the episode, from 0 (after the warm-up frames).
    pub frame: usize,
    /// Time in the episode, s.
    pub time_s: f64,
    /// Illumination schedule (`recorded` for real frames).
    pub illumination: Light,
    /// Ambient light relative to full daylight (none for real frames).
    pub ambient: Option<f32>,
    /// Exposure (ms) and gain (dB) applied, written as two fields.
    #[serde(flatten)]
    pub settings: Settings,
    /// Annotated objects.
    pub objects: usize,
    /// Objects visible in the 180° field.
    pub visible_180: u32,
    /// Detections above the decoding threshold.
    pub detections: usize,
    /// Mean 8-bit value of the formed frame, DN.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mean_dn: Option<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A phase line reads back as a phase, and as nothing else (the enum is untagged); an
    /// unknown part is refused naming the allowed ones.
    #[test]
    fn a_phase_record_round_trips_and_is_told_from_the_other_events() {
        let e = Event::Phase(PhaseRecord { phase: RunPhase::AverageRetest, wall_s: 8.5 });
        let line = serde_json::to_string(&e).unwrap();
        assert_eq!(line, r#"{"phase":"average-retest","wall_s":8.5}"#);
        assert_eq!(serde_json::from_str::<Event>(&line).unwrap(), e);
        let warm =
            r#"{"warm_start_frames":3,"imitation_loss_first":1.0,"imitation_loss_last":0.5}"#;
        assert!(matches!(serde_json::from_str::<Event>(warm).unwrap(), Event::WarmStart(_)));
        let e = serde_json::from_str::<PhaseRecord>(r#"{"phase":"lunch","wall_s":1.0}"#);
        assert!(e.unwrap_err().to_string().contains("lunch"));
    }
}
