//! The rasteriser's shortcuts against the full computation.

use super::ground::{ground_points, ground_points_portable};
use super::*;
use rand::Rng;

fn camera(rng: &mut impl Rng) -> PinholeCamera {
    let (w, h) = (rng.random_range(40..200), rng.random_range(30..150));
    let f = rng.random_range(20.0..400.0);
    PinholeCamera::centred((w, h), (f, f), [1.5, 0.0, 1.4])
}

/// The default town of map seed 5, for views of a whole city.
fn town() -> City {
    City::generate(
        &crate::CityConfig::default(),
        &mut joca_core::SeedStreams::new(5).stream("city"),
    )
}

/// The bits of every colour and depth value of `t`, to compare renders exactly.
fn value_bits(t: &Target) -> Vec<u32> {
    t.colour.iter().chain(&t.inv_depth).map(|v| v.to_bits()).collect()
}

/// A box's screen reach is conservative: a rejected box, rasterised face by face, covers no
/// pixel centre, and a bounded one draws only inside its rectangle and no nearer than its depth
/// bound (which makes skipping hidden boxes exact). Boxes of 2 cm to 20 m, anywhere from beside
/// the camera to 300 m away, in world coordinates of up to 3 km (where f32 rounds to 0.2 mm);
/// the test also asserts that every outcome occurs often, so no branch is left untested, and
/// that the depth bound is tight for some box (a bound loosened by mistake would skip less).
#[test]
fn a_rejected_box_covers_no_pixel() {
    let mut rng = joca_core::SeedStreams::new(7).stream("test");
    let (mut rejected, mut drawn, mut bounded, mut tightest) = (0, 0, 0, 0.0f32);
    for _ in 0..40_000 {
        let pinhole = camera(&mut rng);
        let ego = Pose2 {
            x: rng.random_range(-3000.0..3000.0),
            y: rng.random_range(-3000.0..3000.0),
            yaw: rng.random_range(-3.2..3.2),
        };
        let cam = CameraFrame::new(&pinhole, ego);
        let half = V3::new(
            rng.random_range(0.01..10.0),
            rng.random_range(0.01..10.0),
            rng.random_range(0.01..5.0),
        );
        let range: f32 = rng.random_range(0.0f32..300.0).powi(2) / 300.0;
        let bearing: f32 = rng.random_range(-3.2..3.2);
        let centre = V3::new(ego.x + range * bearing.cos(), ego.y + range * bearing.sin(), half.z);
        let b = OrientedBox { centre, half, yaw: rng.random_range(-3.2..3.2) };
        let mut target = Target::ids_only(pinhole.width_px, pinhole.height_px, 1);
        let reach = screen_reach(&cam, &b, b.axes(), &target);
        let rejects = reach == Reach::Nowhere;
        // Rasterise every face without the rejection.
        let (f, l) = b.axes();
        let up = V3::new(0.0, 0.0, 1.0);
        let h = b.half;
        for (n, hn, ua, hu, va, hv) in [
            (f, h.x, -l, h.y, up, h.z),
            (-f, h.x, l, h.y, up, h.z),
            (l, h.y, f, h.x, up, h.z),
            (-l, h.y, -f, h.x, up, h.z),
            (up, h.z, f, h.x, l, h.y),
            (-up, h.z, f, h.x, -l, h.y),
        ] {
            let c = b.centre + n * hn;
            let verts =
                [(-1.0f32, -1.0f32), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)].map(|(su, sv)| Vertex {
                    cam: cam.camera_from_world(c + ua * (su * hu) + va * (sv * hv)),
                    u: 0.0,
                    v: 0.0,
                });
            raster::draw_polygon(
                &verts,
                &cam,
                &|| (Shade::Constant([0.0; 3]), None),
                1,
                &mut target,
            );
        }
        if rejects {
            rejected += 1;
            assert_eq!(target.coverage[1], 0, "rejected box {b:?} covers pixels");
        } else if target.coverage[1] > 0 {
            drawn += 1;
        }
        // A bounded box draws only inside its rectangle and never nearer than its bound.
        if let Reach::Within { x0, x1, y0, y1, max_inv_z } = reach {
            bounded += 1;
            for (k, &d) in target.inv_depth.iter().enumerate() {
                let (x, y) = (k % pinhole.width_px, k / pinhole.width_px);
                if d > 0.0 {
                    assert!((x0..=x1).contains(&x) && (y0..=y1).contains(&y), "{b:?}: {x} {y}");
                    assert!(d <= max_inv_z, "{b:?}: 1/z {d} beyond the bound {max_inv_z}");
                    tightest = tightest.max(d / max_inv_z);
                }
            }
        }
    }
    assert!(rejected > 2_000 && drawn > 2_000, "rejected {rejected}, drawn {drawn}");
    assert!(bounded > 2_000 && tightest > 0.99, "{bounded} bounded, tightest {tightest}");
}

/// The vectorised ground row gives the bits of the portable one.
#[test]
fn ground_points_are_the_same_on_every_code_path() {
    let mut rng = joca_core::SeedStreams::new(3).stream("test");
    for _ in 0..50 {
        let pinhole = camera(&mut rng);
        let ego = Pose2 {
            x: rng.random_range(-50.0..800.0),
            y: rng.random_range(-50.0..800.0),
            yaw: rng.random_range(-3.2..3.2),
        };
        let cam = CameraFrame::new(&pinhole, ego);
        let slopes: Vec<f32> =
            (0..pinhole.width_px).map(|x| (x as f32 + 0.5 - cam.cx) / cam.fx).collect();
        let t = rng.random_range(1.0..600.0);
        let (mut a, mut b) =
            (vec![(0.0, 0.0, 0.0); slopes.len()], vec![(1.0, 1.0, 1.0); slopes.len()]);
        ground_points(&cam, t, &slopes, &mut a);
        ground_points_portable(&cam, t, &slopes, &mut b);
        for (p, q) in a.iter().zip(&b) {
            assert_eq!(
                (p.0.to_bits(), p.1.to_bits(), p.2.to_bits()),
                (q.0.to_bits(), q.1.to_bits(), q.2.to_bits())
            );
            // And the grain is the scalar per-point function's.
            assert_eq!(q.2.to_bits(), crate::city::ground_grain(q.0, q.1).to_bits());
        }
    }
}

/// The pixel-centre spans without library rounding are the spans `ceil`/`floor` give (the
/// same first and last index where there is one, empty where it is empty): random
/// bounds at every scale, values on and next to the half-pixel boundaries, signed zeros,
/// infinities and NaN.
#[test]
fn pixel_centre_spans_match_the_library_rounding() {
    let reference64 = |lo: f64, hi: f64, size: usize| {
        ((lo - 0.5).ceil().max(0.0), (hi - 0.5).floor().min(size as f64 - 1.0))
    };
    let mut rng = joca_core::SeedStreams::new(3).stream("spans");
    let mut values: Vec<f64> = vec![
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        0.0,
        -0.0,
        1e300,
        -1e300,
        f64::MAX,
        f64::MIN,
        9.2e18,
        -9.2e18,
    ];
    for k in -6..700 {
        let c = f64::from(k) + 0.5;
        values.extend([c, c.next_up(), c.next_down(), f64::from(k), f64::from(k) + 0.25]);
    }
    for _ in 0..20_000 {
        let scale = 10f64.powi(rng.random_range(-3..12));
        values.push(rng.random_range(-1.0..1.0) * scale);
    }
    for size in [1usize, 2, 7, 320, 641] {
        for (i, &lo) in values.iter().enumerate() {
            let hi = values[(i * 7919 + 13) % values.len()];
            for (a, b) in [(lo, hi), (hi, lo), (lo, lo)] {
                let (f, l) = raster::centre_span_f64(a, b, size);
                let (rf, rl) = reference64(a, b, size);
                let same = if rf > rl { f > l } else { f == rf && l == rl };
                assert!(same, "{a} {b} {size}: {f} {l} vs {rf} {rl}");
            }
        }
    }
}

/// A target that held another view renders exactly as a fresh one (every colour, depth, id and
/// coverage value): the simulator reuses its buffers from frame to frame on this. Views in day
/// and at night (lamps and head lights), colour and id-only targets, from spots all over a town.
#[test]
fn a_reused_target_renders_as_a_fresh_one() {
    let city = town();
    let mut rng = joca_core::SeedStreams::new(11).stream("views");
    let pinhole = PinholeCamera {
        width_px: 96,
        height_px: 72,
        fx_px: 80.0,
        fy_px: 80.0,
        cx_px: 48.0,
        cy_px: 36.0,
        mount_m: [1.5, 0.0, 1.4],
        lens: None,
    };
    let objects = city.objects.len();
    fn view<'a>(camera: &'a PinholeCamera, rng: &mut impl Rng) -> View<'a> {
        View {
            camera,
            ego: Pose2 {
                x: rng.random_range(0.0..600.0),
                y: rng.random_range(0.0..600.0),
                yaw: rng.random_range(-3.2..3.2),
            },
            lighting: Lighting {
                ambient: if rng.random_bool(0.5) { 1.0 } else { 0.01 },
                sun_dir: [0.3, 0.2, 0.93],
                beam: 1.0,
                diffuse: 1.0,
                street_lamps_dark: false,
            },
            time_s: rng.random_range(0.0..60.0),
            shadows: None,
            sun_disc: false,
        }
    }
    let (mut colour, mut ids) = (Target::new(96, 72, objects), Target::ids_only(96, 72, objects));
    for _ in 0..20 {
        let v = view(&pinhole, &mut rng);
        render(&city, &v, &mut colour);
        render(&city, &v, &mut ids);
        let (mut fresh, mut fresh_ids) =
            (Target::new(96, 72, objects), Target::ids_only(96, 72, objects));
        render(&city, &v, &mut fresh);
        render(&city, &v, &mut fresh_ids);
        assert_eq!(value_bits(&colour), value_bits(&fresh));
        assert_eq!((&colour.id, &colour.coverage), (&fresh.id, &fresh.coverage));
        assert_eq!(value_bits(&ids), value_bits(&fresh_ids));
        assert_eq!((&ids.id, &ids.coverage), (&fresh_ids.id, &fresh_ids.coverage));
    }
}

/// Skipping the boxes that nearer ones hide changes no colour, depth or id value, nor the
/// coverage of any object seen in the id-only pass: street views (the camera on a road, any
/// heading, in day and at night, where lamps and head lights light the faces) rendered with and
/// without the skipping. It also asserts that most of the objects drawn without it are skipped
/// entirely with it, so the shortcut is exercised.
#[test]
fn skipping_hidden_boxes_changes_no_pixel() {
    let city = town();
    let mut rng = joca_core::SeedStreams::new(12).stream("views");
    let pinhole = PinholeCamera {
        width_px: 160,
        height_px: 120,
        fx_px: 93.0,
        fy_px: 93.0,
        cx_px: 80.0,
        cy_px: 60.0,
        mount_m: [0.43, 0.0, 1.65],
        lens: None,
    };
    let objects = city.objects.len();
    let (mut skipped, mut drawn, mut hidden_whole) = (0usize, 0usize, 0usize);
    for k in 0..40 {
        // On a road: along one of the north-south roads, at a random place, any heading.
        let road = city.roads_x[k % city.roads_x.len()];
        let v = View {
            camera: &pinhole,
            ego: Pose2 {
                x: road.centre_m + rng.random_range(-3.0..3.0),
                y: rng.random_range(0.0..city.extent_m),
                yaw: rng.random_range(-3.2..3.2),
            },
            lighting: Lighting {
                ambient: if k % 2 == 0 { 1.0 } else { 0.01 },
                sun_dir: [0.3, 0.2, 0.93],
                beam: 1.0,
                diffuse: 1.0,
                street_lamps_dark: false,
            },
            time_s: rng.random_range(0.0..60.0),
            shadows: None,
            sun_disc: false,
        };
        let (mut with, mut without) =
            (Target::new(160, 120, objects), Target::new(160, 120, objects));
        draw(&city, &v, &mut with, true);
        draw(&city, &v, &mut without, false);
        assert_eq!(value_bits(&with), value_bits(&without), "view {k}");
        assert_eq!(with.id, without.id, "view {k}");
        let reached = |t: &Target| t.coverage.iter().filter(|&&c| c > 0).count();
        (skipped, drawn) =
            (skipped + reached(&without) - reached(&with), drawn + reached(&without));
        // The id-only pass (the ground truth): the same ids and depths, and the same coverage
        // for every object seen.
        let (mut with, mut without) =
            (Target::ids_only(160, 120, objects), Target::ids_only(160, 120, objects));
        draw(&city, &v, &mut with, true);
        draw(&city, &v, &mut without, false);
        assert_eq!(value_bits(&with), value_bits(&without), "view {k}");
        assert_eq!(with.id, without.id, "view {k}");
        for &id in &with.id {
            let i = id as usize;
            assert_eq!(with.coverage[i], without.coverage[i], "view {k}, object {id}");
        }
        hidden_whole += with.coverage.iter().zip(&without.coverage).filter(|(a, b)| a != b).count();
    }
    // Some objects are hidden entirely, and their coverage is then not counted.
    assert!(hidden_whole > 0);
    assert!(skipped * 2 > drawn, "only {skipped} of {drawn} objects skipped");
}
