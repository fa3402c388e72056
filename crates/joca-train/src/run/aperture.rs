//! The f-numbers a run's hardware search may choose (`[run] f_number`).

use joca_core::optics::CALIBRATION_F_NUMBER;
use serde::{Deserialize, Serialize};

/// The f-numbers the hardware search may choose.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FNumberRange {
    /// Fastest allowed aperture.
    pub min: f64,
    /// Slowest allowed aperture.
    pub max: f64,
}

impl Default for FNumberRange {
    fn default() -> Self {
        Self { min: CALIBRATION_F_NUMBER, max: CALIBRATION_F_NUMBER }
    }
}

impl FNumberRange {
    /// Whether this is the calibration's f/16 alone (no aperture gene).
    pub fn is_calibration(&self) -> bool {
        *self == Self::default()
    }
}
