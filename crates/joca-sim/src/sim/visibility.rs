//! Which simulated objects are reference objects: ranges per class and the visible share.

use joca_core::Class;
use serde::{Deserialize, Serialize};

/// Which objects are reference objects (ground truth) and count towards the 180° total.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VisibilityRules {
    /// Farthest vehicle that counts, metres from the camera (horizontal).
    pub vehicle_range_m: f32,
    /// Farthest walker that counts, metres.
    pub walker_range_m: f32,
    /// Farthest traffic sign that counts, metres.
    pub sign_range_m: f32,
    /// Smallest visible share of an object's camera-facing surface (reference-grid pixels over
    /// the pixels its front faces cover without occlusion; for the 180° count, the share of
    /// sample points on the object that a ray from the eye reaches unoccluded).
    pub min_visible_fraction: f32,
}

impl Default for VisibilityRules {
    /// Vehicles to 100 m; walkers and signs, smaller and met at lower closing speeds, to 50 m
    /// (3 s ahead at the simulator's 15 m/s); 15 % visible.
    fn default() -> Self {
        Self {
            vehicle_range_m: 100.0,
            walker_range_m: 50.0,
            sign_range_m: 50.0,
            min_visible_fraction: 0.15,
        }
    }
}

impl VisibilityRules {
    /// The range of `class`, metres.
    pub fn range_m(&self, class: Class) -> f32 {
        match class {
            Class::Vehicle => self.vehicle_range_m,
            Class::Walker => self.walker_range_m,
            Class::TrafficSign => self.sign_range_m,
        }
    }

    /// The longest of the class ranges, metres.
    pub fn farthest_m(&self) -> f32 {
        Class::ALL.iter().map(|&c| self.range_m(c)).fold(0.0, f32::max)
    }
}
