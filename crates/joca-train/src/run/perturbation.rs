//! DF-Grad's perturbation mode (paper Sec. 5): each member `(p_e, p_g)` of a small GA offsets
//! NeuralAE's prediction by a fraction of each range; the instant is rendered with the
//! perturbed exposure too (so with its own motion blur, which no gradient can see; the applied
//! and perturbed shutters share one grid of sub-frames), formed, detected and scored by the
//! detector's task loss (the presets'), by AP50 (the paper's) or by mAP (`perturbation_score`;
//! the last two pooled with the frames before it where `perturbation_window` asks). The best
//! member's settings become the target of the GA loss l_GA. Each search counts whether members
//! tied for the best score (then the tie-break or the GA's order chose), for `results.json`.
//! Where NeuralAE sets the iris too, each member also offsets the iris's unit position (a third
//! gene) and is rendered and formed at its own f-number (its own defocus and light).

use super::config::{
    PERTURBATION_HALF_RANGE, PerturbationMutation, PerturbationScore, PerturbationSteps, TieBreak,
};
use super::context::Context;
use super::pooled::{Capture, Window};
use super::{Method, RunConfig, ga_err};
use crate::TrainError;
use crate::control::{SensorLimits, for_sensor};
use joca_camera::{AccRanges, ApertureControl, CameraError, DynamicSettings, ImageFormation};
use joca_core::units::DB_PER_STOP;
use joca_core::{Frame, Rgb8Image, SeedStreams, training_targets};
use joca_evolve::{Ga, GaConfig};
use joca_nn::detector::{Precision, PrecisionExt, TrainFrame};
use joca_nn::joint::{GaTarget, JointModel};
use joca_record::SearchTies;
use rand::Rng;
use rayon::prelude::*;

/// The perturbations of the `fixed-perturbation` ablation: ±2.5 % of each range, four signs.
const FIXED: [[f64; 2]; 4] = [[0.025, 0.025], [0.025, -0.025], [-0.025, 0.025], [-0.025, -0.025]];

/// Weight of the clipping tie-break in a member's fitness: below any AP50 difference a frame can
/// make (one object of a frame with hundreds of reference objects moves AP50 by more).
pub(super) const TIE_BREAK_WEIGHT: f64 = 1e-3;

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
    let genes = if config.aperture == ApertureControl::Dynamic { 3 } else { 2 };
    let ga_config = GaConfig::new(
        config.perturbation_population,
        vec![(-PERTURBATION_HALF_RANGE, PERTURBATION_HALF_RANGE); genes],
        (0.9, 1.1),
    )
    .and_then(|c| c.with_shift(shift))
    .map_err(ga_err)?;
    Ok(Ga::new(ga_config, &mut streams.stream("perturbation-init")))
}

/// The frame being perturbed: the sensor, the step's indices and the frames before it.
pub(super) struct Probe<'w> {
    pub(super) sensor: SensorLimits,
    /// The run's formation on the design's native grid.
    pub(super) formation: ImageFormation,
    /// Global step index: seeds the GA's update.
    pub(super) global_step: u64,
    /// The step's scene index, common to the candidates of a generation: seeds the noise.
    pub(super) scene_step: u64,
    /// The frames the controller captured before this one, which a pooled score ranks with it.
    pub(super) window: &'w Window,
}

/// One member of a perturbation search: its settings for the calibration pitch (what l_GA
/// compares NeuralAE's prediction with) and as applied to the sensor (Eq. 4, capped); where
/// NeuralAE sets the iris, its unit position and f-number.
#[derive(Debug, Clone, Copy)]
pub(super) struct Member {
    pub(super) perturbed: DynamicSettings,
    pub(super) applied: DynamicSettings,
    pub(super) iris: Option<f64>,
    pub(super) f_number: Option<f64>,
}

impl Member {
    /// What l_GA pulls NeuralAE's prediction towards if this member wins.
    fn target(&self) -> GaTarget {
        GaTarget { settings: self.perturbed, iris: self.iris }
    }
}

/// The members of one search around `predicted` (NeuralAE's settings for the calibration
/// pitch, and its iris position where it sets the iris): the GA's population, or the ablation's
/// four fixed perturbations (which leave the iris where NeuralAE put it).
pub(super) fn members(
    config: &RunConfig,
    ranges: AccRanges,
    ga: &Ga,
    (predicted, iris): (DynamicSettings, Option<f64>),
    sensor: &SensorLimits,
) -> Vec<Member> {
    let offsets: Vec<Vec<f64>> = if config.method == Method::FixedPerturbation {
        FIXED.iter().map(|p| p.to_vec()).collect()
    } else {
        ga.ask().to_vec()
    };
    let steps = config.perturbation_steps;
    offsets
        .iter()
        .map(|p| {
            let perturbed = perturb(steps, &ranges, predicted, [p[0], p[1]]);
            // The iris's unit position is already even steps of log f-number: offset directly.
            let iris = iris.map(|u| (u + p.get(2).copied().unwrap_or(0.0)).clamp(0.0, 1.0));
            let f_number = sensor.iris.zip(iris).map(|(lens, u)| lens.f_number(u));
            Member { perturbed, applied: for_sensor(perturbed, sensor), iris, f_number }
        })
        .collect()
}

/// `predicted` offset by `p` (normalised units): the exposure by a share of its range
/// (`linear`) or of its log range (`relative`), the gain (dB) by a share of its range; or
/// (`stops:S`) each by `S · p / 0.05` stops; clamped into the ranges.
fn perturb(
    steps: PerturbationSteps,
    ranges: &AccRanges,
    predicted: DynamicSettings,
    p: [f64; 2],
) -> DynamicSettings {
    let e = &ranges.exposure_s;
    // The gain by a share of its range (dB are already relative) in both of the paper's forms.
    let share_of_gain = || predicted.gain_db + p[1] * ranges.gain_db.span();
    let (exposure_s, gain_db) = match steps {
        PerturbationSteps::Linear => (predicted.exposure_s + p[0] * e.span(), share_of_gain()),
        PerturbationSteps::Relative => {
            (predicted.exposure_s * (e.max / e.min).powf(p[0]), share_of_gain())
        }
        PerturbationSteps::Stops(s) => {
            let [se, sg] = p.map(|x| s * x / PERTURBATION_HALF_RANGE);
            (predicted.exposure_s * se.exp2(), predicted.gain_db + sg * DB_PER_STOP)
        }
    };
    ranges.clamp(DynamicSettings::new(exposure_s, gain_db))
}

/// Each perturbed frame's score, higher better: its AP50 or mAP (pooled with `window`'s
/// frames), or its negated task loss.
fn raw_scores(
    score: PerturbationScore,
    min_box_px: f32,
    model: &JointModel,
    (frames, window): (&[Frame], &Window),
    images: &[&Rgb8Image],
    precision: Precision,
) -> Result<Vec<f64>, TrainError> {
    match score {
        PerturbationScore::Ap50 | PerturbationScore::Map => {
            let detections = model.detect_batch_in(images, precision);
            let members = frames.iter().zip(&detections).map(|(frame, found)| Capture {
                truth: &frame.boxes,
                ignore: &frame.ignore,
                visible_180: frame.visible_180,
                detections: found,
            });
            let map = score == PerturbationScore::Map;
            Ok(window.scores(members).map(|s| if map { s.map } else { s.ap50 }).collect())
        }
        PerturbationScore::Loss => {
            // The objects the detector is trained on (small ones are ignore regions there).
            let split: Vec<_> =
                frames.iter().map(|f| training_targets(&f.boxes, &f.ignore, min_box_px)).collect();
            let batch: Vec<TrainFrame<'_>> = images
                .iter()
                .zip(&split)
                .map(|(image, (truth, ignore))| TrainFrame { image, truth, ignore })
                .collect();
            // A non-finite loss ranks last (a NaN must never win the search).
            let losses = model.losses_in(&batch, precision)?;
            Ok(losses
                .into_iter()
                .map(|l| if l.is_finite() { -l } else { f64::NEG_INFINITY })
                .collect())
        }
    }
}

/// Each member's fitness: its score, plus the tie-break (AP50 and mAP); and whether two or more
/// members tied for the best score.
fn score(
    config: &RunConfig,
    model: &JointModel,
    frames: (&[Frame], &Window),
    images: &[&Rgb8Image],
    precision: Precision,
) -> Result<(Vec<f64>, bool), TrainError> {
    let raw = raw_scores(
        config.perturbation_score,
        config.min_box_px as f32,
        model,
        frames,
        images,
        precision,
    )?;
    let top = raw.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let tied = raw.iter().filter(|&&r| r == top).count() > 1;
    let fitness = raw
        .iter()
        .zip(images)
        .map(|(r, image)| match (config.perturbation_score, config.perturbation_tie_break) {
            (PerturbationScore::Ap50 | PerturbationScore::Map, TieBreak::Clipping) => {
                r + TIE_BREAK_WEIGHT * (1.0 - clipped_share(image.data()))
            }
            _ => *r,
        })
        .collect();
    Ok((fitness, tied))
}

/// The member of highest fitness, the first on ties.
fn best_member(fitness: &[f64]) -> usize {
    (0..fitness.len())
        .max_by(|&a, &b| fitness[a].total_cmp(&fitness[b]).then(b.cmp(&a)))
        .unwrap_or(0)
}

/// Scores the members' frames (`frames[i]` rendered with `members[i].applied`'s exposure, all of
/// one instant): each is formed on the same noise sample, the frames go through the detector as
/// one batch, and each is scored by its task loss (the presets') or by AP50 or mAP, pooled with
/// the probe's window (ties by fewer clipped pixels, unless switched off; `perturbation_score`).
/// Unless the perturbations are fixed, tells the GA their fitness. Returns the best member's
/// settings (equal fitness goes to the first member), for the calibration pitch, and iris;
/// `None` without members.
pub(super) fn search(
    cx: &mut Context,
    model: &JointModel,
    ga: &mut Ga,
    probe: &Probe<'_>,
    members: &[Member],
    frames: &[Frame],
) -> Result<Option<GaTarget>, TrainError> {
    // Every member of a step on the same noise sample: they differ by their settings only. The
    // sample is drawn once, the members are formed in parallel (each frame as `form` with that
    // stream would make it).
    let images: Vec<Rgb8Image> = match frames.first() {
        Some(first) => {
            let seed: u64 = cx.streams.indexed("perturbation-noise", probe.scene_step).random();
            let (formation, pitch) = (&probe.formation, probe.sensor.pixel_pitch_um);
            let normals = formation.input_normals(first.hdr.width(), first.hdr.height(), seed);
            members
                .par_iter()
                .zip(frames.par_iter())
                .map(|(m, frame)| {
                    let formation = match m.f_number {
                        Some(n) => formation.with_f_number(n)?,
                        None => *formation,
                    };
                    Ok(formation.form_with_normals(&frame.hdr, m.applied, pitch, &normals))
                })
                .collect::<Result<_, CameraError>>()?
        }
        None => Vec::new(),
    };
    cx.journal.watch.lap(|t| &mut t.perturbation_render_ms);
    let refs: Vec<&Rgb8Image> = images.iter().collect();
    let precision = cx.config.scoring_precision.on_device(model.device());
    let scored = (frames, probe.window);
    let (fitness, tied) = score(&cx.config, model, scored, &refs, precision)?;
    cx.journal.ties.add(SearchTies { searches: 1, tied: u64::from(tied) });
    cx.journal.watch.lap(|t| &mut t.perturbation_detect_ms);
    let best = best_member(&fitness);
    // `joca bench step` only: would the other precision have chosen the same member, and what
    // does this precision's choice lose by the other's scores?
    if let Some(other) = cx.journal.watch.check_precision {
        let (reference, _) = score(&cx.config, model, scored, &refs, other)?;
        let top = reference.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let bottom = reference.iter().copied().fold(f64::INFINITY, f64::min);
        cx.journal.watch.count_check(
            best_member(&reference) == best,
            top - reference[best],
            top - bottom,
        );
    }
    if cx.config.method != Method::FixedPerturbation {
        ga.tell(&fitness, &mut cx.streams.indexed("perturbation-ga", probe.global_step), |_| {})
            .map_err(ga_err)?;
    }
    Ok(members.get(best).map(Member::target))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_steps_add_a_share_of_the_range_and_relative_steps_multiply() {
        let r = AccRanges::PAPER;
        let at = |e_ms: f64| DynamicSettings::new(e_ms * 1e-3, 10.0);
        let ms = |s: DynamicSettings| s.exposure_s * 1e3;
        // Linear: ±5 % of 0.1–50 ms is ±2.495 ms at 50 ms and at 1 ms alike (clamped at 0.1).
        let lin = |e, p| ms(perturb(PerturbationSteps::Linear, &r, at(e), [p, 0.0]));
        assert!((lin(40.0, -0.05) - 37.505).abs() < 1e-9);
        assert!((lin(1.0, 0.05) - 3.495).abs() < 1e-9);
        assert!((lin(1.0, -0.05) - 0.1).abs() < 1e-12, "clamped to the range");
        // Relative: a factor 500^p (the range's ratio): ×0.7329 and ×1.3644 for p = ∓0.05.
        let rel = |e, p| ms(perturb(PerturbationSteps::Relative, &r, at(e), [p, 0.0]));
        assert!((rel(40.0, -0.05) - 40.0 * 500f64.powf(-0.05)).abs() < 1e-9);
        assert!((rel(1.0, -0.05) - 0.732_911).abs() < 1e-6);
        assert!((rel(1.0, 0.05) - 1.364_421).abs() < 1e-6);
        assert!((rel(40.0, 0.5) - 50.0).abs() < 1e-12, "clamped to the range");
        // The gain: a share of 1–30 dB either way.
        let g = perturb(PerturbationSteps::Relative, &r, at(10.0), [0.0, 0.1]).gain_db;
        assert!((g - 12.9).abs() < 1e-9);
    }

    #[test]
    fn stop_steps_offset_exposure_and_gain_by_powers_of_two() {
        let r = AccRanges::PAPER;
        let at = DynamicSettings::new(10e-3, 10.0);
        // A gene at the edge of its ±5 % range is ±S stops: 10 ms × 2^±1.5, 10 dB ± 1.5 · 20·log10 2.
        let up = perturb(PerturbationSteps::Stops(1.5), &r, at, [0.05, 0.05]);
        assert!((up.exposure_s - 10e-3 * 2f64.powf(1.5)).abs() < 1e-12);
        assert!((up.gain_db - (10.0 + 1.5 * 20.0 * 2f64.log10())).abs() < 1e-9);
        let down = perturb(PerturbationSteps::Stops(1.5), &r, at, [-0.05, -0.025]);
        assert!((down.exposure_s - 10e-3 / 2f64.powf(1.5)).abs() < 1e-12);
        assert!((down.gain_db - (10.0 - 0.75 * 20.0 * 2f64.log10())).abs() < 1e-9);
        // Clamped into the ranges: 40 ms × 4 is the 50 ms cap, 10 dB − 4 stops is 1 dB.
        let far = perturb(
            PerturbationSteps::Stops(2.0),
            &r,
            DynamicSettings::new(40e-3, 10.0),
            [0.05, -0.05],
        );
        assert!((far.exposure_s - 50e-3).abs() < 1e-12 && (far.gain_db - 1.0).abs() < 1e-12);
    }

    #[test]
    fn perturbation_steps_read_and_write_every_form_and_refuse_others_naming_the_range() {
        for text in ["linear", "relative", "stops:1", "stops:0.5", "stops:4"] {
            assert_eq!(PerturbationSteps::parse(text).unwrap().to_string(), text);
        }
        for bad in ["log", "stops", "stops:0", "stops:-1", "stops:4.5", "stops:x"] {
            let e = PerturbationSteps::parse(bad).unwrap_err();
            assert!(
                e.contains(bad) && e.contains("at most 4 stops") && e.contains("linear"),
                "{e}"
            );
        }
    }
}
