//! The fixed cameras of the baselines. The methods and scenarios themselves are vocabulary of
//! the run records (`joca_record`).

use joca_camera::{CameraDesign, sensor_by_name};
use serde::{Deserialize, Serialize};

/// The fixed cameras of the baselines, at the nuScenes-like mount (x 0.43 m, z 1.65 m, 3.6 mm).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FixedCamera {
    /// FLIR Flea3: IMX172.
    Flir,
    /// Basler Dart: AR0134.
    Basler,
}

impl FixedCamera {
    /// The design.
    pub fn design(self) -> CameraDesign {
        let name = match self {
            FixedCamera::Flir => "IMX172",
            FixedCamera::Basler => "AR0134",
        };
        CameraDesign {
            x_m: 0.43,
            z_m: 1.65,
            focal_length_mm: 3.6,
            sensor_index: sensor_by_name(name).map(|s| s.index).unwrap_or(0),
        }
    }
}
