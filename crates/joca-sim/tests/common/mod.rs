//! What the simulator's integration tests share.
#![allow(clippy::unwrap_used)]

use joca_core::{FrameRequest, FrameSource, PinholeCamera};
use joca_sim::Simulator;

/// How far a shortcut's frame lies from the exact model's, over every value.
pub struct Agreement {
    /// The exact frame's mean, DN.
    pub level: f32,
    /// Mean |Δ|, DN.
    pub mad: f32,
    /// Largest |Δ|, DN.
    pub worst: f32,
    /// Values off by more than 5 % of the level.
    pub off: usize,
    /// Values compared.
    pub values: usize,
}

/// The shortcut `fast` against the `exact` model on a fast, long exposure (2 × 40 ms of motion)
/// at two instants (episode 1 at 6 s, episode 2 at 9 s), each with more than 5 sub-frames.
pub fn shortcut_against_exact(
    fast: &Simulator,
    exact: &Simulator,
    cam: &PinholeCamera,
) -> Vec<Agreement> {
    [(1u64, 6.0), (2, 9.0)]
        .into_iter()
        .map(|(episode, t)| {
            let request = FrameRequest { episode, time_s: t, exposure_s: 40e-3, motion_scale: 2.0 };
            let a = fast.render(cam, &request).unwrap();
            let b = exact.render(cam, &request).unwrap();
            assert!(a.subframes > 5, "{} sub-frames: too little motion to test", a.subframes);
            let (va, vb) = (a.hdr.data(), b.hdr.data());
            let level = vb.iter().sum::<f32>() / vb.len() as f32;
            let diff = || va.iter().zip(vb).map(|(x, y)| (x - y).abs());
            Agreement {
                level,
                mad: diff().sum::<f32>() / va.len() as f32,
                worst: diff().fold(0.0f32, f32::max),
                off: diff().filter(|&d| d > 0.05 * level).count(),
                values: va.len(),
            }
        })
        .collect()
}
