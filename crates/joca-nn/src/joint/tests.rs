//! The joint step's equations against their closed forms and the camera crate.

use super::equations::{eq4, ga_supervision_loss, iris_light_gradient, limit_exposure, step_cost};
use super::*;
use crate::formation::Scene;
use joca_camera::{Bounds, Iris};
use tch::Kind;

/// l_GA against its closed form: with the ranges 1–100 ms (log) and 0–40 dB, a prediction of
/// 10 ms and 10 dB sits at 1/2 and 1/4 of them; a target of 1 ms and 30 dB at 0 and 3/4.
#[test]
fn ga_supervision_loss_is_the_mean_l1_distance_in_normalised_units() {
    let ranges = AccRanges { exposure_s: Bounds::new(1e-3, 0.1), gain_db: Bounds::new(0.0, 40.0) };
    let bounds = AccBounds::new(ranges);
    let e_pred = Tensor::from_slice(&[0.01f32]);
    let g_pred = Tensor::from_slice(&[10.0f32]);
    let target = |e, g, iris| GaTarget { settings: DynamicSettings::new(e, g), iris };
    let l = ga_supervision_loss(&e_pred, &g_pred, None, target(1e-3, 30.0, None), &bounds)
        .double_value(&[]);
    assert!((l - (0.5 + 0.5) / 2.0).abs() < 1e-6, "{l}");
    let zero = ga_supervision_loss(&e_pred, &g_pred, None, target(0.01, 10.0, None), &bounds)
        .double_value(&[]);
    assert!(zero.abs() < 1e-6, "{zero}");
    // With the iris a third term: a prediction at 0.2 of it against a target at 0.8.
    let u = Tensor::from_slice(&[0.2f32]);
    let bounds = bounds.with_iris();
    let l = ga_supervision_loss(&e_pred, &g_pred, Some(&u), target(1e-3, 30.0, Some(0.8)), &bounds)
        .double_value(&[]);
    assert!((l - (0.5 + 0.5 + 0.6) / 3.0).abs() < 1e-6, "{l}");
}

/// l_step against its closed form: from 10 ms and 10 dB, a prediction of 20 ms (1 stop) and
/// 10 − 2·20·log₁₀2 dB (−2 stops) costs (1² + 2²)/2 = 2.5, and its gradient by the stops moved is
/// the stops themselves (∂l/∂s = s): ∂l/∂ln E = s_E/ln 2, ∂l/∂G = s_G/6.02 dB. Holding costs 0.
#[test]
fn the_step_cost_is_the_mean_square_of_the_stops_moved() {
    let _serial = crate::torch_serial();
    let previous = DynamicSettings::new(0.01, 10.0);
    let down_two = 10.0 - 40.0 * 2f64.log10();
    let e = Tensor::from_slice(&[0.02f64]).set_requires_grad(true);
    let g = Tensor::from_slice(&[down_two]).set_requires_grad(true);
    let l = step_cost(&e, &g, previous);
    assert!((l.double_value(&[]) - 2.5).abs() < 1e-9, "{l}");
    l.backward();
    let per_stop = joca_core::units::DB_PER_STOP;
    // ∂l/∂E = s_E/(E ln 2) with s_E = 1; ∂l/∂G = s_G/6.02 with s_G = −2.
    let de = e.grad().double_value(&[0]);
    assert!((de - 1.0 / (0.02 * 2f64.ln())).abs() < 1e-6, "{de}");
    let dg = g.grad().double_value(&[0]);
    assert!((dg + 2.0 / per_stop).abs() < 1e-9, "{dg}");
    let held =
        step_cost(&Tensor::from_slice(&[0.01f64]), &Tensor::from_slice(&[10.0f64]), previous);
    assert!(held.double_value(&[]).abs() < 1e-12);
}

/// The iris's light factor: 1 in value, and the derivative of `ln (N0/N(u))²` by `u`, which for
/// an iris from f/2 to f/16 (3 doublings of N) is −2·ln 8: a full stop-down costs 64× the light.
#[test]
fn the_iris_light_gradient_is_one_with_the_derivative_of_the_log_light() {
    let _serial = crate::torch_serial();
    let iris = Iris::new(2.0, 16.0);
    let u = Tensor::from_slice(&[0.37f32]).set_requires_grad(true);
    let factor = iris_light_gradient(&u, iris);
    assert_eq!(factor.double_value(&[0]), 1.0);
    factor.sum(Kind::Float).backward();
    let du = u.grad().double_value(&[0]);
    assert!((du + 2.0 * 8f64.ln()).abs() < 1e-5, "{du}");
    // And the value it stands for: (N0/N)² at u against the lens's own light factor.
    let n = iris.f_number(0.37);
    let lens = joca_core::optics::Lens { focal_length_mm: 6.0, f_number: n, focus_m: 5.0 };
    assert!((lens.light_factor() - (16.0 / n).powi(2)).abs() < 1e-9);
}

/// The tensor form of Eq. 4 (needed for gradients) agrees with the one the loop renders
/// with, `joca_camera::compensate_for_pixel_size`, for larger and smaller pixels.
#[test]
fn eq4_on_tensors_matches_the_camera_crate() {
    // Eq. 4 and then the cap, for a tiny pixel whose exposure would exceed 50 ms.
    for (pitch, e, g) in [(1.55, 0.04, 10.0), (1.55, 0.04, 25.0), (5.86, 0.04, 10.0)] {
        let want = joca_camera::limit_exposure(
            joca_camera::compensate_for_pixel_size(DynamicSettings::new(e, g), pitch, 3.75),
            0.05,
            30.0,
        );
        let (et, gt) =
            eq4(&Tensor::from_slice(&[e as f32]), &Tensor::from_slice(&[g as f32]), pitch, 3.75);
        let (et, gt) = limit_exposure(&et, &gt, 0.05, 30.0);
        let (et, gt) = (et.double_value(&[0]), gt.double_value(&[0]));
        assert!((et / want.exposure_s - 1.0).abs() < 1e-5, "{pitch}: E {et} vs {want:?}");
        assert!((gt - want.gain_db).abs() < 1e-4, "{pitch}: G {gt} vs {want:?}");
    }
    for (pitch, e, g) in [(5.86, 0.02, 12.0), (5.86, 0.02, 1.0), (1.55, 0.004, 20.0)] {
        let want = joca_camera::compensate_for_pixel_size(DynamicSettings::new(e, g), pitch, 3.75);
        let (et, gt) =
            eq4(&Tensor::from_slice(&[e as f32]), &Tensor::from_slice(&[g as f32]), pitch, 3.75);
        let (et, gt) = (et.double_value(&[0]), gt.double_value(&[0]));
        assert!((et / want.exposure_s - 1.0).abs() < 1e-5, "{pitch}: E {et} vs {want:?}");
        assert!((gt - want.gain_db).abs() < 1e-4, "{pitch}: G {gt} vs {want:?}");
    }
}

/// Past the exposure cap and the gain's maximum the applied settings stay the camera crate's,
/// but the gradient of the applied light `ln(E·G)` is the uncapped one: 1 per unit of
/// `ln E_pred` and ln 10 / 20 per dB of `G_pred` — not 0, which left a small-pixel camera's
/// controller stuck at the top of its range in every light.
#[test]
fn the_cap_passes_the_gradient_of_the_uncapped_light() {
    let _serial = crate::torch_serial();
    // 1.55 µm pixel: 40 ms → 234 ms before the cap; 25 dB + 13.4 dB > 30 dB: both limits hit.
    for (e0, g0, capped) in [(0.04, 25.0, true), (0.002, 5.0, false)] {
        let e = Tensor::from_slice(&[e0 as f32]).set_requires_grad(true);
        let g = Tensor::from_slice(&[g0 as f32]).set_requires_grad(true);
        let (et, gt) = eq4(&e, &g, 1.55, 3.75);
        let (et, gt) = limit_exposure(&et, &gt, 0.05, 30.0);
        if capped {
            assert!((et.double_value(&[0]) - 0.05).abs() < 1e-7);
            assert!((gt.double_value(&[0]) - 30.0).abs() < 1e-4);
        }
        let light = et.log() + &gt / 20.0 * std::f64::consts::LN_10;
        light.sum(Kind::Float).backward();
        let de = e.grad().double_value(&[0]) * e0; // ∂ light / ∂ ln E_pred
        let dg = g.grad().double_value(&[0]);
        assert!((de - 1.0).abs() < 1e-4, "{e0}: {de}");
        assert!((dg - std::f64::consts::LN_10 / 20.0).abs() < 1e-5, "{e0}: {dg}");
    }
}

/// NeuralAE's warm start: repeated imitation steps on one frame bring its prediction to the
/// target (the L1 distance in normalised units falls), the detector's weights stay as they were,
/// and a restarted optimiser keeps the ACC's learning rate.
#[test]
fn imitation_moves_neural_ae_to_its_target_and_leaves_the_detector() {
    let _serial = crate::torch_serial();
    tch::manual_seed(4);
    let engine = Engine::cpu(1);
    let detector = DetectorConfig { width: 8, classes: 3, deep: false, shared_head: false };
    let formation = ImageFormation::new(joca_camera::Calibration::DEFAULT).unwrap();
    let mut model = JointModel::new(&engine, detector, AccRanges::PAPER, formation, false);
    model.set_acc_output(crate::acc::AccOutputForm::Relative { max_stops: 3.0 });
    let frame =
        Rgb8Image::from_vec(32, 24, (0..32 * 24 * 3).map(|i| (i % 251) as u8).collect()).unwrap();
    let _ = model.observe(&frame);
    let before = model.det.net.forward(&image_tensor(&frame, Device::Cpu));
    let target = GaTarget { settings: DynamicSettings::new(2e-3, 20.0), iris: None };
    let previous = DynamicSettings::new(8e-3, 10.0);
    let mut losses = Vec::new();
    for _ in 0..60 {
        let p = model.predict(&frame, previous, None).unwrap();
        losses.push(model.imitate(&p, target, 1e-3).unwrap());
    }
    assert!(losses[59] < 0.2 * losses[0], "{:?}", (losses[0], losses[59]));
    let after = model.det.net.forward(&image_tensor(&frame, Device::Cpu));
    assert!(before.heatmap.equal(&after.heatmap), "the detector changed");
    model.set_acc_lr(3e-5);
    model.restart_acc_optimizer();
    assert_eq!((model.acc_opt.config().lr, model.acc_opt.steps()), (3e-5, 0));
}

/// DF-Grad with the step cost: NeuralAE, taught first to step 2 stops down (exposure and gain),
/// is pulled back towards holding its settings when the step cost dominates its loss (task
/// weight 1e-3, step weight 1, no GA target, Adam at 1e-4); the report's `l_step` is the closed
/// form of the prediction it trained on, and without a step weight there is none.
#[test]
fn the_step_cost_pulls_neural_ae_towards_holding() {
    let _serial = crate::torch_serial();
    tch::manual_seed(5);
    let engine = Engine::cpu(1);
    let detector = DetectorConfig { width: 8, classes: 3, deep: false, shared_head: false };
    let formation = ImageFormation::new(joca_camera::Calibration::DEFAULT).unwrap();
    let mut model = JointModel::new(&engine, detector, AccRanges::PAPER, formation, false);
    model.set_acc_output(crate::acc::AccOutputForm::Relative { max_stops: 3.0 });
    let (w, h) = (32, 24);
    let frame =
        Rgb8Image::from_vec(w, h, (0..w * h * 3).map(|i| (i % 251) as u8).collect()).unwrap();
    let _ = model.observe(&frame);
    let previous = DynamicSettings::new(8e-3, 20.0);
    let down = GaTarget { settings: DynamicSettings::new(2e-3, 20.0 - 12.04), iris: None };
    for _ in 0..80 {
        let p = model.predict(&frame, previous, None).unwrap();
        model.imitate(&p, down, 1e-3).unwrap();
    }
    let stops = |p: &Prediction| {
        let s = p.settings();
        let e = (s.exposure_s / previous.exposure_s).log2();
        (e, (s.gain_db - previous.gain_db) / joca_core::units::DB_PER_STOP)
    };
    let start = stops(&model.predict(&frame, previous, None).unwrap());
    assert!(start.0 < -1.5 && start.1 < -1.5, "{start:?}");
    let i0: Vec<f32> = (0..w * h * 3).map(|i| 20.0 + (i % 97) as f32).collect();
    let normals = vec![0.0f32; w * h * 3];
    let scene = Scene {
        i0: &i0,
        normals: &normals,
        width: w,
        height: h,
        pixel_pitch_um: formation.calibration().pixel_pitch_um,
        light_factor: 1.0,
        iris: None,
    };
    model.set_acc_lr(1e-4);
    let weights = DfGradWeights { task: 1e-3, ga: 1.0, step: 1.0 };
    for k in 0..60 {
        let p = model.predict(&frame, previous, None).unwrap();
        let (e, g) = stops(&p);
        let r = model.step(&scene, &[], &[], Exposure::Predicted(p), None, weights).unwrap();
        let l = r.step_loss.expect("a step cost where its weight is above 0");
        assert!((l - (e * e + g * g) / 2.0).abs() < 1e-3 * l.max(1.0), "{k}: {l} vs {e}, {g}");
        model.reset_sequence();
        let _ = model.observe(&frame);
    }
    let end = stops(&model.predict(&frame, previous, None).unwrap());
    assert!(end.0.abs() < 0.5 * start.0.abs() && end.1.abs() < 0.5 * start.1.abs(), "{end:?}");
    let p = model.predict(&frame, previous, None).unwrap();
    let none = DfGradWeights { step: 0.0, ..weights };
    let r = model.step(&scene, &[], &[], Exposure::Predicted(p), None, none).unwrap();
    assert_eq!(r.step_loss, None);
}

/// The loss's slope by the light in stops is the pull DF-Grad's task gradient puts on the
/// exposure (the step's probe, `∂l/∂E · E · ln 2` per stop), and exactly 0 where every pixel is
/// saturated and the clamp passes nothing.
#[test]
fn the_loss_slope_is_df_grads_task_pull_in_stops() {
    let _serial = crate::torch_serial();
    tch::manual_seed(6);
    let engine = Engine::cpu(1);
    let detector = DetectorConfig { width: 8, classes: 3, deep: false, shared_head: false };
    let formation = ImageFormation::new(joca_camera::Calibration::DEFAULT).unwrap();
    let mut model = JointModel::new(&engine, detector, AccRanges::PAPER, formation, false);
    model.set_detector_trainable(false);
    let (w, h) = (48usize, 32usize);
    let normals: Vec<f32> = (0..w * h * 3).map(|i| ((i % 7) as f32 - 3.0) / 3.0).collect();
    let truth = [joca_core::Annotation::new(
        joca_core::BBox::new(10.0, 8.0, 30.0, 24.0),
        joca_core::Class::Vehicle,
    )];
    let i0: Vec<f32> = (0..w * h * 3).map(|i| 5.0 + (i % 97) as f32 * 0.5).collect();
    let white = vec![5.0e5f32; w * h * 3];
    let scene = |i0| Scene {
        i0,
        normals: &normals,
        width: w,
        height: h,
        pixel_pitch_um: formation.calibration().pixel_pitch_um,
        light_factor: 1.0,
        iris: None,
    };
    let frame =
        Rgb8Image::from_vec(w, h, (0..w * h * 3).map(|i| (i % 251) as u8).collect()).unwrap();
    let _ = model.observe(&frame);
    let p = model.predict(&frame, DynamicSettings::new(8e-3, 10.0), None).unwrap();
    let settings = p.settings();
    let (loss, slope) = model.loss_slope(&scene(&i0), &truth, &[], settings).unwrap();
    let weights = DfGradWeights { task: 1.0, ga: 0.0, step: 0.0 };
    let r = model.step(&scene(&i0), &truth, &[], Exposure::Predicted(p), None, weights).unwrap();
    let (a, b) = model.bounds.log_exposure;
    let pull = r.task_gradient.unwrap()[0] / (b - a) * std::f64::consts::LN_2;
    assert!((r.loss.total - loss).abs() < 1e-6 * loss.abs().max(1.0), "{loss} vs {:?}", r.loss);
    assert!(slope != 0.0 && (slope - pull).abs() < 1e-4 * slope.abs(), "{slope} vs {pull}");
    assert_eq!(model.loss_slope(&scene(&white), &truth, &[], settings).unwrap().1, 0.0);
}
