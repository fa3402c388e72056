//! The same inputs give the same frame, on any thread count and in reused buffers.

use super::*;

#[test]
fn frames_are_bit_identical_for_the_same_inputs_on_any_thread_count() {
    let cam = camera(160, 120, 100.0, [1.2, 0.0, 1.6]);
    let r = FrameRequest { episode: 4, time_s: 7.3, exposure_s: 20e-3, motion_scale: 2.0 };
    let render = |threads: usize| {
        let sim = Simulator::new(SimConfig { map_seed: 9, ..SimConfig::default() });
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| sim.render(&cam, &r).unwrap())
    };
    let a = render(1);
    let b = render(2);
    assert_eq!(a, b);
    let digest = joca_core::rng::fnv1a64(
        &a.hdr.data().iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>(),
    );
    let again = joca_core::rng::fnv1a64(
        &render(2).hdr.data().iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>(),
    );
    assert_eq!(digest, again);
    // Another map seed gives another frame.
    let other = Simulator::new(SimConfig { map_seed: 10, ..SimConfig::default() })
        .render(&cam, &r)
        .unwrap();
    assert_ne!(a.hdr, other.hdr);
}

/// The simulators of a process reuse render buffers from frame to frame; a frame rendered after
/// buffers held other views (another instant, day and night, a shorter and a longer shutter, a
/// frame of another size in between) is the frame a new simulator renders for it, ground truth
/// included (that a reused target renders as a fresh one is tested in the renderer's tests).
#[test]
fn a_frame_in_reused_buffers_is_the_frame_of_a_fresh_simulator() {
    let cam = camera(160, 120, 100.0, [1.2, 0.0, 1.6]);
    let small = camera(96, 72, 60.0, [1.2, 0.0, 1.6]);
    let config = SimConfig { map_seed: 9, ..SimConfig::default() };
    let request = |episode: u64, time_s: f64, exposure_s: f64| FrameRequest {
        episode,
        time_s,
        exposure_s,
        motion_scale: 1.0,
    };
    let wanted = [request(4, 7.3, 20e-3), request(5, 30.0, 4e-3), request(4, 12.0, 33e-3)];
    let used = Simulator::new(config);
    let mut reused = Vec::new();
    for (k, r) in wanted.iter().enumerate() {
        used.render(&cam, &request(3 + k as u64, 2.0 + k as f64, 30e-3)).unwrap();
        used.render(&small, &request(3, 4.0, 10e-3)).unwrap();
        reused.push(used.render(&cam, r).unwrap());
    }
    for (r, frame) in wanted.iter().zip(&reused) {
        let fresh = Simulator::new(config).render(&cam, r).unwrap();
        assert_eq!(frame, &fresh, "{r:?}");
    }
}
