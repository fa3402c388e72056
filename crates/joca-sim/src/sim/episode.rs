//! Episodes: what stays fixed within one (route, light, sun), drawn from the map seed and the
//! episode's index, and the light of an instant.

use super::Simulator;
use crate::ego::EgoTrajectory;
use crate::lighting::{Illumination, Lighting};
use joca_core::rng::SeedStreams;
use rand::Rng;
use std::sync::Arc;

/// What stays fixed within an episode.
#[derive(Debug, Clone)]
pub struct Episode {
    /// The ego vehicle's route and speed.
    pub ego: EgoTrajectory,
    /// Illumination schedule.
    pub illumination: Illumination,
    /// Schedule offset, seconds.
    pub phase_s: f64,
    /// Direction towards the sun.
    pub sun_dir: [f32; 3],
    /// Where a drive through a tunnel passes its mouth (tunnels as places, `tunnel` light).
    pub mouth: Option<Mouth>,
}

/// When a drive through a tunnel passes a mouth, and which.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mouth {
    /// Time the vehicle passes the mouth's plane, seconds.
    pub time_s: f64,
    /// Entering the tunnel (else leaving it).
    pub entering: bool,
}

impl Simulator {
    /// Episode `index` (created on first use; deterministic in map seed and index).
    pub fn episode(&self, index: u64) -> Arc<Episode> {
        let mut cache = self.episodes.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        cache
            .entry(index)
            .or_insert_with(|| {
                let mut rng = SeedStreams::new(self.config.map_seed).indexed("episode", index);
                let illumination = self.config.illumination.unwrap_or_else(|| {
                    Illumination::ALL[rng.random_range(0..Illumination::ALL.len())]
                });
                let phase_s = rng.random_range(0.0..24.0);
                let azimuth: f32 = rng.random_range(0.0..std::f32::consts::TAU);
                let elevation = self.config.sun_elevation.draw(&mut rng);
                let sun_dir = [
                    elevation.cos() * azimuth.cos(),
                    elevation.cos() * azimuth.sin(),
                    elevation.sin(),
                ];
                let (duration, v_max) = (self.config.episode_s + 1.0, self.config.max_speed_mps);
                let through = illumination == Illumination::Tunnel && self.tunnels_are_places();
                let drives = self.config.city.tunnels.drives;
                let drive = through
                    .then(|| {
                        EgoTrajectory::through_tunnel(&self.city, duration, v_max, drives, &mut rng)
                    })
                    .flatten();
                let (ego, mouth) = match drive {
                    Some((ego, time_s, entering)) => (ego, Some(Mouth { time_s, entering })),
                    None => (EgoTrajectory::generate(&self.city, duration, v_max, &mut rng), None),
                };
                Arc::new(Episode { ego, illumination, phase_s, sun_dir, mouth })
            })
            .clone()
    }

    /// Whether the `tunnel` light drives through the town's tunnels in daylight (instead of
    /// switching the ambient light).
    fn tunnels_are_places(&self) -> bool {
        self.config.city.tunnels.are_places() && !self.city.tunnels().is_empty()
    }

    /// The light where the camera is at `time_s` of episode `index`, relative to full
    /// daylight: the schedule's ambient level, or under a tunnel's ceiling its lamps' level
    /// (the light that the showcase's tunnel step is found by).
    pub fn ambient_at(&self, index: u64, time_s: f64) -> f32 {
        let episode = self.episode(index);
        let lighting = self.lighting(&episode, time_s);
        let ego = episode.ego.pose_at(time_s);
        let p = crate::geometry::V3::new(ego.x, ego.y, 1.0);
        self.city.tunnel_at(p).map_or(lighting.ambient, |t| t.lamp_level)
    }

    /// The light of an instant: a drive through a tunnel is in daylight (the tunnel darkens
    /// what it covers), any other episode follows its schedule.
    pub(super) fn lighting(&self, episode: &Episode, time_s: f64) -> Lighting {
        let elevation = episode.sun_dir[2].clamp(-1.0, 1.0).asin();
        let [beam, diffuse] = self.config.sun_elevation.daylight.levels(elevation);
        Lighting {
            ambient: if episode.mouth.is_some() {
                1.0
            } else {
                episode.illumination.ambient(time_s, episode.phase_s)
            },
            sun_dir: episode.sun_dir,
            beam,
            diffuse,
            street_lamps_dark: !self.city.street_lamps_lit()
                && episode.illumination != Illumination::Tunnel,
        }
    }
}
