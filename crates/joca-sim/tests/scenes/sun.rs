//! The sun's disc: its light on the frame is the sun's irradiance (π·RADIANCE_SCALE_DN·SUN in
//! the renderer's unit), it sits where the sun's direction projects, a nearer surface hides
//! it, and without `sun_disc` (or while the lamps are on) the sky has none.

use super::*;

/// One frame of an empty street from the origin heading +x, 320 × 240 at f = 200 px, the sun
/// at `elevation_deg` straight ahead; `objects` in view.
fn frame(objects: &[Object], light: Illumination, elevation_deg: f32, sun_disc: bool) -> Vec<f32> {
    let config = SimConfig { illumination: Some(light), sun_disc, ..SimConfig::default() };
    let mut city = City::generate(
        &CityConfig { blocks: 4, ..CityConfig::default() },
        &mut joca_core::SeedStreams::new(1).stream("city"),
    );
    city.objects = objects.to_vec();
    let sim = Simulator::with_city(config, city);
    let e = elevation_deg.to_radians();
    sim.set_episode(
        0,
        Episode {
            ego: EgoTrajectory::scripted(Pose2::default(), 0.0, 0.0, 70.0),
            illumination: light,
            phase_s: 0.0,
            sun_dir: [e.cos(), 0.0, e.sin()],
        },
    );
    let cam = camera(320, 240, 200.0, [1.0, 0.0, 1.5]);
    sim.render(&cam, &request(1.0, 5e-3, 1.0)).unwrap().hdr.data().to_vec()
}

#[test]
fn the_sun_s_disc_carries_the_sun_s_irradiance_where_it_projects() {
    let (with, without) =
        (frame(&[], Illumination::Day, 10.0, true), frame(&[], Illumination::Day, 10.0, false));
    // Σ (L − sky)·Ω_pixel over the frame, Ω_pixel = cos³θ/f² at the pixel's angle θ off axis.
    let mut light = 0.0f64;
    let (mut sx, mut sy, mut sw) = (0.0f64, 0.0f64, 0.0f64);
    for (p, (a, b)) in with.chunks_exact(3).zip(without.chunks_exact(3)).enumerate() {
        let d = f64::from(a[0] - b[0]);
        let (a, b) =
            (((p % 320) as f64 + 0.5 - 160.0) / 200.0, ((p / 320) as f64 + 0.5 - 120.0) / 200.0);
        light += d * (1.0 + a * a + b * b).powf(-1.5) / (200.0 * 200.0);
        sx += d * ((p % 320) as f64 + 0.5);
        sy += d * ((p / 320) as f64 + 0.5);
        sw += d;
    }
    let sun = std::f64::consts::PI * f64::from(RADIANCE_SCALE_DN * SUN);
    assert!((light / sun - 1.0).abs() < 0.01, "{light} against {sun}");
    // Its centre: straight ahead, 200·tan 10° above the horizon row.
    let (u, v) = (sx / sw, sy / sw);
    let expect_v = 120.0 - 200.0 * 10f64.to_radians().tan();
    assert!((u - 160.0).abs() < 0.05 && (v - expect_v).abs() < 0.05, "({u}, {v})");
    // Nothing else changed.
    let changed = with.iter().zip(&without).filter(|(a, b)| a != b).count();
    assert!(changed <= 3 * 9, "{changed} values changed");
}

#[test]
fn a_wall_at_night_or_no_disc_leave_the_sky_without_a_sun() {
    let (day, night) = (Illumination::Day, Illumination::Night);
    assert_eq!(frame(&[], night, 10.0, true), frame(&[], night, 10.0, false));
    // A wall 20 m ahead, 30 m high, hides the sun 10° up.
    let wall =
        block(V3::new(21.0, 0.0, 15.0), V3::new(1.0, 60.0, 15.0), Material::Flat([0.3; 3]), None);
    let walled = std::slice::from_ref(&wall);
    assert_eq!(frame(walled, day, 10.0, true), frame(walled, day, 10.0, false));
}
