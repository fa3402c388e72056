//! Thin-lens optics of a camera: how much light its aperture passes and how sharply it images
//! each depth.
//!
//! A lens of focal length f at f-number N, focused at distance s, images a point at depth d as
//! a disc (the circle of confusion) of diameter, on the sensor,
//!
//! ```text
//! c(d) = (f/N) · |d − s| / d · f / (s − f)
//! ```
//!
//! and diffraction at the aperture spreads every point over an Airy pattern whose first dark
//! ring has diameter 2.44·λ·N. joca blurs with a Gaussian of the same second moment as the two
//! together: a disc of diameter c has a per-axis standard deviation c/4, the Airy pattern's
//! Gaussian fit (Zhang, Zerubia and Olivo-Marin, Applied Optics 46(10), 2007) 0.42·λ·N, and
//! independent blurs add their variances: σ² = (c/4)² + (0.42·λ·N)².
//!
//! Light: the irradiance on the sensor scales with 1/N², so relative to the calibration
//! camera's aperture N0 = 16 ([`CALIBRATION_F_NUMBER`]) a frame's signal gains (N0/N)².
//! Depths are along the optical axis (the renderer's z), as the thin-lens equation takes them.

use serde::{Deserialize, Serialize};

/// The aperture the calibration camera's `I0` was recorded at (the paper's lens, f/16).
pub const CALIBRATION_F_NUMBER: f64 = 16.0;

/// The wavelength diffraction is computed for: 550 nm, the peak of the eye's and of a Bayer
/// green channel's sensitivity, micrometres.
pub const WAVELENGTH_UM: f64 = 0.55;

/// Allowed f-numbers: f/1 (the fastest lenses built) to f/32.
pub const F_NUMBER_RANGE: (f64, f64) = (1.0, 32.0);

/// A thin lens: focal length, aperture and focus.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Lens {
    /// Focal length f, millimetres.
    pub focal_length_mm: f64,
    /// f-number N (focal length over aperture diameter).
    pub f_number: f64,
    /// Distance s the lens is focused at, metres along the optical axis (`f64::INFINITY`: at
    /// infinity).
    pub focus_m: f64,
}

impl Lens {
    /// A lens focused at its hyperfocal distance for a circle of confusion of one pixel of
    /// `pixel_pitch_um`: everything from half that distance to infinity blurs by at most a
    /// quarter pixel (σ = c/4), below what the pixel grid resolves.
    pub fn at_hyperfocal(focal_length_mm: f64, f_number: f64, pixel_pitch_um: f64) -> Self {
        let focus_m = hyperfocal_m(focal_length_mm, f_number, pixel_pitch_um * 1e-3);
        Self { focal_length_mm, f_number, focus_m }
    }

    /// Checks the f-number against [`F_NUMBER_RANGE`] and the focus distance against the focal
    /// length; the error names the field and the allowed range.
    pub fn check(&self) -> Result<(), String> {
        let (lo, hi) = F_NUMBER_RANGE;
        if !(self.f_number >= lo && self.f_number <= hi) {
            return Err(format!("f_number = {}: allowed {lo} to {hi}", self.f_number));
        }
        let f_m = self.focal_length_mm * 1e-3;
        if self.focus_m.is_nan() || self.focus_m <= f_m {
            return Err(format!(
                "focus_m = {}: must exceed the focal length ({f_m} m); a lens cannot focus nearer",
                self.focus_m
            ));
        }
        Ok(())
    }

    /// The signal relative to the calibration aperture: (N0/N)².
    pub fn light_factor(&self) -> f64 {
        (CALIBRATION_F_NUMBER / self.f_number).powi(2)
    }

    /// Diameter of the circle of confusion of a point at depth `depth_m`, millimetres on the
    /// sensor (at infinite depth: its limit (f/N)·f/(s − f)).
    pub fn coc_diameter_mm(&self, depth_m: f64) -> f64 {
        let f = self.focal_length_mm;
        let aperture = f / self.f_number;
        if self.focus_m.is_infinite() {
            // s → ∞: c = (f/N) · f / d.
            return if depth_m.is_infinite() { 0.0 } else { aperture * f / (depth_m * 1e3) };
        }
        let s = self.focus_m * 1e3;
        let defocus =
            if depth_m.is_infinite() { 1.0 } else { (depth_m - self.focus_m).abs() / depth_m };
        aperture * defocus * f / (s - f)
    }

    /// Diameter of the Airy disc's first dark ring, 2.44·λ·N, millimetres.
    pub fn airy_diameter_mm(&self) -> f64 {
        2.44 * WAVELENGTH_UM * 1e-3 * self.f_number
    }

    /// Standard deviation per axis of the Gaussian blur for a point at `depth_m`, millimetres
    /// on the sensor (see the module).
    pub fn blur_sigma_mm(&self, depth_m: f64) -> f64 {
        let defocus = self.coc_diameter_mm(depth_m) / 4.0;
        let diffraction = 0.42 * WAVELENGTH_UM * 1e-3 * self.f_number;
        defocus.hypot(diffraction)
    }
}

/// Hyperfocal distance f²/(N·c) + f for a circle of confusion `coc_mm`, metres.
pub fn hyperfocal_m(focal_length_mm: f64, f_number: f64, coc_mm: f64) -> f64 {
    (focal_length_mm * focal_length_mm / (f_number * coc_mm) + focal_length_mm) * 1e-3
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, rel: f64) -> bool {
        (a - b).abs() <= rel * b.abs()
    }

    #[test]
    fn circle_of_confusion_at_three_depths_matches_the_thin_lens_equation() {
        // 8 mm at f/1.4 focused at 5 m. By hand from the lens equation: the image of depth d
        // lies at v(d) = f·d/(d − f); the cone from the aperture (diameter A = f/N) to v(d)
        // crosses the sensor (at v(s)) in a disc of diameter A·|v(d) − v(s)|/v(d).
        let lens = Lens { focal_length_mm: 8.0, f_number: 1.4, focus_m: 5.0 };
        let v = |d_mm: f64| 8.0 * d_mm / (d_mm - 8.0);
        for d_m in [1.0, 2.5, 40.0] {
            let by_geometry = (8.0 / 1.4) * (v(d_m * 1e3) - v(5000.0)).abs() / v(d_m * 1e3);
            let c = lens.coc_diameter_mm(d_m);
            assert!(close(c, by_geometry, 1e-9), "{d_m} m: {c} vs {by_geometry}");
        }
        // Printed values: 1 m → 36.6 µm, 2.5 m → 9.16 µm, 40 m → 8.0 µm (far side: 7/8 of the
        // limit (f/N)·f/(s − f) = 9.16 µm).
        assert!(close(lens.coc_diameter_mm(1.0), 0.036_63, 1e-3));
        assert!(close(lens.coc_diameter_mm(2.5), 0.009_157, 1e-3));
        assert!(close(lens.coc_diameter_mm(40.0), 0.008_012, 1e-3));
        assert_eq!(lens.coc_diameter_mm(5.0), 0.0);
        assert!(close(lens.coc_diameter_mm(f64::INFINITY), 0.009_157, 1e-3));
    }

    #[test]
    fn hyperfocal_focus_keeps_half_of_it_to_infinity_within_the_circle() {
        let lens = Lens::at_hyperfocal(6.0, 2.8, 3.0);
        let c = 3.0e-3;
        // H = f²/(N c) + f = 36 / 0.0084 + 6 mm = 4.2917 m.
        assert!(close(lens.focus_m, 4.291_714, 1e-5), "{}", lens.focus_m);
        assert!(close(lens.coc_diameter_mm(f64::INFINITY), c, 1e-9));
        // The near limit of the depth of field of a lens focused at H is H/2 (to first order).
        assert!(lens.coc_diameter_mm(lens.focus_m / 2.0) <= c * 1.01);
        assert!(lens.coc_diameter_mm(lens.focus_m / 3.0) > c * 1.5);
    }

    #[test]
    fn light_scales_with_the_inverse_square_of_the_f_number() {
        let at = |n: f64| Lens { focal_length_mm: 6.0, f_number: n, focus_m: 10.0 }.light_factor();
        assert_eq!(at(16.0), 1.0);
        assert!(close(at(2.0), 64.0, 1e-12));
        assert!(close(at(1.4) / at(2.8), 4.0, 1e-12));
    }

    #[test]
    fn diffraction_at_f16_is_the_airy_disc_the_issue_quotes() {
        let lens = Lens { focal_length_mm: 6.0, f_number: 16.0, focus_m: f64::INFINITY };
        // 2.44 · 0.55 µm · 16 = 21.5 µm.
        assert!(close(lens.airy_diameter_mm(), 0.021_472, 1e-4));
        // In focus, only diffraction blurs: σ = 0.42 · λ · N = 3.70 µm.
        assert!(close(lens.blur_sigma_mm(f64::INFINITY), 0.003_696, 1e-3));
        // A defocus disc and the Airy core add in quadrature.
        let open = Lens { f_number: 1.4, focus_m: 5.0, ..lens };
        let c = open.coc_diameter_mm(1.0);
        let want = ((c / 4.0).powi(2) + (0.42 * 0.55e-3 * 1.4f64).powi(2)).sqrt();
        assert!(close(open.blur_sigma_mm(1.0), want, 1e-12));
    }

    #[test]
    fn bad_lenses_name_the_field_and_the_range() {
        let ok = Lens { focal_length_mm: 6.0, f_number: 2.0, focus_m: 5.0 };
        assert!(ok.check().is_ok());
        let e = Lens { f_number: 0.8, ..ok }.check().unwrap_err();
        assert!(e.contains("f_number") && e.contains("1 to 32"), "{e}");
        let e = Lens { focus_m: 0.006, ..ok }.check().unwrap_err();
        assert!(e.contains("focus_m") && e.contains("0.006 m"), "{e}");
        assert!(Lens { f_number: f64::NAN, ..ok }.check().is_err());
    }
}
