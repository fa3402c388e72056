//! Unit conversions. Every physical quantity in joca carries its unit in its name
//! (`exposure_s`, `gain_db`, `focal_length_mm`, `pixel_pitch_um`); these functions convert.
//!
//! Gain is expressed in decibels of *amplitude*: a gain of `g` dB multiplies pixel values by
//! `10^(g/20)` (so +6.02 dB doubles them). This is how machine-vision camera vendors specify
//! analogue gain, and it is the convention of docs/design.md.

/// Linear amplitude factor of a gain in decibels: `10^(dB/20)`.
pub fn linear_from_db(gain_db: f64) -> f64 {
    10f64.powf(gain_db / 20.0)
}

/// Decibels of gain that double pixel values (one stop): `20·log10 2`.
pub const DB_PER_STOP: f64 = 6.020_599_913_279_624;

/// Gain in decibels of a linear amplitude factor: `20·log10(linear)`.
///
/// Returns negative infinity for 0 and NaN for negative input, as `log10` does; callers clamp.
pub fn db_from_linear(gain_linear: f64) -> f64 {
    20.0 * gain_linear.log10()
}

/// Milliseconds from seconds.
pub fn ms_from_s(seconds: f64) -> f64 {
    seconds * 1e3
}

/// Seconds from milliseconds.
pub fn s_from_ms(milliseconds: f64) -> f64 {
    milliseconds * 1e-3
}

/// Metres from millimetres.
pub fn m_from_mm(millimetres: f64) -> f64 {
    millimetres * 1e-3
}

/// Millimetres from micrometres.
pub fn mm_from_um(micrometres: f64) -> f64 {
    micrometres * 1e-3
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decibels_of_amplitude() {
        // 20 dB is a factor of 10 in amplitude, 0 dB is unity, 6.0206 dB doubles.
        assert!((linear_from_db(20.0) - 10.0).abs() < 1e-12);
        assert!((linear_from_db(0.0) - 1.0).abs() < 1e-15);
        assert!((linear_from_db(20.0 * 2f64.log10()) - 2.0).abs() < 1e-12);
        for db in [-3.0, 1.0, 10.0, 30.0] {
            assert!((db_from_linear(linear_from_db(db)) - db).abs() < 1e-12);
        }
    }

    #[test]
    fn time_and_length() {
        assert!((ms_from_s(0.005) - 5.0).abs() < 1e-12);
        assert!((s_from_ms(50.0) - 0.05).abs() < 1e-15);
        assert!((m_from_mm(3.6) - 0.0036).abs() < 1e-15);
        assert!((mm_from_um(3.75) - 0.00375).abs() < 1e-15);
    }
}
