use super::DetectorModel;
use super::*;
use crate::{Adam, AdamConfig, Engine, load_weights, save_weights};
use joca_core::{Annotation, BBox};
use tch::nn::VarStore;

mod batch;
mod targets;
mod training;

fn frame_with_box(w: usize, h: usize, b: BBox) -> Rgb8Image {
    let mut data = vec![30u8; w * h * 3];
    for y in b.y_min as usize..b.y_max as usize {
        for x in b.x_min as usize..b.x_max as usize {
            data[(y * w + x) * 3..(y * w + x) * 3 + 3].copy_from_slice(&[220, 60, 40]);
        }
    }
    Rgb8Image::from_vec(w, h, data).unwrap()
}

/// A freshly initialised width-8 detector without the stride-32 stage.
fn small_model(engine: &Engine) -> DetectorModel {
    DetectorModel::new(
        engine,
        DetectorConfig { width: 8, classes: 3, deep: false, shared_head: false },
        AdamConfig::DETECTOR,
    )
}

/// Random weights with a non-trivial head (the initial output weights are ~1e-3, which would
/// make every comparison below trivially close).
fn random_detector(engine: &Engine, seed: i64) -> (VarStore, Detector) {
    engine.seed(seed as u64);
    let vs = VarStore::new(engine.device());
    let d = Detector::new(
        &vs.root(),
        DetectorConfig { width: 8, classes: 3, deep: true, shared_head: false },
    );
    let _guard = tch::no_grad_guard();
    // In name order, as the optimiser and the weights files take them: the map's own order
    // changes from process to process, and with it which head gets which draws.
    let mut heads: Vec<(String, Tensor)> =
        vs.variables().into_iter().filter(|(name, _)| name.ends_with("out.weight")).collect();
    heads.sort_by(|a, b| a.0.cmp(&b.0));
    for (_, mut t) in heads {
        let _ = t.normal_(0.0, 0.1);
    }
    (vs, d)
}

#[test]
fn any_input_size_gives_a_quarter_resolution_grid() {
    let _serial = crate::torch_serial();
    let engine = Engine::cpu(1);
    let vs = VarStore::new(engine.device());
    let d = Detector::new(&vs.root(), DetectorConfig::default());
    let out = d.forward(&Tensor::zeros([1, 3, 77, 102], (Kind::Float, engine.device())));
    assert_eq!(out.heatmap.size(), vec![1, 3, 20, 26]);
    assert_eq!(out.size.size(), vec![1, 2, 20, 26]);
    assert_eq!(out.features.size(), vec![1, 32, 20, 26]);
}

/// Finite weights that overflow in the forward pass (every weight ×1e30) are told apart from a
/// network that merely finds nothing.
#[test]
fn weights_that_overflow_are_detected() {
    let _serial = crate::torch_serial();
    let engine = Engine::cpu(1);
    let model = small_model(&engine);
    let frame = frame_with_box(64, 48, BBox::new(10.0, 10.0, 30.0, 30.0));
    assert!(!model.diverges_on(&frame));
    {
        let _guard = tch::no_grad_guard();
        for (_, mut t) in model.vs.variables() {
            let _ = t.g_mul_scalar_(1e30);
        }
    }
    assert!(model.diverges_on(&frame));
    assert!(model.detect(&frame).is_empty());
}

#[test]
fn decoding_survives_nan_output() {
    let _serial = crate::torch_serial();
    let h = Tensor::full([1, 3, 4, 4], f64::NAN, (Kind::Float, Device::Cpu));
    let out = DetectorOutput {
        heatmap: h,
        size: Tensor::zeros([1, 2, 4, 4], (Kind::Float, Device::Cpu)),
        offset: Tensor::zeros([1, 2, 4, 4], (Kind::Float, Device::Cpu)),
        features: Tensor::zeros([1, 2, 4, 4], (Kind::Float, Device::Cpu)),
    };
    assert!(decode(&out, 16, 16, 100, 0.01).is_empty());
}

#[test]
fn the_deep_detector_keeps_the_quarter_resolution_heads_on_any_input() {
    let _serial = crate::torch_serial();
    let vs = VarStore::new(Device::Cpu);
    let d = Detector::new(
        &vs.root(),
        DetectorConfig { width: 4, classes: 3, deep: true, shared_head: false },
    );
    for (h, w) in [(48i64, 64i64), (77, 102), (33, 35)] {
        let out = d.forward(&Tensor::rand([1, 3, h, w], (Kind::Float, Device::Cpu)));
        let expect = [1, 3, (h + 3) / 4, (w + 3) / 4];
        assert_eq!(out.heatmap.size(), expect, "{h}×{w}");
        assert_eq!(out.size.size()[2..], expect[2..]);
    }
}

#[test]
fn a_shared_head_saves_two_hidden_convolutions() {
    let _serial = crate::torch_serial();
    // Two 3×3 convolutions of 4c → 4c channels at stride 4, 2 FLOPs per multiply-add.
    let separate = DetectorConfig { width: 16, classes: 3, deep: true, shared_head: false };
    let shared = DetectorConfig { shared_head: true, ..separate };
    let (h, w) = (240, 320);
    let hidden = 2.0 * 64.0 * 64.0 * 9.0 * (60.0 * 80.0);
    let saved = forward_flops(separate, h, w) - forward_flops(shared, h, w);
    assert_eq!(saved, 2.0 * hidden);
    // Same parameter count difference: two hidden layers (weights and biases).
    let count = |config| {
        let vs = VarStore::new(Device::Cpu);
        let _ = Detector::new(&vs.root(), config);
        vs.trainable_variables().iter().map(Tensor::numel).sum::<usize>()
    };
    assert_eq!(count(separate) - count(shared), 2 * (64 * 64 * 9 + 64));
}
