//! Tunnels as places: the road inside reads the lamps' level plus the mouths' daylight (their
//! closed form, written out here), the portal and the street outside keep the daylight, a tunnel
//! episode passes its mouth when it says, the rest of the town is the town without tunnels, and
//! the frames repeat.

use super::*;
use joca_sim::city::{CLEARANCE_M, Tunnel};
use joca_sim::{TunnelDrives, Tunnels};

const LAMPS: f32 = 0.02;

fn town(tunnels: Tunnels) -> City {
    let config = CityConfig { tunnels, ..CityConfig::default() };
    City::generate(&config, &mut joca_core::SeedStreams::new(5).stream("city"))
}

fn places() -> Tunnels {
    Tunnels { count: 3, lamp_level: LAMPS, ..Tunnels::places() }
}

/// The daylight a mouth lets in at `d` metres, as the module documents it: a disc of the
/// mouth's area and luminance 0.3·E/π, on a surface parallel to the axis.
fn mouth_light(t: &Tunnel, d: f32) -> f32 {
    let area = 2.0 * t.half_width_m * CLEARANCE_M;
    let a2 = area / std::f32::consts::PI;
    let c = 0.5 * area.sqrt();
    0.5 * 0.3 * a2 / (a2 + d * d) * c / (c * c + d * d).sqrt()
}

/// A simulator on `city` without its moving objects, the ego standing in the tunnel's lane at
/// `along`, looking along it, by day with the sun at 50°.
fn standing(city: &City, t: &Tunnel, along: f32) -> Simulator {
    let mut city = city.clone();
    city.objects.retain(|o| o.motion.is_static() && o.class.is_none());
    let p = t.world(along, -1.75, 0.0);
    let yaw = if t.along_x { 0.0 } else { std::f32::consts::FRAC_PI_2 };
    let config = SimConfig {
        illumination: Some(Illumination::Day),
        city: CityConfig { tunnels: places(), ..CityConfig::default() },
        ..SimConfig::default()
    };
    let sim = Simulator::with_city(config, city);
    let e = 50f32.to_radians();
    sim.set_episode(
        0,
        Episode {
            ego: EgoTrajectory::scripted(Pose2 { x: p.x, y: p.y, yaw }, 0.0, 0.0, 70.0),
            illumination: Illumination::Day,
            phase_s: 0.0,
            sun_dir: [e.cos() * 0.6, e.cos() * 0.8, e.sin()],
            mouth: None,
        },
    );
    sim
}

/// The radiance of the ground straight ahead, `ahead` metres in front of the camera, and the
/// irradiance the closed form gives there (`along`: the camera's place).
fn ground_ahead(city: &City, t: &Tunnel, along: f32, ahead: f32) -> (f32, f32) {
    let sim = standing(city, t, along);
    let (w, h, f, z) = (320usize, 240usize, 200.0f32, 1.5f32);
    let cam = camera(w, h, f64::from(f), [0.0, 0.0, f64::from(z)]);
    let frame = sim.render(&cam, &request(1.0, 5e-3, 1.0)).unwrap();
    // The row whose ray meets the ground `ahead` metres on: b = z / ahead below the axis.
    let y = (h as f32 / 2.0 + f * z / ahead - 0.5).round();
    let at = t.world(along + ahead_exact(y, h, f, z), -1.75, 0.0);
    let rho = city.ground_albedo(at.x, at.y)[1];
    let pixel = frame.hdr.data()[(y as usize * w + w / 2) * 3 + 1];
    let a = along + ahead_exact(y, h, f, z);
    let e = LAMPS + (mouth_light(t, a - t.from_m) + mouth_light(t, t.to_m - a)) * outside();
    (pixel, RADIANCE_SCALE_DN * rho * e)
}

/// Where row `y`'s ray meets the ground, metres ahead.
fn ahead_exact(y: f32, h: usize, f: f32, z: f32) -> f32 {
    z / ((y + 0.5 - h as f32 / 2.0) / f)
}

/// Daylight on the open ground: the sun at 50° and the sky.
fn outside() -> f32 {
    SUN * 50f32.to_radians().sin() + SKY
}

#[test]
fn the_road_inside_reads_the_lamps_and_the_mouths_daylight() {
    let city = town(places());
    assert_eq!(city.tunnels().len(), 3);
    let t = city.tunnels()[0];
    assert!((45.0..=80.0).contains(&t.length_m()), "{}", t.length_m());
    // From the middle (lamps dominate) and from just inside a mouth (its daylight dominates).
    for (along, ahead) in [(t.from_m + 0.3 * t.length_m(), 8.0), (t.from_m + 1.0, 3.0)] {
        let (pixel, expected) = ground_ahead(&city, &t, along, ahead);
        assert!((pixel / expected - 1.0).abs() < 0.02, "{along}: {pixel} against {expected}");
    }
    // Mid-tunnel the road is some 50 times darker than the open road, under a twentieth of it.
    let mid = t.from_m + 0.5 * t.length_m();
    let e = LAMPS + mouth_light(&t, 0.5 * t.length_m()) * 2.0 * outside();
    assert!(e < 0.05 * outside(), "{e}");
    assert!((t.irradiance(mid, 1.0, outside()) / e - 1.0).abs() < 1e-5);
}

#[test]
fn the_street_outside_keeps_its_daylight() {
    let city = town(places());
    let t = city.tunnels()[0];
    // Standing 20 m before the mouth and looking at the road 6 m ahead: sun and sky, and the
    // portal's shadow does not reach there (no cast shadows asked for).
    let sim = standing(&city, &t, t.from_m - 20.0);
    let cam = camera(320, 240, 200.0, [0.0, 0.0, 1.5]);
    let frame = sim.render(&cam, &request(1.0, 5e-3, 1.0)).unwrap();
    let y = (120.0f32 + 200.0 * 1.5 / 6.0 - 0.5).round();
    let ahead = ahead_exact(y, 240, 200.0, 1.5);
    let at = t.world(t.from_m - 20.0 + ahead, -1.75, 0.0);
    let rho = city.ground_albedo(at.x, at.y)[1];
    let pixel = frame.hdr.data()[(y as usize * 320 + 160) * 3 + 1];
    let expected = RADIANCE_SCALE_DN * rho * outside();
    assert!((pixel / expected - 1.0).abs() < 0.02, "{pixel} against {expected}");
}

/// A simulator of tunnel episodes through tunnels as places, driven as `drives` says.
fn tunnel_drives(drives: TunnelDrives) -> Simulator {
    Simulator::new(SimConfig {
        illumination: Some(Illumination::Tunnel),
        city: CityConfig { tunnels: Tunnels { drives, ..places() }, ..CityConfig::default() },
        ..SimConfig::default()
    })
}

#[test]
fn a_direction_of_drives_turns_only_the_drives_that_went_the_other_way() {
    let both = tunnel_drives(TunnelDrives::Both);
    for (drives, entering) in [(TunnelDrives::Entering, true), (TunnelDrives::Leaving, false)] {
        let sim = tunnel_drives(drives);
        for e in 0..12 {
            let (mouth, free) = (sim.episode(e).mouth.unwrap(), both.episode(e).mouth.unwrap());
            assert_eq!(mouth.entering, entering, "{drives} episode {e}");
            // The same draws: the same instant at the mouth; the same route where the drawn
            // direction was already this one.
            assert_eq!(mouth.time_s, free.time_s, "{drives} episode {e}");
            if free.entering == entering {
                let (a, b) = (sim.episode(e).ego.pose_at(3.0), both.episode(e).ego.pose_at(3.0));
                assert_eq!((a.x, a.y), (b.x, b.y), "{drives} episode {e}");
            }
            // Half a metre past the mouth's plane the camera is inside when it enters.
            let episode = sim.episode(e);
            let speed = episode.ego.speed_at(mouth.time_s);
            if speed > 1.0 {
                let p = episode.ego.pose_at(mouth.time_s + 0.5 / speed);
                let inside = sim.city().tunnel_at(V3::new(p.x, p.y, 1.0)).is_some();
                assert_eq!(inside, entering, "{drives} episode {e}");
            }
        }
    }
}

#[test]
fn a_tunnel_episode_passes_its_mouth_when_it_says() {
    let config = SimConfig {
        illumination: Some(Illumination::Tunnel),
        city: CityConfig { tunnels: places(), ..CityConfig::default() },
        ..SimConfig::default()
    };
    let sim = Simulator::new(config);
    let mut seen = [false; 2];
    for e in 0..12 {
        let episode = sim.episode(e);
        let mouth = episode.mouth.expect("a tunnel episode drives through a tunnel");
        assert!((1.3..=2.7).contains(&mouth.time_s), "{}", mouth.time_s);
        seen[usize::from(mouth.entering)] = true;
        let inside = |t_s: f64| {
            let p = episode.ego.pose_at(t_s);
            sim.city().tunnel_at(V3::new(p.x, p.y, 1.0)).is_some()
        };
        // Half a metre either side of the mouth's plane (unless the vehicle stands still there).
        let speed = episode.ego.speed_at(mouth.time_s);
        if speed > 1.0 {
            let dt = 0.5 / speed;
            assert_eq!(inside(mouth.time_s + dt), mouth.entering, "episode {e}");
            assert_eq!(inside(mouth.time_s - dt), !mouth.entering, "episode {e}");
        }
        // Daylight outside, the lamps' level inside: the light the showcase finds the step by.
        let level = sim.ambient_at(e, mouth.time_s + if mouth.entering { 0.5 } else { -0.5 });
        assert!(level == LAMPS || speed < 1.0, "episode {e}: {level}");
    }
    assert!(seen[0] && seen[1], "both entering and leaving drives");
    // Other lights keep their schedules and routes.
    let night = Simulator::new(SimConfig { illumination: Some(Illumination::Night), ..config });
    assert!(night.episode(0).mouth.is_none());
}

#[test]
fn the_rest_of_the_town_is_the_town_without_tunnels() {
    let (with, without) = (town(places()), town(Tunnels::default()));
    assert!(without.tunnels().is_empty());
    assert_eq!((&with.roads_x, &with.roads_y), (&without.roads_x, &without.roads_y));
    // Every object of the tunnel town that is not part of a tunnel stands in the plain town,
    // which adds only the street lamps the tunnels displaced.
    let covered = |o: &Object| {
        let p = o.position_at(0.0);
        with.tunnels().iter().any(|t| {
            let (along, across) = t.local(p.x, p.y);
            across.abs() < t.half_width_m + 2.0 && along > t.from_m - 2.0 && along < t.to_m + 2.0
        })
    };
    let built: Vec<&Object> =
        with.objects.iter().filter(|o| !without.objects.contains(o)).collect();
    assert!(built.iter().all(|o| covered(o)), "tunnel parts only");
    let gone: Vec<&Object> = without.objects.iter().filter(|o| !with.objects.contains(o)).collect();
    assert!(!gone.is_empty());
    assert!(
        gone.iter().all(|o| covered(o) && o.parts.iter().any(|p| p.material == Material::Lamp))
    );
}

#[test]
fn frames_in_a_tunnel_town_repeat() {
    let config = SimConfig {
        illumination: Some(Illumination::Tunnel),
        city: CityConfig { tunnels: places(), ..CityConfig::default() },
        ..SimConfig::default()
    };
    let cam = camera(160, 120, 100.0, [0.4, 0.0, 1.5]);
    let frame = |sim: &Simulator| sim.render(&cam, &request(2.0, 20e-3, 1.0)).unwrap();
    let (a, b) = (frame(&Simulator::new(config)), frame(&Simulator::new(config)));
    assert_eq!(a.hdr.data(), b.hdr.data());
    assert_eq!(a.boxes, b.boxes);
}
