//! Where the sun stands: the range of elevations a simulator's episodes draw from, and how much
//! light it and the sky give at an elevation.

/// The range of sun elevations the episodes draw from (uniformly), degrees above the horizon.
/// The default, 45–55°, is where white paper on the ground reads 203–225 DN (the calibration's
/// daylight white); a lower sun lights the ground less (by the sine of its elevation), facades
/// facing it more, and casts longer shadows.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SunElevation {
    /// Lowest elevation, degrees.
    pub min_deg: f32,
    /// Highest elevation, degrees.
    pub max_deg: f32,
    /// How the sun's and the sky's light follow the elevation.
    #[serde(default, skip_serializing_if = "Daylight::is_constant")]
    pub daylight: Daylight,
}

impl Default for SunElevation {
    fn default() -> Self {
        Self { min_deg: 45.0, max_deg: 55.0, daylight: Daylight::Constant }
    }
}

crate::named_enum! {
    /// How the sun's and the sky's light follow the sun's elevation.
    #[derive(Default)]
    pub enum Daylight("daylight") {
        /// The sun's beam and the sky's light keep their levels at any elevation (a low sun
        /// lights the ground by the sine of its elevation only): what runs before the choice
        /// existed rendered.
        #[default]
        Constant = "constant",
        /// A cloudless sky's: the beam thins with the air mass it crosses and the sky's light
        /// with it ([`clear_sky`]), both relative to their levels at [`REFERENCE_ELEVATION_DEG`].
        ClearSky = "clear-sky",
    }
}

impl Daylight {
    /// Whether this is the default (left out of saved configurations).
    pub fn is_constant(&self) -> bool {
        *self == Self::Constant
    }

    /// The sun's beam (on a surface facing it) and the sky's light (on a horizontal surface)
    /// at `elevation_rad`, each relative to its level where the calibration's daylight stands.
    pub fn levels(self, elevation_rad: f32) -> [f32; 2] {
        match self {
            Self::Constant => [1.0, 1.0],
            Self::ClearSky => {
                let reference = clear_sky(f64::from(REFERENCE_ELEVATION_DEG).to_radians());
                let here = clear_sky(f64::from(elevation_rad));
                [(here[0] / reference[0]) as f32, (here[1] / reference[1]) as f32]
            }
        }
    }
}

/// The elevation at which `clear-sky` daylight equals `constant`'s: the middle of the default
/// range, where white paper on the ground reads the calibration's daylight white.
pub const REFERENCE_ELEVATION_DEG: f32 = 50.0;

/// The relative optical air mass at `elevation_rad` (Kasten & Young 1989, Applied Optics 28,
/// 4735): `1 / (sin h + 0.50572 (h + 6.07995°)^−1.6364)`, h in degrees; 1 overhead, 37.9 at the
/// horizon.
pub fn air_mass(elevation_rad: f64) -> f64 {
    let h = elevation_rad.to_degrees();
    1.0 / (elevation_rad.sin() + 0.50572 * (h + 6.07995).powf(-1.6364))
}

/// A cloudless sky's direct normal and diffuse horizontal irradiance, W/m², at `elevation_rad`:
/// the beam after Meinel & Meinel (1976), `1353 · 0.7^(AM^0.678)`, and the diffuse light the
/// global horizontal irradiance of Haurwitz (1945), `1098 · sin h · exp(−0.057 / sin h)`, less
/// the beam's share on the ground (never below zero). Overhead 947 and 90 W/m²; at 50° 882 and
/// 105; at 5° 240 and 29.
pub fn clear_sky(elevation_rad: f64) -> [f64; 2] {
    let sin_h = elevation_rad.sin().max(1e-6);
    let beam = 1353.0 * 0.7f64.powf(air_mass(elevation_rad).powf(0.678));
    let global = 1098.0 * sin_h * (-0.057 / sin_h).exp();
    [beam, (global - beam * sin_h).max(0.0)]
}

impl SunElevation {
    /// The elevations allowed, degrees: a sun under 2° would cast shadows hundreds of metres
    /// long over the map while lighting almost nothing.
    pub const ALLOWED_DEG: (f32, f32) = (2.0, 90.0);

    /// Whether this is the default range.
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// One elevation, fixed.
    pub fn at(deg: f32) -> Self {
        Self { min_deg: deg, max_deg: deg, daylight: Daylight::Constant }
    }

    /// Refuses a range outside [`SunElevation::ALLOWED_DEG`] or with min above max, saying
    /// what is allowed.
    pub fn check(&self) -> Result<(), String> {
        let (lo, hi) = Self::ALLOWED_DEG;
        let ok = |v: f32| (lo..=hi).contains(&v);
        if ok(self.min_deg) && ok(self.max_deg) && self.min_deg <= self.max_deg {
            Ok(())
        } else {
            Err(format!("{lo} to {hi} degrees, min_deg at most max_deg"))
        }
    }

    /// An elevation drawn from the range, radians. One draw from `rng` whatever the range (a
    /// fixed elevation discards it), so the rest of an episode is drawn alike.
    pub fn draw(&self, rng: &mut impl rand::Rng) -> f32 {
        let (lo, hi) = (self.min_deg.to_radians(), self.max_deg.to_radians());
        if lo < hi {
            rng.random_range(lo..hi)
        } else {
            let _: f32 = rng.random_range(0.0..1.0);
            lo
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn air_mass_follows_kasten_and_young() {
        // Their table's exact air masses: 1.0 overhead, 1.9942 at 30°, 5.60 at 10°, 38.09 at the
        // horizon, which the formula meets within its stated 0.5 %.
        assert!((air_mass(90f64.to_radians()) - 1.0).abs() < 1e-3);
        assert!((air_mass(30f64.to_radians()) - 1.9942).abs() < 2e-3);
        assert!((air_mass(10f64.to_radians()) - 5.60).abs() < 0.02);
        assert!((air_mass(0.0) / 38.09 - 1.0).abs() < 5e-3);
    }

    #[test]
    fn clear_sky_levels_follow_the_published_closed_forms() {
        // Overhead: Meinel's 1353·0.7 = 947.1 W/m², Haurwitz's 1098·e^−0.057 = 1037.2 W/m².
        let [beam, diffuse] = clear_sky(90f64.to_radians());
        assert!((beam - 947.1).abs() < 0.5, "{beam}");
        assert!((diffuse - (1037.2 - 947.1)).abs() < 1.0, "{diffuse}");
        // Low sun: both fall; at 5° to about a quarter of their 50° levels.
        let [sun, sky] = Daylight::ClearSky.levels(5f32.to_radians());
        assert!((0.25..0.30).contains(&sun) && (0.24..0.32).contains(&sky), "{sun} {sky}");
        // At the reference elevation clear-sky equals constant; within the default range it
        // stays within 3 %.
        let at = |deg: f32| Daylight::ClearSky.levels(deg.to_radians());
        assert_eq!(at(REFERENCE_ELEVATION_DEG), [1.0, 1.0]);
        for deg in [45.0, 55.0] {
            assert!(at(deg).iter().all(|v| (v - 1.0).abs() < 0.03), "{:?}", at(deg));
        }
        assert_eq!(Daylight::Constant.levels(0.1), [1.0, 1.0]);
        // The beam grows with the elevation all the way up; the diffuse light never goes negative.
        let mut last = 0.0;
        for deg in (2..=90).map(f64::from) {
            let [b, d] = clear_sky(deg.to_radians());
            assert!(b > last && d >= 0.0, "{deg}: {b} {d}");
            last = b;
        }
    }
}
