//! Pixel-size compensation of predicted settings (paper Eq. 4).
//!
//! The ACC predicts `(E_pred, G_pred)` as if for the calibration camera (pitch p0). A sensor of
//! pitch p collects `(p/p0)²` times the light per pixel, so the prediction is rescaled to keep
//! the same brightness `E·G·(p/p0)²`, preferring the lowest gain (gain amplifies read noise,
//! Eq. 3):
//!
//! ```text
//! if (p/p0)² > 1:  G_t = max(G_pred·p0²/p², 1)    E_t = E_pred·G_pred·p0²/(p²·G_t)
//! else:            G_t = G_pred                  E_t = E_pred·p0²/p²
//! ```
//!
//! exactly as printed. Gains here are linear factors (Eq. 2 multiplies by G/G0), so the floor
//! `1` is unity gain, 0 dB — slightly below the ACC's 1 dB range minimum.
//!
//! With small pixels Eq. 4 alone may ask for more exposure than a frame can have (a 1.55 µm
//! pixel needs 5.85× the calibration camera's: 292 ms for a 50 ms prediction, beyond the
//! 100 ms frame interval). [`limit_exposure`] caps the exposure at the longest the camera can
//! use (the ACC range's maximum, or the frame interval if shorter) and lets gain make up the
//! rest, up to the gain range's maximum; beyond that the frame is darker than predicted.

use crate::settings::DynamicSettings;
use joca_core::units::{db_from_linear, linear_from_db};

/// Eq. 4: the settings actually applied by a sensor of pitch `pixel_pitch_um` when the ACC
/// predicted `predicted` for the calibration pitch `calibration_pitch_um`.
pub fn compensate_for_pixel_size(
    predicted: DynamicSettings,
    pixel_pitch_um: f64,
    calibration_pitch_um: f64,
) -> DynamicSettings {
    let area_ratio = (pixel_pitch_um / calibration_pitch_um).powi(2); // p²/p0²
    let g_pred = linear_from_db(predicted.gain_db);
    if area_ratio > 1.0 {
        let g_t = (g_pred / area_ratio).max(1.0);
        let e_t = predicted.exposure_s * g_pred / (area_ratio * g_t);
        DynamicSettings::new(e_t, db_from_linear(g_t))
    } else {
        DynamicSettings::new(predicted.exposure_s / area_ratio, predicted.gain_db)
    }
}

/// `settings` with the exposure capped at `max_exposure_s` and the gain raised by the same
/// factor (brightness `E·G` kept), the gain capped at `max_gain_db`.
pub fn limit_exposure(
    settings: DynamicSettings,
    max_exposure_s: f64,
    max_gain_db: f64,
) -> DynamicSettings {
    if settings.exposure_s <= max_exposure_s {
        return settings;
    }
    let excess = settings.exposure_s / max_exposure_s;
    DynamicSettings::new(
        max_exposure_s,
        (settings.gain_db + db_from_linear(excess)).min(max_gain_db),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_exposure_beyond_the_cap_is_traded_for_gain_up_to_its_maximum() {
        // A 1.55 µm pixel: Eq. 4 turns 50 ms into 50·(3.75/1.55)² = 292.7 ms.
        let applied = compensate_for_pixel_size(DynamicSettings::new(0.05, 5.0), 1.55, 3.75);
        assert!((applied.exposure_s - 0.05 * (3.75f64 / 1.55).powi(2)).abs() < 1e-12);
        let capped = limit_exposure(applied, 0.05, 30.0);
        assert_eq!(capped.exposure_s, 0.05);
        // E·G kept: 5.854× less exposure is 15.35 dB more gain.
        assert!((capped.gain_db - (5.0 + 20.0 * (3.75f64 / 1.55).powi(2).log10())).abs() < 1e-9);
        // At 20 dB the gain range's 30 dB maximum cuts it: the frame comes out darker.
        let dark = limit_exposure(DynamicSettings::new(applied.exposure_s, 20.0), 0.05, 30.0);
        assert_eq!((dark.exposure_s, dark.gain_db), (0.05, 30.0));
        // Within the cap nothing changes.
        let ok = DynamicSettings::new(0.02, 12.0);
        assert_eq!(limit_exposure(ok, 0.05, 30.0), ok);
    }

    fn brightness(s: DynamicSettings, p: f64) -> f64 {
        s.exposure_s * linear_from_db(s.gain_db) * (p / 3.75).powi(2)
    }

    #[test]
    fn large_pixels_lower_the_gain_first() {
        // p = 7.5 µm: area ratio 4. G_pred = 20 dB (×10) → G_t = 2.5 (7.96 dB), E unchanged.
        let pred = DynamicSettings::new(5e-3, 20.0);
        let got = compensate_for_pixel_size(pred, 7.5, 3.75);
        assert!((linear_from_db(got.gain_db) - 2.5).abs() < 1e-12);
        assert!((got.exposure_s - 5e-3).abs() < 1e-15);
        assert!((brightness(got, 7.5) - brightness(pred, 3.75)).abs() < 1e-12);
    }

    #[test]
    fn large_pixels_hit_the_unity_gain_floor_then_shorten_exposure() {
        // G_pred = 6.0206 dB (×2) with area ratio 4: G_t = max(0.5, 1) = 1 (0 dB),
        // E_t = E·2/(4·1) = E/2.
        let pred = DynamicSettings::new(8e-3, 20.0 * 2f64.log10());
        let got = compensate_for_pixel_size(pred, 7.5, 3.75);
        assert!(got.gain_db.abs() < 1e-12);
        assert!((got.exposure_s - 4e-3).abs() < 1e-15);
        assert!((brightness(got, 7.5) - brightness(pred, 3.75)).abs() < 1e-12);
    }

    #[test]
    fn small_pixels_lengthen_exposure_and_keep_gain() {
        // p = 1.875 µm: area ratio 1/4, so E ×4 and G unchanged.
        let pred = DynamicSettings::new(5e-3, 12.0);
        let got = compensate_for_pixel_size(pred, 1.875, 3.75);
        assert_eq!(got.gain_db, 12.0);
        assert!((got.exposure_s - 20e-3).abs() < 1e-15);
        // Equal pitch is the "otherwise" branch and changes nothing.
        assert_eq!(compensate_for_pixel_size(pred, 3.75, 3.75), pred);
    }
}
