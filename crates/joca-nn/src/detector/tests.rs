use super::DetectorModel;
use super::*;
use crate::{Adam, AdamConfig, Engine, load_weights, save_weights};
use joca_core::{Annotation, BBox};
use tch::nn::VarStore;

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

#[test]
fn any_input_size_gives_a_quarter_resolution_grid() {
    let _serial = crate::TORCH_SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let engine = Engine::cpu(1);
    let vs = VarStore::new(engine.device());
    let d = Detector::new(&vs.root(), DetectorConfig::default());
    let out = d.forward(&Tensor::zeros([1, 3, 77, 102], (Kind::Float, engine.device())));
    assert_eq!(out.heatmap.size(), vec![1, 3, 20, 26]);
    assert_eq!(out.size.size(), vec![1, 2, 20, 26]);
    assert_eq!(out.features.size(), vec![1, 32, 20, 26]);
}

/// The input batch is `DN / 255 − 0.5` in planar channels, bit for bit what the tensor ops
/// `permute`, `to_kind(Float)`, `/ 255`, `− 0.5` give for every byte value, in either frame of a
/// batch, with 2 threads (vectorised loops) as with 1.
#[test]
fn the_input_batch_is_the_tensor_ops_bit_for_bit() {
    let _serial = crate::TORCH_SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let (w, h) = (37usize, 29usize);
    let a: Vec<u8> = (0..w * h * 3).map(|i| (i * 7 % 256) as u8).collect();
    let b: Vec<u8> = (0..w * h * 3).map(|i| (255 - i * 13 % 256) as u8).collect();
    let frames = [Rgb8Image::from_vec(w, h, a).unwrap(), Rgb8Image::from_vec(w, h, b).unwrap()];
    let refs: Vec<&Rgb8Image> = frames.iter().collect();
    for threads in [1, 2] {
        let engine = Engine::cpu(threads);
        let bytes: Vec<u8> = frames.iter().flat_map(|f| f.data().iter().copied()).collect();
        let want = Tensor::from_slice(&bytes)
            .view([2, h as i64, w as i64, 3])
            .permute([0, 3, 1, 2])
            .contiguous()
            .to_kind(Kind::Float)
            / 255.0
            - 0.5;
        let got = batch_tensor(&refs, engine.device(), Precision::Fp32);
        assert_eq!(got.size(), vec![2, 3, h as i64, w as i64]);
        let (want, got) = (
            Vec::<f32>::try_from(want.view([-1])).unwrap(),
            Vec::<f32>::try_from(got.view([-1])).unwrap(),
        );
        assert!(
            want.iter().zip(&got).all(|(x, y)| x.to_bits() == y.to_bits()),
            "{threads} threads"
        );
        // Every byte value occurs (in the first frame already).
        assert!((0..=255u8).all(|v| frames[0].data().contains(&v)));
    }
}

#[test]
fn targets_peak_at_object_centres() {
    let _serial = crate::TORCH_SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let a = [Annotation::new(BBox::new(8.0, 12.0, 24.0, 20.0), Class::Walker)];
    let t = Targets::new(&a, &[], 3, 10, 10, Device::Cpu);
    assert_eq!(t.count, 1);
    assert!(t.ignore.is_none());
    // Centre (16, 16) px → cell (4, 4), offset (0, 0); size 16×8 px → log(4), log(2).
    assert_eq!(t.heatmap.double_value(&[0, 1, 4, 4]), 1.0);
    assert!(t.heatmap.double_value(&[0, 1, 4, 5]) < 1.0);
    assert_eq!(t.heatmap.double_value(&[0, 0, 4, 4]), 0.0);
    assert_eq!(t.indices.int64_value(&[0]), 44);
    assert!((t.size.double_value(&[0, 0]) - 4f64.ln()).abs() < 1e-6);
    assert!((t.size.double_value(&[1, 0]) - 2f64.ln()).abs() < 1e-6);
}

#[test]
fn firing_inside_an_ignore_region_costs_nothing() {
    let _serial = crate::TORCH_SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    // A walker ignore region over px x 9–23, y 13–19: cells x 2..6, y 3..5 of the walker plane.
    let region = [Annotation::new(BBox::new(9.0, 13.0, 23.0, 19.0), Class::Walker)];
    let object = [Annotation::new(BBox::new(40.0, 8.0, 60.0, 24.0), Class::Vehicle)];
    let t = Targets::new(&object, &region, 3, 10, 20, Device::Cpu);
    let mask = t.ignore.as_ref().unwrap();
    assert_eq!(mask.sum(Kind::Float).double_value(&[]), 8.0);
    assert_eq!(mask.double_value(&[0, 1, 3, 2]), 1.0);
    assert_eq!(mask.double_value(&[0, 1, 4, 5]), 1.0);
    assert_eq!(mask.double_value(&[0, 1, 5, 2]), 0.0);
    assert_eq!(mask.double_value(&[0, 0, 3, 2]), 0.0);
    let output = |logit_in_region: f64| {
        let heatmap = Tensor::full([1, 3, 10, 20], -2.19, (Kind::Float, Device::Cpu));
        let _ = heatmap.get(0).get(1).get(4).get(3).fill_(logit_in_region);
        DetectorOutput {
            heatmap,
            size: Tensor::zeros([1, 2, 10, 20], (Kind::Float, Device::Cpu)),
            offset: Tensor::zeros([1, 2, 10, 20], (Kind::Float, Device::Cpu)),
            features: Tensor::zeros([1, 1, 10, 20], (Kind::Float, Device::Cpu)),
        }
    };
    let loss = |logit: f64, t: &Targets| DetectionLoss::new(&output(logit), t).heatmap;
    assert_eq!(loss(6.0, &t), loss(-2.19, &t));
    let plain = Targets::new(&object, &[], 3, 10, 20, Device::Cpu);
    // Without the region, a logit of 6 where nothing is costs −p²·log(1 − p) ≈ 6.0 (one object).
    let expected = {
        let p = 1.0 / (1.0 + (-6.0f64).exp());
        -(p * p) * (1.0 - p).ln()
    };
    let extra = loss(6.0, &plain) - loss(-2.19, &plain);
    assert!((extra - expected).abs() < 1e-2 * expected, "{extra} vs {expected}");
}

#[test]
fn class_weights_scale_that_class_and_nothing_else() {
    let _serial = crate::TORCH_SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    // A vehicle 16×16 px and a walker 8×16 px on a 10×20 grid (stride 4); every logit 0 (p = ½)
    // and every size/offset output 0.
    let vehicle = Annotation::new(BBox::new(8.0, 8.0, 24.0, 24.0), Class::Vehicle);
    let walker = Annotation::new(BBox::new(48.0, 12.0, 56.0, 28.0), Class::Walker);
    let output = DetectorOutput {
        heatmap: Tensor::zeros([1, 3, 10, 20], (Kind::Float, Device::Cpu)),
        size: Tensor::zeros([1, 2, 10, 20], (Kind::Float, Device::Cpu)),
        offset: Tensor::zeros([1, 2, 10, 20], (Kind::Float, Device::Cpu)),
        features: Tensor::zeros([1, 1, 10, 20], (Kind::Float, Device::Cpu)),
    };
    let weights = [1.0, 3.0, 1.0];
    let both = [vehicle, walker];
    let plain = DetectionLoss::new(&output, &Targets::new(&both, &[], 3, 10, 20, Device::Cpu));
    let t = Targets::new(&both, &[], 3, 10, 20, Device::Cpu).with_class_weights(&weights);
    let weighted = DetectionLoss::new(&output, &t);
    // Each peak costs −(1 − p)²·log p = ¼·ln 2; the walker's now counts 3 times; the loss is
    // normalised by the 2 objects either way.
    let peak = 0.25 * 2f64.ln();
    assert!((weighted.heatmap - plain.heatmap - 2.0 * peak / 2.0).abs() < 1e-6);
    // Log sizes in cells: vehicle (ln 4, ln 4), walker (ln 2, ln 4); with output 0 the errors
    // are those values, averaged with weights 1 and 3 over both coordinates.
    let (l2, l4) = (2f64.ln(), 4f64.ln());
    assert!((plain.size - (l4 + l4 + l2 + l4) / 4.0).abs() < 1e-6);
    assert!((weighted.size - (l4 + l4 + 3.0 * (l2 + l4)) / 8.0).abs() < 1e-6);
    // A frame without walkers trains exactly as before.
    let alone = [vehicle];
    let plain = DetectionLoss::new(&output, &Targets::new(&alone, &[], 3, 10, 20, Device::Cpu));
    let t = Targets::new(&alone, &[], 3, 10, 20, Device::Cpu).with_class_weights(&weights);
    let weighted = DetectionLoss::new(&output, &t);
    assert_eq!(weighted.heatmap, plain.heatmap);
    assert_eq!(weighted.size, plain.size);
    assert_eq!(weighted.offset, plain.offset);
}

/// Size and offset maps that hold each regression target at its sample's cell (zero elsewhere).
fn maps_from(t: &Targets, h: i64, w: i64) -> (Tensor, Tensor) {
    let scatter = |values: &Tensor| {
        let flat = Tensor::zeros([2, h * w], (Kind::Float, Device::Cpu));
        let index = t.indices.view([1, -1]).expand([2, -1], false);
        flat.scatter(1, &index, values).view([1, 2, h, w])
    };
    (scatter(&t.size), scatter(&t.offset))
}

#[test]
fn gaussian_regression_decodes_the_box_from_a_peak_next_to_the_centre() {
    let _serial = crate::TORCH_SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    // A vehicle 40×32 px centred on (40, 24) px: 10×8 cells, centre cell (10, 6), offset (0, 0).
    // CenterNet's radius for 8×10 cells at IoU 0.7 is 2.43 → 2, so σ = 5/6 and the Gaussian
    // covers the 5×5 cells around the centre.
    let b = BBox::new(20.0, 8.0, 60.0, 40.0);
    let ann = [Annotation::new(b, Class::Vehicle)];
    let (h, w) = (10, 20);
    let t = Targets::with_style(&ann, &[], 3, (h, w), Regression::Gaussian, 0, Device::Cpu);
    assert_eq!(t.count, 1);
    assert_eq!(t.indices.size(), vec![25]);
    let sample = |x: i64, y: i64| {
        let cells: Vec<i64> = Vec::try_from(&t.indices).unwrap();
        cells.iter().position(|&c| c == y * w + x).unwrap() as i64
    };
    let (centre, right) = (sample(10, 6), sample(11, 6));
    assert_eq!(t.weights.double_value(&[0, centre]), 1.0);
    // exp(−1 / (2σ²)) with σ = 5/6.
    assert!((t.weights.double_value(&[0, right]) - (-0.72f64).exp()).abs() < 1e-6);
    assert_eq!(t.offset.double_value(&[0, right]), -1.0);
    assert_eq!(t.offset.double_value(&[1, right]), 0.0);
    assert!((t.size.double_value(&[0, right]) - 10f64.ln()).abs() < 1e-6);
    // Heads that output exactly these targets cost nothing, and a heatmap whose peak is one
    // cell right of the centre still decodes the annotated box.
    let (size, offset) = maps_from(&t, h, w);
    let heatmap = Tensor::full([1, 3, h, w], -8.0, (Kind::Float, Device::Cpu));
    let _ = heatmap.get(0).get(0).get(6).get(11).fill_(4.0);
    let features = Tensor::zeros([1, 1, h, w], (Kind::Float, Device::Cpu));
    let output = DetectorOutput { heatmap, size, offset, features };
    let loss = DetectionLoss::new(&output, &t);
    assert!(loss.size.abs() < 1e-6 && loss.offset.abs() < 1e-6, "{loss:?}");
    let found = decode(&output, 80, 40, 10, 0.5);
    assert_eq!(found.len(), 1);
    let d = found[0].bbox;
    for (got, want) in [(d.x_min, 20.0), (d.y_min, 8.0), (d.x_max, 60.0), (d.y_max, 40.0)] {
        assert!((got - want).abs() < 1e-4, "{d:?}");
    }
    // Centre regression trains only the centre cell, with weight 1.
    let c = Targets::new(&ann, &[], 3, h, w, Device::Cpu);
    assert_eq!(Vec::<i64>::try_from(&c.indices).unwrap(), vec![6 * w + 10]);
    assert_eq!(c.weights.double_value(&[0, 0]), 1.0);
}

#[test]
fn gaussian_regression_keeps_every_centre_for_its_own_object() {
    let _serial = crate::TORCH_SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    // Two overlapping vehicles with centre cells (10, 6) and (11, 6): each lies in the other's
    // Gaussian, but a centre (value 1) outranks a neighbour.
    let a = Annotation::new(BBox::new(20.0, 8.0, 60.0, 40.0), Class::Vehicle);
    let b = Annotation::new(BBox::new(28.0, 12.0, 64.0, 38.0), Class::Vehicle);
    let t = Targets::with_style(&[a, b], &[], 3, (10, 20), Regression::Gaussian, 0, Device::Cpu);
    let cells: Vec<i64> = Vec::try_from(&t.indices).unwrap();
    let at = |cell: i64| cells.iter().position(|&c| c == cell).unwrap() as i64;
    assert_eq!(cells.len(), cells.iter().collect::<std::collections::BTreeSet<_>>().len());
    let (ca, cb) = (at(6 * 20 + 10), at(6 * 20 + 11));
    assert_eq!(t.weights.double_value(&[0, ca]), 1.0);
    assert_eq!(t.weights.double_value(&[0, cb]), 1.0);
    assert!((t.size.double_value(&[0, ca]) - 10f64.ln()).abs() < 1e-6);
    assert!((t.size.double_value(&[0, cb]) - 9f64.ln()).abs() < 1e-6);
}

#[test]
fn learns_to_find_a_box_in_a_few_hundred_steps() {
    let _serial = crate::TORCH_SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    for shared_head in [false, true] {
        let engine = Engine::cpu(2);
        engine.seed(3);
        let vs = VarStore::new(engine.device());
        let config = DetectorConfig { width: 8, classes: 3, deep: false, shared_head };
        let d = Detector::new(&vs.root(), config);
        let mut opt = Adam::new(&vs, AdamConfig { lr: 2e-3, ..AdamConfig::DETECTOR });
        let b = BBox::new(20.0, 16.0, 44.0, 36.0);
        let frame = frame_with_box(64, 48, b);
        let x = image_tensor(&frame, engine.device());
        let ann = [Annotation::new(b, Class::Vehicle)];
        let targets = Targets::new(&ann, &[], 3, 12, 16, engine.device());
        let mut first = 0.0;
        for step in 0..250 {
            let loss = DetectionLoss::new(&d.forward(&x), &targets);
            if step == 0 {
                first = loss.total.double_value(&[]);
            }
            opt.zero_grad();
            loss.total.backward();
            opt.step();
        }
        let last = DetectionLoss::new(&d.forward(&x), &targets).total.double_value(&[]);
        assert!(last < 0.1 * first, "shared head {shared_head}: loss {first} -> {last}");
        let dets = decode(&d.forward(&x), 64, 48, 100, 0.05);
        let best = dets.first().unwrap();
        assert_eq!(best.class, Class::Vehicle);
        assert!(best.bbox.iou(&b) > 0.6, "shared head {shared_head}: {best:?}");
    }
}

#[test]
fn decoding_survives_nan_output() {
    let _serial = crate::TORCH_SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
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
fn weights_round_trip_and_refuse_another_architecture() {
    let _serial = crate::TORCH_SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = std::env::temp_dir().join(format!("joca-nn-weights-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("det.safetensors");
    let vs = VarStore::new(Device::Cpu);
    let d = Detector::new(
        &vs.root(),
        DetectorConfig { width: 8, classes: 3, deep: false, shared_head: false },
    );
    save_weights(&vs, &path).unwrap();
    let mut same = VarStore::new(Device::Cpu);
    let d2 = Detector::new(
        &same.root(),
        DetectorConfig { width: 8, classes: 3, deep: false, shared_head: false },
    );
    load_weights(&mut same, &path).unwrap();
    let x = Tensor::rand([1, 3, 32, 32], (Kind::Float, Device::Cpu));
    let diff = (d.forward(&x).heatmap - d2.forward(&x).heatmap).abs().max().double_value(&[]);
    assert_eq!(diff, 0.0);

    let mut wider = VarStore::new(Device::Cpu);
    let _ = Detector::new(
        &wider.root(),
        DetectorConfig { width: 16, classes: 3, deep: false, shared_head: false },
    );
    let e = load_weights(&mut wider, &path).unwrap_err().to_string();
    assert!(e.contains("det.safetensors") && e.contains("backbone.") && e.contains("shape"), "{e}");
    // Weights without the stride-32 stage do not load into a deep detector: the error names a
    // tensor of that stage.
    let mut deep = VarStore::new(Device::Cpu);
    let _ = Detector::new(
        &deep.root(),
        DetectorConfig { width: 8, classes: 3, deep: true, shared_head: false },
    );
    let e = load_weights(&mut deep, &path).unwrap_err().to_string();
    assert!(e.contains("layer4") || e.contains("lateral4") || e.contains("smooth3"), "{e}");
    // The file tells its architecture.
    let shallow = DetectorConfig { width: 8, classes: 3, deep: false, shared_head: false };
    assert_eq!(DetectorConfig::of_weights(&path).unwrap(), shallow);
    save_weights(&deep, &path).unwrap();
    assert_eq!(
        DetectorConfig::of_weights(&path).unwrap(),
        DetectorConfig { deep: true, ..shallow }
    );
    // A shared-head file says so, and does not load into separate heads (nor the reverse).
    let shared = DetectorConfig { shared_head: true, ..shallow };
    let mut one_head = VarStore::new(Device::Cpu);
    let _ = Detector::new(&one_head.root(), shared);
    save_weights(&one_head, &path).unwrap();
    assert_eq!(DetectorConfig::of_weights(&path).unwrap(), shared);
    let e = load_weights(&mut same, &path).unwrap_err().to_string();
    assert!(e.contains("heads."), "{e}");
    save_weights(&same, &path).unwrap();
    let e = load_weights(&mut one_head, &path).unwrap_err().to_string();
    assert!(e.contains("heads.shared"), "{e}");
    std::fs::write(&path, b"not safetensors").unwrap();
    let e = DetectorConfig::of_weights(&path).unwrap_err().to_string();
    assert!(e.contains("det.safetensors") && e.contains("not a readable"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_deep_detector_keeps_the_quarter_resolution_heads_on_any_input() {
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
fn a_non_finite_loss_is_refused_before_any_weight_changes() {
    let _serial = crate::TORCH_SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let engine = Engine::cpu(1);
    let mut model = small_model(&engine);
    let frame = frame_with_box(32, 32, BBox::new(4.0, 4.0, 12.0, 12.0));
    let before = model.detect(&frame);
    let bad = [Annotation::new(BBox::new(4.0, 4.0, f32::INFINITY, 12.0), Class::Walker)];
    let err = model.train_step(&frame, &bad, &[]).unwrap_err().to_string();
    assert!(err.contains("detector loss is inf"), "{err}");
    assert_eq!(model.detect(&frame), before);
}

#[test]
fn the_weight_average_follows_the_closed_form() {
    let _serial = crate::TORCH_SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let engine = Engine::cpu(1);
    engine.seed(5);
    let config = DetectorConfig { width: 8, classes: 3, deep: false, shared_head: false };
    let mut model = DetectorModel::new(&engine, config, AdamConfig::DETECTOR);
    let mut average = WeightAverage::new(&engine, &model, 0.99);
    let name = "heads.heatmap.out.bias";
    let value = |m: &DetectorModel| m.vs.variables()[name].double_value(&[0]);
    let w0 = value(&model);
    assert_eq!(value(average.model()), w0);
    let set = |m: &mut DetectorModel, v: f64| {
        let _guard = tch::no_grad_guard();
        let mut vars = m.vs.variables();
        let _ = vars.get_mut(name).map(|t| t.fill_(v));
    };
    // Update 5: d = min(0.99, 6/15) = 0.4.
    set(&mut model, 1.0);
    average.update(5);
    let a1 = 0.4 * w0 + 0.6;
    assert!((value(average.model()) - a1).abs() < 1e-6);
    // Update 10 000: d = 0.99.
    set(&mut model, -1.0);
    average.update(10_000);
    assert!((value(average.model()) - (0.99 * a1 - 0.01)).abs() < 1e-6);
    // The source is untouched.
    assert_eq!(value(&model), -1.0);
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
fn a_batch_loss_is_the_object_weighted_combination_of_its_images() {
    let _serial = crate::TORCH_SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let engine = Engine::cpu(1);
    let (_vs, d) = random_detector(&engine, 3);
    let boxes = [
        vec![
            Annotation::new(BBox::new(4.0, 6.0, 20.0, 18.0), Class::Vehicle),
            Annotation::new(BBox::new(30.0, 10.0, 38.0, 30.0), Class::Walker),
        ],
        vec![
            Annotation::new(BBox::new(10.0, 2.0, 22.0, 12.0), Class::TrafficSign),
            Annotation::new(BBox::new(40.0, 20.0, 60.0, 34.0), Class::Vehicle),
            Annotation::new(BBox::new(2.0, 24.0, 14.0, 44.0), Class::Walker),
        ],
    ];
    let ignore = [Annotation::new(BBox::new(44.0, 2.0, 60.0, 10.0), Class::Vehicle)];
    let frames =
        [frame_with_box(64, 48, boxes[0][0].bbox), frame_with_box(64, 48, boxes[1][1].bbox)];
    let targets = |i: usize| {
        let ig: &[Annotation] = if i == 1 { &ignore } else { &[] };
        Targets::with_style(&boxes[i], ig, 3, (12, 16), Regression::Gaussian, 0, Device::Cpu)
    };
    let single: Vec<DetectionLoss> = (0..2)
        .map(|i| {
            DetectionLoss::new(&d.forward(&image_tensor(&frames[i], Device::Cpu)), &targets(i))
        })
        .collect();
    let x = batch_tensor(&[&frames[0], &frames[1]], Device::Cpu, Precision::Fp32);
    assert_eq!(x.size(), [2, 3, 48, 64]);
    let stacked = Targets::stack(vec![targets(0), targets(1)]);
    assert_eq!(stacked.count, 5);
    let both = DetectionLoss::new(&d.forward(&x), &stacked);
    // Heatmap: per-image sums over all cells, normalised by the batch's 5 objects.
    let heatmap = (single[0].heatmap * 2.0 + single[1].heatmap * 3.0) / 5.0;
    // (float32 sums in another order: relative tolerance)
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-5 * b.abs().max(1.0);
    assert!(close(both.heatmap, heatmap), "{} vs {heatmap}", both.heatmap);
    // Size and offset: means weighted by each image's total sample weight.
    let w = |i: usize| targets(i).weights.sum(Kind::Float).double_value(&[]);
    let (w0, w1) = (w(0), w(1));
    for (b, s0, s1) in [
        (both.size, single[0].size, single[1].size),
        (both.offset, single[0].offset, single[1].offset),
    ] {
        let expect = (s0 * w0 + s1 * w1) / (w0 + w1);
        assert!(close(b, expect), "{b} vs {expect}");
    }
}

#[test]
fn bfloat16_computation_stays_close_to_float32_and_trains_the_float32_weights() {
    let _serial = crate::TORCH_SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let engine = Engine::cpu(1);
    let (vs, d) = random_detector(&engine, 4);
    let frame = frame_with_box(64, 48, BBox::new(10.0, 8.0, 34.0, 26.0));
    let fp32 = d.forward(&batch_tensor(&[&frame], Device::Cpu, Precision::Fp32));
    let bf16 = d.forward(&batch_tensor(&[&frame], Device::Cpu, Precision::Bf16));
    for (a, b) in [(&fp32.heatmap, &bf16.heatmap), (&fp32.size, &bf16.size)] {
        assert_eq!(b.kind(), Kind::Float);
        let scale = a.abs().max().double_value(&[]);
        let diff = (a - b).abs().max().double_value(&[]);
        // bfloat16 keeps 8 significant bits (relative rounding 2^-9 per operation).
        assert!(scale > 0.1 && diff < 0.05 * scale, "diff {diff}, scale {scale}");
    }
    assert_eq!(bf16.features.kind(), Kind::Float);
    assert!(vs.variables().values().all(|t| t.kind() == Kind::Float));

    // A model of its own seed, not whatever state `random_detector` left the generator in.
    engine.seed(5);
    let mut model = small_model(&engine);
    model.set_precision(Precision::Bf16);
    let truth = [Annotation::new(BBox::new(10.0, 8.0, 34.0, 26.0), Class::Vehicle)];
    let before = model.vs.variables()["backbone.stem.weight"].copy();
    let first = model.train_step(&frame, &truth, &[]).unwrap().total;
    let after = &model.vs.variables()["backbone.stem.weight"];
    assert_eq!(after.kind(), Kind::Float);
    assert!((after - &before).abs().max().double_value(&[]) > 0.0, "the stem did not learn");
    for _ in 0..30 {
        model.train_step(&frame, &truth, &[]).unwrap();
    }
    let last = model.train_step(&frame, &truth, &[]).unwrap().total;
    assert!(last < 0.5 * first, "bfloat16 training does not fit one frame: {first} → {last}");
}

#[test]
fn a_batch_of_frames_of_different_sizes_is_refused() {
    let _serial = crate::TORCH_SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let engine = Engine::cpu(1);
    let mut model = small_model(&engine);
    let (a, b) = (Rgb8Image::zeros(32, 24), Rgb8Image::zeros(24, 32));
    let frame = |image| TrainFrame { image, truth: &[], ignore: &[] };
    let err = model.train_batch(&[frame(&a), frame(&b)]).unwrap_err().to_string();
    assert_eq!(err, "training batch: frames of 32×24 and 24×32: a batch needs frames of one size");
    assert!(model.train_batch(&[]).is_err());
}

#[test]
fn a_minimum_radius_softens_the_neighbours_of_a_small_objects_centre() {
    let _serial = crate::TORCH_SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    // A 10×10 px sign centred at (18, 18) px: 2.5 cells, CenterNet radius 0, centre cell (4, 4).
    let a = [Annotation::new(BBox::new(13.0, 13.0, 23.0, 23.0), Class::TrafficSign)];
    let at = |t: &Targets, y: i64, x: i64| t.heatmap.double_value(&[0, 2, y, x]);
    let plain = Targets::with_style(&a, &[], 3, (10, 10), Regression::Centre, 0, Device::Cpu);
    assert_eq!(at(&plain, 4, 4), 1.0);
    assert_eq!(at(&plain, 4, 5), 0.0);
    let soft = Targets::with_style(&a, &[], 3, (10, 10), Regression::Centre, 1, Device::Cpu);
    assert_eq!(at(&soft, 4, 4), 1.0);
    // Radius 1: σ = (2·1 + 1)/6 = 0.5, so a side neighbour has exp(−1/(2·0.25)) = e^−2 and a
    // diagonal one e^−4; nothing beyond the radius.
    for (y, x) in [(4, 5), (4, 3), (3, 4), (5, 4)] {
        assert!((at(&soft, y, x) - (-2f64).exp()).abs() < 1e-6);
    }
    assert!((at(&soft, 5, 5) - (-4f64).exp()).abs() < 1e-6);
    assert_eq!(at(&soft, 4, 6), 0.0);
    // The regression sample and object count do not change.
    assert_eq!((soft.count, soft.indices.int64_value(&[0])), (1, 44));
    // A large object keeps CenterNet's radius (here 2 cells > 1).
    let big = [Annotation::new(BBox::new(0.0, 0.0, 40.0, 40.0), Class::Vehicle)];
    let r0 = Targets::with_style(&big, &[], 3, (10, 10), Regression::Centre, 0, Device::Cpu);
    let r1 = Targets::with_style(&big, &[], 3, (10, 10), Regression::Centre, 1, Device::Cpu);
    assert!(r0.heatmap.equal(&r1.heatmap));
}

#[test]
fn a_shared_head_saves_two_hidden_convolutions() {
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

/// A batch gives each frame the detections it gets alone (group normalisation is per frame):
/// same classes and order, boxes and scores equal to float rounding.
#[test]
fn a_batch_detects_what_each_frame_does_alone() {
    let _serial = crate::TORCH_SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let engine = Engine::cpu(2);
    engine.seed(5);
    let model = small_model(&engine);
    let frames = [
        frame_with_box(64, 48, BBox::new(20.0, 16.0, 44.0, 36.0)),
        frame_with_box(64, 48, BBox::new(2.0, 3.0, 12.0, 40.0)),
        Rgb8Image::from_vec(64, 48, vec![200; 64 * 48 * 3]).unwrap(),
    ];
    let batch = model.detect_batch(&frames.iter().collect::<Vec<_>>());
    assert_eq!(batch.len(), 3);
    for (frame, got) in frames.iter().zip(&batch) {
        let alone = model.detect(frame);
        assert!(!alone.is_empty());
        assert_eq!(got.len(), alone.len());
        for (a, b) in got.iter().zip(&alone) {
            assert_eq!(a.class, b.class);
            assert!((a.score - b.score).abs() < 1e-5, "{a:?} vs {b:?}");
            assert!(a.bbox.iou(&b.bbox) > 0.999, "{a:?} vs {b:?}");
        }
    }
    assert!(model.detect_batch(&[]).is_empty());
}

#[test]
fn each_frames_loss_is_the_training_loss_of_that_frame_alone() {
    let _serial = crate::TORCH_SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let engine = Engine::cpu(1);
    engine.seed(5);
    let mut model = small_model(&engine);
    let b = BBox::new(20.0, 16.0, 44.0, 36.0);
    let seen = frame_with_box(64, 48, b);
    let blank = Rgb8Image::zeros(64, 48);
    let truth = [Annotation::new(b, Class::Vehicle)];
    let frame = |image| TrainFrame { image, truth: &truth, ignore: &[] };
    let losses = model.losses_in(&[frame(&seen), frame(&blank)], Precision::Fp32).unwrap();
    // Scoring changes nothing: the same losses again, and a training step on each frame alone
    // reports (before its update) the loss the batch gave that frame.
    assert_eq!(model.losses_in(&[frame(&seen), frame(&blank)], Precision::Fp32).unwrap(), losses);
    let alone = model.losses_in(&[frame(&blank)], Precision::Fp32).unwrap();
    assert!((alone[0] - losses[1]).abs() < 1e-6 * losses[1].abs().max(1.0));
    let trained = model.train_step(&seen, &truth, &[]).unwrap().total;
    assert!((trained - losses[0]).abs() < 1e-5 * trained.abs().max(1.0), "{trained} {losses:?}");
    // After training on the frame with its object, that frame costs less than the blank one
    // that hides it.
    for _ in 0..150 {
        model.train_step(&seen, &truth, &[]).unwrap();
    }
    let after = model.losses_in(&[frame(&seen), frame(&blank)], Precision::Fp32).unwrap();
    assert!(after[0] < after[1], "{after:?}");
    assert!(model.losses_in(&[], Precision::Fp32).unwrap().is_empty());
}
