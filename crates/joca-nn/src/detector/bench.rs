//! Timing of the detector (`joca bench detector`) and its analytic operation count.

use super::{
    DetectionLoss, Detector, DetectorConfig, Precision, Targets, batch_tensor, image_tensor,
};
use crate::{Adam, AdamConfig, Engine};
use joca_core::{Annotation, BBox, Class, Rgb8Image};
use std::time::Instant;
use tch::nn::VarStore;

/// Floating-point operations (multiply and add counted separately) of one forward pass on an
/// `h × w` image: the sum over convolutions of `2·Cin·Cout·k²·Hout·Wout`, mirroring
/// [`Detector::forward`]. Normalisation, activations and upsampling are left out (<2 %).
pub fn forward_flops(config: DetectorConfig, h: i64, w: i64) -> f64 {
    let c = config.width as f64;
    let down = |n: i64| (n + 1) / 2; // stride-2 convolution with padding k/2
    let conv =
        |cin: f64, cout: f64, k: f64, ho: i64, wo: i64| 2.0 * cin * cout * k * k * (ho * wo) as f64;
    let (h2, w2) = (down(h), down(w));
    let (h4, w4) = (down(h2), down(w2));
    let (h8, w8) = (down(h4), down(w4));
    let (h16, w16) = (down(h8), down(w8));
    let block = |cin: f64, cout: f64, ho: i64, wo: i64, shortcut: bool| {
        conv(cin, cout, 3.0, ho, wo)
            + conv(cout, cout, 3.0, ho, wo)
            + if shortcut { conv(cin, cout, 1.0, ho, wo) } else { 0.0 }
    };
    let mut f = conv(3.0, c, 3.0, h2, w2) + conv(c, 2.0 * c, 3.0, h4, w4);
    f += block(2.0 * c, 2.0 * c, h4, w4, false);
    f += block(2.0 * c, 4.0 * c, h8, w8, true) + block(4.0 * c, 4.0 * c, h8, w8, false);
    f += block(4.0 * c, 8.0 * c, h16, w16, true) + block(8.0 * c, 8.0 * c, h16, w16, false);
    if config.deep {
        let (h32, w32) = (down(h16), down(w16));
        f += block(8.0 * c, 16.0 * c, h32, w32, true) + block(16.0 * c, 16.0 * c, h32, w32, false);
        f += conv(16.0 * c, 4.0 * c, 1.0, h32, w32) + conv(4.0 * c, 4.0 * c, 3.0, h16, w16);
    }
    f += conv(8.0 * c, 4.0 * c, 1.0, h16, w16)
        + conv(4.0 * c, 4.0 * c, 1.0, h8, w8)
        + conv(4.0 * c, 4.0 * c, 3.0, h8, w8);
    f += conv(2.0 * c, 4.0 * c, 1.0, h4, w4) + conv(4.0 * c, 4.0 * c, 3.0, h4, w4);
    let hidden = conv(4.0 * c, 4.0 * c, 3.0, h4, w4);
    let hiddens = if config.shared_head { 1.0 } else { 3.0 };
    let outs = conv(4.0 * c, config.classes as f64 + 4.0, 1.0, h4, w4);
    f + hiddens * hidden + outs
}

/// Best-of-`repeats` wall times in milliseconds of inference and of one training step
/// (forward, CenterNet loss, backward, AdamW update) on an `h × w` frame, float32.
pub fn time_detector(
    engine: &Engine,
    config: DetectorConfig,
    h: usize,
    w: usize,
    repeats: usize,
) -> (f64, f64) {
    let vs = VarStore::new(engine.device());
    let net = Detector::new(&vs.root(), config);
    let x = image_tensor(&bench_frame(w, h), engine.device());
    let infer = best_ms(repeats, &mut || {
        let _g = tch::no_grad_guard();
        let o = net.forward(&x);
        let _ = o.heatmap.double_value(&[0, 0, 0, 0]);
    });
    (infer, time_training(engine, config, h, w, repeats, 1, Precision::Fp32))
}

/// Best-of-`repeats` wall time in milliseconds of one training step on a batch of `batch`
/// `h × w` frames in `precision`, divided by `batch`: the training cost per frame.
pub fn time_training(
    engine: &Engine,
    config: DetectorConfig,
    h: usize,
    w: usize,
    repeats: usize,
    batch: usize,
    precision: Precision,
) -> f64 {
    let times = training_step_times(engine, config, h, w, repeats, batch, precision);
    times.iter().copied().fold(f64::INFINITY, f64::min) / batch as f64
}

/// The wall time in milliseconds of each of `repeats` training steps (after one warm-up step)
/// on a batch of `batch` `h × w` frames in `precision`: forward, CenterNet loss, backward and
/// AdamW update.
pub fn training_step_times(
    engine: &Engine,
    config: DetectorConfig,
    h: usize,
    w: usize,
    repeats: usize,
    batch: usize,
    precision: Precision,
) -> Vec<f64> {
    let vs = VarStore::new(engine.device());
    let net = Detector::new(&vs.root(), config);
    let mut opt = Adam::new(&vs, AdamConfig::DETECTOR);
    let frame = bench_frame(w, h);
    let x = batch_tensor(&vec![&frame; batch], engine.device(), precision);
    let truth: Vec<Annotation> = (0..6)
        .map(|k| {
            let (fx, fy) = ((k as f32 * 0.15 + 0.1) * w as f32, (k as f32 * 0.1 + 0.3) * h as f32);
            Annotation::new(BBox::new(fx, fy, fx + 20.0, fy + 14.0), Class::ALL[k % 3])
        })
        .collect();
    let out = net.forward(&x);
    let s = out.heatmap.size();
    let one = || Targets::new(&truth, &[], config.classes, s[2], s[3], engine.device());
    let targets = Targets::stack((0..batch).map(|_| one()).collect());
    times_ms(repeats, &mut || {
        let loss = DetectionLoss::new(&net.forward(&x), &targets);
        opt.zero_grad();
        loss.total.backward();
        opt.step();
        engine.synchronize();
    })
}

/// A deterministic textured frame.
fn bench_frame(w: usize, h: usize) -> Rgb8Image {
    Rgb8Image::from_vec(w, h, (0..w * h * 3).map(|i| (i * 31 % 251) as u8).collect())
        .unwrap_or_else(|_| Rgb8Image::zeros(w, h))
}

/// The best of `repeats` timed calls after one warm-up call, milliseconds.
fn best_ms(repeats: usize, f: &mut dyn FnMut()) -> f64 {
    times_ms(repeats, f).into_iter().fold(f64::INFINITY, f64::min)
}

/// Each of `repeats` (at least 1) timed calls after one warm-up call, milliseconds.
fn times_ms(repeats: usize, f: &mut dyn FnMut()) -> Vec<f64> {
    f();
    (0..repeats.max(1))
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect()
}
