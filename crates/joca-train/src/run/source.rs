//! Recorded frames in a run: where frames come from (`source`, `test_source`) and how the
//! real-image mode reads them (`[run.real]`).

use crate::TrainError;
use joca_camera::Calibration;
use joca_data::blur::Linearize;
use joca_data::folder::{FolderConfig, OnBadFrame, Recording};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// How the real-image mode reads recorded frames (`[run.real]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RealConfig {
    /// `srgb` (undo the sRGB curve of 8-bit frames) or `none` (frames are linear).
    pub linearize: String,
    /// Exposure of frames without `exposure_s`, ms; 0 refuses such frames.
    pub default_exposure_ms: f64,
    /// A frame that cannot be read: `stop` the run naming it, or `skip` it with a warning.
    pub on_bad_frame: String,
    /// Waymo camera to use (`key.camera_name`; FRONT_LEFT = 2, the paper's).
    pub waymo_camera: i64,
}

impl Default for RealConfig {
    fn default() -> Self {
        Self {
            linearize: "srgb".into(),
            default_exposure_ms: 0.0,
            on_bad_frame: "stop".into(),
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
            linearize: Linearize::from_name(&self.linearize).map_err(|_| {
                bad("linearize", format!("{:?}", self.linearize), "\"srgb\" or \"none\"")
            })?,
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
            on_bad_frame: match self.on_bad_frame.as_str() {
                "stop" => OnBadFrame::Stop,
                "skip" => OnBadFrame::Skip,
                other => {
                    return Err(bad("on_bad_frame", format!("{other:?}"), "\"stop\" or \"skip\""));
                }
            },
            calibration_exposure_s: cal.exposure_s,
            calibration_gain_db: cal.gain_db,
            ..FolderConfig::default()
        })
    }
}

/// Where frames come from (`source`, `test_source`): written `sim` (or empty), `folder:DIR` or
/// `waymo:DIR` in configuration files, parsed once when the file is read.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum Source {
    /// The built-in simulator (as `test_source`: the default test frames).
    #[default]
    Sim,
    /// A recording in the folder format (frames and a COCO `annotations.json`).
    Folder(PathBuf),
    /// Waymo Open Dataset v2 parquet files (`DIR/camera_image`, `DIR/camera_box`).
    Waymo(PathBuf),
}

impl Source {
    /// What a configuration file may say.
    pub const ALLOWED: &str = "\"sim\" (the built-in simulator), \"folder:DIR\" (a recording in \
        the folder format) or \"waymo:DIR\" (Waymo Open Dataset v2 parquet: DIR/camera_image, \
        DIR/camera_box)";

    /// Parses a configuration value.
    pub fn parse(text: &str) -> Result<Self, String> {
        match text {
            "" | "sim" => Ok(Source::Sim),
            s if s.len() > 7 && s.starts_with("folder:") => {
                Ok(Source::Folder(PathBuf::from(&s[7..])))
            }
            s if s.len() > 6 && s.starts_with("waymo:") => {
                Ok(Source::Waymo(PathBuf::from(&s[6..])))
            }
            s => Err(format!("unknown frame source {s:?}; allowed: {}", Self::ALLOWED)),
        }
    }

    /// Whether frames come from a recording (the real-image mode).
    pub fn is_recording(&self) -> bool {
        *self != Source::Sim
    }

    /// Opens a recording; `None` for the simulator.
    pub(super) fn open(&self, real: &RealConfig) -> Result<Option<Recording>, TrainError> {
        let folder = real.folder_config()?;
        Ok(match self {
            Source::Sim => None,
            Source::Folder(dir) => Some(Recording::open(dir, folder)?),
            Source::Waymo(dir) => Some(Recording::open_waymo(dir, real.waymo_camera, folder)?),
        })
    }
}

impl std::fmt::Display for Source {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Source::Sim => f.write_str("sim"),
            Source::Folder(dir) => write!(f, "folder:{}", dir.display()),
            Source::Waymo(dir) => write!(f, "waymo:{}", dir.display()),
        }
    }
}

impl Serialize for Source {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for Source {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let text = String::deserialize(deserializer)?;
        Source::parse(&text).map_err(serde::de::Error::custom)
    }
}
