//! Motion blur against exposure and speed, and the shutter's sub-frame grid against finer ones.

use super::*;

/// Pixels of row `y` (green channel) lying strictly between 10 % and 90 % of the way from the
/// darkest to the brightest value of the row: the width of the blurred edges.
fn edge_spread(frame: &joca_core::Frame, y: usize) -> usize {
    let w = frame.hdr.width();
    let row: Vec<f32> = (0..w).map(|x| frame.hdr.pixel(x, y)[1]).collect();
    let lo = row.iter().copied().fold(f32::INFINITY, f32::min);
    let hi = row.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let (a, b) = (lo + 0.1 * (hi - lo), lo + 0.9 * (hi - lo));
    row.iter().filter(|&&v| v > a && v < b).count()
}

/// A dark 6 m tall pillar 12 m ahead and 4 m to the left, seen against the sky.
fn pillar_scene(speed: f64, yaw_rate: f64) -> Simulator {
    let pillar =
        block(V3::new(13.0, 4.0, 3.0), V3::new(0.5, 0.5, 3.0), Material::Flat([0.04; 3]), None);
    scene(
        vec![pillar],
        Pose2 { x: 0.0, y: 0.0, yaw: 0.0 },
        speed,
        yaw_rate,
        Illumination::Day,
        50.0,
    )
}

#[test]
fn blur_grows_with_exposure_and_speed_and_vanishes_without_motion() {
    let cam = camera(320, 240, 200.0, [1.0, 0.0, 1.5]);
    let row = 70; // above the horizon (120): the pillar against the sky
    let spread = |sim: &Simulator, e: f64| {
        edge_spread(&sim.render(&cam, &request(0.5, e, 1.0)).unwrap(), row)
    };
    let fast = pillar_scene(15.0, 0.0);
    let s: Vec<usize> = [1e-3, 10e-3, 40e-3].iter().map(|&e| spread(&fast, e)).collect();
    assert!(s[0] <= 2 && s[0] < s[1] && s[1] < s[2], "spread over exposure {s:?}");
    let slow = pillar_scene(5.0, 0.0);
    assert!(spread(&slow, 40e-3) < s[2], "slow {} vs fast {}", spread(&slow, 40e-3), s[2]);
    // Turning blurs too, even at a crawl.
    let turning = pillar_scene(0.5, 0.8);
    assert!(spread(&turning, 40e-3) > spread(&pillar_scene(0.5, 0.0), 40e-3));

    // No ego motion, no actor motion: the shutter time changes nothing at all.
    let still = pillar_scene(0.0, 0.0);
    let a = still.render(&cam, &request(0.5, 1e-3, 1.0)).unwrap();
    let b = still.render(&cam, &request(0.5, 45e-3, 1.0)).unwrap();
    assert_eq!(a.hdr, b.hdr);
    assert!(edge_spread(&b, row) <= 2);
}

#[test]
fn motion_blur_scale_multiplies_the_motion_during_the_shutter() {
    let sim = pillar_scene(12.0, 0.3);
    let cam = camera(320, 240, 200.0, [1.0, 0.0, 1.5]);
    // ×4 over 10 ms integrates exactly the motion of 40 ms.
    let scaled = sim.render(&cam, &request(0.5, 10e-3, 4.0)).unwrap();
    let long = sim.render(&cam, &request(0.5, 40e-3, 1.0)).unwrap();
    assert_eq!(scaled.hdr, long.hdr);
    let plain = sim.render(&cam, &request(0.5, 10e-3, 1.0)).unwrap();
    assert!(edge_spread(&scaled, 70) > edge_spread(&plain, 70));
}

/// Mean absolute difference of two frames over the mean of the second (relative error).
fn relative_difference(a: &joca_core::Frame, b: &joca_core::Frame) -> f64 {
    let (x, y) = (a.hdr.data(), b.hdr.data());
    let diff: f64 = x.iter().zip(y).map(|(p, q)| f64::from((p - q).abs())).sum();
    let mean: f64 = y.iter().map(|&q| f64::from(q)).sum();
    diff / mean
}

#[test]
fn the_frames_of_one_instant_share_one_grid_and_equal_separate_renders_on_it() {
    // Driving and turning past the pillar: every sub-frame differs.
    let sim = pillar_scene(12.0, 0.3);
    let cam = camera(320, 240, 200.0, [1.0, 0.0, 1.5]);
    let exposures = [2e-3, 11e-3, 30e-3];
    let r = request(0.5, 0.0, 1.0);
    let frames = sim.render_exposures(&cam, &r, &exposures).unwrap();
    // The longest shutter uses every cell of the grid.
    let cells = frames[2].subframes as usize;
    assert!(cells > 9, "{cells} cells");
    assert!(frames[0].subframes < frames[1].subframes && frames[1].subframes < cells as u32);
    let grid = ShutterGrid::new(0.5, 30e-3, cells);
    for (frame, &e) in frames.iter().zip(&exposures) {
        let alone = sim.render_on_grid(&cam, &r, &[e], &grid).unwrap().remove(0);
        assert_eq!(frame, &alone, "exposure {e}");
        // Ground truth is of the frame's time, whatever the exposure.
        assert_eq!(frame.boxes, frames[0].boxes);
    }
    // `render` is `render_exposures` of one exposure: the longest alone has the same grid.
    assert_eq!(sim.render(&cam, &request(0.5, 30e-3, 1.0)).unwrap(), frames[2]);
    // The grid's weights are a box filter in time: they sum to 1 and are symmetric.
    for s in [0.0, 1e-3, 11e-3, 30e-3] {
        let w = grid.weights(s);
        assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6, "{s}: {w:?}");
        assert!(w.iter().zip(w.iter().rev()).all(|(a, b)| (a - b).abs() < 1e-7), "{s}: {w:?}");
    }
}

#[test]
fn nested_shutters_are_within_the_sampling_error_of_a_grid_four_times_finer() {
    let sim = pillar_scene(14.0, 0.4);
    let cam = camera(320, 240, 200.0, [1.0, 0.0, 1.5]);
    let r = request(0.5, 0.0, 1.0);
    let exposures = [4e-3, 12e-3, 25e-3, 40e-3];
    let nested = sim.render_exposures(&cam, &r, &exposures).unwrap();
    for (frame, &e) in nested.iter().zip(&exposures) {
        // Today's per-exposure grid (the exposure rendered alone) and a reference grid with four
        // times its sub-frames.
        let own = sim.render(&cam, &request(0.5, e, 1.0)).unwrap();
        let fine = ShutterGrid::new(0.5, e, 4 * own.subframes as usize);
        let reference = sim.render_on_grid(&cam, &r, &[e], &fine).unwrap().remove(0);
        let (err_nested, err_own) =
            (relative_difference(frame, &reference), relative_difference(&own, &reference));
        eprintln!(
            "E {:.0} ms: nested {} cells, own {} cells: error {err_nested:.5} vs {err_own:.5}",
            e * 1e3,
            frame.subframes,
            own.subframes
        );
        assert!(err_nested <= 2.0 * err_own + 1e-3, "E {e}: {err_nested} vs {err_own}");
    }
}
