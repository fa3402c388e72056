//! The training frames of pre-training: random camera designs in blocks, each design's lanes
//! driving their own episodes of the training towns, exposed by AverageAE, rendered, formed and
//! annotated batch by batch. Nothing here depends on the detector, which is what lets
//! [`super::config::ExperimentalConfig::pipeline`] make frames while the detector trains.

use super::PretrainConfig;
use super::spread::spread;
use crate::TrainError;
use joca_camera::{
    AverageAe, Calibration, CameraDesign, Capture, DetectorInput, DynamicSettings, GenomeCodec,
    ImageFormation,
};
use joca_core::{
    Annotation, FrameRequest, FrameSource, PinholeCamera, Rgb8Image, SeedStreams, training_targets,
};
use joca_nn::detector::TrainFrame;
use joca_sim::{SimConfig, Simulator, train_map_seed};
use rand::Rng;
use rayon::prelude::*;
use std::collections::HashMap;

/// A formed training frame with its ground truth (the HDR render is not kept).
#[derive(Debug)]
pub(super) struct Shot {
    image: Rgb8Image,
    truth: Vec<Annotation>,
    ignore: Vec<Annotation>,
}

impl Shot {
    pub(super) fn train_frame(&self) -> TrainFrame<'_> {
        TrainFrame { image: &self.image, truth: &self.truth, ignore: &self.ignore }
    }

    /// How many extra times the frame is trained on, given the `repeats` of each class: the
    /// largest over the classes of its annotated objects (0 without any).
    pub(super) fn repeats(&self, per_class: &[u32; 3]) -> u32 {
        self.truth.iter().map(|a| per_class[a.class.index()]).max().unwrap_or(0)
    }
}

/// The frames of one design waiting to be trained on again (`repeats`): each is due in as
/// many of the design's next batches as it has repeats.
#[derive(Debug)]
pub(super) struct Repeats<T> {
    queue: Vec<(T, u32)>,
}

impl<T> Default for Repeats<T> {
    fn default() -> Self {
        Self { queue: Vec::new() }
    }
}

impl<T> Repeats<T> {
    /// The frames to add to the design's current batch, oldest first.
    pub(super) fn due(&self) -> impl Iterator<Item = &T> {
        self.queue.iter().map(|(item, _)| item)
    }

    /// After a batch: each due frame has one repeat less, and `fresh` frames (with their
    /// repeats, 0 for none) join the queue.
    pub(super) fn advance(&mut self, fresh: impl IntoIterator<Item = (T, u32)>) {
        self.queue.iter_mut().for_each(|(_, left)| *left -= 1);
        self.queue.retain(|(_, left)| *left > 0);
        self.queue.extend(fresh.into_iter().filter(|(_, n)| *n > 0));
    }
}

/// A run of consecutive steps over `designs` camera designs, `frames_per_design` frames each,
/// ending with a checkpoint. Within a block the designs' batches are interleaved (design 0's
/// batch 0, design 1's batch 0, …, design 0's batch 1, …): with small batches, 45 frames of one
/// camera in a row pull the detector towards that camera and scene, and the next design pulls
/// it away again. A design's batch holds one frame of each of its `batch` lanes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Block {
    pub(super) first_design: usize,
    pub(super) designs: usize,
    pub(super) first_step: usize,
    pub(super) end_step: usize,
}

impl Block {
    /// The block that `step` falls in. The last block may be cut short by `steps`; it then
    /// interleaves only as many designs as its steps need.
    pub(super) fn containing(config: &PretrainConfig, step: usize) -> Self {
        let per_block = config.checkpoint_every_designs * config.data.frames_per_design;
        let b = step / per_block;
        let first_step = b * per_block;
        let end_step = (first_step + per_block).min(config.steps);
        Self {
            first_design: b * config.checkpoint_every_designs,
            designs: (end_step - first_step).div_ceil(config.data.frames_per_design),
            first_step,
            end_step,
        }
    }
}

/// The fresh frames of one batch: one from each lane of a design.
pub(super) struct Batch {
    /// Frames trained before this batch.
    pub(super) step: usize,
    /// The design's index within its block.
    pub(super) design: usize,
    pub(super) shots: Vec<Shot>,
    /// Where the first lane's frame comes from, for the log.
    pub(super) about: BatchAbout,
    /// Seconds spent making the frames.
    pub(super) seconds: f64,
}

/// A batch's design and episode, as logged.
#[derive(Debug, Clone, Copy)]
pub(super) struct BatchAbout {
    pub(super) index: usize,
    pub(super) design: CameraDesign,
    pub(super) map_seed: u64,
    pub(super) episode: u64,
    /// The frames' width and height, pixels.
    pub(super) frame_px: [usize; 2],
}

/// Makes the training frames batch by batch, in step order: a block's lanes are rebuilt from
/// the seed when the block starts, and each lane's next frame is exposed by AverageAE's
/// settings from its previous frame. Nothing here depends on the detector.
pub(super) struct FrameStream<'w> {
    world: &'w World<'w>,
    codec: &'w GenomeCodec,
    block: Option<Block>,
    runs: Vec<DesignRun>,
    sims: HashMap<u64, Simulator>,
}

impl<'w> FrameStream<'w> {
    pub(super) fn new(world: &'w World<'w>, codec: &'w GenomeCodec) -> Self {
        Self { world, codec, block: None, runs: Vec::new(), sims: HashMap::new() }
    }

    /// The batch that starts after `step` frames (the batches must be asked for in order).
    pub(super) fn make(&mut self, step: usize) -> Result<Batch, TrainError> {
        let clock = std::time::Instant::now();
        let (world, config) = (self.world, self.world.config);
        let b = config.batch;
        let block = Block::containing(config, step);
        if self.block != Some(block) {
            self.runs = (block.first_design..block.first_design + block.designs)
                .flat_map(|d| (0..b).map(move |lane| (d, lane)))
                .map(|(d, lane)| DesignRun::new(d, lane, self.codec, world))
                .collect::<Result<Vec<_>, TrainError>>()?;
            self.block = Some(block);
        }
        let tick = (step - block.first_step) / b;
        let (d, j) = (tick % block.designs, tick / block.designs);
        let lanes = &mut self.runs[d * b..(d + 1) * b];
        for run in lanes.iter_mut() {
            if j % config.data.frames_per_episode == 0 {
                run.start_episode(j / config.data.frames_per_episode, world, &mut self.sims)?;
            }
            run.simulator(world, &mut self.sims); // builds the lane's town if it is new
        }
        // The lanes' frames render side by side, each with AverageAE's settings for its next
        // frame: a small frame with few sub-frames keeps one core busy at most. Each lane's
        // noise stream is its own, so the frames are the same in any order.
        let sims = &self.sims;
        let made = lanes
            .par_iter()
            .enumerate()
            .map(|(lane, run)| {
                let sim = &sims[&run.map_seed];
                let request = FrameRequest {
                    episode: run.episode,
                    time_s: run.t0
                        + (j % config.data.frames_per_episode) as f64 * sim.frame_interval_s(),
                    exposure_s: run.settings.exposure_s,
                    motion_scale: 1.0,
                };
                let mut noise = world.streams.indexed("pretrain-noise", (step + lane) as u64);
                let settings = spread(run.settings, config.data.exposure_spread, &mut noise);
                let request = FrameRequest { exposure_s: settings.exposure_s, ..request };
                let Capture { frame, image } = run.formation.capture(
                    sim,
                    &run.camera,
                    &request,
                    settings,
                    run.pitch_um,
                    &mut noise,
                )?;
                let next = world.ae.step(settings, &image);
                let (truth, ignore) = training_targets(
                    &frame.boxes,
                    &frame.ignore,
                    world.config.experimental.min_box_px as f32,
                );
                Ok((Shot { image, truth, ignore }, next))
            })
            .collect::<Result<Vec<_>, TrainError>>()?;
        let (shots, next): (Vec<Shot>, Vec<DynamicSettings>) = made.into_iter().unzip();
        for (run, settings) in lanes.iter_mut().zip(next) {
            run.settings = settings;
        }
        let run = &lanes[0];
        let about = BatchAbout {
            index: run.index,
            design: run.design,
            map_seed: run.map_seed,
            episode: run.episode,
            frame_px: [shots[0].image.width(), shots[0].image.height()],
        };
        Ok(Batch { step, design: d, shots, about, seconds: clock.elapsed().as_secs_f64() })
    }
}

/// Batches the frame thread may be ahead of the trainer with [`ExperimentalConfig::pipeline`]: a
/// night frame with a long exposure takes several times a day frame to render, and a buffer
/// evens that out instead of stalling the trainer.
pub(super) const FRAMES_AHEAD: usize = 16;

/// The threads that make frames with [`ExperimentalConfig::pipeline`].
pub(super) fn frame_pool(config: &PretrainConfig) -> Result<rayon::ThreadPool, TrainError> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(config.threads / 2)
        .build()
        .map_err(|e| TrainError::Thread { what: "frame thread pool".into(), reason: e.to_string() })
}

/// What every design's frames are made with.
pub(super) struct World<'a> {
    pub(super) config: &'a PretrainConfig,
    pub(super) streams: &'a SeedStreams,
    pub(super) formation: ImageFormation,
    pub(super) ae: AverageAe,
    pub(super) sim_config: SimConfig,
}

/// The design's episode number of lane `lane`'s episode `e`: lanes own consecutive ranges, so
/// no two frames of a batch come from one episode.
fn design_episode(lane: usize, episodes_per_lane: usize, e: usize) -> u64 {
    (lane * episodes_per_lane + e) as u64
}

/// AverageAE iterations on an episode's first view before its first training frame.
const AE_SETTLE_ITERATIONS: usize = 8;

/// One random camera design and the episode one of its lanes is currently driving.
struct DesignRun {
    index: usize,
    /// Lane of the design's frames (0 with batch size 1).
    lane: usize,
    /// Episodes per lane: lane `l`'s episode `e` is the design's episode
    /// `l · episodes_per_lane + e`.
    episodes_per_lane: usize,
    design: CameraDesign,
    camera: PinholeCamera,
    /// The run's formation on the design's native grid.
    formation: ImageFormation,
    pitch_um: f64,
    settings: DynamicSettings,
    map_seed: u64,
    episode: u64,
    t0: f64,
}

impl DesignRun {
    /// Lane `lane` of design number `index`, drawn uniformly from the synthetic design space.
    fn new(
        index: usize,
        lane: usize,
        codec: &GenomeCodec,
        world: &World<'_>,
    ) -> Result<Self, TrainError> {
        let mut rng = world.streams.indexed("pretrain-design", index as u64);
        let genes: Vec<f64> =
            codec.genes().iter().map(|g| rng.random_range(g.bounds.min..=g.bounds.max)).collect();
        let design = codec.decode(&genes)?;
        let config = world.config;
        let lane_frames = config.data.frames_per_design / config.batch;
        Ok(Self {
            index,
            lane,
            episodes_per_lane: lane_frames.div_ceil(config.data.frames_per_episode),
            camera: design.pinhole(&world.config.input),
            formation: world.formation.for_sensor(design.sensor()),
            pitch_um: design.sensor().pixel_pitch_um,
            design,
            settings: default_settings(),
            map_seed: 0,
            episode: 0,
            t0: 0.0,
        })
    }

    fn simulator<'s>(
        &self,
        world: &World<'_>,
        sims: &'s mut HashMap<u64, Simulator>,
    ) -> &'s Simulator {
        let map_seed = self.map_seed;
        sims.entry(map_seed)
            .or_insert_with(|| Simulator::new(SimConfig { map_seed, ..world.sim_config }))
    }

    /// Starts the lane's episode number `e`: a random training town, drive and start time,
    /// and AverageAE settled on a quarter-resolution view of the first frame (iterated on that
    /// one view, as a camera that had been driving there already would have converged), so that
    /// no training frame is one of the badly exposed frames of an AE start-up.
    fn start_episode(
        &mut self,
        e: usize,
        world: &World<'_>,
        sims: &mut HashMap<u64, Simulator>,
    ) -> Result<(), TrainError> {
        let id = (self.index as u64) << 16 | design_episode(self.lane, self.episodes_per_lane, e);
        let mut rng = world.streams.indexed("pretrain-episode", id);
        let config = world.config;
        self.map_seed = train_map_seed(rng.random_range(0..config.data.train_maps));
        self.episode = rng.random_range(0..1_000_000);
        let sim_config = &world.sim_config;
        let span = config.data.frames_per_episode as f64 * sim_config.frame_interval_s;
        self.t0 = rng.random_range(1.0..(sim_config.episode_s - 1.0 - span).max(1.0 + 1e-9));
        let quarter = DetectorInput {
            short_px: (config.input.short_px / 4).max(1),
            long_max_px: (config.input.long_max_px / 4).max(1),
            ..config.input
        };
        let probe = self.design.pinhole(&quarter);
        let request = FrameRequest {
            episode: self.episode,
            time_s: self.t0,
            exposure_s: default_settings().exposure_s,
            motion_scale: 1.0,
        };
        let view = self.simulator(world, sims).render(&probe, &request)?;
        let mut noise = world.streams.indexed("pretrain-probe", id);
        let mut settings = default_settings();
        for _ in 0..AE_SETTLE_ITERATIONS {
            let image = world.formation.form(&view.hdr, settings, self.pitch_um, &mut noise);
            settings = world.ae.step(settings, &image);
        }
        self.settings = settings;
        Ok(())
    }
}

fn default_settings() -> DynamicSettings {
    DynamicSettings::new(Calibration::DEFAULT.exposure_s, Calibration::DEFAULT.gain_db)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_is_repeated_in_exactly_as_many_later_batches_as_asked() {
        let mut r = Repeats::default();
        let mut batches = Vec::new();
        // Batch 0 brings frames a (2 repeats), b (none), c (1); batch 1 brings d (3).
        let fresh: [&[(char, u32)]; 5] =
            [&[('a', 2), ('b', 0), ('c', 1)], &[('d', 3)], &[], &[], &[]];
        for frames in fresh {
            batches.push(r.due().copied().collect::<String>());
            r.advance(frames.iter().copied());
        }
        assert_eq!(batches, ["", "ac", "ad", "d", "d"]);
        assert_eq!(r.due().count(), 0);
    }

    #[test]
    fn the_frames_of_a_design_come_from_distinct_episodes_per_lane() {
        // 45 frames in batches of 5: 5 lanes of 9 frames, episodes of 5 frames → 2 per lane.
        let (fpd, fpe, batch): (usize, usize, usize) = (45, 5, 5);
        let per_lane = (fpd / batch).div_ceil(fpe);
        assert_eq!(per_lane, 2);
        let mut seen = std::collections::BTreeMap::new();
        for lane in 0..batch {
            for j in 0..fpd / batch {
                let e = design_episode(lane, per_lane, j / fpe);
                seen.entry(e).or_insert_with(Vec::new).push((lane, j % fpe));
            }
        }
        // Every episode belongs to one lane, and each (episode, frame) pair occurs once.
        for frames in seen.values() {
            assert!(frames.iter().all(|(l, _)| *l == frames[0].0));
            let mut k: Vec<usize> = frames.iter().map(|(_, f)| *f).collect();
            k.dedup();
            assert_eq!(k.len(), frames.len());
        }
        assert_eq!(seen.len(), 10);
        // Batch size 1: the design's episodes are numbered as they always were.
        assert_eq!(design_episode(0, 9, 4), 4);
    }
}
