//! DF-Grad's perturbation mode (paper Sec. 5): each member `(p_e, p_g)` of a small GA offsets
//! NeuralAE's prediction by a fraction of each range; the frame is rendered again with the
//! perturbed exposure (so with its own motion blur, which no gradient can see), formed, detected
//! and scored by AP50. The best member's settings become the target of the GA loss l_GA.

use super::config::{PerturbationMutation, TieBreak};
use super::{Context, Method, RunConfig, ga_err};
use crate::TrainError;
use crate::control::{SensorLimits, for_sensor};
use joca_camera::DynamicSettings;
use joca_core::{FrameRequest, FrameSource, PinholeCamera, SeedStreams};
use joca_evolve::{Ga, GaConfig};
use joca_metrics::TaskMetrics;
use joca_nn::joint::JointModel;

/// The perturbations of the `fixed-perturbation` ablation: ±2.5 % of each range, four signs.
const FIXED: [[f64; 2]; 4] = [[0.025, 0.025], [0.025, -0.025], [-0.025, 0.025], [-0.025, -0.025]];

/// Weight of the clipping tie-break in a member's fitness: below any AP50 difference a frame can
/// make (one object of a frame with hundreds of reference objects moves AP50 by more).
const TIE_BREAK_WEIGHT: f64 = 1e-3;

/// Share of 8-bit values at 0 or 255.
pub(super) fn clipped_share(data: &[u8]) -> f64 {
    if data.is_empty() {
        return 0.0;
    }
    data.iter().filter(|&&v| v == 0 || v == 255).count() as f64 / data.len() as f64
}

/// The perturbation GA of DF-Grad: `(p_e, p_g)` in normalised units within ±5 % of each range,
/// mutation ×U(0.9, 1.1) and, unless the paper's operator is chosen, a normal shift of 10 % of
/// the range.
pub(super) fn ga(config: &RunConfig, streams: &SeedStreams) -> Result<Ga, TrainError> {
    let shift = match config.perturbation_mutation {
        PerturbationMutation::Paper => 0.0,
        PerturbationMutation::Additive => 0.1,
    };
    let ga_config =
        GaConfig::new(config.perturbation_population, vec![(-0.05, 0.05); 2], (0.9, 1.1))
            .and_then(|c| c.with_shift(shift))
            .map_err(ga_err)?;
    Ok(Ga::new(ga_config, &mut streams.stream("perturbation-init")))
}

/// The frame being perturbed: its source, camera, request and the sensor's pixel pitch.
pub(super) struct Probe<'a> {
    pub(super) source: &'a dyn FrameSource,
    pub(super) camera: &'a PinholeCamera,
    pub(super) request: FrameRequest,
    pub(super) sensor: SensorLimits,
    /// Global step index: seeds the GA's update.
    pub(super) global_step: u64,
    /// The step's scene index, common to the candidates of a generation: seeds the noise.
    pub(super) scene_step: u64,
}

/// One perturbation search around `predicted` (NeuralAE's settings for the calibration pitch):
/// scores every member and, unless the perturbations are fixed, tells the GA their fitness.
/// Returns the best member's settings (equal fitness goes to the first member), for the
/// calibration pitch.
pub(super) fn search(
    cx: &mut Context,
    model: &JointModel,
    ga: &mut Ga,
    probe: &Probe<'_>,
    predicted: DynamicSettings,
) -> Result<DynamicSettings, TrainError> {
    let fixed = cx.config.method == Method::FixedPerturbation;
    let members: Vec<Vec<f64>> =
        if fixed { FIXED.iter().map(|p| p.to_vec()).collect() } else { ga.ask().to_vec() };
    let mut fitness = Vec::with_capacity(members.len());
    let mut settings = Vec::with_capacity(members.len());
    for p in &members {
        let perturbed = cx.ranges.clamp(DynamicSettings::new(
            predicted.exposure_s + p[0] * cx.ranges.exposure_s.span(),
            predicted.gain_db + p[1] * cx.ranges.gain_db.span(),
        ));
        let applied = for_sensor(perturbed, &probe.sensor);
        // Every member of a step on the same noise sample: they differ by their settings only.
        let mut noise = cx.streams.indexed("perturbation-noise", probe.scene_step);
        let joca_camera::Capture { frame, image } = cx.formation.capture(
            probe.source,
            probe.camera,
            &probe.request,
            applied,
            probe.sensor.pixel_pitch_um,
            &mut noise,
        )?;
        cx.watch.lap(|t| &mut t.perturbation_render_ms);
        let mut one = TaskMetrics::default();
        one.update(&frame.boxes, &frame.ignore, &model.detect(&image), frame.visible_180);
        let tie_break = match cx.config.perturbation_tie_break {
            TieBreak::Clipping => TIE_BREAK_WEIGHT * (1.0 - clipped_share(image.data())),
            TieBreak::None => 0.0,
        };
        fitness.push(one.compute().ap50 + tie_break);
        settings.push(perturbed);
        cx.watch.lap(|t| &mut t.perturbation_detect_ms);
    }
    let best = (0..fitness.len())
        .max_by(|&a, &b| fitness[a].total_cmp(&fitness[b]).then(b.cmp(&a)))
        .unwrap_or(0);
    if !fixed {
        ga.tell(&fitness, &mut cx.streams.indexed("perturbation-ga", probe.global_step), |_| {})
            .map_err(ga_err)?;
    }
    Ok(settings[best])
}
