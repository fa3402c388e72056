//! `headroom.json`: the room any exposure controller has on one design and detector (`joca
//! headroom`): the same test frames captured at a ladder of settings and under closed-loop
//! controllers, each scored, and what the best choices in hindsight would score.

use crate::{DesignSummary, Light, Provenance, Scenario, Settings, World, WorldLayout};
use joca_metrics::TaskScores;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The newest layout version of `headroom.json` this joca reads and writes. Version 2 adds the
/// world's light (`cast_shadows`, `sun_elevation`); a record in the default world is written as
/// version 1, which an older reader reads correctly ([`HeadroomRecord::layout_version`]);
/// version 3 the lens's veiling glare (`glare`) and the sun's disc (`sun_disc`); version 4 the
/// GPU (`device`); version 5 tunnels as places (`tunnels`); version 6 daylight that follows the
/// sun's elevation (`sun_elevation.daylight`); version 7 tunnel drives in one direction
/// (`tunnels.drives`); version 8 streets whose lamps stay dark at night (`dark_streets`). A
/// policy's `task_loss` needs no version of its own: a reader that does not know it reads the
/// rest correctly.
pub const HEADROOM_FORMAT_VERSION: u32 = 8;

/// What one design and detector leave to a controller (`headroom.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeadroomRecord {
    /// Layout version ([`HEADROOM_FORMAT_VERSION`]).
    pub format_version: u32,
    /// The scenario the frames were formed under.
    pub scenario: Scenario,
    /// The test family's town driven (0: the test town).
    pub town: u64,
    /// The world's light (each part absent: the default).
    #[serde(flatten)]
    pub world: World,
    /// The design.
    pub design: DesignSummary,
    /// The detector: `trained` (a run's own, from its checkpoint) or the weights file.
    pub detector: String,
    /// The run directory the design and detector came from, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub run: Option<String>,
    /// Scored frames (every policy scores the same instants).
    pub frames: u64,
    /// The ladder's settings, as the sensor applied them, rung by rung.
    pub ladder: Vec<Settings>,
    /// Every policy's scores: the ladder's rungs (`rung-<i>`), the closed-loop controllers
    /// (`average-<DN>`, `trained`) and the choices in hindsight (`best-constant`,
    /// `best-target`, `target-by-light`, `constant-by-light`, `oracle`, `map-search`,
    /// `map-search-16`, `loss-by-light`, `loss-oracle`, `objects-loss-by-light`,
    /// `objects-loss-oracle`).
    pub policies: Vec<PolicyScores>,
    /// The CPU the numbers were computed on.
    pub cpu: String,
    /// The GPU the detector ran on (as [`crate::RunResults::device`]); absent: the CPU.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub device: Option<String>,
    /// Which joca, commit and configuration computed the record.
    pub provenance: Provenance,
}

/// One policy's scores over the frames, overall and by light.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PolicyScores {
    /// Its name (see [`HeadroomRecord::policies`]).
    pub policy: String,
    /// What it is, for a reader (e.g. `AverageAE holding 170 DN`, `per-frame oracle over the
    /// ladder, chosen in hindsight`).
    pub label: String,
    /// Whether it was chosen with knowledge of the test frames' scores (an upper bound or an
    /// estimate of one, not a controller).
    pub hindsight: bool,
    /// Scores over every frame.
    pub scores: TaskScores,
    /// Scores and frames by light.
    pub by_light: BTreeMap<Light, PolicyLight>,
}

/// A policy's frames of one light.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PolicyLight {
    /// mAP@[.5:.95] of these frames.
    pub map: f64,
    /// AP50 of these frames.
    pub ap50: f64,
    /// Mean settings.
    pub settings: Settings,
    /// Mean exposure × linear gain, ms.
    pub exposure_gain_ms: f64,
    /// Mean frame level, DN.
    pub mean_dn: f64,
    /// Mean share of pixels with a channel at 255.
    pub clipped_share: f64,
    /// Mean detector task loss on the run's training objects (absent: not computed, as for the
    /// closed-loop controllers).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub task_loss: Option<f64>,
    /// Mean of the task loss's heatmap background term (confidence where no object is; the
    /// loss less it is the loss on the objects), where the task loss was computed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub background_loss: Option<f64>,
    /// Mean slope of the task loss by the light in stops through the differentiable formation
    /// (`[ladder] slopes`; negative: more light lowers the loss).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub loss_slope: Option<f64>,
    /// Share of frames whose slope is negative (more light would lower their loss).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub more_light_share: Option<f64>,
    /// Frames.
    pub frames: u64,
}

impl HeadroomRecord {
    /// The lowest layout version that holds this record: 8 with dark streets, 7 with tunnel
    /// drives in one direction, 6 with a clear sky's daylight, 5 with tunnels as places, 4 with a
    /// GPU, 3 with veiling glare or the sun's disc, 2 where the world's light is not the default
    /// one, else 1.
    pub fn layout_version(&self) -> u32 {
        match self.world.layout() {
            WorldLayout::DarkStreets => 8,
            WorldLayout::TunnelDrives => 7,
            WorldLayout::Daylight => 6,
            WorldLayout::TunnelPlaces => 5,
            _ if self.device.is_some() => 4,
            WorldLayout::GlareOrDisc => 3,
            WorldLayout::ShadowsOrSun => 2,
            WorldLayout::Default => 1,
        }
    }

    /// The world the frames were rendered in, for a reader: `default light`, or what differs
    /// (`cast shadows, sun 10–30°`).
    pub fn world(&self) -> String {
        self.world.summary()
    }

    /// The policy named `name`.
    pub fn policy(&self, name: &str) -> Option<&PolicyScores> {
        self.policies.iter().find(|p| p.policy == name)
    }
}
