//! Checks shared by the `[run]` and `[pretrain]` tables: the detector architecture and input,
//! a camera crate's range error as a configuration error naming the field, and a `[run]` field's
//! refusal.

use crate::TrainError;
use joca_camera::{CameraError, DetectorInput};
use joca_nn::detector::DetectorConfig;

/// A refused field of the `[run]` table: the error naming `run.<field>`, its value and what is
/// allowed.
pub(super) fn refuse(field: &str, value: String, allowed: &str) -> Result<(), TrainError> {
    Err(TrainError::Config { field: format!("run.{field}"), value, allowed: allowed.into() })
}

/// Checks a detector architecture (`table.detector`): a width that fits memory, joca's three
/// classes.
pub(crate) fn check_detector(d: &DetectorConfig, table: &str) -> Result<(), TrainError> {
    let bad = |field: &str, value: i64, allowed: &str| {
        Err(TrainError::Config {
            field: format!("{table}.detector.{field}"),
            value: value.to_string(),
            allowed: allowed.into(),
        })
    };
    if !(4..=128).contains(&d.width) {
        return bad("width", d.width, "4 to 128");
    }
    if d.classes != 3 {
        return bad("classes", d.classes, "3 (vehicle, walker, traffic sign)");
    }
    Ok(())
}

/// Checks a detector input (`table.input`), naming the field and its range.
pub(crate) fn check_input(input: &DetectorInput, table: &str) -> Result<(), TrainError> {
    input.validate(&format!("{table}.input")).map_err(|e| range_error(e, "", ""))
}

/// A camera crate's range error as a configuration error: the field (after `prefix`), the value
/// and the range (followed by `note`).
pub(super) fn range_error(e: CameraError, prefix: &str, note: &str) -> TrainError {
    match e {
        CameraError::OutOfRange { field, value, min, max, unit } => TrainError::Config {
            field: format!("{prefix}{field}"),
            value: value.to_string(),
            allowed: format!("{min} to {max}{unit}{note}"),
        },
        other => TrainError::Camera(other),
    }
}
