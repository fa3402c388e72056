//! Fog and a thin lens: the light changes, the ground truth does not, and the integrated frame's
//! defocus matches defocus per sub-frame.

use super::*;

/// Fog and an open lens change the light, never the ground truth, and render alike twice.
#[test]
fn fog_and_defocus_keep_the_ground_truth_and_repeat_exactly() {
    use joca_core::optics::Lens;
    use joca_sim::Weather;
    let request = FrameRequest { episode: 3, time_s: 4.0, exposure_s: 10e-3, motion_scale: 1.0 };
    let cam = camera(200, 150, 180.0, [0.43, 0.0, 1.65]);
    let world = |weather| {
        Simulator::new(SimConfig {
            illumination: Some(Illumination::Day),
            weather,
            map_seed: 2,
            ..SimConfig::default()
        })
    };
    let clear = world(Weather::Clear).render(&cam, &request).unwrap();
    let foggy = world(Weather::Fog { visibility_m: 50.0 });
    let fog = foggy.render(&cam, &request).unwrap();
    assert_eq!(fog.boxes, clear.boxes);
    assert_eq!(fog.ignore, clear.ignore);
    assert_eq!(fog, foggy.render(&cam, &request).unwrap());
    // Dense fog pulls every pixel toward the airlight: the frame's spread of values shrinks
    // (the near road keeps most of its contrast; the closed form is render::lens's test).
    let spread = |f: &joca_core::Frame| {
        let v = f.hdr.data();
        let m = v.iter().sum::<f32>() / v.len() as f32;
        (v.iter().map(|x| (x - m).powi(2)).sum::<f32>() / v.len() as f32).sqrt()
    };
    assert!(spread(&fog) < 0.8 * spread(&clear), "{} vs {}", spread(&fog), spread(&clear));

    // Rain: the same ground truth, the same drops for every exposure of an instant (so the
    // perturbation search compares exposures, not draws), and the same frame twice.
    let rainy = world(Weather::Rain { rate_mm_h: 25.0 });
    let short = FrameRequest { exposure_s: 2e-3, ..request };
    let both = rainy.render_exposures(&cam, &short, &[2e-3, 10e-3]).unwrap();
    assert_eq!(both[1].boxes, clear.boxes);
    assert_eq!(both[0], rainy.render(&cam, &short).unwrap());
    assert_eq!(both[1], rainy.render(&cam, &request).unwrap());
    assert_ne!(both[1].hdr, clear.hdr);

    // 1.8 mm at 180 px focal length: 10 µm view pixels. f/1 focused at 0.3 m blurs the street.
    let lens = Lens { focal_length_mm: 1.8, f_number: 1.0, focus_m: 0.3 };
    let open = PinholeCamera { lens: Some(lens), ..cam };
    let sim = world(Weather::Clear);
    let blurred = sim.render(&open, &request).unwrap();
    assert_eq!(blurred.boxes, clear.boxes);
    assert_eq!(blurred, sim.render(&open, &request).unwrap());
    assert!(spread(&blurred) < spread(&clear));
    assert_ne!(blurred.hdr, clear.hdr);

    // A moving iris: each shot of an instant is the frame that lens, stopped to the shot's
    // f-number (focus kept), renders alone; `None` is the lens as it is. A pinhole has no iris.
    let shots = [
        Shot { exposure_s: 10e-3, f_number: Some(8.0) },
        Shot::exposure(10e-3),
        Shot { exposure_s: 10e-3, f_number: Some(2.0) },
    ];
    // (One shutter for all three: shots of different shutters share the longest one's grid,
    // which a lone render of a shorter one does not, as the shared-grid test above shows.)
    let frames = sim.render_shots(&open, &request, &shots).unwrap();
    for (frame, shot) in frames.iter().zip(&shots) {
        let alone = sim
            .render(
                &open.stopped_to(shot.f_number).unwrap(),
                &FrameRequest { exposure_s: shot.exposure_s, ..request },
            )
            .unwrap();
        assert_eq!(frame, &alone, "{shot:?}");
    }
    assert_eq!(frames[1], blurred);
    assert!(spread(&frames[0]) > spread(&blurred), "stopping down sharpens the street");
    assert!(sim.render_shots(&cam, &request, &shots).is_err());
}

/// The default blurs the shutter-integrated frame by the depths of its middle instant; the
/// exact model blurs every sub-frame by its own. On a fast, long exposure (2 × 40 ms of motion)
/// through an open lens focused near (every pixel blurred) they agree but at moving depth edges.
#[test]
fn defocus_of_the_integrated_frame_matches_defocus_per_sub_frame() {
    use joca_core::optics::Lens;
    // Focused at 8 cm: σ ≈ 1 px (10 µm view pixels) far away, every pixel blurred.
    let lens = Lens { focal_length_mm: 1.8, f_number: 1.0, focus_m: 0.08 };
    let cam = PinholeCamera { lens: Some(lens), ..camera(200, 150, 180.0, [0.43, 0.0, 1.65]) };
    let config = SimConfig {
        illumination: Some(Illumination::Day),
        map_seed: 4,
        max_speed_mps: 15.0,
        ..SimConfig::default()
    };
    let fast = Simulator::new(config);
    let exact = Simulator::new(SimConfig { optics_per_subframe: true, ..config });
    for Agreement { level, mad, worst, off, values } in shortcut_against_exact(&fast, &exact, &cam)
    {
        // Measured (map 4): mean |Δ| 0.2–0.4 % of the level; 1.1–1.7 % of the values off by more
        // than 5 % (up to 100 DN), all where a moving depth edge crosses the pixel during the
        // shutter and the middle instant's depth decides the occlusion for the whole frame.
        assert!(mad < 0.01 * level, "mean |Δ| {mad} DN at level {level} DN (max {worst})");
        assert!(off * 100 < 3 * values, "{off} of {values} values off by > 5 %");
    }
}

/// Veiling glare in the simulator: the glared frame is the glare of the frame without it (once
/// on the shutter-integrated frame), it keeps all but what leaves the frame, and it lifts the
/// night's darks around the lamps and head lights; the closed forms are `render::glare`'s.
#[test]
fn glare_veils_a_night_street_and_keeps_its_light() {
    use joca_sim::Glare;
    let request = FrameRequest { episode: 1, time_s: 3.0, exposure_s: 20e-3, motion_scale: 1.0 };
    let cam = camera(240, 160, 200.0, [0.43, 0.0, 1.65]);
    let glare = Glare { fraction: 0.05, scale_deg: 1.0 };
    let world = |glare| {
        Simulator::new(SimConfig {
            illumination: Some(Illumination::Night),
            map_seed: 4,
            glare,
            ..SimConfig::default()
        })
    };
    let off = world(Glare::default()).render(&cam, &request).unwrap();
    let on = world(glare).render(&cam, &request).unwrap();
    assert_eq!(on.boxes, off.boxes);
    let mut expect = off.hdr.data().to_vec();
    joca_sim::render::glare::veiling_glare(&mut expect, (240, 160), &cam, &glare);
    for (a, b) in on.hdr.data().iter().zip(&expect) {
        assert!((a - b).abs() <= 1e-5 * b.abs().max(1.0), "{a} against {b}");
    }
    let sum = |d: &[f32]| d.iter().map(|&v| f64::from(v)).sum::<f64>();
    let (before, after) = (sum(off.hdr.data()), sum(on.hdr.data()));
    assert!(after <= before && after >= (1.0 - 0.05) * before, "{after} of {before}");
    let dark = |d: &[f32]| {
        let mut v = d.to_vec();
        v.sort_by(f32::total_cmp);
        v[v.len() / 200]
    };
    assert!(dark(on.hdr.data()) > dark(off.hdr.data()), "the darks are not lifted");
}
