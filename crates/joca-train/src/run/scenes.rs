//! Where a run's scenes come from: the simulator's towns, each built once per town and light, or
//! the recordings of the real-image mode. Training, validation, the test and the warm start ask it
//! for a town; none of them builds one itself.

use super::RunConfig;
use joca_data::folder::Recording;
use joca_record::Light;
use joca_sim::{CityConfig, Illumination, SimConfig, Simulator};
use std::collections::HashMap;
use std::sync::Arc;

/// Training and test recordings of the real-image mode.
pub(super) struct RealSources {
    pub(super) train: Recording,
    /// `None`: the test plays the training recording (no `test_source`).
    pub(super) held_out: Option<Recording>,
}

impl RealSources {
    /// The recording the test plays.
    pub(super) fn test(&self) -> &Recording {
        self.held_out.as_ref().unwrap_or(&self.train)
    }
}

/// The towns built so far and the recordings, if the run plays recordings.
pub(super) struct SceneSource {
    /// What every town shares (speed, reference objects, weather); each town sets its map seed
    /// and light.
    template: SimConfig,
    /// Towns by map seed and illumination.
    towns: HashMap<(u64, Option<Illumination>), Arc<Simulator>>,
    /// The recorded sources of the real-image mode (`None`: the simulator).
    pub(super) real: Option<Arc<RealSources>>,
}

impl SceneSource {
    /// The scenes of `config`: its towns, or `real`'s recordings.
    pub(super) fn new(config: &RunConfig, real: Option<Arc<RealSources>>) -> Self {
        let template = SimConfig {
            max_speed_mps: config.max_speed_mps,
            visibility: config.reference.rules(),
            weather: config.weather,
            cast_shadows: config.cast_shadows,
            sun_elevation: config.sun_elevation,
            glare: config.glare,
            sun_disc: config.sun_disc,
            city: CityConfig {
                tunnels: config.tunnels,
                street_lamps: !config.dark_streets,
                ..CityConfig::default()
            },
            ..SimConfig::default()
        };
        Self { template, towns: HashMap::new(), real }
    }

    /// The town of `map_seed` under `illumination` (`None`: drawn per episode), built once.
    pub(super) fn town(
        &mut self,
        map_seed: u64,
        illumination: Option<Illumination>,
    ) -> Arc<Simulator> {
        let template = &self.template;
        Arc::clone(self.towns.entry((map_seed, illumination)).or_insert_with(|| {
            Arc::new(Simulator::new(SimConfig { map_seed, illumination, ..*template }))
        }))
    }

    /// Whether the run plays recordings (no towns, no lights of its own).
    pub(super) fn recorded(&self) -> bool {
        self.real.is_some()
    }
}

/// The records' name for the light of frames under `illumination` (`None`: a recording's).
pub(crate) fn light_of(illumination: Option<Illumination>) -> Light {
    match illumination {
        None => Light::Recorded,
        Some(Illumination::Day) => Light::Day,
        Some(Illumination::Night) => Light::Night,
        Some(Illumination::Tunnel) => Light::Tunnel,
        Some(Illumination::Cycle) => Light::Cycle,
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_records_name_each_light_as_the_simulator_does() {
        for &i in joca_sim::Illumination::ALL {
            assert_eq!(super::light_of(Some(i)).name(), i.name());
        }
        assert_eq!(super::light_of(None).name(), "recorded");
    }
}
