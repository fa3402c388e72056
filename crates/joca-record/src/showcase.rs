//! `test/showcase.json`: fixed closed-loop sequences on the test town, the same scenes for every
//! run, whose frames, settings and boxes the reports draw.

use joca_core::{Annotation, Detection};
use serde::{Deserialize, Serialize};

/// One frame of a showcase sequence.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShowcaseFrame {
    /// Frame index in the sequence.
    pub frame: usize,
    /// Simulation time, s.
    pub time_s: f64,
    /// Ambient light relative to full daylight.
    pub ambient: f32,
    /// Exposure the sensor used, ms.
    pub exposure_ms: f64,
    /// Gain the sensor used, dB.
    pub gain_db: f64,
    /// Ground truth at the shutter midpoint.
    pub boxes: Vec<Annotation>,
    /// Detections on the formed frame.
    pub detections: Vec<Detection>,
    /// The saved 8-bit frame, relative to `test/`, if saved.
    pub image: Option<String>,
}

/// A showcase sequence.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Showcase {
    /// Name (`tunnel`, `day`, `night`).
    pub name: String,
    /// Illumination schedule (`day`, `night`, `tunnel`, `cycle`).
    pub illumination: String,
    /// Output frame size, pixels.
    pub size_px: (usize, usize),
    /// Frames in order.
    pub frames: Vec<ShowcaseFrame>,
}
