//! The run directory's record formats (docs/design.md, "Run directory"): `joca-train` writes them,
//! `joca-report` reads them, so the two cannot disagree about a field.
//!
//! - [`RunResults`], [`DesignSummary`] — `results.json`, `best_design.json`;
//! - [`Event`] — the lines of `events.jsonl` ([`StepRecord`], [`CandidateRecord`],
//!   [`GenerationRecord`]); [`TraceRecord`] — the lines of `test/trace.jsonl`;
//! - [`Showcase`] — `test/showcase.json`;
//! - [`HeadroomRecord`] — `headroom.json` (`joca headroom`);
//! - [`World`] — the world's light both records name alike;
//! - [`Provenance`] — which joca, commit and configuration made a record;
//! - [`Method`], [`Scenario`], [`Source`], [`TestController`] — the vocabulary the records use
//!   (with joca-core's [`compute`](joca_core::compute) names).
//!
//! ```
//! use joca_record::{Event, Method};
//! let line = r#"{"generation_done": 0, "fitness": [0.2, 0.4]}"#;
//! let event: Event = serde_json::from_str(line).unwrap();
//! assert!(matches!(event, Event::Generation(g) if g.fitness == [0.2, 0.4]));
//! assert_eq!(Method::from_name("joca"), Ok(Method::Joca));
//! ```
#![deny(missing_docs)]

mod by_light;
mod events;
mod headroom;
mod method;
mod provenance;
mod results;
mod retest;
mod settings;
mod showcase;
mod vocabulary;
mod world;

/// The record types that come from the crates below: boxes, and the task scores.
pub use joca_core::{Annotation, BBox, Class, Detection};
pub use joca_metrics::{BandScores, TaskScores};

pub use by_light::{ByLight, LightResults};
pub use events::{
    CandidateRecord, Event, GenerationRecord, LossRecord, PhaseRecord, RunPhase, StepRecord,
    TraceRecord, WarmStartRecord,
};
pub use headroom::{HEADROOM_FORMAT_VERSION, HeadroomRecord, PolicyLight, PolicyScores};
pub use method::{Method, Scenario};
pub use provenance::{BUILD_COMMIT, Provenance, config_sha256};
pub use results::{DesignSummary, RESULTS_FORMAT_VERSION, RunResults, SearchTies, Validated};
pub use retest::Retest;
pub use settings::Settings;
pub use showcase::{LightStep, Showcase, ShowcaseFrame};
pub use vocabulary::{Light, Source, TestController};
pub use world::{World, WorldLayout};
