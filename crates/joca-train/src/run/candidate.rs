//! Who learns: one hardware candidate's k steps of joint training (paper Sec. 5, Fig. 2) on the
//! scenes [`super::stretches`] draws: each step sets exposure and gain (NeuralAE, or AverageAE
//! for `tacos-average`), renders the frame, runs the perturbation search where the method has
//! one, and takes the DF-Grad step (detector and NeuralAE through the differentiable
//! formation). The candidate's fitness scores its k frames together, or comes from
//! [`super::judge`] where it learned from scenes of its own.

use super::config::TrainingScenes;
use super::context::Context;
use super::judge::judge;
use super::perturbation::{self, Probe};
use super::pooled::{Capture, Window};
use super::stretches::{Scenes, Stretch, Stretches};
use crate::TrainError;
use crate::control::{Decision, controller};
use joca_camera::CameraDesign;
use joca_core::{Frame, Shot, SourceError, training_targets};
use joca_evolve::Ga;
use joca_metrics::{TaskMetrics, TaskScores};
use joca_nn::formation::Scene;
use joca_nn::joint::{DfGradWeights, JointModel, Prediction, StepReport};
use joca_record::{Event, LossRecord, Settings, StepRecord};
use rand::Rng;

/// Trains on candidate `index` (`design`) for `steps_per_candidate` steps and scores its frames.
///
/// With shared scenes the candidate learns from generation `scenes`'s ([`Stretches::draw`]):
/// every candidate of a generation drives the same towns, episodes, start times and sensor noise
/// (common random numbers), so the GA compares designs, not luck. With fresh scenes it learns
/// from scenes of its own (`index`) and is judged on the generation's ([`judge`]).
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
    let drawn = if fresh { Scenes::Own(index) } else { Scenes::Common(scenes) };
    let stretches =
        Stretches::draw(&c, &cx.streams, &mut cx.scenes, (drawn, c.steps_per_candidate));
    let rig = cx.rigs.rig(design, stretches.frame_interval_s());
    let (camera, formation, sensor) = (&rig.camera, rig.formation, rig.sensor);
    let mut control = controller(c.method.neural(), sensor, cx.rigs.ranges);
    let weights = DfGradWeights { task: c.task_weight, ga: 1.0, step: c.step_weight };
    let mut metrics = TaskMetrics::default();
    rig.start_sequence(model);
    let first = control.start();
    let mut previous_frame = None;
    // The frames a pooled search ranks with its members (none where the method searches none).
    let pooled = if c.method.perturbations() { c.perturbation_window } else { 1 };
    let mut window = Window::new(pooled);
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
        let at = stretches.at(step);
        let request = rig.request(at.stretch.episode, at.time_s, decision.applied.exposure_s);
        // 2. Perturbation mode: the same instant with perturbed settings (each with its own
        // blur), rendered with the applied frame from one grid of sub-frames, and scored.
        let members = match (predicted, c.method.perturbations()) {
            (Some(predicted), true) => perturbation::members(
                &c,
                cx.rigs.ranges,
                perturbation,
                (predicted, predicted_iris),
                &sensor,
            ),
            _ => Vec::new(),
        };
        let shots = shots(Shot { exposure_s: decision.applied.exposure_s, f_number }, &members);
        let mut frames = at.source.render_shots(camera, &request, &shots)?.into_iter();
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
            let probe = Probe {
                sensor,
                formation,
                global_step: global,
                scene_step: common,
                window: &window,
            };
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
        let light_factor = rig.formation_at(f_number)?.light_factor();
        let scene = Scene {
            i0: frame.hdr.data(),
            normals: &normals,
            width: camera.width_px,
            height: camera.height_px,
            pixel_pitch_um: rig.pitch_um(),
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
        window.push(Capture {
            truth: &frame.boxes,
            ignore: &frame.ignore,
            visible_180: frame.visible_180,
            detections: &report.detections,
        });
        if step % 5 == 0 {
            cx.journal.log(&Event::Step(record(global, &report, f_number, at.stretch)))?;
        }
        previous_frame = Some(report.frame);
        on_step(step + 1, c.steps_per_candidate);
    }
    if fresh {
        return judge(cx, model, design, scenes);
    }
    Ok(metrics.compute())
}

/// The applied frame's shot, then each perturbation member's, rendered from one grid.
fn shots(applied: Shot, members: &[perturbation::Member]) -> Vec<Shot> {
    std::iter::once(applied)
        .chain(
            members.iter().map(|m| Shot { exposure_s: m.applied.exposure_s, f_number: m.f_number }),
        )
        .collect()
}

/// What `events.jsonl` records of one DF-Grad step.
fn record(
    global: u64,
    report: &StepReport,
    f_number: Option<f64>,
    stretch: &Stretch,
) -> StepRecord {
    let l = report.loss;
    StepRecord {
        step: global,
        loss: LossRecord { total: l.total, heatmap: l.heatmap, size: l.size, offset: l.offset },
        ga_loss: report.ga_loss,
        step_loss: report.step_loss,
        task_gradient: report.task_gradient,
        settings: Settings::from(report.applied).at(f_number),
        illumination: Some(super::light_of(stretch.illumination)),
    }
}

/// Noise indices of candidates' own scenes start here, far above any generation's.
const FRESH_NOISE_OFFSET: u64 = 1 << 40;
