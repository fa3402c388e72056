//! Which simulated objects every design is scored against (`[run.reference]`).

use joca_sim::VisibilityRules;
use serde::{Deserialize, Serialize};

/// The reference objects of the simulator's ground truth: every object of a class in the
/// camera's view within the class's range and at least 15 % visible, at any size in pixels.
/// A field left out of a `[run.reference]` table keeps its default.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReferenceConfig {
    /// Farthest vehicle, metres.
    pub vehicle_m: f64,
    /// Farthest walker, metres.
    pub walker_m: f64,
    /// Farthest traffic sign, metres.
    pub traffic_sign_m: f64,
}

/// Longest reference range, metres (objects are drawn to 220 m).
pub const MAX_REFERENCE_RANGE_M: f64 = 200.0;

impl Default for ReferenceConfig {
    fn default() -> Self {
        let r = VisibilityRules::default();
        Self {
            vehicle_m: f64::from(r.vehicle_range_m),
            walker_m: f64::from(r.walker_range_m),
            traffic_sign_m: f64::from(r.sign_range_m),
        }
    }
}

impl ReferenceConfig {
    /// The simulator's rules.
    pub fn rules(&self) -> VisibilityRules {
        VisibilityRules {
            vehicle_range_m: self.vehicle_m as f32,
            walker_range_m: self.walker_m as f32,
            sign_range_m: self.traffic_sign_m as f32,
            ..VisibilityRules::default()
        }
    }
}
