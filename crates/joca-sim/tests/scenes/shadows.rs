//! Cast shadows against the lighting model's closed forms: a surface in shadow keeps the sky's
//! share of its irradiance, exactly, and only where the geometry puts the shadow.

use super::*;

/// The camera of these tests: 320 × 240, f = 200 px, 1.5 m above the ground at the origin,
/// looking along +x.
fn cam() -> PinholeCamera {
    camera(320, 240, 200.0, [1.0, 0.0, 1.5])
}

/// The pixel that sees world point `p` through [`cam`] from the origin, heading +x.
fn pixel_of(p: V3) -> (usize, usize) {
    let depth = p.x - 1.0;
    let x = 160.0 + 200.0 * (-p.y) / depth;
    let y = 120.0 + 200.0 * (1.5 - p.z) / depth;
    (x as usize, y as usize)
}

/// One daylight frame of `objects` under a sun at `elevation_deg`, from `azimuth_deg`
/// (counter-clockwise from +x), with or without cast shadows.
fn frame(
    objects: &[Object],
    elevation_deg: f32,
    azimuth_deg: f32,
    shadows: bool,
) -> joca_core::Frame {
    frame_in(objects, elevation_deg, azimuth_deg, shadows, Daylight::Constant)
}

/// [`frame`] with the sun's and the sky's levels following `daylight`.
fn frame_in(
    objects: &[Object],
    elevation_deg: f32,
    azimuth_deg: f32,
    shadows: bool,
    daylight: Daylight,
) -> joca_core::Frame {
    let config = SimConfig {
        illumination: Some(Illumination::Day),
        cast_shadows: shadows,
        sun_elevation: SunElevation { daylight, ..SunElevation::at(elevation_deg) },
        ..SimConfig::default()
    };
    let mut city = City::generate(
        &CityConfig { blocks: 4, ..CityConfig::default() },
        &mut joca_core::SeedStreams::new(1).stream("city"),
    );
    city.objects = objects.to_vec();
    let sim = Simulator::with_city(config, city);
    let (e, a) = (elevation_deg.to_radians(), azimuth_deg.to_radians());
    sim.set_episode(
        0,
        Episode {
            ego: EgoTrajectory::scripted(Pose2::default(), 0.0, 0.0, 70.0),
            illumination: Illumination::Day,
            phase_s: 0.0,
            sun_dir: [e.cos() * a.cos(), e.cos() * a.sin(), e.sin()],
            mouth: None,
        },
    );
    sim.render(&cam(), &request(1.0, 5e-3, 1.0)).unwrap()
}

/// A white plate on the ground, and a 10 m tower placed so that the sun ray from the plate's
/// centre meets it: the shadowed plate reads the sky's level, K·ρ·SKY, and the ground beside it
/// in the tower's shadow loses the same share; the sunlit ground keeps every bit.
#[test]
fn a_shadowed_patch_reads_the_sky_only_level() {
    let (elevation, azimuth) = (45.0f32, 53.13f32);
    let plate =
        block(V3::new(9.0, 0.0, 0.01), V3::new(2.0, 2.0, 0.01), Material::Flat([0.85; 3]), None);
    // 6 m from the plate's centre towards the sun, 10 m high (the ray is 6 m up there).
    let (ux, uy) = (azimuth.to_radians().cos(), azimuth.to_radians().sin());
    let tower = block(
        V3::new(9.0 + 6.0 * ux, 6.0 * uy, 5.0),
        V3::new(1.0, 1.0, 5.0),
        Material::Flat([0.4; 3]),
        None,
    );
    let objects = [plate, tower];
    let lit = frame(&objects, elevation, azimuth, false);
    let shaded = frame(&objects, elevation, azimuth, true);
    let (x, y) = pixel_of(V3::new(9.0, 0.0, 0.02));
    let sky_only = RADIANCE_SCALE_DN * 0.85 * SKY;
    let in_sun = RADIANCE_SCALE_DN * 0.85 * (SUN * elevation.to_radians().sin() + SKY);
    assert!((lit.hdr.pixel(x, y)[1] - in_sun).abs() < 0.5, "{:?}", lit.hdr.pixel(x, y));
    assert!((shaded.hdr.pixel(x, y)[1] - sky_only).abs() < 0.05, "{:?}", shaded.hdr.pixel(x, y));
    // The tower's shadow on the ground runs from its foot away from the sun; 9 m along it
    // (outside the plate) the ground keeps SKY / (SUN sin e + SKY) of its sunlit level.
    let ground = V3::new(9.0 + 6.0 * ux - 9.0 * ux, 6.0 * uy - 9.0 * uy, 0.0);
    let (gx, gy) = pixel_of(ground);
    let ratio = shaded.hdr.pixel(gx, gy)[1] / lit.hdr.pixel(gx, gy)[1];
    let expected = SKY / (SUN * elevation.to_radians().sin() + SKY);
    assert!((ratio - expected).abs() < 1e-4, "ground in shadow: {ratio} vs {expected}");
    // Ground the sun reaches (beside the camera's near field, away from the shadow) is
    // unchanged to the bit.
    let (sx, sy) = pixel_of(V3::new(5.0, 3.0, 0.0));
    assert_eq!(shaded.hdr.pixel(sx, sy), lit.hdr.pixel(sx, sy));
}

/// A cloudless sky's daylight under a low sun: a white plate in the sun reads
/// K·ρ·(SUN·b·sin h + SKY·d) and in a tower's shadow K·ρ·SKY·d, with b and d the beam and the
/// diffuse light of Meinel's and Haurwitz's clear sky at h relative to 50° (written out here from
/// the published forms, not from the crate); the sky seen above the horizon falls by d.
#[test]
fn a_low_sun_in_a_clear_sky_lights_by_the_published_beam_and_diffuse_levels() {
    let (elevation, azimuth) = (8.0f32, 53.13f32);
    let clear = |deg: f64| {
        let h = deg.to_radians();
        let air_mass = 1.0 / (h.sin() + 0.50572 * (deg + 6.07995).powf(-1.6364));
        let beam = 1353.0 * 0.7f64.powf(air_mass.powf(0.678));
        [beam, 1098.0 * h.sin() * (-0.057 / h.sin()).exp() - beam * h.sin()]
    };
    let ([b8, d8], [b50, d50]) = (clear(8.0), clear(50.0));
    let (b, d) = ((b8 / b50) as f32, (d8 / d50) as f32);
    let plate =
        block(V3::new(9.0, 0.0, 0.01), V3::new(2.0, 2.0, 0.01), Material::Flat([0.85; 3]), None);
    let (ux, uy) = (azimuth.to_radians().cos(), azimuth.to_radians().sin());
    // 6 m from the plate towards the sun the ray is 0.84 m up: a 2 m tower shadows the plate.
    let tower = block(
        V3::new(9.0 + 6.0 * ux, 6.0 * uy, 1.0),
        V3::new(1.0, 1.0, 1.0),
        Material::Flat([0.4; 3]),
        None,
    );
    let lit = frame_in(std::slice::from_ref(&plate), elevation, azimuth, true, Daylight::ClearSky);
    let shaded = frame_in(&[plate, tower], elevation, azimuth, true, Daylight::ClearSky);
    let (x, y) = pixel_of(V3::new(9.0, 0.0, 0.02));
    let in_sun = RADIANCE_SCALE_DN * 0.85 * (SUN * b * elevation.to_radians().sin() + SKY * d);
    let sky_only = RADIANCE_SCALE_DN * 0.85 * SKY * d;
    assert!((lit.hdr.pixel(x, y)[1] / in_sun - 1.0).abs() < 1e-3, "{:?}", lit.hdr.pixel(x, y));
    assert!(
        (shaded.hdr.pixel(x, y)[1] / sky_only - 1.0).abs() < 1e-3,
        "{:?}",
        shaded.hdr.pixel(x, y)
    );
    // The sky above the horizon: the constant daylight's radiance times d (the sun is behind
    // the camera's left, its brightening off).
    let constant = frame_in(&[], elevation, azimuth, false, Daylight::Constant);
    let ratio = lit.hdr.pixel(160, 20)[2] / constant.hdr.pixel(160, 20)[2];
    assert!((ratio - d).abs() < 1e-3, "sky: {ratio} vs {d}");
}

/// A facade facing the camera with the sun behind the camera's left shoulder, and a 10 m post
/// in front of it: the post's shadow on the facade is the strip the geometry gives (3 m to the
/// left of the post, up to 5 m high), where the facade keeps SKY/2 over SUN·cos + SKY/2 of its
/// level; everywhere else on it, nothing changes.
#[test]
fn a_post_shadows_a_facade_by_the_sun_lit_to_sky_ratio() {
    let elevation = 45.0f32;
    // From the camera's side: azimuth 180° + 36.87° (−0.8, −0.6 horizontally).
    let azimuth = 216.87f32;
    let wall =
        block(V3::new(30.0, 0.0, 6.0), V3::new(1.0, 12.0, 6.0), Material::Flat([0.6; 3]), None);
    let post =
        block(V3::new(25.0, 0.0, 5.0), V3::new(0.25, 0.25, 5.0), Material::Flat([0.3; 3]), None);
    let objects = [wall, post];
    let lit = frame(&objects, elevation, azimuth, false);
    let shaded = frame(&objects, elevation, azimuth, true);
    let cos = 0.8 * elevation.to_radians().cos();
    let expected = 0.5 * SKY / (SUN * cos + 0.5 * SKY);
    // The sun ray from (29, y, z) crosses x = 25 at y − 3, z + 5: the post (|y| ≤ 0.25, up to
    // 10 m) shadows y ∈ [2.75, 3.25] (a little wider for the post's depth) below z = 5.
    let at = |p: V3| {
        let (x, y) = pixel_of(p);
        shaded.hdr.pixel(x, y)[1] / lit.hdr.pixel(x, y)[1]
    };
    for z in [0.5f32, 2.0, 4.5] {
        let r = at(V3::new(29.0, 3.0, z));
        assert!((r - expected).abs() < 1e-4, "facade in shadow at {z} m: {r} vs {expected}");
    }
    for p in [V3::new(29.0, 3.0, 5.8), V3::new(29.0, 4.5, 2.0), V3::new(29.0, -3.0, 2.0)] {
        assert_eq!(at(p), 1.0, "sunlit facade at {p:?}");
    }
    // Every pixel either keeps its level or loses exactly the sun's share of a face turned
    // towards −x (the facade, the post's front) or of the ground.
    let ground = SKY / (SUN * elevation.to_radians().sin() + SKY);
    let mut shadowed = 0;
    for (a, b) in lit.hdr.data().iter().zip(shaded.hdr.data()) {
        if a != b {
            let r = b / a;
            assert!((r - expected).abs() < 1e-4 || (r - ground).abs() < 1e-4, "ratio {r}");
            shadowed += 1;
        }
    }
    assert!(shadowed > 300, "{shadowed} values in shadow");
}

/// Shadows are a function of the scene alone: a generated town's frames are the same on a
/// second render; a shadow never brightens a pixel; and by day, over six episodes (six suns),
/// a visible share of the view lies in shadow.
#[test]
fn a_town_by_day_has_shadows_and_renders_them_the_same_twice() {
    let config = SimConfig {
        illumination: Some(Illumination::Day),
        cast_shadows: true,
        ..SimConfig::default()
    };
    let with = Simulator::new(config);
    let without = Simulator::new(SimConfig { cast_shadows: false, ..config });
    let cam = cam();
    let (mut darker, mut total) = (0usize, 0usize);
    for episode in 0..6 {
        let request = FrameRequest { episode, ..request(5.0, 5e-3, 1.0) };
        let a = with.render(&cam, &request).unwrap();
        let b = with.render(&cam, &request).unwrap();
        assert_eq!(a.hdr.data(), b.hdr.data(), "episode {episode}");
        let c = without.render(&cam, &request).unwrap();
        for (s, l) in a.hdr.data().iter().zip(c.hdr.data()).step_by(3) {
            assert!(s <= l, "a shadow never brightens");
            darker += usize::from(*s < 0.9 * l);
            total += 1;
        }
    }
    assert!(darker * 20 > total, "only {darker} of {total} pixels in shadow");
}
