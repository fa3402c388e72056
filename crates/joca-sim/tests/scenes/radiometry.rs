//! Frame levels against the lighting model's radiances.

use super::*;

#[test]
fn daylight_white_reads_about_215_dn_and_night_is_orders_darker() {
    // A white (ρ = 0.85) plate on the ground, 8 m ahead: its top face is horizontal.
    let plate =
        block(V3::new(9.0, 0.0, 0.01), V3::new(2.0, 2.0, 0.01), Material::Flat([0.85; 3]), None);
    let cam = camera(320, 240, 200.0, [1.0, 0.0, 1.5]);
    for elevation in [45.0f32, 50.0, 55.0] {
        let sim =
            scene(vec![plate.clone()], Pose2::default(), 0.0, 0.0, Illumination::Day, elevation);
        let frame = sim.render(&cam, &request(1.0, 5e-3, 1.0)).unwrap();
        // The plate is seen around the image centre, 8 m ahead and 1.5 m down: row ≈ 120 +
        // 200·1.5/8.
        let v = frame.hdr.pixel(160, 157);
        let expected = RADIANCE_SCALE_DN * 0.85 * (SUN * elevation.to_radians().sin() + SKY);
        assert!((v[1] - expected).abs() < 0.5, "{v:?} vs {expected}");
        assert!((200.0..=230.0).contains(&v[1]), "daylight white {v:?}");
    }
    // Night on a generated map: the median pixel is 2–4 orders of magnitude below day's.
    let median = |light| {
        let sim = Simulator::new(SimConfig { illumination: Some(light), ..SimConfig::default() });
        let f = sim.render(&cam, &request(3.0, 5e-3, 1.0)).unwrap();
        let mut g: Vec<f32> = f.hdr.data().iter().skip(1).step_by(3).copied().collect();
        g.sort_by(f32::total_cmp);
        (g[g.len() / 2], *g.last().unwrap())
    };
    let (day, _) = median(Illumination::Day);
    let (night, night_max) = median(Illumination::Night);
    let ratio = night / day;
    assert!((1e-4..=1e-2).contains(&ratio), "night/day median ratio {ratio}");
    // …except at the lights, which stay far above white.
    assert!(night_max > 255.0, "brightest night pixel {night_max}");
}
