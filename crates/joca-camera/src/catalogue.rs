//! The catalogue of 43 commercial CMOS image sensors that the paper's design space draws from.
//!
//! The table was published with TaCOS (the paper's predecessor) and is compiled into joca from
//! `data/sensors.csv`, unchanged. Two rows look odd and are kept as published, because the
//! paper's results were produced with them:
//! - MT9V022 is listed at 2.8 µm and 1920×1080; onsemi's datasheet gives 6.0 µm and 752×480.
//!   Its width/height (5.376 × 3.024 mm) are consistent with the listed pitch and grid.
//! - IMX335 is listed with a global shutter; Sony's part is a rolling-shutter sensor.
//!
//! joca models every sensor as global shutter (the paper's Sec. 3 assumption), so the shutter
//! column is informational.

use crate::CameraError;
use serde::Serialize;
use std::sync::OnceLock;

const CATALOGUE_CSV: &str = include_str!("../data/sensors.csv");

/// Shutter type as listed in the catalogue (informational: joca simulates a global shutter).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Shutter {
    /// All rows exposed simultaneously.
    Global,
    /// Rows exposed one after another.
    Rolling,
}

/// One image sensor of the catalogue.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Sensor {
    /// Row index in the published table (0–42); stable identifier.
    pub index: usize,
    /// Manufacturer.
    pub manufacturer: String,
    /// Part name, e.g. `IMX172`.
    pub name: String,
    /// Pixel pitch, micrometres (square pixels).
    pub pixel_pitch_um: f64,
    /// Pixel grid width (columns).
    pub res_x: usize,
    /// Pixel grid height (rows).
    pub res_y: usize,
    /// Active-area width, millimetres.
    pub width_mm: f64,
    /// Active-area height, millimetres.
    pub height_mm: f64,
    /// Shutter type as published.
    pub shutter: Shutter,
}

/// The compiled-in sensor catalogue, in the published row order.
pub fn catalogue() -> &'static [Sensor] {
    static CATALOGUE: OnceLock<Vec<Sensor>> = OnceLock::new();
    CATALOGUE.get_or_init(|| parse_catalogue(CATALOGUE_CSV))
}

/// The sensor called `name` (case-insensitive), or an error listing the valid names.
pub fn sensor_by_name(name: &str) -> Result<&'static Sensor, CameraError> {
    catalogue().iter().find(|s| s.name.eq_ignore_ascii_case(name)).ok_or_else(|| {
        CameraError::UnknownSensor {
            name: name.to_owned(),
            valid: catalogue().iter().map(|s| s.name.as_str()).collect::<Vec<_>>().join(", "),
        }
    })
}

/// The sensor at catalogue row `index`.
///
/// # Panics
/// If `index` is not a catalogue row (indices come from [`Sensor::index`] or a design space).
pub fn sensor(index: usize) -> &'static Sensor {
    &catalogue()[index]
}

/// Parses the embedded CSV. The data is part of the binary and checked by tests, so a parse
/// failure is a build defect, not a user error.
fn parse_catalogue(csv: &str) -> Vec<Sensor> {
    csv.lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|line| {
            let f: Vec<&str> = line.split(',').map(str::trim).collect();
            let num = |i: usize| -> f64 {
                f[i].parse().unwrap_or_else(|_| panic!("sensors.csv: bad number in {line:?}"))
            };
            Sensor {
                index: num(0) as usize,
                manufacturer: f[1].to_owned(),
                name: f[2].to_owned(),
                pixel_pitch_um: num(3),
                res_x: num(4) as usize,
                res_y: num(5) as usize,
                width_mm: num(6),
                height_mm: num(7),
                shutter: if f[8] == "global" { Shutter::Global } else { Shutter::Rolling },
            }
        })
        .collect()
}

impl Sensor {
    /// Whether this sensor's pixel grid fits inside a `width × height` recording (the paper's
    /// real-image restriction: a sensor can only be emulated by downsampling).
    pub fn fits_inside(&self, width_px: usize, height_px: usize) -> bool {
        self.res_x <= width_px && self.res_y <= height_px
    }

    /// Horizontal field of view with a lens of focal length `focal_length_mm`, radians.
    pub fn hfov_rad(&self, focal_length_mm: f64) -> f64 {
        fov_rad(self.width_mm, focal_length_mm)
    }

    /// Vertical field of view with a lens of focal length `focal_length_mm`, radians.
    pub fn vfov_rad(&self, focal_length_mm: f64) -> f64 {
        fov_rad(self.height_mm, focal_length_mm)
    }
}

/// Pinhole field of view of a sensor extent `extent_mm` behind a lens of focal length
/// `focal_length_mm`: `2·atan(extent / 2f)`, radians.
pub fn fov_rad(extent_mm: f64, focal_length_mm: f64) -> f64 {
    2.0 * (extent_mm / (2.0 * focal_length_mm)).atan()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn catalogue_has_the_43_published_rows_in_order() {
        let c = catalogue();
        assert_eq!(c.len(), 43);
        for (i, s) in c.iter().enumerate() {
            assert_eq!(s.index, i);
        }
        let imx172 = sensor_by_name("imx172").unwrap();
        assert_eq!((imx172.res_x, imx172.res_y), (4000, 3000));
        assert_eq!(imx172.pixel_pitch_um, 1.55);
        let ar0134 = sensor_by_name("AR0134").unwrap();
        assert_eq!((ar0134.width_mm, ar0134.height_mm, ar0134.pixel_pitch_um), (4.8, 3.6, 3.75));
    }

    #[test]
    fn published_dimensions_are_consistent_with_pitch_times_grid() {
        // Width = pitch × columns within 1 % for every row (the odd rows included): this guards
        // the copy of the table against transcription errors.
        for s in catalogue() {
            let w = s.pixel_pitch_um * s.res_x as f64 / 1000.0;
            let h = s.pixel_pitch_um * s.res_y as f64 / 1000.0;
            assert!((w / s.width_mm - 1.0).abs() < 0.01, "{}: {w} vs {}", s.name, s.width_mm);
            assert!((h / s.height_mm - 1.0).abs() < 0.01, "{}: {h} vs {}", s.name, s.height_mm);
        }
    }

    #[test]
    fn the_two_odd_rows_are_kept_as_published() {
        let mt = sensor_by_name("MT9V022").unwrap();
        assert_eq!((mt.pixel_pitch_um, mt.res_x, mt.res_y), (2.8, 1920, 1080));
        assert_eq!(sensor_by_name("IMX335").unwrap().shutter, Shutter::Global);
    }

    #[test]
    fn unknown_sensor_lists_the_valid_names() {
        let err = sensor_by_name("IMX999").unwrap_err().to_string();
        assert!(err.contains("IMX999") && err.contains("IMX172") && err.contains("AM41"), "{err}");
    }

    #[test]
    fn field_of_view_closed_form() {
        // A 4.8 mm wide sensor behind 2.4 mm: half-angle atan(1) = 45°, so 90° in all.
        assert!((fov_rad(4.8, 2.4) - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        // Doubling the focal length halves tan(half-angle).
        let s = sensor_by_name("IMX172").unwrap();
        let t1 = (s.hfov_rad(3.6) / 2.0).tan();
        let t2 = (s.hfov_rad(7.2) / 2.0).tan();
        assert!((t1 / t2 - 2.0).abs() < 1e-12);
        // IMX172 behind 3.6 mm: 2·atan(3.1/3.6) = 81.45°.
        assert!((s.hfov_rad(3.6).to_degrees() - 81.464_213).abs() < 1e-4);
    }
}
