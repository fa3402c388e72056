//! One hardware candidate's k steps of joint training (paper Sec. 5, Fig. 2): each step sets
//! exposure and gain (NeuralAE, or AverageAE for `tacos-average`), renders the frame, runs the
//! perturbation search where the method has one, and takes the DF-Grad step (detector and
//! NeuralAE through the differentiable formation). The candidate's fitness scores its k frames
//! together.

use super::perturbation::{self, Probe};
use super::{Context, simulator};
use crate::TrainError;
use crate::control::{Decision, SensorLimits, controller};
use joca_camera::{CameraDesign, ImageFormation};
use joca_core::{FrameRequest, FrameSource};
use joca_evolve::Ga;
use joca_metrics::{TaskMetrics, TaskScores};
use joca_nn::formation::Scene;
use joca_nn::joint::{DfGradWeights, JointModel, Prediction};
use joca_record::{Event, LossRecord, StepRecord};
use joca_sim::{Illumination, train_map_seed};
use rand::Rng;

/// Trains on candidate `index` (`design`) for `steps_per_candidate` steps and scores its frames.
///
/// The scenes come from `scenes` (the generation): every candidate of a generation drives the
/// same town, episode, start time and sensor noise (common random numbers), so the GA compares
/// designs, not luck; generation g drives under `Illumination::ALL[g mod 4]`, so the generations
/// cycle through day, night, tunnel and cycle.
pub(super) fn train(
    cx: &mut Context,
    model: &mut JointModel,
    perturbation: &mut Ga,
    design: &CameraDesign,
    (index, scenes): (u64, u64),
    on_step: &mut dyn FnMut(usize, usize),
) -> Result<TaskScores, TrainError> {
    let c = cx.config.clone();
    let mut rng = cx.streams.indexed("scenes", scenes);
    let illumination = Illumination::ALL[(scenes % Illumination::ALL.len() as u64) as usize];
    let map_seed = train_map_seed(rng.random_range(0..c.train_maps));
    let episode: u64 = rng.random_range(0..1_000_000);
    let real = cx.real.clone();
    let t0: f64 = match &real {
        None => {
            let span = 59.0 - c.steps_per_candidate as f64 * 0.1;
            rng.random_range(1.0..span.max(1.5))
        }
        Some(r) => {
            // A window of k frames inside the recorded sequence (from its start if shorter).
            let room = r.train.duration_s(episode)
                - c.steps_per_candidate as f64 * r.train.frame_interval_s();
            if room > 0.0 { rng.random_range(0.0..room) } else { 0.0 }
        }
    };
    let camera = design.pinhole(c.render_scale);
    let pitch = design.sensor().pixel_pitch_um;
    let town = match &real {
        Some(_) => None,
        None => Some(simulator(&mut cx.sims, map_seed, c.max_speed_mps, Some(illumination))),
    };
    let sim: &dyn FrameSource = match (&real, &town) {
        (Some(r), _) => &r.train,
        (None, Some(town)) => &**town,
        (None, None) => unreachable!("a training town is built above when no recording is used"),
    };
    let sensor = SensorLimits::new(pitch, cx.ranges, sim.frame_interval_s());
    model.set_max_exposure(sensor.max_exposure_s);
    let mut control = controller(c.method.neural(), sensor, cx.ranges);
    let weights = DfGradWeights { task: c.task_weight, ga: 1.0 };
    let mut metrics = TaskMetrics::default();
    model.reset_sequence();
    let first = control.start();
    let mut previous_frame = None;
    for step in 0..c.steps_per_candidate {
        let global = index * c.steps_per_candidate as u64 + step as u64;
        let common = scenes * c.steps_per_candidate as u64 + step as u64;
        cx.watch.restart();
        // 1. Exposure and gain for this frame, from the previous one.
        let decision = match &previous_frame {
            Some(prev) => control.next(model, prev),
            None => Decision { applied: first, prediction: None },
        };
        let predicted = decision.prediction.as_ref().map(Prediction::settings);
        cx.watch.lap(|t| &mut t.acc_predict_ms);
        let request = FrameRequest {
            episode,
            time_s: t0 + step as f64 * sim.frame_interval_s(),
            exposure_s: decision.applied.exposure_s,
            motion_scale: c.scenario.motion_scale(),
        };
        let frame = sim.render(&camera, &request)?;
        cx.watch.lap(|t| &mut t.render_ms);
        // 2. Perturbation mode: re-render with perturbed settings (new blur), score by AP50.
        let mut ga_target = None;
        if let (Some(predicted), true) = (predicted, c.method.perturbations()) {
            let probe = Probe {
                source: sim,
                camera: &camera,
                request,
                sensor,
                global_step: global,
                scene_step: common,
            };
            let best = perturbation::search(cx, model, perturbation, &probe, predicted)?;
            if step % c.ga_every == 0 {
                ga_target = Some(best);
            }
            cx.watch.lap(|t| &mut t.perturbation_ga_ms);
        }
        // 3. Forward mode: differentiable formation, detector, DF-Grad update.
        let noise_seed: u64 = cx.streams.indexed("noise", common).random();
        let normals =
            ImageFormation::standard_normals(camera.width_px, camera.height_px, noise_seed);
        cx.watch.lap(|t| &mut t.noise_ms);
        let scene = Scene {
            i0: frame.hdr.data(),
            normals: &normals,
            width: camera.width_px,
            height: camera.height_px,
            pixel_pitch_um: pitch,
        };
        let exposure = decision.into_exposure();
        let report =
            model.step(&scene, &frame.boxes, &frame.ignore, exposure, ga_target, weights)?;
        cx.watch.restart();
        cx.watch.add_model_step(&report.timings);
        metrics.update(&frame.boxes, &frame.ignore, &report.detections, frame.visible_180);
        if step % 5 == 0 {
            let illumination = if real.is_some() { "recorded" } else { illumination.name() };
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
                exposure_ms: report.applied.exposure_s * 1e3,
                gain_db: report.applied.gain_db,
                illumination: illumination.to_owned(),
            }))?;
        }
        previous_frame = Some(report.frame);
        on_step(step + 1, c.steps_per_candidate);
    }
    Ok(metrics.compute())
}
