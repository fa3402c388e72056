//! The fixed cameras of the baselines. The methods and scenarios themselves are vocabulary of
//! the run records (`joca_record`).

use joca_camera::{CameraDesign, CameraError, DesignSpace, sensor_by_name};
use joca_core::optics::{CALIBRATION_F_NUMBER, F_NUMBER_RANGE};
use serde::{Deserialize, Serialize};

joca_core::named_enum! {
    /// The fixed cameras of the baselines, at the nuScenes-like mount (x 0.43 m, z 1.65 m, 3.6 mm).
    pub enum FixedCamera("camera") {
        /// FLIR Flea3: IMX172.
        Flir = "flir",
        /// Basler Dart: AR0134.
        Basler = "basler",
    }
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
            f_number: CALIBRATION_F_NUMBER,
        }
    }
}

/// A design named in a configuration (`[run] design = { sensor, focal_length_mm, x_m, z_m }`):
/// the hardware of a design panel, held fixed while a method trains its controller and detector.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignSpec {
    /// Catalogue sensor name (case as in `data/sensors.csv`; matched case-insensitively).
    pub sensor: String,
    /// Focal length, mm.
    pub focal_length_mm: f64,
    /// Forward position in the vehicle frame, m.
    pub x_m: f64,
    /// Height, m.
    pub z_m: f64,
    /// Lens f-number (absent: the calibration's f/16).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub f_number: Option<f64>,
}

impl DesignSpec {
    /// The design, if its sensor is in the catalogue and it lies in the paper's design space;
    /// else an error naming the field and what is allowed.
    pub fn design(&self) -> Result<CameraDesign, CameraError> {
        let design = CameraDesign {
            x_m: self.x_m,
            z_m: self.z_m,
            focal_length_mm: self.focal_length_mm,
            sensor_index: sensor_by_name(&self.sensor)?.index,
            f_number: self.f_number.unwrap_or(CALIBRATION_F_NUMBER),
        };
        let (lo, hi) = F_NUMBER_RANGE;
        DesignSpace::synthetic().with_f_numbers(lo, hi)?.check(&design)?;
        Ok(design)
    }

    /// The spec of `design`.
    pub fn of(design: &CameraDesign) -> Self {
        Self {
            sensor: design.sensor().name.clone(),
            focal_length_mm: design.focal_length_mm,
            x_m: design.x_m,
            z_m: design.z_m,
            f_number: (design.f_number != CALIBRATION_F_NUMBER).then_some(design.f_number),
        }
    }
}
