//! The weather's work: the air's extinction on every instant, and the streaks rain draws into
//! each shutter-integrated frame.

use super::{Episode, Simulator};
use crate::render::{self, Target, View};
use joca_core::rng::SeedStreams;
use joca_core::weather::Weather;
use joca_core::{FrameRequest, PinholeCamera};

impl Simulator {
    /// The air between the camera and one instant's scene: fog's or rain's extinction and
    /// airlight along every ray.
    pub(super) fn air(&self, target: &mut Target, camera: &PinholeCamera, view: &View<'_>) {
        // A pooled target may hold the last fog's light depths: every arm sets or empties them.
        match self.config.weather {
            Weather::Clear => target.light_depth.clear(),
            Weather::Fog { visibility_m } => {
                let airlight = view.lighting.sky(0.0);
                render::fog::fog(target, camera, visibility_m, airlight);
                if self.config.optics_per_subframe {
                    let size = (target.width, target.height);
                    let Target { colour, light_depth, .. } = target;
                    render::glow::fog_glow_integrated(colour, light_depth, size, camera, airlight);
                }
            }
            Weather::Rain { rate_mm_h } => {
                let beta = render::rain::extinction_per_m(rate_mm_h);
                render::fog::attenuate(target, camera, beta, view.lighting.sky(0.0));
            }
        }
    }

    /// Fog's glow on each shutter-integrated colour, by its light-weighted optical depths and
    /// the middle instant's airlight (see [`render::glow`]; `optics_per_subframe` glows every
    /// sub-frame instead).
    pub(super) fn glow(
        &self,
        (episode, camera, time_s): (&Episode, &PinholeCamera, f64),
        colours: &mut [Vec<f32>],
        light_depths: &[Vec<f32>],
    ) {
        if !matches!(self.config.weather, Weather::Fog { .. }) {
            return;
        }
        let airlight = self.view(episode, camera, time_s).lighting.sky(0.0);
        let size = (camera.width_px, camera.height_px);
        for (colour, depth) in colours.iter_mut().zip(light_depths) {
            render::glow::fog_glow_integrated(colour, depth, size, camera, airlight);
        }
    }

    /// Draws the streaks of the instant's drops (the same drops for every shutter) into each
    /// shutter's integrated colour, behind the scene's surfaces of the middle instant, as the
    /// moving camera sees them; `at` is the request, the rain rate (mm/h) and the shutters (s).
    pub(super) fn rain_streaks(
        &self,
        episode: &Episode,
        camera: &PinholeCamera,
        (request, rate_mm_h, shutters): (&FrameRequest, f64, &[f64]),
        colours: &mut [Vec<f32>],
        mid: &Target,
    ) {
        // One draw of drops per (map, episode, instant in ms), whatever the exposures.
        let instant = (request.episode << 20) | (request.time_s * 1e3).round() as u64;
        let mut rng = SeedStreams::new(self.config.map_seed).indexed("rain", instant);
        let drops = render::rain::drops(camera, rate_mm_h, &mut rng);
        // A drop refracts the sky above and behind the camera (see render::rain).
        let radiance = self.view(episode, camera, request.time_s).lighting.sky(0.5);
        // The camera moves with the ego during the shutter: streaks lean away from the focus of
        // expansion as well as falling.
        let ego = |dt: f64| episode.ego.pose_at(request.time_s + dt);
        for (colour, &shutter_s) in colours.iter_mut().zip(shutters) {
            let canvas = (colour.as_mut_slice(), mid.inv_depth.as_slice());
            render::rain::streaks(canvas, camera, &ego, &drops, shutter_s, radiance);
        }
    }
}
