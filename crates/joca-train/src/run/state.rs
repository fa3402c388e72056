//! The loop's state (`checkpoint/…/state.json`): where the hardware GA and the perturbation GA
//! stand, the best designs so far and the searches' ties; and the loop's steps on it — starting
//! or resuming, the generation's members, one candidate trained, recorded and checkpointed.

use super::context::Context;
use super::results::summary;
use super::{RunConfig, RunEvent, candidate, ga_err, hardware, perturbation};
use crate::TrainError;
use crate::checkpoint::{CheckpointDir, check_resume, read_json, write_atomic};
use joca_evolve::Ga;
use joca_nn::joint::JointModel;
use joca_record::{CandidateRecord, Event, GenerationRecord, SearchTies};
use serde::{Deserialize, Serialize};
use std::ops::ControlFlow;
use std::path::Path;

/// How many of training's best designs the validation re-scores.
const TOP_DESIGNS: usize = 3;

/// The newest layout of `state.json` this joca reads and writes. Files without the field (0)
/// were written before it existed, in the same layout; a newer one is refused, named.
pub const STATE_FORMAT_VERSION: u32 = 1;

#[derive(Debug, Serialize, Deserialize)]
pub(super) struct RunState {
    /// Layout version ([`STATE_FORMAT_VERSION`] when written; 0 in older checkpoints).
    #[serde(default)]
    pub(super) format_version: u32,
    pub(super) config: RunConfig,
    pub(super) generation: usize,
    pub(super) candidate: usize,
    pub(super) fitness: Vec<f64>,
    pub(super) hardware: Ga,
    pub(super) perturbation: Ga,
    pub(super) best: Option<(Vec<f64>, f64)>,
    /// The best distinct designs of training, best first, with their fitness: the candidates
    /// the validation chooses among.
    #[serde(default)]
    pub(super) top: Vec<(Vec<f64>, f64)>,
    /// The perturbation searches of the finished candidates, and their ties.
    #[serde(default)]
    pub(super) ties: SearchTies,
}

impl RunState {
    /// A new run's state (both GAs drawn from their seed streams), or with `resume` the state
    /// of the last checkpoint (the model loaded from it too). A checkpoint without `resume` is
    /// refused.
    pub(super) fn start(
        cx: &Context,
        model: &mut JointModel,
        ckpt: &CheckpointDir,
        run_dir: &Path,
        resume: bool,
    ) -> Result<Self, TrainError> {
        let config = &cx.config;
        let codec = cx.codec.clone();
        let mut init_rng = cx.streams.stream("hardware-init");
        let mut hardware = Ga::new(
            hardware::ga_config(config.hardware_mutation, config.population, &codec)?,
            &mut init_rng,
        );
        hardware.apply(|g| {
            let _ = codec.snap(g);
        });
        // Perturbations in normalised units: ±5 % of each range.
        let perturbation = perturbation::ga(config, &cx.streams)?;
        let state = RunState {
            format_version: STATE_FORMAT_VERSION,
            config: config.clone(),
            generation: 0,
            candidate: 0,
            fitness: Vec::new(),
            hardware,
            perturbation,
            best: None,
            top: Vec::new(),
            ties: SearchTies::default(),
        };
        match ckpt.existing() {
            Some(dir) if resume => {
                crate::checkpoint::verify_checkpoint(&dir)?;
                let path = dir.join("state.json");
                let mut saved: RunState = read_json(&path)?;
                if saved.format_version > STATE_FORMAT_VERSION {
                    return Err(TrainError::Corrupt {
                        path: path.display().to_string(),
                        reason: format!(
                            "its format_version {} is newer than this joca reads \
                             ({STATE_FORMAT_VERSION}); resume it with the joca that wrote it",
                            saved.format_version
                        ),
                    });
                }
                // An older checkpoint is the same layout; it is written back as the current.
                saved.format_version = STATE_FORMAT_VERSION;
                // Compared as computed: a weights file by content, wherever it is named from.
                check_resume(&saved.config.identity(), &config.identity(), run_dir)?;
                model.load(&dir)?;
                Ok(saved)
            }
            Some(_) => Err(TrainError::Config {
                field: "run directory".into(),
                value: run_dir.display().to_string(),
                allowed: "a directory without a checkpoint (pass --resume to continue it)".into(),
            }),
            None => Ok(state),
        }
    }

    /// The genes of this generation's candidates: the hardware GA's population, or the fixed
    /// design as many times (every method trains on the same number of frames: a fixed camera
    /// drives as many candidates per generation, each on its own scenes, as the GA evaluates).
    pub(super) fn members(&self, cx: &Context) -> Result<Vec<Vec<f64>>, TrainError> {
        if cx.config.hardware_search() {
            Ok(self.hardware.ask().to_vec())
        } else {
            Ok(vec![cx.codec.encode(&cx.config.fixed_design()?)?; cx.config.population])
        }
    }

    /// Records a scored candidate among the top designs.
    fn rank(&mut self, genes: &[f64], fitness: f64) {
        match self.top.iter_mut().find(|(g, _)| g.as_slice() == genes) {
            Some(entry) => entry.1 = entry.1.max(fitness),
            None => self.top.push((genes.to_vec(), fitness)),
        }
        self.top.sort_by(|a, b| b.1.total_cmp(&a.1));
        self.top.truncate(TOP_DESIGNS);
    }

    /// Trains candidate `self.candidate` of `members`, logs it, tells the hardware GA at the
    /// generation's end, and checkpoints; returns its fitness.
    pub(super) fn train_candidate(
        &mut self,
        cx: &mut Context,
        model: &mut JointModel,
        members: &[Vec<f64>],
        ckpt: &CheckpointDir,
        progress: &mut dyn FnMut(&RunEvent) -> ControlFlow<()>,
    ) -> Result<f64, TrainError> {
        let design = cx.codec.decode(&members[self.candidate])?;
        let index = (self.generation * members.len() + self.candidate) as u64;
        let (generation, candidate, candidates) = (self.generation, self.candidate, members.len());
        let best = self.best.as_ref().map(|b| b.1);
        let mut on_step = |step: usize, of: usize| {
            let _ = progress(&RunEvent::Step { generation, candidate, candidates, step, of, best });
        };
        let scores = match candidate::train(
            cx,
            model,
            &mut self.perturbation,
            &design,
            (index, self.generation as u64),
            &mut on_step,
        ) {
            Err(TrainError::Nn(source @ joca_nn::NnError::NonFinite { .. })) => {
                let checkpoint = ckpt.existing().map_or_else(
                    || "none: no candidate had finished".to_owned(),
                    |d| format!("{}, after {index} candidate(s)", d.display()),
                );
                return Err(TrainError::Diverged { generation, candidate, checkpoint, source });
            }
            r => r?,
        };
        // A killed candidate is repeated from the checkpoint: count its searches once.
        self.ties.add(std::mem::take(&mut cx.journal.ties));
        let fitness = scores.fitness();
        self.fitness.push(fitness);
        let genes = &members[self.candidate];
        if self.best.as_ref().is_none_or(|(_, f)| fitness > *f) {
            self.best = Some((genes.clone(), fitness));
        }
        self.rank(genes, fitness);
        cx.journal.log(&Event::Candidate(Box::new(CandidateRecord {
            generation: self.generation,
            candidate: self.candidate,
            design: summary(&design, cx.config.hardware_search()),
            scores,
            fitness,
        })))?;
        self.candidate += 1;
        if self.candidate == members.len() {
            self.end_generation(cx)?;
        }
        self.checkpoint(model, ckpt)?;
        Ok(fitness)
    }

    /// Writes the model and this state as the run's checkpoint.
    pub(super) fn checkpoint(
        &self,
        model: &JointModel,
        ckpt: &CheckpointDir,
    ) -> Result<(), TrainError> {
        ckpt.write(|dir| {
            model.save(dir)?;
            let text = serde_json::to_string(self).map_err(|e| TrainError::Corrupt {
                path: "state.json".into(),
                reason: e.to_string(),
            })?;
            write_atomic(&dir.join("state.json"), &text)
        })
    }

    /// Tells the hardware GA the generation's fitness (when it searches) and moves on.
    fn end_generation(&mut self, cx: &mut Context) -> Result<(), TrainError> {
        if cx.config.hardware_search() {
            let codec = cx.codec.clone();
            let mut rng = cx.streams.indexed("hardware-ga", self.generation as u64);
            self.hardware
                .tell(&self.fitness, &mut rng, |g| {
                    let _ = codec.snap(g);
                })
                .map_err(ga_err)?;
        }
        cx.journal.log(&Event::Generation(GenerationRecord {
            generation_done: self.generation,
            fitness: self.fitness.clone(),
        }))?;
        self.fitness.clear();
        self.candidate = 0;
        self.generation += 1;
        Ok(())
    }
}
