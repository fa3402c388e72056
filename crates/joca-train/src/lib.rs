//! Training and evaluation of joca: detector pre-training now; the joint loop of the paper
//! (hardware GA, NeuralAE with DF-Grad, detector) builds on the same pieces.
//!
//! - [`run()`] — `joca run`: the joint loop (hardware GA, NeuralAE with DF-Grad, detector) for
//!   every method of the paper, then a closed-loop test of the best design.
//! - [`pretrain`] — `joca train-detector`: the detector on random designs with AverageAE.
//! - [`evaluate`] — closed-loop scoring of a design, an exposure controller and a detector on
//!   the test town.
//! - [`CheckpointDir`] — atomic checkpoints; a killed run resumes from the last one.
#![deny(missing_docs)]

mod checkpoint;
mod error;
mod eval;
mod pretrain;
mod run;

pub use checkpoint::{CheckpointDir, write_atomic};
pub use error::TrainError;
pub use eval::{AverageControl, EvalSpec, ExposureControl, evaluate};
pub use pretrain::{
    EvalReport, PretrainConfig, PretrainEvent, differing_fields, evaluate_weights, pretrain,
    reference_design,
};
pub use run::{
    DesignSummary, FixedCamera, Method, RealConfig, RunConfig, RunEvent, RunResults, Scenario,
    Showcase, ShowcaseFrame, StepBreakdown, bench_step, evaluate_run, run,
};
