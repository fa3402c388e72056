//! Training and evaluation of joca: the joint loop of the paper and detector pre-training.
//!
//! - [`run()`] — `joca run`: the joint loop (hardware GA, NeuralAE with DF-Grad, detector) for
//!   every method of the paper, then a closed-loop test of the best design.
//! - [`pretrain`] — `joca train-detector`: the detector on random designs with AverageAE.
//! - [`ExposureControl`] — NeuralAE and AverageAE as closed-loop exposure controllers.
//! - [`evaluate`] — closed-loop scoring of a design, AverageAE and a detector on the test town.
//! - [`CheckpointDir`] — atomic checkpoints; a killed run resumes from the last one.
#![deny(missing_docs)]

mod checkpoint;
mod control;
mod error;
mod eval;
mod pretrain;
mod run;

pub use checkpoint::{CheckpointDir, write_atomic};
pub use control::{
    AverageControl, Decision, ExposureControl, NeuralControl, SensorLimits, TestController,
    for_sensor,
};
pub use error::TrainError;
pub use eval::{EvalSpec, evaluate};
pub use pretrain::{
    DataConfig, EvalConfig, EvalReport, ExperimentalConfig, OptimizerConfig, PretrainConfig,
    PretrainEvent, differing_fields, evaluate_weights, pretrain, reference_design,
};
pub use run::{
    AccOutput, CheckpointTiming, DesignSpec, DesignSummary, EvalOptions, FNumberRange, FixedCamera,
    HardwareMutation, MAX_REFERENCE_RANGE_M, MAX_SPEED_MPS, MAX_TEST_TOWN, Method,
    PerturbationMutation, PerturbationScore, PerturbationSteps, RealConfig, ReferenceConfig,
    RunConfig, RunEvent, RunResults, Scenario, SearchTies, Showcase, ShowcaseFrame, Source,
    StepBreakdown, TieBreak, TrainingScenes, WarmStart, bench_checkpoint, bench_step, check_town,
    cpu_description, evaluate_run, headroom, run,
};
