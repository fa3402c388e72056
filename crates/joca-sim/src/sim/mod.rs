//! The simulator as a [`FrameSource`]: episodes, shutter-integrated motion blur, ground truth.

use crate::city::{City, CityConfig};
use crate::ego::EgoTrajectory;
use crate::geometry::V3;
use crate::lighting::{Illumination, Lighting};
use crate::render::{self, CameraFrame, Target, View};
use joca_core::rng::SeedStreams;
mod truth;

pub use truth::{REFERENCE_MAX_PX, REFERENCE_PX_PER_RAD, reference_camera};

use joca_core::{Class, Frame, FrameRequest, FrameSource, HdrImage, PinholeCamera, SourceError};
use rand::Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// Most sub-frames averaged for one blurred frame. About one sub-frame per pixel of the largest
/// image-space displacement during the shutter is used; beyond this cap (31 px of travel) the
/// blur of the fastest points is rendered as discrete copies 1–2 px apart, which a detector sees
/// as the same streak.
pub const MAX_SUBFRAMES: usize = 31;

/// An instant's ground truth: boxes and ignore regions, and the 180° count.
type Truth = ((Vec<joca_core::Annotation>, Vec<joca_core::Annotation>), u32);

/// Which objects are reference objects (ground truth) and count towards the 180° total.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VisibilityRules {
    /// Farthest vehicle that counts, metres from the camera (horizontal).
    pub vehicle_range_m: f32,
    /// Farthest walker that counts, metres.
    pub walker_range_m: f32,
    /// Farthest traffic sign that counts, metres.
    pub sign_range_m: f32,
    /// Smallest visible share of an object's camera-facing surface (reference-grid pixels over
    /// the pixels its front faces cover without occlusion; for the 180° count, the share of
    /// sample points on the object that a ray from the eye reaches unoccluded).
    pub min_visible_fraction: f32,
}

impl Default for VisibilityRules {
    /// Vehicles to 100 m; walkers and signs, smaller and met at lower closing speeds, to 50 m
    /// (3 s ahead at the simulator's 15 m/s); 15 % visible.
    fn default() -> Self {
        Self {
            vehicle_range_m: 100.0,
            walker_range_m: 50.0,
            sign_range_m: 50.0,
            min_visible_fraction: 0.15,
        }
    }
}

impl VisibilityRules {
    /// The range of `class`, metres.
    pub fn range_m(&self, class: Class) -> f32 {
        match class {
            Class::Vehicle => self.vehicle_range_m,
            Class::Walker => self.walker_range_m,
            Class::TrafficSign => self.sign_range_m,
        }
    }

    /// The longest of the class ranges, metres.
    pub fn farthest_m(&self) -> f32 {
        Class::ALL.iter().map(|&c| self.range_m(c)).fold(0.0, f32::max)
    }
}

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
        }
    }
}

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
}

/// The built-in driving simulator.
#[derive(Debug)]
pub struct Simulator {
    config: SimConfig,
    city: City,
    episodes: Mutex<HashMap<u64, Arc<Episode>>>,
}

impl Simulator {
    /// Builds the city of `config.map_seed`.
    pub fn new(config: SimConfig) -> Self {
        let streams = SeedStreams::new(config.map_seed);
        let city = City::generate(&config.city, &mut streams.stream("city"));
        Self { config, city, episodes: Mutex::new(HashMap::new()) }
    }

    /// A simulator over a given city (e.g. a hand-built test scene).
    pub fn with_city(config: SimConfig, city: City) -> Self {
        Self { config, city, episodes: Mutex::new(HashMap::new()) }
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
                // Sun 45–55° above the horizon: white paper on the ground reads 203–225 DN.
                let elevation: f32 = rng.random_range(45f32.to_radians()..55f32.to_radians());
                let sun_dir = [
                    elevation.cos() * azimuth.cos(),
                    elevation.cos() * azimuth.sin(),
                    elevation.sin(),
                ];
                let ego = EgoTrajectory::generate(
                    &self.city,
                    self.config.episode_s + 1.0,
                    self.config.max_speed_mps,
                    &mut rng,
                );
                Arc::new(Episode { ego, illumination, phase_s, sun_dir })
            })
            .clone()
    }

    fn view<'a>(&self, episode: &Episode, camera: &'a PinholeCamera, time_s: f64) -> View<'a> {
        View {
            camera,
            ego: episode.ego.pose_at(time_s),
            lighting: Lighting {
                ambient: episode.illumination.ambient(time_s, episode.phase_s),
                sun_dir: episode.sun_dir,
            },
            time_s,
        }
    }

    fn render_at(
        &self,
        episode: &Episode,
        camera: &PinholeCamera,
        time_s: f64,
        target: &mut Target,
    ) {
        render::render(&self.city, &self.view(episode, camera, time_s), target);
    }

    /// Number of sub-frames for a shutter from `t0` to `t1`, from the image-space travel of the
    /// scene seen in `mid`: about one per pixel of the largest displacement, odd (so the middle
    /// one falls on the shutter midpoint), at most [`MAX_SUBFRAMES`].
    fn subframes(
        &self,
        episode: &Episode,
        camera: &PinholeCamera,
        t0: f64,
        t1: f64,
        mid: &Target,
    ) -> usize {
        if t1 <= t0 {
            return 1;
        }
        let c0 = CameraFrame::new(camera, episode.ego.pose_at(t0));
        let c1 = CameraFrame::new(camera, episode.ego.pose_at(t1));
        let cm = CameraFrame::new(camera, episode.ego.pose_at(0.5 * (t0 + t1)));
        let project = |c: &CameraFrame, p: V3| -> Option<(f32, f32)> {
            let q = c.camera_from_world(p);
            (q.z > render::NEAR_M).then(|| (c.cx + c.fx * q.x / q.z, c.cy + c.fy * q.y / q.z))
        };
        let mut travel = 0.0f32;
        let mut measure = |a: Option<(f32, f32)>, b: Option<(f32, f32)>| {
            if let (Some(a), Some(b)) = (a, b) {
                travel = travel.max(((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt());
            }
        };
        // Static scene: unproject a sparse grid of the middle view, reproject at both ends.
        let step = 6;
        for y in (step / 2..mid.height).step_by(step) {
            for x in (step / 2..mid.width).step_by(step) {
                let inv_z = mid.inv_depth[y * mid.width + x];
                if inv_z <= 0.0 {
                    continue;
                }
                let z = 1.0 / inv_z;
                let a = (x as f32 + 0.5 - cm.cx) / cm.fx;
                let b = (y as f32 + 0.5 - cm.cy) / cm.fy;
                let p = cm.origin + cm.forward * z + cm.right * (a * z) + V3::new(0.0, 0.0, -b * z);
                measure(project(&c0, p), project(&c1, p));
            }
        }
        // Moving objects in view: their own motion too.
        let mut seen: Vec<u32> = mid.id.iter().copied().filter(|&i| i > 0).collect();
        seen.sort_unstable();
        seen.dedup();
        for id in seen {
            let object = &self.city.objects[id as usize - 1];
            if object.motion.is_static() {
                continue;
            }
            for part in &object.parts {
                let p0 = object.position_at(t0).apply(part.offset);
                let p1 = object.position_at(t1).apply(part.offset);
                measure(project(&c0, p0), project(&c1, p1));
            }
        }
        let n = (travel.ceil() as usize).clamp(1, MAX_SUBFRAMES);
        n | 1
    }

    /// The frames of shutters integrated over `grid`, one per row of `weights` (each shutter's
    /// [`ShutterGrid::weights`]). The middle cell is `mid`, already rendered; the others are
    /// rendered in parallel, each once, and a cell no shutter overlaps is not rendered.
    ///
    /// Shutters are centred on the grid, so a shutter's weights are one value over a symmetric
    /// run of whole cells and one smaller value on the pair of cells just outside it (see
    /// [`RingWeights`]). Each frame is therefore summed ring by ring from the middle outwards,
    /// `((v₀ + v₋₁) + v₊₁) + …`, scaled once, plus its edge pair: the order of every addition
    /// depends only on the grid and that shutter, not on the other shutters sharing the grid nor
    /// on the thread count. Summing rings is also what makes many shutters cheap: the running
    /// sum is shared, and each cell is read once.
    fn integrate(
        &self,
        episode: &Episode,
        camera: &PinholeCamera,
        grid: &ShutterGrid,
        weights: &[Vec<f32>],
        mid: &Target,
    ) -> Vec<Vec<f32>> {
        let (w, h) = (camera.width_px, camera.height_px);
        let objects = self.city.objects.len();
        let middle = grid.cells / 2;
        let rings: Vec<RingWeights> = weights.iter().map(|wk| RingWeights::of(wk)).collect();
        // Cells out to the outermost ring any shutter touches.
        let reach = rings.iter().map(RingWeights::reach).max().unwrap_or(0);
        let others: Vec<usize> =
            (middle - reach..=middle + reach).filter(|&k| k != middle).collect();
        let rendered: Vec<Vec<f32>> = others
            .par_iter()
            .map_init(
                || Target::new(w, h, objects),
                |target, &k| {
                    self.render_at(episode, camera, grid.time(k), target);
                    target.colour.clone()
                },
            )
            .collect();
        let cell = |k: usize| -> &[f32] {
            if k == middle {
                &mid.colour
            } else {
                let i = if k < middle { k - (middle - reach) } else { k - (middle - reach) - 1 };
                &rendered[i]
            }
        };
        // Over blocks of the image in parallel; within a block, rings in order.
        const BLOCK: usize = 4096;
        let mut out = vec![vec![0.0f32; w * h * 3]; weights.len()];
        let mut blocks: Vec<Vec<&mut [f32]>> = Vec::new();
        {
            let mut iters: Vec<_> = out.iter_mut().map(|o| o.chunks_mut(BLOCK)).collect();
            'blocks: loop {
                let mut row = Vec::with_capacity(iters.len());
                for it in &mut iters {
                    match it.next() {
                        Some(b) => row.push(b),
                        None => break 'blocks,
                    }
                }
                blocks.push(row);
            }
        }
        blocks.into_par_iter().enumerate().for_each(|(b, mut frames)| {
            let start = b * BLOCK;
            let len = frames.first().map_or(0, |f| f.len());
            let at = |k: usize| &cell(k)[start..start + len];
            let mut acc: Vec<f32> = at(middle).to_vec();
            for k in 0..=reach {
                if k > 0 {
                    let (lo, hi) = (at(middle - k), at(middle + k));
                    for ((a, &l), &u) in acc.iter_mut().zip(lo).zip(hi) {
                        *a = (*a + l) + u;
                    }
                }
                for (frame, ring) in frames.iter_mut().zip(&rings) {
                    if ring.full != k {
                        continue;
                    }
                    if ring.edge == 0.0 {
                        frame.iter_mut().zip(&acc).for_each(|(f, &a)| *f = ring.inner * a);
                    } else {
                        let (lo, hi) = (at(middle - k - 1), at(middle + k + 1));
                        for (((f, &a), &l), &u) in frame.iter_mut().zip(&acc).zip(lo).zip(hi) {
                            *f = ring.inner * a + ring.edge * (l + u);
                        }
                    }
                }
            }
        });
        out
    }

    /// The grid of sub-frames for shutters up to `longest_s` centred on `request.time_s`: about
    /// one cell per pixel of the largest image-space travel over the longest shutter, odd, at
    /// most [`MAX_SUBFRAMES`]. `mid` is the view at the centre.
    fn grid_for(
        &self,
        episode: &Episode,
        camera: &PinholeCamera,
        centre_s: f64,
        longest_s: f64,
        mid: &Target,
    ) -> ShutterGrid {
        let half = 0.5 * longest_s;
        let cells = self.subframes(episode, camera, centre_s - half, centre_s + half, mid);
        ShutterGrid::new(centre_s, longest_s, cells)
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
        self.render_instant(camera, request, exposures_s, Some(grid))
    }

    /// The frames of `request`'s instant for `exposures_s`: on `grid`, or on the grid of the
    /// longest shutter.
    fn render_instant(
        &self,
        camera: &PinholeCamera,
        request: &FrameRequest,
        exposures_s: &[f64],
        grid: Option<&ShutterGrid>,
    ) -> Result<Vec<Frame>, SourceError> {
        let shutters = self.check(request, exposures_s)?;
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
        let mut mid = Target::new(camera.width_px, camera.height_px, self.city.objects.len());
        // Ground truth and the 180° count run beside the middle sub-frame, which the grid
        // depends on; the other sub-frames then have every thread.
        let truth = rayon::join(
            || {
                let t = request.time_s;
                (self.annotations(&episode, camera, t), self.visible_180(&episode, t))
            },
            || self.render_at(&episode, camera, request.time_s, &mut mid),
        )
        .0;
        let grid = match grid {
            Some(g) => *g,
            None => {
                let longest = shutters.iter().copied().fold(0.0, f64::max);
                self.grid_for(&episode, camera, request.time_s, longest, &mid)
            }
        };
        self.frames(&episode, camera, &grid, &shutters, &mid, truth)
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

    /// The frames of `shutters` on `grid`, with `truth`, the ground truth and 180° count of the
    /// grid's centre.
    fn frames(
        &self,
        episode: &Episode,
        camera: &PinholeCamera,
        grid: &ShutterGrid,
        shutters: &[f64],
        mid: &Target,
        truth: Truth,
    ) -> Result<Vec<Frame>, SourceError> {
        let (w, h) = (camera.width_px, camera.height_px);
        let weights: Vec<Vec<f32>> = shutters.iter().map(|&s| grid.weights(s)).collect();
        let ((boxes, ignore), visible_180) = truth;
        let colours = self.integrate(episode, camera, grid, &weights, mid);
        colours
            .into_iter()
            .zip(&weights)
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

/// The sub-frame grid of one frame: `cells` equal cells over `span_s` seconds centred on
/// `centre_s` (the frame's time). A shutter of `s ≤ span_s` seconds is open over
/// `[centre − s/2, centre + s/2]`: shorter shutters nest in longer ones and share their renders,
/// ground truth and 180° count. Each cell is rendered at its centre and stands for the scene
/// over the whole cell (a box filter in time).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShutterGrid {
    /// The frame's time, seconds: the middle of every shutter.
    pub centre_s: f64,
    /// The longest shutter the grid covers, seconds.
    pub span_s: f64,
    /// Number of cells (odd, so that the middle one is rendered at the centre).
    pub cells: usize,
}

impl ShutterGrid {
    /// A grid of `cells` (made odd, at least 1) over `span_s` centred on `centre_s`.
    pub fn new(centre_s: f64, span_s: f64, cells: usize) -> Self {
        Self { centre_s, span_s: span_s.max(0.0), cells: cells.max(1) | 1 }
    }

    fn step_s(&self) -> f64 {
        self.span_s / self.cells as f64
    }

    /// The time cell `k` is rendered at.
    pub fn time(&self, k: usize) -> f64 {
        self.centre_s + (k as f64 - (self.cells / 2) as f64) * self.step_s()
    }

    /// Each cell's share of a shutter of `shutter_s` seconds centred on the grid: the overlap of
    /// the cell with the open shutter over the shutter's length (they sum to 1). A shutter
    /// shorter than a cell is the middle cell alone, a sharp frame.
    pub fn weights(&self, shutter_s: f64) -> Vec<f32> {
        let mut out = vec![0.0f32; self.cells];
        let middle = self.cells / 2;
        let step = self.step_s();
        if !(shutter_s > 0.0 && step > 0.0) || shutter_s <= step {
            out[middle] = 1.0;
            return out;
        }
        // In units of cells, from the centre: the shutter covers [−r, r], cell k covers
        // [k − m − 1/2, k − m + 1/2].
        let r = 0.5 * shutter_s.min(self.span_s) / step;
        for (k, o) in out.iter_mut().enumerate() {
            let c = k as f64 - middle as f64;
            let overlap = ((c + 0.5).min(r) - (c - 0.5).max(-r)).max(0.0);
            *o = (overlap / (2.0 * r)) as f32;
        }
        out
    }
}

/// A centred shutter's [`ShutterGrid::weights`] in ring form: `inner` on every cell within
/// `full` cells of the middle, `edge` on the two cells at `full + 1` (0 when the shutter ends
/// on a cell boundary), nothing beyond.
#[derive(Debug, Clone, Copy, PartialEq)]
struct RingWeights {
    full: usize,
    inner: f32,
    edge: f32,
}

impl RingWeights {
    /// The ring form of `weights` (symmetric about the middle cell, as every centred shutter's
    /// are: checked in debug builds).
    fn of(weights: &[f32]) -> Self {
        let m = weights.len() / 2;
        let inner = weights[m];
        let full = (1..=m).take_while(|&k| weights[m - k] == inner).count();
        let edge = if full < m { weights[m - full - 1] } else { 0.0 };
        let ring = Self { full, inner, edge };
        debug_assert!(weights.iter().enumerate().all(|(k, &wk)| wk == ring.weight(k.abs_diff(m))));
        ring
    }

    /// The weight of a cell `d` cells from the middle.
    fn weight(&self, d: usize) -> f32 {
        if d <= self.full {
            self.inner
        } else if d == self.full + 1 {
            self.edge
        } else {
            0.0
        }
    }

    /// The farthest ring with a non-zero weight.
    fn reach(&self) -> usize {
        if self.edge > 0.0 { self.full + 1 } else { self.full }
    }
}

impl FrameSource for Simulator {
    fn render(&self, camera: &PinholeCamera, request: &FrameRequest) -> Result<Frame, SourceError> {
        self.render_exposures(camera, request, &[request.exposure_s])?
            .pop()
            .ok_or_else(|| SourceError::OutOfRange { reason: "no frame for the exposure".into() })
    }

    /// One grid for all the exposures, over the longest shutter: the renders of the instant are
    /// shared (see [`ShutterGrid`]).
    fn render_exposures(
        &self,
        camera: &PinholeCamera,
        request: &FrameRequest,
        exposures_s: &[f64],
    ) -> Result<Vec<Frame>, SourceError> {
        self.render_instant(camera, request, exposures_s, None)
    }

    fn frame_interval_s(&self) -> f64 {
        self.config.frame_interval_s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ring form stands for exactly the grid's weights, for shutters from shorter than a
    /// cell to the whole span, on odd grids of 1 to 31 cells.
    #[test]
    fn ring_weights_are_the_grid_weights() {
        for cells in (1..=31).step_by(2) {
            let grid = ShutterGrid::new(1.0, 0.04, cells);
            for i in 0..=400 {
                let shutter = 0.04 * f64::from(i) / 400.0;
                let weights = grid.weights(shutter);
                let ring = RingWeights::of(&weights);
                let m = cells / 2;
                for (k, &wk) in weights.iter().enumerate() {
                    assert_eq!(
                        wk.to_bits(),
                        ring.weight(k.abs_diff(m)).to_bits(),
                        "{cells} {i} {k}"
                    );
                }
                assert!(ring.reach() <= m);
                let total: f32 = weights.iter().sum();
                assert!((total - 1.0).abs() < 1e-5, "weights sum to {total}");
            }
        }
    }
}
