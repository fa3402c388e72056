//! Where things land: projection against the pinhole model, the reference objects, and the
//! ground truth's field of view and occlusion.

use super::*;

#[test]
fn a_known_box_projects_to_the_predicted_pixels_and_scales_with_focal_length() {
    // Ego at the origin heading east; camera 1 m forward, 1.5 m up. A 2×2×2 m box whose centre
    // is 20 m ahead of the camera, 3 m to the left, 1.5 m up.
    let cube = block(
        V3::new(21.0, 3.0, 1.5),
        V3::new(1.0, 1.0, 1.0),
        Material::Flat([0.5; 3]),
        Some(Class::Vehicle),
    );
    let sim =
        scene(vec![cube], Pose2 { x: 0.0, y: 0.0, yaw: 0.0 }, 0.0, 0.0, Illumination::Day, 50.0);
    let mut widths = Vec::new();
    for focal in [200.0, 400.0] {
        let cam = camera(640, 480, focal, [1.0, 0.0, 1.5]);
        let frame = sim.render(&cam, &request(1.0, 1e-3, 1.0)).unwrap();
        assert_eq!(frame.boxes.len(), 1);
        // Closed-form pinhole projection of the extreme visible corners: the near face (19 m
        // from the camera) bounds the box vertically and on the left (its far-left edge at
        // y = 4 m); the side face that looks at the camera ends at 21 m, y = 2 m, on the right.
        let u = |x: f64, y_left: f64| 320.0 - focal * y_left / x;
        let v = |x: f64, z_up: f64| 240.0 - focal * z_up / x;
        let expected = [u(19.0, 4.0), v(19.0, 1.0), u(21.0, 2.0), v(19.0, -1.0)];
        let b = frame.boxes[0].bbox;
        let got = [b.x_min, b.y_min, b.x_max, b.y_max];
        for (g, e) in got.iter().zip(expected) {
            assert!(
                (f64::from(*g) - e).abs() <= 1.0,
                "focal {focal}: got {got:?}, expected {expected:?}"
            );
        }
        assert_eq!(frame.boxes[0].class, Class::Vehicle);
        widths.push(f64::from(b.width()));
        // Doubling the focal length halves tan(FoV/2).
        assert!((cam.hfov_rad() / 2.0).tan() * focal - 320.0 < 1e-9);
    }
    assert!((widths[1] / widths[0] - 2.0).abs() < 0.05, "{widths:?}");
}

#[test]
fn reference_objects_have_any_size_and_end_at_their_class_range() {
    // A 2 m cube at 20 m is ≈ 21 px wide at f = 200 px; at 60 m ≈ 6.8 px, too small for the
    // detector's training rule (8 px) but still a reference object: a miss if not found. At
    // 120 m it lies beyond the vehicle range (100 m): an ignore region where it is. The same
    // cube as a walker at 60 m is beyond the walker range (50 m).
    let cases = [
        (20.0f64, Class::Vehicle, true),
        (60.0, Class::Vehicle, true),
        (120.0, Class::Vehicle, false),
        (60.0, Class::Walker, false),
        (40.0, Class::Walker, true),
    ];
    for (distance, class, reference) in cases {
        let cube = block(
            V3::new(1.0 + distance as f32, 0.0, 1.5),
            V3::new(1.0, 1.0, 1.0),
            Material::Flat([0.5; 3]),
            Some(class),
        );
        let sim = scene(
            vec![cube],
            Pose2 { x: 0.0, y: 0.0, yaw: 0.0 },
            0.0,
            0.0,
            Illumination::Day,
            50.0,
        );
        let frame = sim.render(&camera(640, 480, 200.0, [1.0, 0.0, 1.5]), &request(1.0, 1e-3, 1.0));
        let frame = frame.unwrap();
        let (found, other) =
            if reference { (&frame.boxes, &frame.ignore) } else { (&frame.ignore, &frame.boxes) };
        assert!(other.is_empty(), "{distance} m {class:?}: {frame:?}");
        assert_eq!(found.len(), 1, "{distance} m {class:?}");
        assert_eq!(found[0].class, class);
        // The distance is the horizontal range from the camera to the object's centre.
        let d = f64::from(found[0].distance_m.unwrap());
        assert!((d - distance).abs() < 1e-3, "{d} vs {distance}");
        // Centred on the principal point, 2·200/(d − 1) px wide (the near face); the reference
        // grid samples 2.5 times finer than this camera, so the box is within 0.4 px.
        let expected = 2.0 * 200.0 / (distance - 1.0);
        let b = found[0].bbox;
        assert!((f64::from(b.width()) - expected).abs() <= 0.5, "{distance} m: {b:?}");
        assert!((f64::from(b.x_min + b.x_max) / 2.0 - 320.0).abs() <= 0.5);
    }
}

#[test]
fn two_designs_of_one_field_of_view_get_the_same_reference_objects() {
    // Issue 22 (5): a 64×48 and a 640×480 camera with the same field of view see the same town
    // at the same instant; their reference objects are the same objects, the boxes scaled by
    // the resolution ratio, however few pixels the small camera gives the far ones.
    let sim =
        Simulator::new(SimConfig { illumination: Some(Illumination::Day), ..SimConfig::default() });
    let mut seen = 0;
    for time_s in [2.0, 9.0, 23.0, 41.0] {
        let big = sim.render(&camera(640, 480, 400.0, [1.5, 0.0, 1.5]), &request(time_s, 0.0, 1.0));
        let small = sim.render(&camera(64, 48, 40.0, [1.5, 0.0, 1.5]), &request(time_s, 0.0, 1.0));
        let (big, small) = (big.unwrap(), small.unwrap());
        assert_eq!(big.boxes.len(), small.boxes.len(), "t = {time_s}");
        assert_eq!(big.ignore.len(), small.ignore.len(), "t = {time_s}");
        for (a, b) in big.boxes.iter().zip(&small.boxes).chain(big.ignore.iter().zip(&small.ignore))
        {
            assert_eq!((a.class, a.distance_m), (b.class, b.distance_m));
            let scaled = b.bbox.scaled(10.0, 10.0);
            for (p, q) in [
                (a.bbox.x_min, scaled.x_min),
                (a.bbox.y_min, scaled.y_min),
                (a.bbox.x_max, scaled.x_max),
                (a.bbox.y_max, scaled.y_max),
            ] {
                assert!((p - q).abs() < 1e-3, "t = {time_s}: {a:?} vs {b:?}");
            }
        }
        seen += big.boxes.len();
        // Some of them are smaller than a pixel of the small camera.
    }
    assert!(seen >= 4, "the test needs objects in view: {seen}");
}

#[test]
fn ground_truth_follows_the_field_of_view_and_the_180_count_does_not() {
    let sim =
        Simulator::new(SimConfig { illumination: Some(Illumination::Day), ..SimConfig::default() });
    // The same angular resolution (focal length in pixels) for both, so that only the field of
    // view differs: 40° across 320 px, and 120° across 1523 px.
    let focal = 160.0 / 20f64.to_radians().tan();
    let narrow = camera(320, 240, focal, [1.0, 0.0, 1.5]);
    let wide = camera(
        (2.0 * focal * 60f64.to_radians().tan()).round() as usize,
        240,
        focal,
        [1.0, 0.0, 1.5],
    );
    let (mut n_wide, mut n_narrow) = (0, 0);
    for k in 0..12 {
        let r = FrameRequest {
            episode: 2,
            time_s: 1.0 + k as f64 * 3.0,
            exposure_s: 2e-3,
            motion_scale: 1.0,
        };
        let a = sim.render(&wide, &r).unwrap();
        let b = sim.render(&narrow, &r).unwrap();
        n_wide += a.boxes.len();
        n_narrow += b.boxes.len();
        assert_eq!(a.visible_180, b.visible_180, "frame {k}");
        for x in a.boxes.iter().chain(&b.boxes) {
            // Reference objects have any size, but never less than one reference-grid pixel.
            assert!(x.bbox.width() > 0.0 && x.bbox.height() > 0.0);
            assert!(x.bbox.x_min >= 0.0 && x.bbox.y_min >= 0.0 && x.bbox.y_max <= 240.0);
        }
        assert!(b.boxes.iter().all(|x| x.bbox.x_max <= 320.0));
    }
    assert!(n_wide > n_narrow, "wide {n_wide} vs narrow {n_narrow}");
}

#[test]
fn occluded_objects_have_no_box_and_do_not_count_in_180() {
    // A walker 15 m ahead hidden behind a wall 8 m ahead, and a visible sign 10 m ahead.
    let wall =
        block(V3::new(8.0, 0.0, 2.0), V3::new(0.2, 4.0, 2.0), Material::Flat([0.3; 3]), None);
    let walker = block(
        V3::new(15.0, 0.0, 0.9),
        V3::new(0.2, 0.3, 0.9),
        Material::Flat([0.5; 3]),
        Some(Class::Walker),
    );
    let sign = block(
        V3::new(10.0, -7.0, 2.4),
        V3::new(0.05, 0.35, 0.35),
        Material::Sign(0),
        Some(Class::TrafficSign),
    );
    let sim = scene(vec![wall, walker, sign], Pose2::default(), 0.0, 0.0, Illumination::Day, 50.0);
    let frame =
        sim.render(&camera(320, 240, 160.0, [0.0, 0.0, 1.5]), &request(1.0, 5e-3, 1.0)).unwrap();
    assert_eq!(frame.boxes.len(), 1, "{:?}", frame.boxes);
    assert_eq!(frame.boxes[0].class, Class::TrafficSign);
    assert_eq!(frame.visible_180, 1);
}
