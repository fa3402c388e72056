//! The training targets: heatmap peaks, ignore regions, class weights, the Gaussian regression
//! and the minimum radius.

use super::*;

#[test]
fn targets_peak_at_object_centres() {
    let _serial = crate::torch_serial();
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
    let _serial = crate::torch_serial();
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
    // … all of it in the background term.
    let background = |logit: f64| DetectionLoss::new(&output(logit), &plain).background;
    let extra = background(6.0) - background(-2.19);
    assert!((extra - expected).abs() < 1e-2 * expected, "{extra} vs {expected}");
}

#[test]
fn class_weights_scale_that_class_and_nothing_else() {
    let _serial = crate::torch_serial();
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
    // The background term is the heatmap less the peaks' (¼·ln 2 each, per object), and class
    // weights leave it alone.
    assert!((plain.heatmap - plain.background - peak).abs() < 1e-6);
    assert!((weighted.heatmap - weighted.background - 2.0 * peak).abs() < 1e-6);
    assert!((weighted.background - plain.background).abs() < 1e-9);
    assert!(plain.background > 0.0);
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
    let _serial = crate::torch_serial();
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
    let _serial = crate::torch_serial();
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
fn a_minimum_radius_softens_the_neighbours_of_a_small_objects_centre() {
    let _serial = crate::torch_serial();
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
