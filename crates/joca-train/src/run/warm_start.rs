//! NeuralAE's warm start (`[run] warm_start`): before DF-Grad, NeuralAE drives the first
//! generation's designs through the training towns, one design and light per stretch, and after
//! every frame learns the settings AverageAE (mid-grey) would choose from where NeuralAE stands —
//! its own previous prediction and the frame that prediction produced (on-policy imitation, so
//! it learns to recover from its own mistakes). Each stretch starts at settings drawn anywhere in
//! the ACC ranges, so it also meets frames far from mid-grey. The detector does not change.

use super::context::Context;
use crate::TrainError;
use crate::control::{ExposureControl, NeuralControl};
use joca_camera::{AccRanges, AverageAe, CameraDesign, Capture, DynamicSettings};
use joca_core::{FrameSource, Rgb8Image};
use joca_nn::joint::{GaTarget, JointModel};
use joca_record::{Event, WarmStartRecord};
use joca_sim::{Illumination, train_map_seed};
use rand::Rng;

/// Frames a stretch drives one design in one light (1.5 s at 10 frames/s: AverageAE settles
/// from any start within a few frames, so most of a stretch is its steady state).
const STRETCH_FRAMES: usize = 15;

/// Settings drawn log-uniformly in exposure and uniformly in gain (dB) within `ranges`.
fn anywhere(rng: &mut impl Rng, ranges: AccRanges) -> DynamicSettings {
    let (e, g) = (ranges.exposure_s, ranges.gain_db);
    DynamicSettings::new(
        rng.random_range(e.min.ln()..e.max.ln()).exp(),
        rng.random_range(g.min..g.max),
    )
}

/// Runs the warm start of `cx.config.warm_start` over `designs` (none where it is off), then
/// restarts NeuralAE's optimiser and logs how closely NeuralAE imitated.
pub(super) fn warm_start(
    cx: &mut Context,
    model: &mut JointModel,
    designs: &[CameraDesign],
) -> Result<(), TrainError> {
    let ws = cx.config.warm_start;
    if ws.is_off() || designs.is_empty() || cx.scenes.recorded() {
        return Ok(());
    }
    let started = std::time::Instant::now();
    let c = cx.config.clone();
    let ae = AverageAe::new(cx.rigs.ranges);
    let mut rng = cx.streams.stream("warm-start");
    let mut losses = Vec::with_capacity(ws.frames);
    for s in 0..ws.frames.div_ceil(STRETCH_FRAMES) {
        let design = &designs[s % designs.len()];
        let illumination = Illumination::ALL[s % Illumination::ALL.len()];
        let map_seed = train_map_seed(rng.random_range(0..c.train_maps));
        let town = cx.scenes.town(map_seed, Some(illumination));
        let episode: u64 = rng.random_range(0..1_000_000);
        let frames = STRETCH_FRAMES.min(ws.frames - s * STRETCH_FRAMES);
        let dt = town.frame_interval_s();
        let span = town.config().episode_s - 1.0 - frames as f64 * dt;
        let t0 = rng.random_range(1.0..span.max(1.5));
        let start = anywhere(&mut rng, cx.rigs.ranges);
        let mut noise = cx.streams.indexed("warm-start-noise", s as u64);

        let rig = cx.rigs.rig(design, dt);
        rig.start_sequence(model);
        let mut control = NeuralControl::starting_at(rig.sensor, start);
        let mut last: Option<Rgb8Image> = None;
        for f in 0..frames {
            if let Some(prev) = &last {
                // What AverageAE would set from NeuralAE's last prediction and its frame.
                let target = ae.step_from_mean(control.predicted(), prev.mean());
                if let Some(p) = control.next(model, prev).prediction {
                    let target = GaTarget { settings: target, iris: p.iris() };
                    losses.push(model.imitate(&p, target, ws.lr)?);
                }
            }
            let instant = (episode, t0 + f as f64 * dt);
            let (applied, f_number) = (control.applied(), control.f_number());
            let Capture { image, .. } =
                rig.capture(&*town, instant, applied, f_number, &mut noise)?;
            model.observe(&image);
            last = Some(image);
        }
    }
    model.restart_acc_optimizer();
    model.reset_sequence();
    let quarter = (losses.len() / 4).max(1);
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let record = WarmStartRecord {
        warm_start_frames: ws.frames,
        imitation_loss_first: mean(&losses[..quarter.min(losses.len())]),
        imitation_loss_last: mean(&losses[losses.len().saturating_sub(quarter)..]),
        warm_start_s: Some(started.elapsed().as_secs_f64()),
    };
    cx.journal.log(&Event::WarmStart(record))
}
