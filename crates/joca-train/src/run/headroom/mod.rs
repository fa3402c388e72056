//! `joca headroom`: the room any exposure controller has on one design and detector
//! (docs/design.md, "Evaluation protocol"). The test's frames — the same episodes, instants and
//! noise draws as `joca run`'s test — are captured at every rung of a settings [`ladder`] (each
//! rung with its own motion blur, noise and clipping) and under closed-loop controllers (AverageAE
//! at several frame-mean targets, and a run's own trained controller), and every capture is
//! detected and scored. [`policies`] then scores the choices made in hindsight: the best constant
//! setting, the best target, either chosen per light, and the per-frame oracle over the ladder.
//!
//! Nothing here trains: the detector and controller are a run's (from its checkpoint) or a
//! weights file's on a fixed design.

mod by_loss;
mod by_map;
pub mod ladder;
mod policies;

use super::closed_loop::{Plan, TOWN_START_S, towns};
use super::context::{Context, setup};
use super::driver::{WARMUP_FRAMES, levels};
use super::evaluate::{best_design, load_run};
use super::results::summary;
use super::{RunConfig, Scenario, cpu_description, light_of};
use crate::TrainError;
use crate::control::TestController;
use joca_camera::{CameraDesign, DynamicSettings};
use joca_core::{Annotation, Detection, FrameSource, Rgb8Image, training_targets};
use joca_nn::detector::TrainFrame;
use joca_nn::formation::Scene;
use joca_nn::joint::JointModel;
use joca_record::{HEADROOM_FORMAT_VERSION, HeadroomRecord, Light, Provenance, Settings};
use ladder::LadderConfig;
use rand::Rng;
use std::path::{Path, PathBuf};

/// Where the design and detector come from.
#[derive(Debug, Clone)]
pub enum Subject {
    /// A run directory: its best design (chosen as its test chose it), its trained detector
    /// and, for a NeuralAE method, its trained controller as one more row.
    Run(PathBuf),
    /// A fixed design (`[run] design`) and the detector weights `[run] detector_weights`.
    Design(Box<RunConfig>),
}

/// What `joca headroom` measures besides the subject.
#[derive(Debug, Clone, Default)]
pub struct HeadroomOptions {
    /// The ladder and the AverageAE targets.
    pub ladder: LadderConfig,
    /// The configuration file the ladder came from, for error messages.
    pub ladder_file: String,
    /// Another scenario than the subject's.
    pub scenario: Option<Scenario>,
    /// The test family's town (0: the test town; 2 and on: fresh towns; 1 is refused).
    pub town: u64,
    /// Episodes and frames per episode instead of the configuration's test counts.
    pub episodes: Option<u64>,
    /// Scored frames per episode.
    pub frames_per_episode: Option<usize>,
    /// Another device for the detector than the configuration's.
    pub device: Option<joca_nn::device::DeviceChoice>,
    /// Another kind of tunnel light than the configuration's (its count and lamps kept).
    pub tunnels: Option<joca_sim::TunnelKind>,
}

/// One capture of a test instant under one policy, as scored.
#[derive(Debug, Clone)]
pub(crate) struct Outcome {
    pub(crate) light: Light,
    pub(crate) truth: Vec<Annotation>,
    pub(crate) ignore: Vec<Annotation>,
    pub(crate) visible_180: u32,
    pub(crate) detections: Vec<Detection>,
    pub(crate) settings: DynamicSettings,
    pub(crate) mean_dn: f64,
    /// Share of pixels with a channel at 255.
    pub(crate) clipped: f64,
    /// [`joca_metrics::frame_utility_of`] of the detections.
    pub(crate) utility: f64,
    /// The detector's task loss on the capture (the loss DF-Grad descends, on the objects the
    /// run trains on), where it was computed (the ladder's rungs).
    pub(crate) loss: Option<f64>,
    /// Its heatmap's background term (confidence where no object is), computed with it.
    pub(crate) background: Option<f64>,
    /// The task loss's slope by the light in stops through the differentiable formation, where
    /// it was asked for (`[ladder] slopes`).
    pub(crate) slope: Option<f64>,
}

/// Measures the headroom of `subject` (see the module documentation).
pub fn headroom(
    subject: &Subject,
    options: &HeadroomOptions,
) -> Result<HeadroomRecord, TrainError> {
    super::evaluate::check_town(options.town)?;
    // A reader's lock on the run directory, held only while its checkpoint is read (below): the
    // measurement writes nothing there, so several may measure one run at once.
    let (mut config, loaded, lock) = match subject {
        Subject::Run(dir) => {
            let (config, state, checkpoint, lock) = load_run(dir, true)?;
            (config, Some((dir.clone(), state, checkpoint)), Some(lock))
        }
        Subject::Design(config) => (config.as_ref().clone(), None, None),
    };
    if let Some(s) = options.scenario {
        config.scenario = s;
    }
    if let Some(n) = options.episodes {
        config.test_episodes = n;
    }
    if let Some(n) = options.frames_per_episode {
        config.test_frames_per_episode = n;
    }
    if let Some(d) = options.device {
        config.device = d;
    }
    if let Some(kind) = options.tunnels {
        config.tunnels.kind = kind;
    }
    config.validate()?;
    let (mut cx, mut model) = setup(&config, Box::new(std::io::sink()), PathBuf::from("(none)"))?;
    options.ladder.validate(cx.rigs.ranges, &options.ladder_file)?;
    if cx.scenes.recorded() {
        return Err(TrainError::Config {
            field: "run.source".into(),
            value: config.source.to_string(),
            allowed: "\"sim\": the headroom drives the simulator's test towns".into(),
        });
    }
    let (design, detector, run, trained) = match &loaded {
        Some((dir, state, checkpoint)) => {
            model.load(checkpoint)?;
            let (design, _) = best_design(&mut cx, &mut model, state)?;
            drop(lock);
            (design, "trained".to_owned(), Some(dir.display().to_string()), config.method.neural())
        }
        None => {
            let Some(weights) = config.detector_weights.clone() else {
                return Err(TrainError::Config {
                    field: "run.detector_weights".into(),
                    value: "none".into(),
                    allowed: "a weights file (the headroom of a design needs a detector)".into(),
                });
            };
            if config.design.is_none() {
                return Err(TrainError::Config {
                    field: "run.design".into(),
                    value: "none".into(),
                    allowed: "a fixed design { sensor, focal_length_mm, x_m, z_m } (or give a run \
                              directory)"
                        .into(),
                });
            }
            (config.fixed_design()?, weights.display().to_string(), None, false)
        }
    };
    cx.test.town = options.town;
    let plan = Plan::test(&config, options.town);
    let frame_interval_s = towns(&mut cx, plan)[0].frame_interval_s();
    let max_exposure_s = cx.rigs.ranges.exposure_s.max.min(frame_interval_s);
    let rungs = options.ladder.rungs(cx.rigs.ranges, max_exposure_s);
    let min_box_px = config.min_box_px as f32;
    let slopes = options.ladder.slopes;
    let ladder = ladder_outcomes(&mut cx, &model, &design, (plan, min_box_px, slopes), &rungs)?;
    let mut controllers = Vec::new();
    for target_dn in options.ladder.targets() {
        let c = TestController::Average { target_dn };
        controllers.push((c, closed_loop_outcomes(&mut cx, &mut model, &design, plan, c)?));
    }
    if trained {
        let c = TestController::Trained;
        controllers.push((c, closed_loop_outcomes(&mut cx, &mut model, &design, plan, c)?));
    }
    let policies = policies::score(&rungs, &ladder, &controllers);
    let mut record = HeadroomRecord {
        format_version: HEADROOM_FORMAT_VERSION,
        scenario: config.scenario,
        town: options.town,
        world: config.world(),
        design: summary(&design, config.hardware_search()),
        detector,
        run,
        frames: ladder.first().map_or(0, |r| r.len() as u64),
        ladder: rungs.iter().map(|&s| Settings::from(s)).collect(),
        policies,
        cpu: cpu_description(),
        device: joca_nn::device::gpu_description(model.device()),
        provenance: Provenance::of_this_build(&(config.identity(), &options.ladder)),
    };
    record.format_version = record.layout_version();
    Ok(record)
}

/// Every scored test instant captured at every rung: `[rung][frame]`, each with the detector's
/// task loss on the objects of at least `min_box_px` (the smaller ones ignored, as training
/// does), and with `slopes` its slope by the light. An instant is rendered once per distinct
/// exposure (the simulator shares its sub-frames between them); every rung draws the same noise
/// (the test's stream for that instant), so rungs differ only by their settings.
fn ladder_outcomes(
    cx: &mut Context,
    model: &JointModel,
    design: &CameraDesign,
    (plan, min_box_px, slopes): (Plan, f32, bool),
    rungs: &[DynamicSettings],
) -> Result<Vec<Vec<Outcome>>, TrainError> {
    let mut exposures: Vec<f64> = rungs.iter().map(|r| r.exposure_s).collect();
    exposures.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
    let towns = towns(cx, plan);
    // Only the view, the formation and the motion: every rung's settings are the ladder's.
    let rig = cx.rigs.rig(design, towns[0].frame_interval_s());
    let mut out = vec![Vec::new(); rungs.len()];
    for episode in 0..plan.episodes {
        let town = &towns[episode as usize % towns.len()];
        let light = light_of(Some(town.episode(episode).illumination));
        for k in WARMUP_FRAMES..WARMUP_FRAMES + plan.frames_per_episode {
            let time_s = TOWN_START_S + k as f64 * town.frame_interval_s();
            let request = rig.request(episode, time_s, exposures[0]);
            let frames = town.render_exposures(&rig.camera, &request, &exposures)?;
            let stream = cx.streams.indexed(plan.noise, episode * 10_000 + k as u64);
            // Every rung's noise field: the seed `form` draws from the instant's stream, drawn
            // once for the differentiable formation's equal frame.
            let (w, h) = (rig.camera.width_px, rig.camera.height_px);
            let normals =
                slopes.then(|| rig.formation.input_normals(w, h, stream.clone().random::<u64>()));
            for (r, rung) in rungs.iter().enumerate() {
                let i = exposures.iter().position(|e| (e - rung.exposure_s).abs() < 1e-12);
                let frame = &frames[i.unwrap_or(0)];
                let mut noise = stream.clone();
                let image = rig.formation.form(&frame.hdr, *rung, rig.pitch_um(), &mut noise);
                let (truth, ignore) = training_targets(&frame.boxes, &frame.ignore, min_box_px);
                let (detections, loss) = model.detect_with_loss(TrainFrame {
                    image: &image,
                    truth: &truth,
                    ignore: &ignore,
                });
                let mut o = outcome(light, frame, detections, *rung, &image);
                (o.loss, o.background) = (Some(loss.total), Some(loss.background));
                if let Some(normals) = &normals {
                    let scene = Scene {
                        i0: frame.hdr.data(),
                        normals,
                        width: w,
                        height: h,
                        pixel_pitch_um: rig.pitch_um(),
                        light_factor: rig.formation.light_factor(),
                        iris: None,
                    };
                    o.slope = Some(model.loss_slope(&scene, &truth, &ignore, *rung)?.1);
                }
                out[r].push(o);
            }
        }
    }
    Ok(out)
}

/// The scored test instants driven in closed loop by `controller` (the test's own loop:
/// warm-up frames first, then the scored frames).
fn closed_loop_outcomes(
    cx: &mut Context,
    model: &mut JointModel,
    design: &CameraDesign,
    plan: Plan,
    controller: TestController,
) -> Result<Vec<Outcome>, TrainError> {
    let towns = towns(cx, plan);
    let mut out = Vec::new();
    for episode in 0..plan.episodes {
        let town = &towns[episode as usize % towns.len()];
        let light = light_of(Some(town.episode(episode).illumination));
        let source: &dyn FrameSource = &**town;
        let mut driver = cx.rigs.driver(model, design, source.frame_interval_s(), controller);
        for k in 0..WARMUP_FRAMES + plan.frames_per_episode {
            let time_s = TOWN_START_S + k as f64 * source.frame_interval_s();
            let mut noise = cx.streams.indexed(plan.noise, episode * 10_000 + k as u64);
            let s = driver.step(model, source, (episode, time_s), &mut noise)?;
            if k >= WARMUP_FRAMES
                && let Some(image) = driver.last_image()
            {
                out.push(outcome(light, &s.frame, s.detections, driver.applied(), image));
            }
        }
    }
    Ok(out)
}

/// One capture scored.
fn outcome(
    light: Light,
    frame: &joca_core::Frame,
    detections: Vec<Detection>,
    settings: DynamicSettings,
    image: &Rgb8Image,
) -> Outcome {
    let utility = joca_metrics::frame_utility_of(&frame.boxes, &frame.ignore, &detections);
    let (mean_dn, clipped) = levels(image);
    Outcome {
        light,
        truth: frame.boxes.clone(),
        ignore: frame.ignore.clone(),
        visible_180: frame.visible_180,
        detections,
        settings,
        mean_dn,
        clipped,
        utility,
        loss: None,
        background: None,
        slope: None,
    }
}

/// Writes `headroom.json` and `headroom.md` into `dir` (created if needed).
pub fn write_headroom(
    dir: &Path,
    record: &HeadroomRecord,
    markdown: &str,
) -> Result<(), TrainError> {
    std::fs::create_dir_all(dir).map_err(|e| TrainError::io(dir, e))?;
    let json = serde_json::to_string_pretty(record).unwrap_or_default();
    crate::checkpoint::write_atomic(&dir.join("headroom.json"), &json)?;
    crate::checkpoint::write_atomic(&dir.join("headroom.md"), markdown)
}
