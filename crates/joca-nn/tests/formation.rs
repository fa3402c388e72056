//! The differentiable formation reproduces joca-camera's 8-bit formation for the same noise
//! sample, and its gradient with respect to exposure is the closed form.
#![allow(clippy::unwrap_used)]

use joca_camera::{Calibration, DynamicSettings, ImageFormation};
use joca_core::{HdrImage, SeedStreams};
use joca_nn::formation::{ClipGradient, Scene, form};
use rand::Rng;
use tch::{Device, Kind, Tensor};

#[test]
fn same_noise_sample_gives_the_same_frame() {
    let (w, h) = (53, 37);
    let mut i0 = HdrImage::zeros(w, h);
    for (k, v) in i0.data_mut().iter_mut().enumerate() {
        *v = ((k * 7919) % 300) as f32 * 0.9;
    }
    let cal = Calibration::DEFAULT;
    let settings = DynamicSettings::new(7e-3, 14.0);
    // A sensor grid of 530 × 370 resized to the 53 × 37 input: the noise carries the resize's
    // gain, which the input normals hold for both paths.
    let formation =
        ImageFormation::new(cal).unwrap().with_noise_scale(3.0).unwrap().on_native_grid(530, 370);
    let streams = SeedStreams::new(5);
    let reference = formation.form(&i0, settings, 2.4, &mut streams.stream("n"));
    let z = formation.input_normals(w, h, streams.stream("n").random());
    let e = Tensor::from_slice(&[7e-3f32]).set_requires_grad(true);
    let g = Tensor::from_slice(&[14.0f32]).set_requires_grad(true);
    let scene = Scene {
        i0: i0.data(),
        normals: &z,
        width: w,
        height: h,
        pixel_pitch_um: 2.4,
        light_factor: 1.0,
        iris: None,
    };
    let frame = form(&scene, &e, &g, &formation, ClipGradient::Clamp, Device::Cpu);
    let ours: Vec<f32> =
        Vec::try_from(frame.squeeze_dim(0).permute([1, 2, 0]).contiguous().view([-1])).unwrap();
    let mut differ = 0;
    for (a, &b) in ours.iter().zip(reference.data()) {
        let d = (a - f32::from(b)).abs();
        assert!(d <= 1.0, "{a} vs {b}");
        differ += usize::from(d > 0.0);
    }
    // Only values within float rounding of a .5 boundary may round differently.
    assert!(differ * 1000 < ours.len(), "{differ} of {} differ", ours.len());

    // Gradient: where nothing clips, d(sum I)/dE = sum(I)/E (I is linear in E; the noise
    // standard deviation grows as √E, whose share is small but included in the tolerance).
    let unclipped = frame.gt(5.0).logical_and(&frame.lt(250.0)).to_kind(Kind::Float);
    (&frame * &unclipped).sum(Kind::Float).backward();
    let de = e.grad().double_value(&[0]);
    let expected = (&frame * &unclipped).sum(Kind::Double).double_value(&[]) / 7e-3;
    assert!((de / expected - 1.0).abs() < 0.05, "{de} vs {expected}");
    assert!(g.grad().double_value(&[0]) > 0.0);
}

/// Where every pixel saturates far beyond the white point, the clamp (and the smooth clip) pass
/// no gradient to the exposure — the loss cannot ask a white frame for less light — and the
/// straight-through clip passes the unclipped one.
#[test]
fn a_saturated_frame_passes_gradient_only_straight_through() {
    let (w, h) = (8, 6);
    let i0 = HdrImage::from_vec(w, h, vec![200.0; w * h * 3]).unwrap();
    let formation = ImageFormation::new(Calibration::DEFAULT).unwrap();
    let z = vec![0.0f32; w * h * 3];
    let scene = Scene {
        i0: i0.data(),
        normals: &z,
        width: w,
        height: h,
        pixel_pitch_um: 3.75,
        light_factor: 1.0,
        iris: None,
    };
    let grad = |clip| {
        // Four times the calibration exposure: 800 DN before clipping.
        let e = Tensor::from_slice(&[20e-3f32]).set_requires_grad(true);
        let g = Tensor::from_slice(&[10.0f32]).set_requires_grad(true);
        let frame = form(&scene, &e, &g, &formation, clip, Device::Cpu);
        assert_eq!(frame.max().double_value(&[]), 255.0);
        frame.sum(Kind::Float).backward();
        e.grad().double_value(&[0])
    };
    assert_eq!(grad(ClipGradient::Clamp), 0.0);
    // d(sum I)/dE = sum(I)/E with I = 800 DN in every value.
    let expected = (w * h * 3) as f64 * 800.0 / 20e-3;
    assert!((grad(ClipGradient::StraightThrough) / expected - 1.0).abs() < 1e-3);
    // The soft clip's slope at 800 DN is σ((255 − 800)/16) − σ(−800/16) ≈ e^−34: deep in
    // saturation it is as blind as the clamp.
    let smooth = grad(ClipGradient::Smooth);
    assert!(smooth.abs() < expected * 1e-12, "{smooth}");
}

/// Just above the white point the soft clip passes about half the gradient, closed form: at
/// 256 DN before clipping σ(−1/16) − σ(−256/16) of the identity's.
#[test]
fn the_smooth_clip_passes_a_share_near_the_white_point() {
    let (w, h) = (4, 4);
    let i0 = HdrImage::from_vec(w, h, vec![64.0; w * h * 3]).unwrap();
    let formation = ImageFormation::new(Calibration::DEFAULT).unwrap();
    let z = vec![0.0f32; w * h * 3];
    let scene = Scene {
        i0: i0.data(),
        normals: &z,
        width: w,
        height: h,
        pixel_pitch_um: 3.75,
        light_factor: 1.0,
        iris: None,
    };
    let grad = |clip| {
        // Four times the calibration exposure: 256 DN before clipping.
        let e = Tensor::from_slice(&[20e-3f32]).set_requires_grad(true);
        let g = Tensor::from_slice(&[10.0f32]).set_requires_grad(true);
        let frame = form(&scene, &e, &g, &formation, clip, Device::Cpu);
        assert_eq!(frame.max().double_value(&[]), 255.0);
        frame.sum(Kind::Float).backward();
        e.grad().double_value(&[0])
    };
    let sigma = |x: f64| 1.0 / (1.0 + (-x).exp());
    let share = sigma(-1.0 / 16.0) - sigma(-256.0 / 16.0);
    let ratio = grad(ClipGradient::Smooth) / grad(ClipGradient::StraightThrough);
    assert!((ratio / share - 1.0).abs() < 1e-3, "{ratio} vs {share}");
}

/// An open aperture: the tensor formation with the scene's light factor (N0/N)² gives the frame
/// joca-camera forms behind that lens, for the same noise sample.
#[test]
fn the_lens_light_factor_forms_the_same_frame_on_both_paths() {
    let (w, h) = (31, 23);
    let mut i0 = HdrImage::zeros(w, h);
    for (k, v) in i0.data_mut().iter_mut().enumerate() {
        *v = ((k * 104_729) % 97) as f32 * 0.5;
    }
    // f/2: 64× the light of f/16, so a 0.3 ms exposure lands mid-range.
    let formation = ImageFormation::new(Calibration::DEFAULT).unwrap().with_f_number(2.0).unwrap();
    assert_eq!(formation.light_factor(), 64.0);
    let settings = DynamicSettings::new(0.3e-3, 6.0);
    let streams = SeedStreams::new(9);
    let reference = formation.form(&i0, settings, 3.75, &mut streams.stream("n"));
    let z = formation.input_normals(w, h, streams.stream("n").random());
    let scene = Scene {
        i0: i0.data(),
        normals: &z,
        width: w,
        height: h,
        pixel_pitch_um: 3.75,
        light_factor: formation.light_factor(),
        iris: None,
    };
    let e = Tensor::from_slice(&[0.3e-3f32]);
    let g = Tensor::from_slice(&[6.0f32]);
    let frame = form(&scene, &e, &g, &formation, ClipGradient::Clamp, Device::Cpu);
    let ours: Vec<f32> =
        Vec::try_from(frame.squeeze_dim(0).permute([1, 2, 0]).contiguous().view([-1])).unwrap();
    let mean = ours.iter().sum::<f32>() / ours.len() as f32;
    // I0 averages 24 DN; (0.3/5)·10^(−4/20)·64 = 2.42 of it: about 58 DN.
    assert!((mean - 58.0).abs() < 3.0, "mean {mean} DN");
    let differ = ours.iter().zip(reference.data()).filter(|(a, b)| **a != f32::from(**b)).count();
    assert!(ours.iter().zip(reference.data()).all(|(a, &b)| (a - f32::from(b)).abs() <= 1.0));
    assert!(differ * 100 < ours.len(), "{differ} of {} differ", ours.len());
}
