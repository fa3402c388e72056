//! Who judges a candidate when it learned from scenes of its own (`training_scenes = "fresh"`):
//! the generation's common scenes (`judge_frames` of them), driven in closed loop by the
//! controller and detector as they are after its training, without any update, so every
//! candidate of a generation is scored on the same stretches and noise.

use super::context::Context;
use super::stretches::{Scenes, Stretches};
use crate::TrainError;
use joca_camera::CameraDesign;
use joca_metrics::{TaskMetrics, TaskScores};
use joca_nn::joint::JointModel;

/// The fitness of `design` on generation `scenes`'s common scenes.
pub(super) fn judge(
    cx: &mut Context,
    model: &mut JointModel,
    design: &CameraDesign,
    scenes: u64,
) -> Result<TaskScores, TrainError> {
    let c = cx.config.clone();
    let frames = c.judge_frames();
    let drawn = (Scenes::Common(scenes), frames);
    let stretches = Stretches::draw(&c, &cx.streams, &mut cx.scenes, drawn);
    // The controller carries its settings across stretches, as in training.
    let mut driver =
        cx.rigs.driver(model, design, stretches.frame_interval_s(), cx.test.controller);
    let mut metrics = TaskMetrics::default();
    for step in 0..frames {
        let at = stretches.at(step);
        let mut noise = cx.streams.indexed("judge-noise", scenes * frames as u64 + step as u64);
        let s = driver.step(model, at.source, (at.stretch.episode, at.time_s), &mut noise)?;
        metrics.update(&s.frame.boxes, &s.frame.ignore, &s.detections, s.frame.visible_180);
    }
    Ok(metrics.compute())
}
