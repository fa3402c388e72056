//! Which scenes a candidate plays: its k steps split into stretches, each a town, light,
//! episode and start time (or a window of the recording), drawn for a generation's candidates
//! together (common random numbers) or for one candidate alone (`training_scenes = "fresh"`).

use super::RunConfig;
use super::scenes::{RealSources, SceneSource};
use joca_core::{FrameSource, SeedStreams};
use joca_sim::{Illumination, Simulator, train_map_seed};
use rand::Rng;
use std::sync::Arc;

/// Which scenes a stretch list is drawn for.
#[derive(Debug, Clone, Copy)]
pub(super) enum Scenes {
    /// Generation g's, shared by its candidates.
    Common(u64),
    /// One candidate's own (its global index), no other candidate's.
    Own(u64),
}

/// A stretch of a candidate's frames driven in one scene.
pub(super) struct Stretch {
    /// The training town (`None`: the recording).
    town: Option<Arc<Simulator>>,
    /// Its light (`None` for a recording).
    pub(super) illumination: Option<Illumination>,
    pub(super) episode: u64,
    /// Time of the stretch's first frame, seconds.
    t0: f64,
    /// The candidate's step at which the stretch begins.
    first_step: usize,
}

/// A candidate's stretches, in step order, and where their frames come from.
pub(super) struct Stretches {
    list: Vec<Stretch>,
    real: Option<Arc<RealSources>>,
}

/// Where and when one step of a candidate plays.
pub(super) struct Moment<'a> {
    /// Its stretch.
    pub(super) stretch: &'a Stretch,
    /// The frames' source.
    pub(super) source: &'a dyn FrameSource,
    /// The frame's time in its episode, seconds.
    pub(super) time_s: f64,
}

impl Stretches {
    /// The stretches of `scenes`, `k` frames. In the simulator the k frames are split into four
    /// stretches, one per illumination (day, night, tunnel, cycle, starting at `ALL[i mod 4]`
    /// for scene index i), each in its own training town, episode and start time. The
    /// controller carries its settings from one stretch into the next, as through a tunnel
    /// portal, so it meets 100–1000× changes of light within every candidate, and every
    /// candidate's fitness covers all four lights. A recording is one stretch.
    pub(super) fn draw(
        config: &RunConfig,
        streams: &SeedStreams,
        towns: &mut SceneSource,
        (scenes, k): (Scenes, usize),
    ) -> Self {
        let (stream, index) = match scenes {
            Scenes::Common(g) => ("scenes", g),
            Scenes::Own(candidate) => ("candidate-scenes", candidate),
        };
        let mut rng = streams.indexed(stream, index);
        let real = towns.real.clone();
        if let Some(r) = &real {
            let episode: u64 = rng.random_range(0..1_000_000);
            // A window of k frames inside the recorded sequence (from its start if shorter).
            let room = r.train.duration_s(episode) - k as f64 * r.train.frame_interval_s();
            let t0 = if room > 0.0 { rng.random_range(0.0..room) } else { 0.0 };
            let list = vec![Stretch { town: None, illumination: None, episode, t0, first_step: 0 }];
            return Self { list, real };
        }
        let n = Illumination::ALL.len().min(k);
        let list = (0..n)
            .map(|s| {
                let illumination =
                    Illumination::ALL[(index as usize + s) % Illumination::ALL.len()];
                let map_seed = train_map_seed(rng.random_range(0..config.train_maps));
                let episode: u64 = rng.random_range(0..1_000_000);
                let (first_step, last) = (s * k / n, (s + 1) * k / n);
                let town = towns.town(map_seed, Some(illumination));
                // From 1 s into the episode, with room for the stretch's frames before its end.
                let span = town.config().episode_s
                    - 1.0
                    - (last - first_step) as f64 * town.frame_interval_s();
                let t0 = rng.random_range(1.0..span.max(1.5));
                let illumination = Some(illumination);
                Stretch { town: Some(town), illumination, episode, t0, first_step }
            })
            .collect();
        Self { list, real }
    }

    /// The frames' source of `stretch`.
    fn source<'a>(&'a self, stretch: &'a Stretch) -> &'a dyn FrameSource {
        match (&self.real, &stretch.town) {
            (Some(r), _) => &r.train,
            (None, Some(town)) => &**town,
            (None, None) => unreachable!("every simulator stretch has its town"),
        }
    }

    /// The interval between frames (every stretch's source has the same).
    pub(super) fn frame_interval_s(&self) -> f64 {
        self.source(&self.list[0]).frame_interval_s()
    }

    /// Where and when step `step` of the candidate plays.
    pub(super) fn at(&self, step: usize) -> Moment<'_> {
        let stretch =
            self.list.iter().rev().find(|s| s.first_step <= step).unwrap_or(&self.list[0]);
        let source = self.source(stretch);
        let time_s = stretch.t0 + (step - stretch.first_step) as f64 * source.frame_interval_s();
        Moment { stretch, source, time_s }
    }
}
