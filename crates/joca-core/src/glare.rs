//! Veiling glare: the share of a lens's light that its surfaces and barrel scatter over the
//! sensor instead of imaging (ISO 9358 measures it as the veiling glare index: the light at the
//! centre of a black spot's image in a uniform bright field, relative to the field's).
//!
//! **Model.** The image is `(1 − g)·E + g·(P ∗ E)`, where `g` is [`Glare::fraction`] and P the
//! glare spread function, the normalised two-dimensional Poisson kernel of angular scale θ0
//! ([`Glare::scale_deg`]):
//! `P(θ) = θ0 / (2π (θ0² + θ²)^{3/2})`. It integrates to 1, holds the share
//! `θ0 / √(θ0² + R²)` of its light beyond angle R ([`Glare::share_beyond`]) and falls as θ⁻³ far
//! from the source, as the envelope of a diffraction pattern does. A black spot of angular
//! radius ρ in a uniform field L then reads `g·L·θ0/√(θ0² + ρ²)`: g is the veiling glare index of
//! a spot much smaller than θ0.
//!
//! P is a scale mixture of Gaussians — the variance s of a Gaussian of density
//! `1/(2πs)·exp(−θ²/2s)` drawn from the Lévy distribution of scale θ0² — so it is blurred as
//! Gaussians whose weights are that distribution's mass per band of σ ([`Glare::band_weights`];
//! its CDF is `erfc(θ0/√(2s))`).

/// A lens's veiling glare: the share of the light spread and the spread's angular scale.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Glare {
    /// The share of the light spread by the glare spread function, 0 (none) to below 1.
    pub fraction: f32,
    /// The glare spread function's angular scale θ0, degrees: half its light falls within
    /// √3·θ0 of the source.
    #[serde(default = "default_scale_deg")]
    pub scale_deg: f32,
}

fn default_scale_deg() -> f32 {
    Glare::DEFAULT_SCALE_DEG
}

impl Default for Glare {
    fn default() -> Self {
        Self { fraction: 0.0, scale_deg: Self::DEFAULT_SCALE_DEG }
    }
}

impl Glare {
    /// The spread's default angular scale, degrees.
    pub const DEFAULT_SCALE_DEG: f32 = 1.0;
    /// The angular scales allowed, degrees: below 0.1° the spread stays within a few pixels of
    /// its source (a blur, not a veil), above 20° it is a uniform veil.
    pub const ALLOWED_SCALE_DEG: (f32, f32) = (0.1, 20.0);

    /// No glare.
    pub fn is_off(&self) -> bool {
        self.fraction == 0.0
    }

    /// Whether this is the default (no glare at the default scale).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// Refuses a fraction outside [0, 1) or a scale outside [`Glare::ALLOWED_SCALE_DEG`],
    /// naming the field and what is allowed.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        if !(self.fraction >= 0.0 && self.fraction < 1.0) {
            return Err(("fraction", "0 (none) to below 1".into()));
        }
        let (lo, hi) = Self::ALLOWED_SCALE_DEG;
        if !(self.scale_deg >= lo && self.scale_deg <= hi) {
            return Err(("scale_deg", format!("{lo} to {hi} degrees")));
        }
        Ok(())
    }

    /// θ0, radians.
    pub fn scale_rad(&self) -> f64 {
        f64::from(self.scale_deg).to_radians()
    }

    /// The share of the glare spread function's light beyond angle `theta_rad` of its source.
    pub fn share_beyond(&self, theta_rad: f64) -> f64 {
        let t0 = self.scale_rad();
        t0 / (t0 * t0 + theta_rad * theta_rad).sqrt()
    }

    /// The glare spread function's density at angle `theta_rad`, per steradian.
    pub fn spread(&self, theta_rad: f64) -> f64 {
        let t0 = self.scale_rad();
        t0 / (2.0 * std::f64::consts::PI * (t0 * t0 + theta_rad * theta_rad).powf(1.5))
    }

    /// The weights of Gaussians of standard deviations `sigmas_rad` (ascending, each step a
    /// factor of 2) that stand for the glare spread function: the mixing distribution's mass
    /// between the geometric midpoints of neighbouring σ; the first takes all below, the last
    /// all above, so the weights sum to 1.
    pub fn band_weights(&self, sigmas_rad: &[f64]) -> Vec<f64> {
        let t0 = self.scale_rad();
        // The Lévy CDF of the variance s = σ², as a function of σ.
        let cdf = |sigma: f64| erfc(t0 / (std::f64::consts::SQRT_2 * sigma));
        let n = sigmas_rad.len();
        (0..n)
            .map(|k| {
                let lo = if k == 0 { 0.0 } else { cdf((sigmas_rad[k - 1] * sigmas_rad[k]).sqrt()) };
                let hi =
                    if k + 1 == n { 1.0 } else { cdf((sigmas_rad[k] * sigmas_rad[k + 1]).sqrt()) };
                hi - lo
            })
            .collect()
    }
}

/// The complementary error function, to a relative error under 1.2·10⁻⁷ (the Chebyshev fit of
/// Press et al., Numerical Recipes, §6.2).
pub fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let r = t * poly.exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn erfc_matches_tabulated_values() {
        // Abramowitz and Stegun, table 7.1 (erf), to nine digits.
        for (x, erf) in
            [(0.0, 0.0), (0.5, 0.520_499_878), (1.0, 0.842_700_793), (2.0, 0.995_322_265)]
        {
            // The fit's relative error bound, plus the table's last digit.
            let close = |got: f64, want: f64| (got - want).abs() <= 1.2e-7 * want + 1e-9;
            assert!(close(erfc(x), 1.0 - erf), "erfc({x}) = {}", erfc(x));
            assert!(close(erfc(-x), 1.0 + erf), "erfc(-{x}) = {}", erfc(-x));
        }
    }

    #[test]
    fn the_spread_integrates_to_its_share_beyond() {
        // ∫_R^∞ 2πθ·P(θ) dθ by the midpoint rule in log θ against the closed form.
        let g = Glare { fraction: 0.05, scale_deg: 1.0 };
        for r in [1e-3, 1e-2, 0.1, 1.0] {
            let (lo, hi, n) = (f64::ln(r), f64::ln(1e4), 200_000);
            let d = (hi - lo) / f64::from(n);
            let integral: f64 = (0..n)
                .map(|i| {
                    let t = (lo + (f64::from(i) + 0.5) * d).exp();
                    2.0 * std::f64::consts::PI * t * t * g.spread(t) * d
                })
                .sum();
            let expect = g.share_beyond(r) - g.share_beyond(1e4);
            assert!(
                (integral - expect).abs() < 1e-6 * expect.max(1e-3),
                "{r}: {integral} {expect}"
            );
        }
        assert!((g.share_beyond(0.0) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn the_band_weights_are_the_mixing_mass_and_rebuild_the_spread() {
        let g = Glare { fraction: 0.02, scale_deg: 1.0 };
        let sigmas: Vec<f64> = (0..14).map(|k| 1e-4 * f64::from(1u32 << k)).collect();
        let w = g.band_weights(&sigmas);
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        assert!(w.iter().all(|&v| v >= 0.0));
        // The mixture's light beyond R against the closed form, where the bands resolve it.
        for r in [0.005, 0.0175, 0.05, 0.2] {
            let mix: f64 =
                w.iter().zip(&sigmas).map(|(w, s)| w * (-r * r / (2.0 * s * s)).exp()).sum();
            let rel = mix / g.share_beyond(r) - 1.0;
            assert!(rel.abs() < 0.06, "beyond {r} rad: {mix} against {}", g.share_beyond(r));
        }
    }

    #[test]
    fn bad_glare_is_refused_naming_the_field() {
        assert!(Glare::default().check().is_ok() && Glare::default().is_off());
        for (g, field) in [
            (Glare { fraction: 1.0, scale_deg: 1.0 }, "fraction"),
            (Glare { fraction: -0.01, scale_deg: 1.0 }, "fraction"),
            (Glare { fraction: f32::NAN, scale_deg: 1.0 }, "fraction"),
            (Glare { fraction: 0.02, scale_deg: 0.05 }, "scale_deg"),
            (Glare { fraction: 0.02, scale_deg: 25.0 }, "scale_deg"),
        ] {
            assert_eq!(g.check().unwrap_err().0, field, "{g:?}");
        }
    }
}
