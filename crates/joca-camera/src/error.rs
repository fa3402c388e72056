//! Errors of the camera model.

use thiserror::Error;

/// What can go wrong when building or using a camera model.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CameraError {
    /// A numeric value is outside its allowed range.
    #[error("{field} = {value} is out of range: allowed {min} to {max}{unit}")]
    OutOfRange {
        /// The field or flag, e.g. `focal_length_mm`.
        field: String,
        /// The value given.
        value: f64,
        /// Smallest allowed value.
        min: f64,
        /// Largest allowed value.
        max: f64,
        /// Unit suffix for the message, e.g. `" mm"`.
        unit: &'static str,
    },
    /// A numeric value is not finite.
    #[error("{field} = {value} is not a finite number")]
    NotFinite {
        /// The field or flag.
        field: String,
        /// The value given.
        value: f64,
    },
    /// A sensor name is not in the catalogue.
    #[error("unknown sensor {name:?}; the catalogue has: {valid}")]
    UnknownSensor {
        /// The name given.
        name: String,
        /// Comma-separated valid names.
        valid: String,
    },
    /// A design space or restriction leaves no sensor to choose from.
    #[error("no catalogue sensor satisfies {constraint}")]
    NoSensor {
        /// The restriction that removed every sensor.
        constraint: String,
    },
    /// A genome has the wrong number of genes for its codec.
    #[error("genome has {got} genes but the codec expects {expected}")]
    GenomeLength {
        /// Genes expected.
        expected: usize,
        /// Genes given.
        got: usize,
    },
    /// An image passed to a calibration or formation routine is unusable.
    #[error("{reason}")]
    BadInput {
        /// What is wrong.
        reason: String,
    },
}
