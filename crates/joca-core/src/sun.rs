//! Where the sun stands: the range of elevations a simulator's episodes draw from.

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
}

impl Default for SunElevation {
    fn default() -> Self {
        Self { min_deg: 45.0, max_deg: 55.0 }
    }
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
        Self { min_deg: deg, max_deg: deg }
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
