//! The sun in the sky: its disc's light on the frame is the sun's irradiance
//! (π·RADIANCE_SCALE_DN·SUN in the renderer's unit) where the sun's direction projects, the sky
//! brightens towards it as the CIE clear sky, a nearer surface hides the disc, and without
//! `sun_disc` (or while the lamps are on) the sky has neither.

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
            mouth: None,
        },
    );
    let cam = camera(320, 240, 200.0, [1.0, 0.0, 1.5]);
    sim.render(&cam, &request(1.0, 5e-3, 1.0)).unwrap().hdr.data().to_vec()
}

#[test]
fn the_sun_s_disc_carries_the_sun_s_irradiance_where_it_projects() {
    let (with, without) =
        (frame(&[], Illumination::Day, 10.0, true), frame(&[], Illumination::Day, 10.0, false));
    // Σ (L − f·sky)·Ω_pixel within 5 px of the disc (f: the aureole's indicatrix, which the
    // sky there carries), Ω_pixel = cos³θ/f² at the pixel's angle θ off axis.
    let e = 10f64.to_radians();
    let (cu, cv) = (160.0, 120.0 - 200.0 * e.tan());
    let mut light = 0.0f64;
    let (mut sx, mut sy, mut sw) = (0.0f64, 0.0f64, 0.0f64);
    for (p, (a, b)) in with.chunks_exact(3).zip(without.chunks_exact(3)).enumerate() {
        let (x, y) = ((p % 320) as f64 + 0.5, (p / 320) as f64 + 0.5);
        if (x - cu).hypot(y - cv) > 5.0 {
            continue;
        }
        let (ta, tb) = ((x - 160.0) / 200.0, (y - 120.0) / 200.0);
        let norm = (1.0 + ta * ta + tb * tb).sqrt();
        let chi = ((e.cos() - tb * e.sin()) / norm).clamp(-1.0, 1.0).acos();
        let d = f64::from(a[0]) - f64::from(b[0] * joca_sim::render::sun::indicatrix(chi as f32));
        light += d / norm.powi(3) / (200.0 * 200.0);
        sx += d * x;
        sy += d * y;
        sw += d;
    }
    let sun = std::f64::consts::PI * f64::from(RADIANCE_SCALE_DN * SUN);
    assert!((light / sun - 1.0).abs() < 0.01, "{light} against {sun}");
    // Its centre: straight ahead, 200·tan 10° above the horizon row.
    let (u, v) = (sx / sw, sy / sw);
    assert!((u - cu).abs() < 0.05 && (v - cv).abs() < 0.05, "({u}, {v})");
}

/// The sky away from the disc reads the renderer's sky times the CIE clear sky's indicatrix at
/// each pixel's angle from the sun; the ground does not change.
#[test]
fn the_sky_brightens_towards_the_sun_as_the_cie_clear_sky() {
    use joca_sim::render::sun::indicatrix;
    let (with, without) =
        (frame(&[], Illumination::Day, 10.0, true), frame(&[], Illumination::Day, 10.0, false));
    let e = 10f64.to_radians();
    let sun = [e.cos(), 0.0, e.sin()];
    for (x, y) in [(160usize, 60usize), (170, 80), (20, 10), (300, 100), (160, 5)] {
        // The pixel's view ray: +x ahead, +y to the left, up for rows above 120.
        let (a, b) = ((x as f64 + 0.5 - 160.0) / 200.0, (y as f64 + 0.5 - 120.0) / 200.0);
        let norm = (1.0 + a * a + b * b).sqrt();
        let chi = ((sun[0] - b * sun[2]) / norm).acos();
        let p = (y * 320 + x) * 3;
        let ratio = with[p] / without[p];
        let expect = indicatrix(chi as f32);
        assert!((ratio / expect - 1.0).abs() < 1e-4, "({x}, {y}): {ratio} against {expect}");
    }
    assert!(indicatrix(0.0) > 11.0 && (indicatrix(std::f32::consts::FRAC_PI_2) - 1.0).abs() < 1e-6);
    let ground = 200 * 320 * 3;
    assert_eq!(with[ground..], without[ground..]);
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
