//! Dynamic camera settings: exposure time and gain, their ranges, and normalised units.
//!
//! The ACC network predicts settings inside [`AccRanges`] (paper Sec. 6.3: exposure 0.1–50 ms,
//! gain 1–30 dB). The GA supervision loss (Eq. 5) and the perturbation bounds (±5 % of each
//! range) are expressed in normalised units, where each range maps to [0, 1], so that one
//! millisecond and one decibel are not compared directly.

use crate::CameraError;
use joca_core::units::linear_from_db;
use serde::{Deserialize, Serialize};

/// Exposure time and analogue gain of one frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DynamicSettings {
    /// Shutter interval, seconds.
    pub exposure_s: f64,
    /// Analogue gain, decibels of amplitude.
    pub gain_db: f64,
}

impl DynamicSettings {
    /// Settings from exposure (seconds) and gain (dB).
    pub fn new(exposure_s: f64, gain_db: f64) -> Self {
        Self { exposure_s, gain_db }
    }

    /// Linear gain factor `10^(gain_db/20)`.
    pub fn gain_linear(&self) -> f64 {
        linear_from_db(self.gain_db)
    }
}

/// A closed interval of allowed values.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Bounds {
    /// Smallest allowed value.
    pub min: f64,
    /// Largest allowed value.
    pub max: f64,
}

impl Bounds {
    /// `[min, max]`.
    pub const fn new(min: f64, max: f64) -> Self {
        Self { min, max }
    }

    /// A single allowed value (a fixed, non-optimised parameter).
    pub const fn fixed(value: f64) -> Self {
        Self { min: value, max: value }
    }

    /// Whether `min == max`.
    pub fn is_fixed(&self) -> bool {
        self.max - self.min <= 0.0
    }

    /// Width of the interval.
    pub fn span(&self) -> f64 {
        self.max - self.min
    }

    /// `value` clamped into the interval.
    pub fn clamp(&self, value: f64) -> f64 {
        value.clamp(self.min, self.max)
    }

    /// Whether `value` lies in the interval (inclusive).
    pub fn contains(&self, value: f64) -> bool {
        value >= self.min && value <= self.max
    }

    /// `value` if it lies in the interval, else an error naming `field`, the range and `unit`.
    pub fn check(&self, field: &str, value: f64, unit: &'static str) -> Result<f64, CameraError> {
        if !value.is_finite() {
            return Err(CameraError::NotFinite { field: field.to_owned(), value });
        }
        if self.contains(value) {
            Ok(value)
        } else {
            Err(CameraError::OutOfRange {
                field: field.to_owned(),
                value,
                min: self.min,
                max: self.max,
                unit,
            })
        }
    }

    /// Maps `value` to [0, 1] over the interval (0 for a fixed interval).
    pub fn normalise(&self, value: f64) -> f64 {
        if self.is_fixed() { 0.0 } else { (value - self.min) / self.span() }
    }

    /// Inverse of [`Bounds::normalise`].
    pub fn denormalise(&self, unit: f64) -> f64 {
        self.min + unit * self.span()
    }
}

/// The ranges the ACC may choose exposure and gain from.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AccRanges {
    /// Exposure time, seconds.
    pub exposure_s: Bounds,
    /// Gain, dB.
    pub gain_db: Bounds,
}

impl AccRanges {
    /// The paper's ranges: exposure 0.1–50 ms, gain 1–30 dB.
    pub const PAPER: AccRanges =
        AccRanges { exposure_s: Bounds::new(0.1e-3, 50e-3), gain_db: Bounds::new(1.0, 30.0) };

    /// Both settings clamped into their ranges.
    pub fn clamp(&self, s: DynamicSettings) -> DynamicSettings {
        DynamicSettings::new(self.exposure_s.clamp(s.exposure_s), self.gain_db.clamp(s.gain_db))
    }

    /// Settings in normalised units `[e, g] ∈ [0, 1]²`.
    pub fn normalise(&self, s: DynamicSettings) -> [f64; 2] {
        [self.exposure_s.normalise(s.exposure_s), self.gain_db.normalise(s.gain_db)]
    }

    /// Inverse of [`AccRanges::normalise`].
    pub fn denormalise(&self, unit: [f64; 2]) -> DynamicSettings {
        DynamicSettings::new(
            self.exposure_s.denormalise(unit[0]),
            self.gain_db.denormalise(unit[1]),
        )
    }
}

impl Default for AccRanges {
    fn default() -> Self {
        Self::PAPER
    }
}

/// The iris of a lens whose aperture the controller sets frame by frame: from the lens's widest
/// f-number (the design's) to its narrowest. The controller works in the iris's unit position
/// `u ∈ [0, 1]`, even steps of log f-number (so of stops of light): `N = N_w·(N_n/N_w)^u`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Iris {
    /// f-number fully open (u = 0).
    pub widest: f64,
    /// f-number fully stopped down (u = 1); never below `widest`.
    pub narrowest: f64,
}

impl Iris {
    /// Where a sequence starts and an untrained NeuralAE puts the iris: halfway, in stops,
    /// between wide open and stopped down. (At an end, u = 0.99 through the sigmoid, the task
    /// gradient reaching the iris is 25× weaker than here; a quick run started there moved the
    /// iris little in 1,350 steps.)
    pub const START_UNIT: f64 = 0.5;

    /// An iris from `widest` to `narrowest` (a lens already at or past `narrowest` cannot stop
    /// down: both ends are `widest`).
    pub fn new(widest: f64, narrowest: f64) -> Self {
        Self { widest, narrowest: narrowest.max(widest) }
    }

    /// The f-number at unit position `unit` (clamped into [0, 1]).
    pub fn f_number(&self, unit: f64) -> f64 {
        self.widest * (self.narrowest / self.widest).powf(unit.clamp(0.0, 1.0))
    }

    /// The unit position of `f_number` (clamped into [0, 1]; 0 where the iris cannot move).
    pub fn unit(&self, f_number: f64) -> f64 {
        let (a, b) = self.log_range();
        if b > a { ((f_number.ln() - a) / (b - a)).clamp(0.0, 1.0) } else { 0.0 }
    }

    /// `(ln N_w, ln N_n)`.
    pub fn log_range(&self) -> (f64, f64) {
        (self.widest.ln(), self.narrowest.ln())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_iris_moves_in_even_stops() {
        let iris = Iris::new(2.0, 16.0);
        assert_eq!(iris.f_number(0.0), 2.0);
        assert!((iris.f_number(1.0) - 16.0).abs() < 1e-12);
        // f/2 to f/16 is 6 stops (64× the light): a third of the way is f/4, two stops.
        assert!((iris.f_number(1.0 / 3.0) - 4.0).abs() < 1e-12);
        assert!((iris.unit(5.6) - (5.6f64 / 2.0).ln() / 8f64.ln()).abs() < 1e-12);
        assert_eq!((iris.f_number(-1.0), iris.unit(32.0)), (2.0, 1.0));
        // A lens at f/16 already cannot stop down.
        let fixed = Iris::new(16.0, 16.0);
        assert_eq!((fixed.f_number(0.7), fixed.unit(16.0)), (16.0, 0.0));
        assert_eq!(Iris::new(22.0, 16.0).narrowest, 22.0);
    }

    #[test]
    fn normalised_units_round_trip() {
        let r = AccRanges::PAPER;
        let s = DynamicSettings::new(5e-3, 10.0);
        let n = r.normalise(s);
        assert!((n[0] - (5e-3 - 0.1e-3) / (49.9e-3)).abs() < 1e-12);
        assert!((n[1] - 9.0 / 29.0).abs() < 1e-12);
        let back = r.denormalise(n);
        assert!((back.exposure_s - 5e-3).abs() < 1e-15 && (back.gain_db - 10.0).abs() < 1e-12);
    }

    #[test]
    fn check_names_the_field_and_range() {
        let b = Bounds::new(1.0, 10.0);
        assert_eq!(b.check("focal_length_mm", 3.6, " mm"), Ok(3.6));
        let e = b.check("focal_length_mm", 12.0, " mm").unwrap_err().to_string();
        assert_eq!(e, "focal_length_mm = 12 is out of range: allowed 1 to 10 mm");
        assert!(b.check("f", f64::NAN, "").is_err());
    }

    #[test]
    fn gain_is_amplitude_decibels() {
        assert!((DynamicSettings::new(1e-3, 20.0).gain_linear() - 10.0).abs() < 1e-12);
    }
}
