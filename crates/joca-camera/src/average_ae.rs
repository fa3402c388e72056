//! AverageAE: the classic mean-intensity auto-exposure the paper compares against.
//!
//! From the previous 8-bit frame's mean `I_mean`, the factor `k = 0.5·255 / I_mean` would bring
//! the mean to mid-grey. Since brightness is proportional to `E·G` (Eq. 1), the paper splits the
//! correction evenly: `E ← E·√k`, `G ← G·√k` (G linear), then clamps both to the ACC ranges.
//! A black frame would make `k` infinite; the mean is floored at [`MIN_MEAN_DN`] so the result
//! is "open up as far as the ranges allow", never NaN or infinity.

use crate::settings::{AccRanges, DynamicSettings};
use joca_core::Rgb8Image;
use joca_core::units::{db_from_linear, linear_from_db};

/// The paper's target frame mean, half the 8-bit range, DN.
pub const MID_GREY_DN: f64 = 0.5 * 255.0;

/// Floor on the measured mean, DN: a frame darker than this is treated as this dark.
pub const MIN_MEAN_DN: f64 = 1e-3;

/// Mean-intensity auto-exposure targeting mid-grey.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AverageAe {
    ranges: AccRanges,
    target_dn: f64,
}

impl AverageAe {
    /// AverageAE with the paper's target 0.5·255 within `ranges`.
    pub fn new(ranges: AccRanges) -> Self {
        Self::with_target(ranges, MID_GREY_DN)
    }

    /// AverageAE holding the frame mean at `target_dn` instead of mid-grey (for tests of what
    /// a darker or brighter policy does to the task).
    pub fn with_target(ranges: AccRanges, target_dn: f64) -> Self {
        Self { ranges, target_dn }
    }

    /// Settings for the next frame, given the previous frame's settings and mean intensity.
    pub fn step_from_mean(&self, previous: DynamicSettings, mean_dn: f64) -> DynamicSettings {
        let mean = if mean_dn.is_finite() { mean_dn.max(MIN_MEAN_DN) } else { self.target_dn };
        let root = (self.target_dn / mean).sqrt();
        let gain = linear_from_db(previous.gain_db) * root;
        self.ranges.clamp(DynamicSettings::new(previous.exposure_s * root, db_from_linear(gain)))
    }

    /// Settings for the next frame, given the previous frame and its settings.
    pub fn step(&self, previous: DynamicSettings, frame: &Rgb8Image) -> DynamicSettings {
        self.step_from_mean(previous, frame.mean())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mid_grey_is_a_fixed_point() {
        let ae = AverageAe::new(AccRanges::PAPER);
        let s = DynamicSettings::new(5e-3, 10.0);
        let got = ae.step_from_mean(s, 127.5);
        assert!((got.exposure_s - s.exposure_s).abs() < 1e-15);
        assert!((got.gain_db - s.gain_db).abs() < 1e-12);
        let frame = Rgb8Image::from_vec(1, 2, vec![127, 127, 127, 128, 128, 128]).unwrap();
        assert_eq!(ae.step(s, &frame), got);
    }

    #[test]
    fn a_quarter_bright_frame_doubles_e_times_g() {
        // Mean 127.5/4: k = 4, √k = 2 on each of E and G (G +6.02 dB): E·G grows by 4.
        let ae = AverageAe::new(AccRanges::PAPER);
        let got = ae.step_from_mean(DynamicSettings::new(5e-3, 10.0), 127.5 / 4.0);
        assert!((got.exposure_s - 10e-3).abs() < 1e-15);
        assert!((got.gain_db - (10.0 + 20.0 * 2f64.log10())).abs() < 1e-12);
    }

    #[test]
    fn a_custom_target_is_a_fixed_point() {
        // Target 50 DN: a frame at 50 DN keeps the settings, one at 200 DN quarters E·G.
        let ae = AverageAe::with_target(AccRanges::PAPER, 50.0);
        let s = DynamicSettings::new(8e-3, 12.0);
        let same = ae.step_from_mean(s, 50.0);
        assert!((same.exposure_s - s.exposure_s).abs() < 1e-15);
        assert!((same.gain_db - s.gain_db).abs() < 1e-12);
        let got = ae.step_from_mean(s, 200.0);
        assert!((got.exposure_s - 4e-3).abs() < 1e-15);
        assert!((got.gain_db - (12.0 - 20.0 * 2f64.log10())).abs() < 1e-12);
    }

    #[test]
    fn black_and_saturated_frames_stay_finite_and_in_range() {
        let ae = AverageAe::new(AccRanges::PAPER);
        let s = DynamicSettings::new(5e-3, 10.0);
        let dark = ae.step(s, &Rgb8Image::zeros(4, 4));
        assert_eq!((dark.exposure_s, dark.gain_db), (50e-3, 30.0));
        let bright = ae.step_from_mean(s, 255.0 * 1e6);
        assert_eq!((bright.exposure_s, bright.gain_db), (0.1e-3, 1.0));
        let nan = ae.step_from_mean(s, f64::NAN);
        assert!(nan.exposure_s.is_finite() && nan.gain_db.is_finite());
    }
}
