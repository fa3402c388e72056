//! Illumination: schedules over an episode, and the radiometric constants that put rendered
//! values in calibrated DN.
//!
//! A diffuse surface of reflectance ρ receiving relative irradiance `E` (1 = the daylight level
//! of a horizontal surface lit by the sun alone) has radiance `K·ρ·E` DN, with `K` =
//! [`RADIANCE_SCALE_DN`] chosen so that white paper (ρ = 0.85) on the ground in full daylight
//! (sun 45–55° high plus sky) reads 203–225 DN — what the calibration camera records at E0, G0
//! (docs/design.md: daylight white ≈ 200–230 DN). Night lowers the sun-and-sky term by three orders of
//! magnitude; street lamps, lit windows and vehicle lights then dominate, giving the high dynamic
//! range of real night scenes.

pub use joca_core::sun::SunElevation;

/// DN per unit reflectance per unit relative irradiance.
pub const RADIANCE_SCALE_DN: f32 = 226.0;
/// Direct sun irradiance on a surface facing it, relative units.
pub const SUN: f32 = 1.0;
/// Sky (diffuse) irradiance on a horizontal surface, relative units.
pub const SKY: f32 = 0.35;
/// Ambient (sun + sky) level at night, relative to day.
pub const NIGHT_AMBIENT: f32 = 1e-3;
/// Ambient level inside a tunnel, relative to day.
pub const TUNNEL_AMBIENT: f32 = 2e-3;
/// Seconds between the abrupt changes of the tunnel schedule.
pub const TUNNEL_PHASE_S: f64 = 4.0;
/// Period of the gradual day–night cycle, seconds.
pub const CYCLE_PERIOD_S: f64 = 24.0;
/// Radiant intensity of the ego vehicle's head lights: irradiance at distance d is this / d².
pub const EGO_HEADLIGHT: f32 = 0.4;
/// Half angle of the head-light cone, radians.
pub const EGO_HEADLIGHT_HALF_ANGLE: f32 = 0.45;
/// Street lamps and the ego vehicle's head lights are switched on when the ambient level falls
/// below this (dusk), as their automatic light sensors would; in daylight they would add under
/// 3 % and are off.
pub const LIGHTS_ON_BELOW: f32 = 0.2;
/// Colour of street-lamp light (warm white).
pub const LAMP_TINT: [f32; 3] = [1.0, 0.82, 0.58];
/// Emitted radiance of a lit window, calibrated DN: about 1 % of white paper in daylight
/// (a lit interior seen through glass at night is ~50 cd/m², a sunlit facade ~5000 cd/m²).
pub const WINDOW_GLOW: [f32; 3] = [2.6, 2.1, 1.5];

joca_core::named_enum! {
    /// How the ambient light changes over an episode.
    pub enum Illumination("illumination") {
        /// Full daylight throughout.
        Day = "day",
        /// Night throughout: street lamps, lit windows and vehicle lights.
        Night = "night",
        /// Abrupt switches between daylight and a dark tunnel every few seconds.
        Tunnel = "tunnel",
        /// A gradual day → night → day cycle.
        Cycle = "cycle",
    }
}

impl Illumination {
    /// Ambient (sun + sky) level at `t_s`, relative to full daylight; `phase_s` shifts the
    /// schedule so episodes do not all start alike.
    pub fn ambient(self, t_s: f64, phase_s: f64) -> f32 {
        let t = t_s + phase_s;
        match self {
            Illumination::Day => 1.0,
            Illumination::Night => NIGHT_AMBIENT,
            Illumination::Tunnel => {
                if (t / TUNNEL_PHASE_S).floor().rem_euclid(2.0) < 1.0 {
                    1.0
                } else {
                    TUNNEL_AMBIENT
                }
            }
            Illumination::Cycle => {
                // Log-linear between day and night, so the change is even in stops.
                let w = 0.5 + 0.5 * (std::f64::consts::TAU * t / CYCLE_PERIOD_S).cos();
                let log_night = f64::from(NIGHT_AMBIENT).ln();
                (log_night * (1.0 - w)).exp() as f32
            }
        }
    }
}

/// Lighting of one instant: ambient level and sun direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lighting {
    /// Ambient level, relative to day.
    pub ambient: f32,
    /// Unit vector towards the sun (world frame).
    pub sun_dir: [f32; 3],
    /// The sun's beam and the sky's light at the sun's elevation, each relative to their
    /// [`SUN`] and [`SKY`] levels ([`joca_core::sun::Daylight::levels`]; 1 and 1 with constant
    /// daylight).
    pub beam: f32,
    /// See [`Lighting::beam`].
    pub diffuse: f32,
    /// Whether the street lamps stay dark though the lights are on: the night of a town with
    /// dark streets, never the tunnel switch's dark phase (whose lamps stand in for a tunnel's).
    pub street_lamps_dark: bool,
}

impl Lighting {
    /// Whether street lamps and head lights are on.
    pub fn lights_on(&self) -> bool {
        self.ambient < LIGHTS_ON_BELOW
    }

    /// Whether the street lamps shine: the lights are on and the streets' lamps are not dark.
    pub fn street_lamps_on(&self) -> bool {
        self.lights_on() && !self.street_lamps_dark
    }

    /// Relative irradiance from sun and sky on a surface with unit normal `n`.
    pub fn sun_sky(&self, n: [f32; 3]) -> f32 {
        self.ambient * (SUN * self.beam * self.cos_sun(n) + SKY * self.diffuse * (0.5 + 0.5 * n[2]))
    }

    /// The sun's share of [`Lighting::sun_sky`]: what a surface with unit normal `n` loses in
    /// the shadow of another (the sky's share stays).
    pub fn direct_sun(&self, n: [f32; 3]) -> f32 {
        self.ambient * SUN * self.beam * self.cos_sun(n)
    }

    fn cos_sun(&self, n: [f32; 3]) -> f32 {
        (n[0] * self.sun_dir[0] + n[1] * self.sun_dir[1] + n[2] * self.sun_dir[2]).max(0.0)
    }

    /// Sky radiance in DN for a view ray with vertical component `dir_z` (unit ray).
    pub fn sky(&self, dir_z: f32) -> [f32; 3] {
        // Brighter and whiter at the horizon, bluer overhead; a clear day sky is about as bright
        // as white paper in sun, so it clips when the exposure favours shadows.
        let up = dir_z.clamp(0.0, 1.0);
        let base = [0.78 - 0.18 * up, 0.86 - 0.12 * up, 1.0 - 0.02 * up];
        let level = RADIANCE_SCALE_DN * self.ambient * self.diffuse * 0.95;
        // At night a faint city glow remains near the horizon.
        let glow = 0.08 * (1.0 - up).powi(4);
        [base[0] * level + glow * 1.2, base[1] * level + glow, base[2] * level + glow * 0.8]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schedules_span_day_and_night() {
        assert_eq!(Illumination::Day.ambient(3.0, 0.0), 1.0);
        assert_eq!(Illumination::Night.ambient(3.0, 0.0), NIGHT_AMBIENT);
        assert_eq!(Illumination::Tunnel.ambient(1.0, 0.0), 1.0);
        assert_eq!(Illumination::Tunnel.ambient(TUNNEL_PHASE_S + 1.0, 0.0), TUNNEL_AMBIENT);
        assert!((Illumination::Cycle.ambient(0.0, 0.0) - 1.0).abs() < 1e-6);
        let mid = Illumination::Cycle.ambient(CYCLE_PERIOD_S / 2.0, 0.0);
        assert!((mid - NIGHT_AMBIENT).abs() < 1e-6);
        assert!(Illumination::from_name("dusk").unwrap_err().contains("day, night, tunnel, cycle"));
    }

    #[test]
    fn white_paper_in_daylight_reads_about_215_dn() {
        let s = std::f32::consts::FRAC_1_SQRT_2;
        let light = Lighting {
            ambient: 1.0,
            sun_dir: [s, 0.0, s],
            beam: 1.0,
            diffuse: 1.0,
            street_lamps_dark: false,
        };
        let dn = RADIANCE_SCALE_DN * 0.85 * light.sun_sky([0.0, 0.0, 1.0]);
        assert!((200.0..=230.0).contains(&dn), "{dn}");
    }
}
