//! Recorded frames in a run: where frames come from (`source`, `test_source`) and how the
//! real-image mode reads them (`[run.real]`).

use crate::TrainError;
use joca_camera::Calibration;
use joca_data::blur::Linearize;
use joca_data::folder::{FolderConfig, OnBadFrame, Recording};
use serde::{Deserialize, Serialize};

/// How the real-image mode reads recorded frames (`[run.real]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RealConfig {
    /// `srgb` (undo the sRGB curve of 8-bit frames) or `none` (frames are linear).
    pub linearize: Linearize,
    /// Exposure of frames without `exposure_s`, ms; 0 refuses such frames.
    pub default_exposure_ms: f64,
    /// A frame that cannot be read: `stop` the run naming it, or `skip` it with a warning.
    pub on_bad_frame: OnBadFrame,
    /// Waymo camera to use (`key.camera_name`; FRONT_LEFT = 2, the paper's).
    pub waymo_camera: i64,
}

impl Default for RealConfig {
    fn default() -> Self {
        Self {
            linearize: Linearize::Srgb,
            default_exposure_ms: 0.0,
            on_bad_frame: OnBadFrame::Stop,
            waymo_camera: joca_data::waymo::FRONT_LEFT,
        }
    }
}

impl RealConfig {
    pub(super) fn folder_config(&self) -> Result<FolderConfig, TrainError> {
        let bad = |field: &str, value: String, allowed: &str| TrainError::Config {
            field: format!("run.real.{field}"),
            value,
            allowed: allowed.into(),
        };
        let cal = Calibration::DEFAULT;
        Ok(FolderConfig {
            linearize: self.linearize,
            default_exposure_s: if self.default_exposure_ms > 0.0 {
                Some(self.default_exposure_ms * 1e-3)
            } else if self.default_exposure_ms == 0.0 {
                None
            } else {
                return Err(bad(
                    "default_exposure_ms",
                    self.default_exposure_ms.to_string(),
                    "0 (none) or above",
                ));
            },
            on_bad_frame: self.on_bad_frame,
            calibration_exposure_s: cal.exposure_s,
            calibration_gain_db: cal.gain_db,
            ..FolderConfig::default()
        })
    }
}

pub use joca_record::Source;

/// Opens the recording `source` names (`None` for the simulator), read as `real` says.
pub(super) fn open(source: &Source, real: &RealConfig) -> Result<Option<Recording>, TrainError> {
    let folder = real.folder_config()?;
    Ok(match source {
        Source::Sim => None,
        Source::Folder(dir) => Some(Recording::open(dir, folder)?),
        Source::Waymo(dir) => Some(Recording::open_waymo(dir, real.waymo_camera, folder)?),
    })
}
