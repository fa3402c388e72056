//! What a run reports: the records of `joca_record`, filled from the loop's types.

use joca_camera::CameraDesign;
pub use joca_record::{DesignSummary, RunResults, SearchTies};

/// `design` as the result tables show it.
pub(super) fn summary(d: &CameraDesign, optimised: bool) -> DesignSummary {
    let s = d.sensor();
    DesignSummary {
        x_m: d.x_m,
        z_m: d.z_m,
        focal_length_mm: d.focal_length_mm,
        sensor: s.name.clone(),
        sensor_mm: (s.width_mm, s.height_mm),
        pixel_pitch_um: s.pixel_pitch_um,
        optimised,
        f_number: (d.f_number != joca_core::optics::CALIBRATION_F_NUMBER).then_some(d.f_number),
    }
}
