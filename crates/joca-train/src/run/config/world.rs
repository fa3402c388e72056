//! The world's part of a run's configuration check: the weather, the sun and its shadows, the
//! lens's glare — the simulator's alone, since a recording has its own.

use super::RunConfig;
use crate::TrainError;
use joca_sim::Weather;

impl RunConfig {
    /// The world's light of every training and test town, as the records name it.
    pub fn world(&self) -> joca_record::World {
        joca_record::World {
            cast_shadows: self.cast_shadows,
            sun_elevation: self.sun_elevation,
            glare: self.glare,
            sun_disc: self.sun_disc,
            tunnels: self.tunnels,
            dark_streets: self.dark_streets,
        }
    }

    /// The world's part of [`RunConfig::validate`]: the weather, the sun and its shadows, the
    /// lens's glare (the simulator's alone: a recording has its own).
    pub(super) fn validate_world(&self) -> Result<(), TrainError> {
        let bad = super::checks::refuse;
        if let Err(e) = self.weather.check() {
            return bad("weather", format!("\"{}\"", self.weather), &e);
        }
        if self.weather != Weather::Clear && self.source.is_recording() {
            return bad("weather", format!("\"{}\"", self.weather), "\"clear\" with a recording");
        }
        if let Err(e) = self.sun_elevation.check() {
            let s = self.sun_elevation;
            return bad(
                "sun_elevation",
                format!("{{ min_deg = {}, max_deg = {} }}", s.min_deg, s.max_deg),
                &e,
            );
        }
        if !self.sun_elevation.is_default() && self.source.is_recording() {
            return bad("sun_elevation", "a range".into(), "the default with a recording");
        }
        if self.cast_shadows && self.source.is_recording() {
            return bad("cast_shadows", "true".into(), "false with a recording");
        }
        if let Err((field, allowed)) = self.glare.check() {
            let value = match field {
                "fraction" => self.glare.fraction,
                _ => self.glare.scale_deg,
            };
            return bad(&format!("glare.{field}"), value.to_string(), &allowed);
        }
        if self.dark_streets && self.source.is_recording() {
            return bad("dark_streets", "true".into(), "false with a recording");
        }
        if self.sun_disc && self.source.is_recording() {
            return bad("sun_disc", "true".into(), "false with a recording");
        }
        if let Err((field, allowed)) = self.tunnels.check() {
            let value = match field {
                "count" => self.tunnels.count.to_string(),
                "drives" => self.tunnels.drives.to_string(),
                _ => self.tunnels.lamp_level.to_string(),
            };
            return bad(&format!("tunnels.{field}"), value, &allowed);
        }
        if self.tunnels.are_places() && self.source.is_recording() {
            return bad("tunnels", "places".into(), "the switch with a recording");
        }
        if !self.glare.is_off() && self.source.is_recording() {
            return bad("glare", "a fraction above 0".into(), "none with a recording");
        }
        Ok(())
    }
}
