//! NeuralAE's histograms, output ranges and forms, checked against closed forms.
use super::*;

#[test]
fn histograms_sum_to_one_per_tile_and_locate_brightness() {
    let _serial = crate::torch_serial();
    let mut data = vec![0u8; 14 * 14 * 3];
    // The top-left quarter is white.
    for y in 0..7 {
        for x in 0..7 {
            data[(y * 14 + x) * 3..(y * 14 + x) * 3 + 3].copy_from_slice(&[255, 255, 255]);
        }
    }
    let h = histograms(&Rgb8Image::from_vec(14, 14, data).unwrap());
    for tile in h.chunks(256) {
        assert!((tile.iter().sum::<f32>() - 1.0).abs() < 1e-6);
    }
    assert!((h[255] - 0.25).abs() < 1e-6 && (h[0] - 0.75).abs() < 1e-6); // whole image
    assert_eq!(h[256 + 255], 1.0); // 3×3 tile (0, 0) is all white
    assert_eq!(h[256 * 9], 1.0); // 3×3 tile (2, 2) is all black
}

#[test]
fn outputs_stay_inside_the_ranges_and_carry_gradients() {
    let _serial = crate::torch_serial();
    tch::manual_seed(1);
    let vs = nn::VarStore::new(Device::Cpu);
    let bounds = AccBounds::new(AccRanges::PAPER);
    let net = NeuralAe::new(&vs.root(), 32, bounds);
    let features = Tensor::randn([1, 32, 12, 16], (Kind::Float, Device::Cpu));
    let hist = histograms(&Rgb8Image::zeros(16, 12));
    let out = net.forward(&hist, &features, &[0.5, 0.5], Device::Cpu);
    let e = out.exposure_s.double_value(&[0]);
    let g = out.gain_db.double_value(&[0]);
    assert!((0.1e-3..=50e-3).contains(&e) && (1.0..=30.0).contains(&g), "{e} {g}");
    (out.exposure_s.sum(Kind::Float) + out.gain_db.sum(Kind::Float)).backward();
    let grads: f64 = vs
        .trainable_variables()
        .iter()
        .map(|v| v.grad().abs().sum(Kind::Double).double_value(&[]))
        .sum();
    assert!(grads > 0.0);
    assert_eq!(bounds.unit(50e-3, 1.0), [1.0, 0.0]);
    // Untrained, it predicts the calibration settings.
    assert!((e / 5e-3 - 1.0).abs() < 0.1 && (g - 10.0).abs() < 1.0, "{e} {g}");
    assert!(out.iris.is_none());
}

/// A relative head: untrained it holds the previous settings; its step is at most
/// `max_stops` on each of exposure and gain (a factor 2^s, 6.02·s dB); at a range's end the
/// value stays inside while the gradient still reaches the step.
#[test]
fn a_relative_output_holds_untrained_steps_at_most_its_stops_and_passes_gradients() {
    let _serial = crate::torch_serial();
    tch::manual_seed(3);
    let vs = nn::VarStore::new(Device::Cpu);
    let bounds = AccBounds::new(AccRanges::PAPER);
    let mut net = NeuralAe::new(&vs.root(), 32, bounds);
    net.set_form(AccOutputForm::Relative { max_stops: 2.0 });
    let features = Tensor::randn([1, 32, 12, 16], (Kind::Float, Device::Cpu));
    let hist = histograms(&Rgb8Image::zeros(16, 12));
    let out = net.forward(&hist, &features, &bounds.unit(8e-3, 12.0), Device::Cpu);
    let (e, g) = (out.exposure_s.double_value(&[0]), out.gain_db.double_value(&[0]));
    // Small random output weights: a step of a few hundredths of a stop at most.
    assert!((e / 8e-3).log2().abs() < 0.05 && (g - 12.0).abs() < 0.3, "{e} {g}");
    // A saturated step: +2 stops of exposure (×4), +2 stops of gain (+12.04 dB).
    if let Some(bias) = net.out.bs.as_mut() {
        let _guard = tch::no_grad_guard();
        let _ = bias.narrow(0, 0, 2).fill_(50.0);
    }
    let out = net.forward(&hist, &features, &bounds.unit(8e-3, 12.0), Device::Cpu);
    let (e, g) = (out.exposure_s.double_value(&[0]), out.gain_db.double_value(&[0]));
    assert!((e - 32e-3).abs() < 1e-5 && (g - 24.04).abs() < 0.01, "{e} {g}");
    // From 30 ms and 25 dB the same step ends at the ranges' 50 ms and 30 dB.
    let out = net.forward(&hist, &features, &bounds.unit(30e-3, 25.0), Device::Cpu);
    let (e, g) = (out.exposure_s.double_value(&[0]), out.gain_db.double_value(&[0]));
    assert!((e - 50e-3).abs() < 1e-6 && (g - 30.0).abs() < 1e-4, "{e} {g}");
    // A step into range (bias -0.5: tanh -0.46, ~-0.92 stops) carries a gradient to the head.
    if let Some(bias) = net.out.bs.as_mut() {
        let _guard = tch::no_grad_guard();
        let _ = bias.narrow(0, 0, 2).fill_(-0.5);
    }
    let out = net.forward(&hist, &features, &bounds.unit(50e-3, 30.0), Device::Cpu);
    out.exposure_s.sum(Kind::Float).backward();
    let grad = vs.variables()["out.bias"].grad().double_value(&[0]);
    assert!(grad > 0.0, "{grad}");
}

#[test]
fn with_the_iris_a_third_output_starts_halfway_and_learns() {
    let _serial = crate::torch_serial();
    tch::manual_seed(2);
    let vs = nn::VarStore::new(Device::Cpu);
    let bounds = AccBounds::new(AccRanges::PAPER).with_iris();
    let net = NeuralAe::new(&vs.root(), 32, bounds);
    let features = Tensor::randn([1, 32, 12, 16], (Kind::Float, Device::Cpu));
    let previous = bounds.previous(5e-3, 10.0, None);
    assert_eq!(previous.len(), 3);
    let out =
        net.forward(&histograms(&Rgb8Image::zeros(16, 12)), &features, &previous, Device::Cpu);
    let iris = out.iris.expect("a third output");
    let u = iris.double_value(&[0]);
    assert!((u - 0.5).abs() < 0.01, "untrained iris at {u}");
    iris.sum(Kind::Float).backward();
    let out_grad = vs.variables()["out.weight"].grad().abs().sum(Kind::Double).double_value(&[]);
    assert!(out_grad > 0.0);
}
