//! Static camera hardware: where the camera sits, which lens, which sensor.
//!
//! A [`CameraDesign`] is one point of the hardware design space Φcam of the paper (Sec. 6.3):
//! forward position x and height z of the camera centre in the vehicle frame (the camera stays
//! on the vehicle's midline, y = 0, looking along the heading), focal length f, and one sensor
//! of the catalogue. [`DesignSpace`] bounds each of them.

use crate::CameraError;
use crate::catalogue::{Sensor, catalogue, sensor};
use crate::input::DetectorInput;
use crate::settings::Bounds;
use joca_core::PinholeCamera;
use joca_core::optics::{CALIBRATION_F_NUMBER, F_NUMBER_RANGE, Lens};
use serde::{Deserialize, Serialize};

joca_core::named_enum! {
    /// How a design's lens images the scene.
    #[derive(Default)]
    pub enum LensModel("lens model") {
        /// An ideal pinhole: every depth sharp, the light of the calibration's f/16 (the
        /// paper's model).
        #[default]
        Pinhole = "pinhole",
        /// A thin lens at the design's f-number, focused at its hyperfocal distance: defocus
        /// and diffraction by depth, light ∝ 1/N².
        Thin = "thin",
    }
}

joca_core::named_enum! {
    /// Who sets a thin lens's aperture while the camera runs.
    #[derive(Default)]
    pub enum ApertureControl("aperture control") {
        /// The design's f-number for every frame (the paper's: the aperture is hardware).
        #[default]
        Fixed = "fixed",
        /// The exposure controller sets the iris every frame, from the design's f-number (the
        /// lens wide open) to the calibration's f/16 (beyond the paper: its future work).
        Dynamic = "dynamic",
    }
}

impl ApertureControl {
    /// Whether every frame keeps the design's f-number.
    pub fn is_fixed(&self) -> bool {
        *self == Self::Fixed
    }
}

/// One camera hardware design.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CameraDesign {
    /// Forward position of the camera centre from the vehicle centre, metres.
    pub x_m: f64,
    /// Height of the camera centre above the ground, metres.
    pub z_m: f64,
    /// Lens focal length, millimetres.
    pub focal_length_mm: f64,
    /// Catalogue row of the image sensor ([`crate::Sensor::index`]).
    pub sensor_index: usize,
    /// Lens f-number N (absent in files of designs at the calibration aperture, f/16).
    #[serde(default = "calibration_f_number", skip_serializing_if = "at_calibration_aperture")]
    pub f_number: f64,
}

fn calibration_f_number() -> f64 {
    CALIBRATION_F_NUMBER
}

fn at_calibration_aperture(f_number: &f64) -> bool {
    *f_number == CALIBRATION_F_NUMBER
}

impl CameraDesign {
    /// The design's sensor.
    pub fn sensor(&self) -> &'static Sensor {
        sensor(self.sensor_index)
    }

    /// Horizontal field of view, radians.
    pub fn hfov_rad(&self) -> f64 {
        self.sensor().hfov_rad(self.focal_length_mm)
    }

    /// Vertical field of view, radians.
    pub fn vfov_rad(&self) -> f64 {
        self.sensor().vfov_rad(self.focal_length_mm)
    }

    /// The detector's input size for this design's frames: the sensor's pixel grid scaled to
    /// `input` (short side, long-side cap, aspect kept). Every design of a run gets about the
    /// same number of input pixels, whatever its sensor's pixel count.
    pub fn resolution(&self, input: &DetectorInput) -> (usize, usize) {
        let s = self.sensor();
        input.size_for(s.res_x, s.res_y)
    }

    /// The lens of this design focused at its hyperfocal distance (for the sensor's pixel: see
    /// [`Lens::at_hyperfocal`]).
    pub fn lens(&self) -> Lens {
        Lens::at_hyperfocal(self.focal_length_mm, self.f_number, self.sensor().pixel_pitch_um)
    }

    /// The camera that renders this design's frames at the detector's input size: the pinhole
    /// projection, with [`Self::lens`] where `model` is [`LensModel::Thin`].
    pub fn view(&self, input: &DetectorInput, model: LensModel) -> PinholeCamera {
        let lens = (model == LensModel::Thin).then(|| self.lens());
        PinholeCamera { lens, ..self.pinhole(input) }
    }

    /// The pinhole camera of this design at the detector's input size.
    ///
    /// The focal length in pixels is `f · width_px / width_mm`, so the rendered field of view is
    /// exactly the sensor's, whatever the rounding of the resolution.
    pub fn pinhole(&self, input: &DetectorInput) -> PinholeCamera {
        let s = self.sensor();
        let (width_px, height_px) = self.resolution(input);
        PinholeCamera::centred(
            (width_px, height_px),
            (
                self.focal_length_mm * width_px as f64 / s.width_mm,
                self.focal_length_mm * height_px as f64 / s.height_mm,
            ),
            [self.x_m, 0.0, self.z_m],
        )
    }
}

/// The set of designs the hardware GA may propose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DesignSpace {
    /// Forward position, metres.
    pub x_m: Bounds,
    /// Height, metres.
    pub z_m: Bounds,
    /// Focal length, millimetres.
    pub focal_length_mm: Bounds,
    /// Allowed catalogue rows, ascending.
    pub sensors: Vec<usize>,
    /// Lens f-number (fixed at the calibration's f/16 unless the aperture is a gene).
    #[serde(default = "calibration_aperture")]
    pub f_number: Bounds,
}

fn calibration_aperture() -> Bounds {
    Bounds::fixed(CALIBRATION_F_NUMBER)
}

impl DesignSpace {
    /// The paper's synthetic design space: x ∈ [0, 2.4] m, z ∈ [1.3, 1.7] m, f ∈ [1, 10] mm,
    /// any of the 43 sensors.
    pub fn synthetic() -> Self {
        Self {
            x_m: Bounds::new(0.0, 2.4),
            z_m: Bounds::new(1.3, 1.7),
            focal_length_mm: Bounds::new(1.0, 10.0),
            sensors: (0..catalogue().len()).collect(),
            f_number: calibration_aperture(),
        }
    }

    /// The same space with the f-number a gene within `min..=max` (equal: fixed there);
    /// refused outside [`F_NUMBER_RANGE`].
    pub fn with_f_numbers(&self, min: f64, max: f64) -> Result<Self, CameraError> {
        let (lo, hi) = F_NUMBER_RANGE;
        let range = Bounds::new(lo, hi);
        range.check("f_number_min", min, "")?;
        range.check("f_number_max", max, "")?;
        if max < min {
            return Err(CameraError::OutOfRange {
                field: "f_number_max".into(),
                value: max,
                min,
                max: hi,
                unit: "",
            });
        }
        Ok(Self { f_number: Bounds::new(min, max), ..self.clone() })
    }

    /// A space with the mount and lens fixed (the paper's real-image mode, where the recording
    /// fixes them) and the sensors of `self`.
    pub fn with_fixed_mount(&self, x_m: f64, z_m: f64, focal_length_mm: f64) -> Self {
        Self {
            x_m: Bounds::fixed(x_m),
            z_m: Bounds::fixed(z_m),
            focal_length_mm: Bounds::fixed(focal_length_mm),
            sensors: self.sensors.clone(),
            f_number: self.f_number,
        }
    }

    /// Keeps only sensors whose pixel grid fits inside a `width × height` recording.
    pub fn restricted_to_recording(
        &self,
        width_px: usize,
        height_px: usize,
    ) -> Result<Self, CameraError> {
        let sensors: Vec<usize> = self
            .sensors
            .iter()
            .copied()
            .filter(|&i| sensor(i).fits_inside(width_px, height_px))
            .collect();
        if sensors.is_empty() {
            return Err(CameraError::NoSensor {
                constraint: format!("a pixel grid that fits inside {width_px}x{height_px}"),
            });
        }
        Ok(Self { sensors, ..self.clone() })
    }

    /// `design` if it lies in this space, else an error naming the offending field.
    pub fn check(&self, design: &CameraDesign) -> Result<(), CameraError> {
        self.x_m.check("x_m", design.x_m, " m")?;
        self.z_m.check("z_m", design.z_m, " m")?;
        self.focal_length_mm.check("focal_length_mm", design.focal_length_mm, " mm")?;
        self.f_number.check("f_number", design.f_number, "")?;
        if !self.sensors.contains(&design.sensor_index) {
            return Err(CameraError::UnknownSensor {
                name: sensor_name_or_index(design.sensor_index),
                valid: self.sensor_names().join(", "),
            });
        }
        Ok(())
    }

    /// Names of the allowed sensors.
    pub fn sensor_names(&self) -> Vec<&'static str> {
        self.sensors.iter().map(|&i| sensor(i).name.as_str()).collect()
    }
}

fn sensor_name_or_index(index: usize) -> String {
    catalogue().get(index).map_or_else(|| format!("#{index}"), |s| s.name.clone())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::catalogue::sensor_by_name;

    fn design(name: &str, f: f64) -> CameraDesign {
        CameraDesign {
            x_m: 0.43,
            z_m: 1.65,
            focal_length_mm: f,
            sensor_index: sensor_by_name(name).unwrap().index,
            f_number: 16.0,
        }
    }

    #[test]
    fn pinhole_preserves_the_sensor_fov() {
        let d = design("IMX172", 3.6);
        let input =
            DetectorInput { short_px: 240, long_max_px: 400, resampler: Default::default() };
        let cam = d.pinhole(&input);
        assert_eq!((cam.width_px, cam.height_px), (320, 240));
        assert!((cam.hfov_rad() - d.hfov_rad()).abs() < 1e-12);
        assert!((cam.vfov_rad() - d.vfov_rad()).abs() < 1e-12);
        assert_eq!(cam.mount_m, [0.43, 0.0, 1.65]);
        // Square pixels: the same focal length in pixels both ways.
        assert!((cam.fx_px - cam.fy_px).abs() / cam.fx_px < 1e-3);
        // Every design gets the one input: a 1280 × 960 sensor as a 4000 × 3000 one, a wide one
        // capped at the long side, each with its own field of view.
        let basler = design("AR0134", 3.6).pinhole(&input);
        assert_eq!((basler.width_px, basler.height_px), (320, 240));
        let wide = design("IMX324", 3.6);
        let cam = wide.pinhole(&input);
        assert_eq!((cam.width_px, cam.height_px), (400, 200));
        assert!((cam.hfov_rad() - wide.hfov_rad()).abs() < 1e-12);
    }

    #[test]
    fn real_image_restriction_keeps_grids_that_fit() {
        let space = DesignSpace::synthetic().restricted_to_recording(1920, 1280).unwrap();
        for &i in &space.sensors {
            let s = sensor(i);
            assert!(s.res_x <= 1920 && s.res_y <= 1280, "{}", s.name);
        }
        for s in catalogue() {
            if s.res_x <= 1920 && s.res_y <= 1280 {
                assert!(space.sensors.contains(&s.index));
            }
        }
        // Every sensor the paper's Table 2 reports for Waymo is among them.
        for name in ["AR0134", "MT9V022", "IMX422", "PYTHON1300", "IMX249", "IMX392", "LUX1310"] {
            assert!(space.sensor_names().contains(&name), "{name}");
        }
        assert!(DesignSpace::synthetic().restricted_to_recording(100, 100).is_err());
    }

    #[test]
    fn check_names_the_field() {
        let space = DesignSpace::synthetic();
        assert!(space.check(&design("AR0134", 3.6)).is_ok());
        let e = space.check(&design("AR0134", 12.0)).unwrap_err().to_string();
        assert!(e.contains("focal_length_mm") && e.contains("1 to 10 mm"), "{e}");
        let narrow = space.restricted_to_recording(1280, 960).unwrap();
        let e = narrow.check(&design("IMX172", 3.6)).unwrap_err().to_string();
        assert!(e.contains("IMX172") && e.contains("AR0134"), "{e}");
    }
}
