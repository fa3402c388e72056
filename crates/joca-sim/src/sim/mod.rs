//! The simulator as a [`FrameSource`]: episodes, shutter-integrated motion blur, ground truth.

use crate::city::{City, CityConfig};
use crate::lighting::{Illumination, SunElevation};
use crate::render::shadow::Shadows;
use crate::render::{self, Target, View};
use joca_core::glare::Glare;
use joca_core::rng::SeedStreams;
use joca_core::weather::Weather;
mod episode;
mod grid;
mod pool;
mod shadows;
mod truth;
mod visibility;
mod weather;

pub use episode::{Episode, Mouth};
pub use grid::ShutterGrid;
pub use visibility::VisibilityRules;

pub use truth::{REFERENCE_MAX_PX, REFERENCE_PX_PER_RAD, reference_camera};

use joca_core::{Frame, FrameRequest, FrameSource, HdrImage, PinholeCamera, Shot, SourceError};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// Most sub-frames averaged for one blurred frame. About one sub-frame per pixel of the largest
/// image-space displacement during the shutter is used; beyond this cap (31 px of travel) the
/// blur of the fastest points is rendered as discrete copies 1–2 px apart, which a detector sees
/// as the same streak.
pub const MAX_SUBFRAMES: usize = 31;

/// An instant's ground truth: boxes and ignore regions, and the 180° count.
type Truth = ((Vec<joca_core::Annotation>, Vec<joca_core::Annotation>), u32);

/// Simulator settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimConfig {
    /// Seed of the city map.
    pub map_seed: u64,
    /// City generation parameters.
    pub city: CityConfig,
    /// Length of an episode, seconds.
    pub episode_s: f64,
    /// Time between frames, seconds.
    pub frame_interval_s: f64,
    /// Ego top speed, m/s.
    pub max_speed_mps: f64,
    /// Illumination of every episode, or `None` to draw one of the four per episode.
    pub illumination: Option<Illumination>,
    /// Visibility rules for ground truth.
    pub visibility: VisibilityRules,
    /// The air between camera and scene (ground truth ignores it: a fogged-out object is a
    /// miss).
    pub weather: Weather,
    /// Blur each sub-frame by its own depths (exact) instead of the shutter-integrated frame by
    /// the depths of its middle instant (the default: one blur per frame rather than one per
    /// sub-frame; within the test's tolerance of the exact one, see the simulator's tests). Holds
    /// for the lens's defocus and for fog's glow.
    pub optics_per_subframe: bool,
    /// Let the sun cast shadows: buildings, vehicles, walkers, signs and lamp posts shadow the
    /// ground, facades and each other (the shadowed surface keeps the sky's share). Off: every
    /// surface is lit by its angle to the sun alone.
    pub cast_shadows: bool,
    /// The sun's elevations, drawn per episode.
    pub sun_elevation: SunElevation,
    /// The lens's veiling glare (none by default).
    pub glare: Glare,
    /// The sun in the sky by day: the sky brighter towards it and its disc where the view sees
    /// it (off: the sky has no sun).
    pub sun_disc: bool,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            map_seed: 0,
            city: CityConfig::default(),
            episode_s: 60.0,
            frame_interval_s: 0.1,
            max_speed_mps: 15.0,
            illumination: None,
            visibility: VisibilityRules::default(),
            weather: Weather::Clear,
            optics_per_subframe: false,
            cast_shadows: false,
            sun_elevation: SunElevation::default(),
            glare: Glare::default(),
            sun_disc: false,
        }
    }
}

/// The built-in driving simulator.
#[derive(Debug)]
pub struct Simulator {
    config: SimConfig,
    city: City,
    episodes: Mutex<HashMap<u64, Arc<Episode>>>,
    /// The static city's shadows by sun direction (its bits), most recently used last.
    shadows: Mutex<Vec<([u32; 3], Arc<Shadows>)>>,
}

impl Simulator {
    /// Builds the city of `config.map_seed`.
    pub fn new(config: SimConfig) -> Self {
        let streams = SeedStreams::new(config.map_seed);
        let city = City::generate(&config.city, &mut streams.stream("city"));
        Self::with_city(config, city)
    }

    /// A simulator over a given city (e.g. a hand-built test scene).
    pub fn with_city(config: SimConfig, city: City) -> Self {
        Self { config, city, episodes: Mutex::new(HashMap::new()), shadows: Mutex::new(Vec::new()) }
    }

    /// Replaces episode `index` with a scripted one.
    pub fn set_episode(&self, index: u64, episode: Episode) {
        let mut cache = self.episodes.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        cache.insert(index, Arc::new(episode));
    }

    /// The city.
    pub fn city(&self) -> &City {
        &self.city
    }

    /// The settings.
    pub fn config(&self) -> &SimConfig {
        &self.config
    }

    fn view<'a>(&self, episode: &Episode, camera: &'a PinholeCamera, time_s: f64) -> View<'a> {
        View {
            camera,
            ego: episode.ego.pose_at(time_s),
            lighting: self.lighting(episode, time_s),
            time_s,
            shadows: None,
            sun_disc: self.config.sun_disc,
        }
    }

    fn render_at(
        &self,
        episode: &Episode,
        camera: &PinholeCamera,
        time_s: f64,
        target: &mut Target,
    ) {
        let shadows = self.static_shadows(episode);
        let view = View { shadows: shadows.as_deref(), ..self.view(episode, camera, time_s) };
        render::render(&self.city, &view, target);
        // The air first, then the lens: fog acts along the ray, the blur on what reaches it.
        self.air(target, camera, &view);
        if self.config.optics_per_subframe {
            render::lens::defocus(target, camera);
        }
    }

    /// Frames of one instant for several exposures on a given grid (the shared-grid renderer
    /// behind [`FrameSource::render_exposures`]; public so that a frame can be checked against a
    /// render on a finer grid). The grid must be centred on `request.time_s` and every shutter
    /// must fit in its span.
    pub fn render_on_grid(
        &self,
        camera: &PinholeCamera,
        request: &FrameRequest,
        exposures_s: &[f64],
        grid: &ShutterGrid,
    ) -> Result<Vec<Frame>, SourceError> {
        let shots: Vec<Shot> = exposures_s.iter().map(|&e| Shot::exposure(e)).collect();
        self.render_instant(camera, request, &shots, Some(grid))
    }

    /// The frames of `request`'s instant for `shots`: on `grid`, or on the grid of the longest
    /// shutter. A shot's f-number changes only its defocus (the light is image formation's).
    fn render_instant(
        &self,
        camera: &PinholeCamera,
        request: &FrameRequest,
        shots: &[Shot],
        grid: Option<&ShutterGrid>,
    ) -> Result<Vec<Frame>, SourceError> {
        let exposures_s: Vec<f64> = shots.iter().map(|s| s.exposure_s).collect();
        let shutters = self.check(request, &exposures_s)?;
        if self.config.optics_per_subframe && shots.iter().any(|s| s.f_number.is_some()) {
            return Err(SourceError::OutOfRange {
                reason: "optics_per_subframe blurs the shared sub-frames through one lens: \
                         shots cannot set their own f-number"
                    .into(),
            });
        }
        let cameras =
            shots.iter().map(|s| camera.stopped_to(s.f_number)).collect::<Result<Vec<_>, _>>()?;
        if let Some(g) = grid {
            let longest = shutters.iter().any(|&s| s > g.span_s * (1.0 + 1e-9));
            if longest || g.centre_s != request.time_s {
                return Err(SourceError::OutOfRange {
                    reason: format!(
                        "the grid ({} s centred on {} s) must be centred on the frame's time \
                         ({} s) and cover every shutter",
                        g.span_s, g.centre_s, request.time_s
                    ),
                });
            }
        }
        let episode = self.episode(request.episode);
        let (w, h) = (camera.width_px, camera.height_px);
        // Ground truth and the 180° count run beside the frame's own renders: the middle
        // sub-frame first (the grid depends on it), then the others, which the thread that did
        // the ground truth joins when it is done.
        let (truth, (weights, colours)) = rayon::join(
            || {
                let t = request.time_s;
                (self.annotations(&episode, camera, t), self.visible_180(&episode, t))
            },
            || {
                let mut mid = pool::take(w, h, self.city.objects.len(), true);
                self.render_at(&episode, camera, request.time_s, &mut mid);
                let grid = match grid {
                    Some(g) => *g,
                    None => {
                        let longest = shutters.iter().copied().fold(0.0, f64::max);
                        self.grid_for(&episode, camera, request.time_s, longest, &mid)
                    }
                };
                let weights: Vec<Vec<f32>> = shutters.iter().map(|&s| grid.weights(s)).collect();
                let integrated = self.integrate(&episode, camera, &grid, &weights, &mid);
                let mut colours = integrated.colours;
                if let Weather::Rain { rate_mm_h } = self.config.weather {
                    let at = (request, rate_mm_h, shutters.as_slice());
                    self.rain_streaks(&episode, camera, at, &mut colours, &mid);
                }
                if !self.config.optics_per_subframe {
                    let at = (episode.as_ref(), camera, request.time_s);
                    self.glow(at, &mut colours, &integrated.light_depths);
                    for (colour, camera) in colours.iter_mut().zip(&cameras) {
                        render::lens::defocus_colour(colour, &mid.inv_depth, w, h, camera);
                    }
                }
                // The lens's veiling glare: linear and the same at every instant, so once on
                // the shutter-integrated frame is exact.
                for colour in &mut colours {
                    render::glare::veiling_glare(colour, (w, h), camera, &self.config.glare);
                }
                pool::give([mid]);
                (weights, colours)
            },
        );
        self.frames(camera, &weights, colours, truth)
    }

    /// Validates `request` and `exposures_s`; returns the shutter intervals (exposure × motion
    /// scale).
    fn check(&self, request: &FrameRequest, exposures_s: &[f64]) -> Result<Vec<f64>, SourceError> {
        if !(request.time_s >= 0.0 && request.time_s <= self.config.episode_s) {
            return Err(SourceError::OutOfRange {
                reason: format!(
                    "time {} s outside the episode (0 to {} s)",
                    request.time_s, self.config.episode_s
                ),
            });
        }
        let bad = |e: f64| !(e >= 0.0 && e.is_finite());
        if exposures_s.is_empty()
            || exposures_s.iter().any(|&e| bad(e))
            || bad(request.motion_scale)
        {
            return Err(SourceError::OutOfRange {
                reason: format!(
                    "exposures {exposures_s:?} s and motion scale {} must be finite and \
                     non-negative (at least one exposure)",
                    request.motion_scale
                ),
            });
        }
        Ok(exposures_s.iter().map(|&e| e * request.motion_scale).collect())
    }

    /// The frames from their integrated colours and grid weights (one per shutter), with
    /// `truth`, the ground truth and 180° count of the grid's centre.
    fn frames(
        &self,
        camera: &PinholeCamera,
        weights: &[Vec<f32>],
        colours: Vec<Vec<f32>>,
        truth: Truth,
    ) -> Result<Vec<Frame>, SourceError> {
        let (w, h) = (camera.width_px, camera.height_px);
        let ((boxes, ignore), visible_180) = truth;
        colours
            .into_iter()
            .zip(weights)
            .map(|(colour, wk)| {
                let hdr = HdrImage::from_vec(w, h, colour)
                    .map_err(|e| SourceError::OutOfRange { reason: e.to_string() })?;
                let subframes = wk.iter().filter(|&&a| a > 0.0).count() as u32;
                Ok(Frame {
                    hdr,
                    boxes: boxes.clone(),
                    ignore: ignore.clone(),
                    visible_180,
                    subframes,
                })
            })
            .collect()
    }
}

impl FrameSource for Simulator {
    fn render(&self, camera: &PinholeCamera, request: &FrameRequest) -> Result<Frame, SourceError> {
        self.render_exposures(camera, request, &[request.exposure_s])?
            .pop()
            .ok_or_else(|| SourceError::OutOfRange { reason: "no frame for the exposure".into() })
    }

    /// One grid for all the shots, over the longest shutter: the renders of the instant are
    /// shared (see [`ShutterGrid`]); each shot's f-number sets its own defocus.
    fn render_shots(
        &self,
        camera: &PinholeCamera,
        request: &FrameRequest,
        shots: &[Shot],
    ) -> Result<Vec<Frame>, SourceError> {
        self.render_instant(camera, request, shots, None)
    }

    fn frame_interval_s(&self) -> f64 {
        self.config.frame_interval_s
    }
}
