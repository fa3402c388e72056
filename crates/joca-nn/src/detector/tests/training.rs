//! Training: a box learnt in a few hundred steps, weights saved and refused, a non-finite loss
//! refused, the weight average, bfloat16 against float32.

use super::*;

#[test]
fn learns_to_find_a_box_in_a_few_hundred_steps() {
    let _serial = crate::torch_serial();
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
fn weights_round_trip_and_refuse_another_architecture() {
    let _serial = crate::torch_serial();
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
fn a_non_finite_loss_is_refused_before_any_weight_changes() {
    let _serial = crate::torch_serial();
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
    let _serial = crate::torch_serial();
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

#[test]
fn bfloat16_computation_stays_close_to_float32_and_trains_the_float32_weights() {
    let _serial = crate::torch_serial();
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
