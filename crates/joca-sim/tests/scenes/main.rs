//! The simulator against closed-form expectations: projection, blur, radiometry, ground truth,
//! determinism. Most tests use a hand-built scene (one object on an empty map, a scripted ego
//! vehicle) so that the expected values can be computed independently.
//! One test binary; its parts by subject.
#![allow(clippy::unwrap_used)]

mod blur;
#[path = "../common/mod.rs"]
mod common;
mod dark_streets;
mod determinism;
mod geometry;
mod optics;
mod radiometry;
mod shadows;
mod sun;
mod tunnels;

use common::{Agreement, shortcut_against_exact};
use joca_core::sun::{Daylight, SunElevation};
use joca_core::{Class, FrameRequest, FrameSource, PinholeCamera, Shot};
use joca_sim::geometry::{Pose2, V3};
use joca_sim::lighting::{Illumination, RADIANCE_SCALE_DN, SKY, SUN};
use joca_sim::objects::{Material, Motion, Object, Part};
use joca_sim::{City, CityConfig, EgoTrajectory, Episode, ShutterGrid, SimConfig, Simulator};

fn camera(width: usize, height: usize, focal_px: f64, mount: [f64; 3]) -> PinholeCamera {
    PinholeCamera::centred((width, height), (focal_px, focal_px), mount)
}

/// An empty map holding only `objects`, with a scripted ego vehicle in episode 0.
fn scene(
    objects: Vec<Object>,
    start: Pose2,
    speed_mps: f64,
    yaw_rate: f64,
    light: Illumination,
    sun_elevation_deg: f32,
) -> Simulator {
    let config = SimConfig { illumination: Some(light), ..SimConfig::default() };
    let mut city = City::generate(
        &CityConfig { blocks: 4, ..CityConfig::default() },
        &mut joca_core::SeedStreams::new(1).stream("city"),
    );
    city.objects = objects;
    let sim = Simulator::with_city(config, city);
    let e = sun_elevation_deg.to_radians();
    sim.set_episode(
        0,
        Episode {
            ego: EgoTrajectory::scripted(start, speed_mps, yaw_rate, 70.0),
            illumination: light,
            phase_s: 0.0,
            sun_dir: [e.cos() * 0.6, e.cos() * 0.8, e.sin()],
            mouth: None,
        },
    );
    sim
}

fn block(centre: V3, half: V3, material: Material, class: Option<Class>) -> Object {
    Object::new(
        class,
        vec![Part::new(V3::new(0.0, 0.0, centre.z), half, material)],
        Motion::Static(Pose2 { x: centre.x, y: centre.y, yaw: 0.0 }),
    )
}

fn request(time_s: f64, exposure_s: f64, motion_scale: f64) -> FrameRequest {
    FrameRequest { episode: 0, time_s, exposure_s, motion_scale }
}
