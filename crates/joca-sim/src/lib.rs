//! The built-in procedural driving simulator of joca.
//!
//! CARLA cannot ship with joca, so this crate renders what the paper's experiments need from a
//! simulator, deterministically and fast enough to sit inside the training loop:
//!
//! - [`City`]: a seeded Manhattan-grid town — roads with lanes, zebra crossings, sidewalks,
//!   buildings with windows, street lamps, traffic signs, parked and moving vehicles (with head
//!   and tail lights), walkers. Training and test maps come from different seed families.
//! - [`EgoTrajectory`]: the ego vehicle follows the roads, turns at intersections, and its speed
//!   keeps changing between 0 and a maximum.
//! - [`Illumination`]: day, night, tunnel (abrupt) and cycle (gradual) schedules, with radiometry
//!   in calibrated DN (daylight white ≈ 215 DN; night three orders darker except at lights).
//! - [`Simulator`]: a [`joca_core::FrameSource`] that renders `I0` for a camera, averages
//!   sub-frames over the shutter interval (motion blur from ego and actor motion), and extracts
//!   ground truth at the shutter midpoint plus the 180° visible-object count.
//!
//! ```
//! use joca_core::{FrameRequest, FrameSource, PinholeCamera};
//! use joca_sim::{SimConfig, Simulator};
//!
//! let sim = Simulator::new(SimConfig::default());
//! let camera = PinholeCamera {
//!     width_px: 64, height_px: 48, fx_px: 40.0, fy_px: 40.0, cx_px: 32.0, cy_px: 24.0,
//!     mount_m: [1.0, 0.0, 1.5],
//!     lens: None,
//! };
//! let request = FrameRequest { episode: 0, time_s: 2.0, exposure_s: 5e-3, motion_scale: 1.0 };
//! let frame = sim.render(&camera, &request).unwrap();
//! assert_eq!(frame.hdr.width(), 64);
//! ```
#![deny(missing_docs)]

pub mod city;
pub mod ego;
pub mod geometry;
pub mod lighting;
pub mod objects;
pub mod render;
mod sim;

pub use city::{City, CityConfig};
pub use ego::EgoTrajectory;
pub use joca_core::glare::Glare;
pub use joca_core::tunnels::{TunnelDrives, TunnelKind, Tunnels};
pub use joca_core::weather::Weather;
pub use lighting::{Illumination, SunElevation, TUNNEL_PHASE_S};
pub use sim::{
    Episode, MAX_SUBFRAMES, Mouth, REFERENCE_MAX_PX, REFERENCE_PX_PER_RAD, ShutterGrid, SimConfig,
    Simulator, VisibilityRules, reference_camera,
};

use rand::Rng;

/// Map seed of training town `index`. Training and test towns come from separate seed families
/// (the paper tests on a town never seen in training); neither depends on a run's seed, so every
/// run trains on the same towns and is tested on the same one.
pub fn train_map_seed(index: u64) -> u64 {
    joca_core::SeedStreams::new(0x6a6f_6361).indexed("train-map", index).random()
}

/// Map seed of test town `index` (see [`train_map_seed`]).
pub fn test_map_seed(index: u64) -> u64 {
    joca_core::SeedStreams::new(0x6a6f_6361).indexed("test-map", index).random()
}
