//! Batches: the input tensor, the object-weighted loss, frames of different sizes, and each frame
//! detected and scored as it would be alone.

use super::*;

/// The input batch is `DN / 255 − 0.5` in planar channels, bit for bit what the tensor ops
/// `permute`, `to_kind(Float)`, `/ 255`, `− 0.5` give for every byte value, in either frame of a
/// batch, with 2 threads (vectorised loops) as with 1.
#[test]
fn the_input_batch_is_the_tensor_ops_bit_for_bit() {
    let _serial = crate::torch_serial();
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
fn a_batch_loss_is_the_object_weighted_combination_of_its_images() {
    let _serial = crate::torch_serial();
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
fn a_batch_of_frames_of_different_sizes_is_refused() {
    let _serial = crate::torch_serial();
    let engine = Engine::cpu(1);
    let mut model = small_model(&engine);
    let (a, b) = (Rgb8Image::zeros(32, 24), Rgb8Image::zeros(24, 32));
    let frame = |image| TrainFrame { image, truth: &[], ignore: &[] };
    let err = model.train_batch(&[frame(&a), frame(&b)]).unwrap_err().to_string();
    assert_eq!(err, "training batch: frames of 32×24 and 24×32: a batch needs frames of one size");
    assert!(model.train_batch(&[]).is_err());
}

/// A batch gives each frame the detections it gets alone (group normalisation is per frame):
/// same classes and order, boxes and scores equal to float rounding.
#[test]
fn a_batch_detects_what_each_frame_does_alone() {
    let _serial = crate::torch_serial();
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
    let _serial = crate::torch_serial();
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

/// One forward pass gives what the two separate calls give: `detect`'s detections to the bit,
/// and the training step's loss of the frame (reported before its update).
#[test]
fn detect_with_loss_is_detect_and_the_frames_training_loss() {
    let _serial = crate::torch_serial();
    let engine = Engine::cpu(1);
    engine.seed(7);
    let mut model = small_model(&engine);
    let b = BBox::new(20.0, 16.0, 44.0, 36.0);
    let seen = frame_with_box(64, 48, b);
    let truth = [Annotation::new(b, Class::Vehicle)];
    let (found, loss) =
        model.detect_with_loss(TrainFrame { image: &seen, truth: &truth, ignore: &[] });
    assert_eq!(found, model.detect(&seen));
    let trained = model.train_step(&seen, &truth, &[]).unwrap().total;
    let loss = loss.total;
    assert!((trained - loss).abs() < 1e-5 * trained.abs().max(1.0), "{trained} {loss}");
}
