//! The exposure spread of pre-training frames: each frame's exposure × gain is AverageAE's
//! times a random factor, so the detector also sees the under- and over-exposed frames other
//! controllers make (`[pretrain.data] exposure_spread`).

use joca_camera::{AccRanges, DynamicSettings};
use rand::Rng;

/// `settings` with exposure × gain multiplied by a factor log-uniform in `[1/spread, spread]`,
/// split at random between the two (a share `u` of the log factor to exposure), each clamped
/// to its range. A spread of 1 returns `settings` and draws nothing.
pub(super) fn spread(
    settings: DynamicSettings,
    spread: f64,
    rng: &mut impl Rng,
) -> DynamicSettings {
    if spread <= 1.0 {
        return settings;
    }
    let log_factor = rng.random_range(-spread.ln()..spread.ln());
    let u: f64 = rng.random();
    let ranges = AccRanges::PAPER;
    let exposure_s = ranges.exposure_s.clamp(settings.exposure_s * (u * log_factor).exp());
    // A linear gain factor g is 20·log10(g) dB.
    let gain_db = ranges
        .gain_db
        .clamp(settings.gain_db + 20.0 * (1.0 - u) * log_factor / std::f64::consts::LN_10);
    DynamicSettings::new(exposure_s, gain_db)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_spread_moves_exposure_times_gain_within_its_factor() {
        use joca_core::SeedStreams;
        let mut rng = SeedStreams::new(4).stream("spread");
        let base = DynamicSettings::new(5e-3, 10.0);
        assert_eq!(spread(base, 1.0, &mut rng), base);
        let total = |s: DynamicSettings| (s.exposure_s * s.gain_linear()).ln();
        let (mut lower, mut higher) = (0, 0);
        for _ in 0..2000 {
            let s = spread(base, 4.0, &mut rng);
            let d = total(s) - total(base);
            // Within [1/4, 4] (nothing clamps around 5 ms and 10 dB with a factor of 4).
            assert!(d.abs() <= 4f64.ln() + 1e-9, "{s:?}");
            lower += usize::from(d < -1.0);
            higher += usize::from(d > 1.0);
        }
        // Uniform on [−ln 4, ln 4]: P(d < −1) = P(d > 1) = (ln 4 − 1)/(2 ln 4) ≈ 0.139, 278 of
        // 2000 (binomial standard deviation 15).
        assert!((218..338).contains(&lower) && (218..338).contains(&higher), "{lower} {higher}");
    }
}
