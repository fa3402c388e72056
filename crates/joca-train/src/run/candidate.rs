//! One hardware candidate's k steps of joint training (paper Sec. 5, Fig. 2): each step sets
//! exposure and gain (NeuralAE, or AverageAE for `tacos-average`), renders the frame, runs the
//! perturbation search where the method has one, and takes the DF-Grad step (detector and
//! NeuralAE through the differentiable formation). The candidate's fitness scores its k frames
//! together.

use super::RunConfig;
use super::config::TrainingScenes;
use super::driver::Driver;
use super::perturbation::{self, Probe};
use super::{Context, RealSources};
use crate::TrainError;
use crate::control::{Decision, SensorLimits, controller};
use joca_camera::{ApertureControl, CameraDesign, Iris};
use joca_core::optics::CALIBRATION_F_NUMBER;
use joca_core::{Frame, FrameRequest, FrameSource, Shot, SourceError, training_targets};
use joca_evolve::Ga;
use joca_metrics::{TaskMetrics, TaskScores};
use joca_nn::formation::Scene;
use joca_nn::joint::{DfGradWeights, JointModel, Prediction};
use joca_record::{Event, LossRecord, Settings, StepRecord};
use joca_sim::{Illumination, Simulator, train_map_seed};
use rand::Rng;
use std::sync::Arc;

/// Which scenes a stretch list is drawn for.
#[derive(Debug, Clone, Copy)]
enum Scenes {
    /// Generation g's, shared by its candidates.
    Common(u64),
    /// One candidate's own (its global index), no other candidate's.
    Own(u64),
}

/// A stretch of a candidate's frames driven in one scene.
struct Stretch {
    /// The training town (`None`: the recording).
    town: Option<Arc<Simulator>>,
    /// Its light (`None` for a recording).
    illumination: Option<Illumination>,
    episode: u64,
    /// Time of the stretch's first frame, seconds.
    t0: f64,
    /// The candidate's step at which the stretch begins.
    first_step: usize,
}

/// The scenes of generation `scenes`, the same for every candidate of it (common random numbers).
/// In the simulator the k steps are split into four stretches, one per illumination (day, night,
/// tunnel, cycle, starting at `ALL[g mod 4]`), each in its own training town, episode and start
/// time. The controller carries its settings from one stretch into the next, as through a
/// tunnel portal, so it meets 100–1000× changes of light within every candidate, and every
/// candidate's fitness covers all four lights. A recording is one stretch.
fn stretches(cx: &mut Context, scenes: Scenes) -> Vec<Stretch> {
    let c = cx.config.clone();
    let (stream, scenes) = match scenes {
        Scenes::Common(g) => ("scenes", g),
        Scenes::Own(candidate) => ("candidate-scenes", candidate),
    };
    let mut rng = cx.streams.indexed(stream, scenes);
    let k = c.steps_per_candidate;
    if let Some(r) = cx.scenes.real.clone() {
        let episode: u64 = rng.random_range(0..1_000_000);
        // A window of k frames inside the recorded sequence (from its start if shorter).
        let room = r.train.duration_s(episode) - k as f64 * r.train.frame_interval_s();
        let t0 = if room > 0.0 { rng.random_range(0.0..room) } else { 0.0 };
        return vec![Stretch { town: None, illumination: None, episode, t0, first_step: 0 }];
    }
    let n = Illumination::ALL.len().min(k);
    (0..n)
        .map(|s| {
            let illumination = Illumination::ALL[(scenes as usize + s) % Illumination::ALL.len()];
            let map_seed = train_map_seed(rng.random_range(0..c.train_maps));
            let episode: u64 = rng.random_range(0..1_000_000);
            let (first_step, last) = (s * k / n, (s + 1) * k / n);
            let town = cx.scenes.town(map_seed, Some(illumination));
            // From 1 s into the episode, with room for the stretch's frames before its end.
            let sim = town.config();
            let span = sim.episode_s - 1.0 - (last - first_step) as f64 * town.frame_interval_s();
            let t0 = rng.random_range(1.0..span.max(1.5));
            Stretch { town: Some(town), illumination: Some(illumination), episode, t0, first_step }
        })
        .collect()
}

/// The iris NeuralAE moves for `design` where the run sets the aperture frame by frame: from
/// the design's f-number (the lens wide open) to the calibration's f/16.
pub(super) fn iris(config: &RunConfig, design: &CameraDesign) -> Option<Iris> {
    (config.aperture == ApertureControl::Dynamic)
        .then(|| Iris::new(design.f_number, CALIBRATION_F_NUMBER))
}

/// Where a stretch's frames come from.
fn source<'a>(real: &'a Option<Arc<RealSources>>, s: &'a Stretch) -> &'a dyn FrameSource {
    match (real, &s.town) {
        (Some(r), _) => &r.train,
        (None, Some(town)) => &**town,
        (None, None) => unreachable!("every simulator stretch has its town"),
    }
}

/// Trains on candidate `index` (`design`) for `steps_per_candidate` steps and scores its frames.
///
/// The scenes come from `scenes` (the generation, see [`stretches`]): every candidate of a
/// generation drives the same towns, episodes, start times and sensor noise (common random
/// numbers), so the GA compares designs, not luck.
pub(super) fn train(
    cx: &mut Context,
    model: &mut JointModel,
    perturbation: &mut Ga,
    design: &CameraDesign,
    (index, scenes): (u64, u64),
    on_step: &mut dyn FnMut(usize, usize),
) -> Result<TaskScores, TrainError> {
    let c = cx.config.clone();
    let fresh = c.training_scenes == TrainingScenes::Fresh;
    let stretches = stretches(cx, if fresh { Scenes::Own(index) } else { Scenes::Common(scenes) });
    let real = cx.scenes.real.clone();
    let camera = design.view(&c.input, c.lens);
    let formation = cx.formation.for_design(design);
    // Eq. 4 compensates the pixel area; the aperture's light is the formation's (so the
    // controller's whole range stays the camera's at every f-number).
    let pitch = design.sensor().pixel_pitch_um;
    let sim = source(&real, &stretches[0]);
    let sensor =
        SensorLimits::new(pitch, cx.ranges, sim.frame_interval_s()).with_iris(iris(&c, design));
    model.set_max_exposure(sensor.max_exposure_s);
    let mut control = controller(c.method.neural(), sensor, cx.ranges);
    let weights = DfGradWeights { task: c.task_weight, ga: 1.0, step: c.step_weight };
    let mut metrics = TaskMetrics::default();
    model.reset_sequence();
    let first = control.start();
    let mut previous_frame = None;
    for step in 0..c.steps_per_candidate {
        let global = index * c.steps_per_candidate as u64 + step as u64;
        // The noise of the frame: the scene's (shared by the generation's candidates, or this
        // candidate's own, in a range no generation index reaches).
        let common = if fresh {
            FRESH_NOISE_OFFSET + global
        } else {
            scenes * c.steps_per_candidate as u64 + step as u64
        };
        cx.journal.watch.restart();
        // 1. Exposure and gain for this frame, from the previous one.
        let decision = match &previous_frame {
            Some(prev) => control.next(model, prev),
            None => Decision { applied: first, prediction: None },
        };
        let predicted = decision.prediction.as_ref().map(Prediction::settings);
        let predicted_iris = decision.prediction.as_ref().and_then(Prediction::iris);
        // The frame's f-number where NeuralAE sets the iris (`None`: the design's).
        let f_number = control.f_number();
        cx.journal.watch.lap(|t| &mut t.acc_predict_ms);
        let stretch =
            stretches.iter().rev().find(|s| s.first_step <= step).unwrap_or(&stretches[0]);
        let sim = source(&real, stretch);
        let request = FrameRequest {
            episode: stretch.episode,
            time_s: stretch.t0 + (step - stretch.first_step) as f64 * sim.frame_interval_s(),
            exposure_s: decision.applied.exposure_s,
            motion_scale: c.scenario.motion_scale(),
        };
        // 2. Perturbation mode: the same instant with perturbed settings (each with its own
        // blur), rendered with the applied frame from one grid of sub-frames, and scored.
        let members = match (predicted, c.method.perturbations()) {
            (Some(predicted), true) => {
                perturbation::members(cx, perturbation, predicted, predicted_iris, &sensor)
            }
            _ => Vec::new(),
        };
        let shots: Vec<Shot> =
            std::iter::once(Shot { exposure_s: decision.applied.exposure_s, f_number })
                .chain(
                    members
                        .iter()
                        .map(|m| Shot { exposure_s: m.applied.exposure_s, f_number: m.f_number }),
                )
                .collect();
        let mut frames = sim.render_shots(&camera, &request, &shots)?.into_iter();
        let frame = frames.next().ok_or_else(|| SourceError::OutOfRange {
            reason: "the frame source returned no frame".into(),
        })?;
        let perturbed: Vec<Frame> = frames.collect();
        cx.journal.watch.lap(|t| &mut t.render_ms);
        cx.journal
            .watch
            .count_subframes(perturbed.iter().map(|f| f.subframes).fold(frame.subframes, u32::max));
        let mut ga_target = None;
        if !members.is_empty() {
            let probe = Probe { sensor, formation, global_step: global, scene_step: common };
            let best = perturbation::search(cx, model, perturbation, &probe, &members, &perturbed)?;
            if step % c.ga_every == 0 {
                ga_target = best;
            }
            cx.journal.watch.lap(|t| &mut t.perturbation_ga_ms);
        }
        // 3. Forward mode: differentiable formation, detector, DF-Grad update.
        let noise_seed: u64 = cx.streams.indexed("noise", common).random();
        let normals = formation.input_normals(camera.width_px, camera.height_px, noise_seed);
        cx.journal.watch.lap(|t| &mut t.noise_ms);
        let light_factor = match f_number {
            Some(n) => formation.with_f_number(n)?.light_factor(),
            None => formation.light_factor(),
        };
        let scene = Scene {
            i0: frame.hdr.data(),
            normals: &normals,
            width: camera.width_px,
            height: camera.height_px,
            pixel_pitch_um: pitch,
            light_factor,
            iris: sensor.iris,
        };
        let exposure = decision.into_exposure();
        // The detector learns objects of at least `min_box_px`; the fitness counts every
        // reference object.
        let (targets, ignore) = training_targets(&frame.boxes, &frame.ignore, c.min_box_px as f32);
        let report = model.step(&scene, &targets, &ignore, exposure, ga_target, weights)?;
        cx.journal.watch.restart();
        cx.journal.watch.add_model_step(&report.timings);
        metrics.update(&frame.boxes, &frame.ignore, &report.detections, frame.visible_180);
        if step % 5 == 0 {
            let l = report.loss;
            cx.log(&Event::Step(StepRecord {
                step: global,
                loss: LossRecord {
                    total: l.total,
                    heatmap: l.heatmap,
                    size: l.size,
                    offset: l.offset,
                },
                ga_loss: report.ga_loss,
                step_loss: report.step_loss,
                task_gradient: report.task_gradient,
                settings: Settings::from(report.applied).at(f_number),
                illumination: Some(super::light_of(stretch.illumination)),
            }))?;
        }
        previous_frame = Some(report.frame);
        on_step(step + 1, c.steps_per_candidate);
    }
    if fresh {
        return judge(cx, model, design, scenes);
    }
    Ok(metrics.compute())
}

/// Noise indices of candidates' own scenes start here, far above any generation's.
const FRESH_NOISE_OFFSET: u64 = 1 << 40;

/// The candidate's fitness with `training_scenes = "fresh"`: the generation's common scenes
/// (the stretches and noise every candidate of it is judged on) driven in closed loop by the
/// controller and detector as they are after its training, without any update.
fn judge(
    cx: &mut Context,
    model: &mut JointModel,
    design: &CameraDesign,
    scenes: u64,
) -> Result<TaskScores, TrainError> {
    let c = cx.config.clone();
    let stretches = stretches(cx, Scenes::Common(scenes));
    let real = cx.scenes.real.clone();
    let camera = design.view(&c.input, c.lens);
    let dt = source(&real, &stretches[0]).frame_interval_s();
    // The controller carries its settings across stretches, as in training.
    let mut driver = Driver::new(cx, model, design, dt);
    let mut metrics = TaskMetrics::default();
    for step in 0..c.steps_per_candidate {
        let stretch =
            stretches.iter().rev().find(|s| s.first_step <= step).unwrap_or(&stretches[0]);
        let sim = source(&real, stretch);
        let time_s = stretch.t0 + (step - stretch.first_step) as f64 * sim.frame_interval_s();
        let mut noise =
            cx.streams.indexed("judge-noise", scenes * c.steps_per_candidate as u64 + step as u64);
        let s = driver.step(cx, model, sim, &camera, stretch.episode, time_s, &mut noise)?;
        metrics.update(&s.frame.boxes, &s.frame.ignore, &s.detections, s.frame.visible_180);
    }
    Ok(metrics.compute())
}
