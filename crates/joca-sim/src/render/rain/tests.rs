//! Rain against its closed forms: extinction, fall speed, streak geometry and light.
use super::*;
use joca_core::SeedStreams;

fn camera(w: usize, h: usize, f_px: f64) -> PinholeCamera {
    PinholeCamera::centred((w, h), (f_px, f_px), [0.0, 0.0, 1.5])
}

#[test]
fn extinction_and_fall_speed_match_their_closed_forms() {
    // β = π·N0/Λ³: at 10 mm/h Λ = 4.1·10^−0.21 = 2.5281 per mm, β = 1.5556e-3 per m.
    let lambda: f64 = 4.1 * 10f64.powf(-0.21);
    assert!((mp_slope(10.0) - lambda).abs() < 1e-12);
    let beta = extinction_per_m(10.0);
    assert!((beta - std::f64::consts::PI * 8000.0 / lambda.powi(3) * 1e-6).abs() < 1e-15);
    assert!((beta - 1.5556e-3).abs() < 1e-7, "{beta}");
    // The visibility ln 20 / β: 1.9 km in moderate rain, under 1 km in a downpour.
    assert!((20f64.ln() / beta - 1925.8).abs() < 0.5);
    assert!(20f64.ln() / extinction_per_m(50.0) < 1000.0);
    // Atlas et al.: 2 mm drops fall at 6.55 m/s, the largest near 9.4 m/s.
    assert!((terminal_speed_mps(2.0) - 6.5477).abs() < 1e-3);
    assert!((terminal_speed_mps(6.0) - 9.3686).abs() < 1e-3);
}

/// A camera that stands still.
fn standing(_: f64) -> Pose2 {
    Pose2::default()
}

/// Per column, the coverage summed down it (a streak on a black canvas, radiance 1).
fn coverage(t: &Target) -> (Vec<f32>, f64) {
    let cols: Vec<f32> = (0..t.width)
        .map(|x| (0..t.colour.len() / 3 / t.width).map(|y| t.colour[(y * t.width + x) * 3]).sum())
        .collect();
    let total = f64::from(cols.iter().sum::<f32>());
    (cols, total)
}

#[test]
fn a_streak_is_as_long_as_the_drop_falls_during_the_shutter() {
    // A 2 mm drop 2 m away, 500 px focal length: d = 0.5 px, v = 6.55 m/s.
    let area = std::f64::consts::FRAC_PI_4 * 0.25;
    for shutter_s in [5e-3, 20e-3, 40e-3] {
        let cam = camera(40, 400, 500.0);
        let mut t = Target::new(40, 400, 0);
        let drop = Drop { u: 20.5, v: 200.0, z_m: 2.0, d_mm: 2.0 };
        streak(&mut t, &cam, &standing, &drop, shutter_s, [1.0; 3]);
        let column: Vec<f32> = (0..400).map(|y| t.colour[(y * 40 + 20) * 3]).collect();
        // The fall ℓ = f·v·T/z, swept by a square of side 1: ℓ + 1 pixels covered.
        let fall = 500.0 * terminal_speed_mps(2.0) * shutter_s / 2.0;
        let first = column.iter().position(|&c| c > 0.0).unwrap() as f64;
        let last = column.iter().rposition(|&c| c > 0.0).unwrap() as f64 + 1.0;
        assert!(
            (last - first - (fall + 1.0)).abs() <= 1.0,
            "{shutter_s}: {first}..{last}, ℓ {fall}"
        );
        // The disc's area, spread along it: (π/4)·d² in all, and away from the ends each
        // pixel holds it for 1/ℓ of the shutter: a share of (π/4)·d²/ℓ.
        let (_, total) = coverage(&t);
        assert!((total - area).abs() < 1e-3 * area, "{total} vs {area}");
        // Sampled about once per pixel of path, each pixel's share ripples around it by up to
        // ~10 %; their mean is the share.
        let share = area / fall;
        let plateau: Vec<f64> =
            (first as usize + 2..last as usize - 2).map(|y| f64::from(column[y])).collect();
        let mean = plateau.iter().sum::<f64>() / plateau.len() as f64;
        assert!((mean - share).abs() < 0.02 * share, "{mean} vs {share}");
        assert!(plateau.iter().all(|s| (s - share).abs() < 0.12 * share), "{plateau:?}");
        // Nothing left or right of the drop's column.
        assert!(t.colour.iter().enumerate().all(|(i, &c)| c == 0.0 || (i / 3) % 40 == 20));
    }
}

#[test]
fn a_driving_camera_draws_streaks_away_from_the_focus_of_expansion() {
    // Driving forward (+x, the camera's view) at 15 m/s; a 2 mm drop 2 m ahead, 60 px right
    // of and 40 px above the principal point; 20 ms shutter.
    let (speed, shutter_s, f) = (15.0, 20e-3, 500.0);
    let driving = move |dt: f64| Pose2 { x: (speed * dt) as f32, y: 0.0, yaw: 0.0 };
    let cam = camera(400, 400, f);
    let drop = Drop { u: 260.0, v: 160.0, z_m: 2.0, d_mm: 2.0 };
    // Closed form: camera coordinates at the middle, then X/(Z − s·t), (Y + v·t)/(Z − s·t).
    let (x, y, z) = (60.0 * 2.0 / f, -40.0 * 2.0 / f, 2.0);
    let v = terminal_speed_mps(2.0);
    let at = |t: f64| (200.0 + f * x / (z - speed * t), 200.0 + f * (y + v * t) / (z - speed * t));
    let ((u0, v0), (u1, v1)) = (at(-shutter_s / 2.0), at(shutter_s / 2.0));
    assert!(u1 - u0 > 5.0, "the streak runs outward: {u0} → {u1}");
    let mut t = Target::new(400, 400, 0);
    streak(&mut t, &cam, &driving, &drop, shutter_s, [1.0; 3]);
    let covered: Vec<(usize, usize)> =
        (0..400 * 400).filter(|&p| t.colour[p * 3] > 0.0).map(|p| (p % 400, p / 400)).collect();
    let (xs, ys): (Vec<f64>, Vec<f64>) = covered.iter().map(|&(x, y)| (x as f64, y as f64)).unzip();
    let min = |v: &[f64]| v.iter().copied().fold(f64::MAX, f64::min);
    let max = |v: &[f64]| v.iter().copied().fold(f64::MIN, f64::max);
    // The covered pixels span the projections at opening and closing, a square wide.
    assert!((min(&xs) - (u0 - 0.5).floor()).abs() <= 1.0, "{} vs {u0}", min(&xs));
    assert!((max(&xs) + 1.0 - (u1 + 0.5).ceil()).abs() <= 1.0, "{} vs {u1}", max(&xs));
    assert!((min(&ys) - (v0.min(v1) - 0.5).floor()).abs() <= 1.0, "{} vs {v0}", min(&ys));
    assert!((max(&ys) + 1.0 - (v0.max(v1) + 0.5).ceil()).abs() <= 1.0, "{} vs {v1}", max(&ys));
    // The drop's image grows as it nears: the light is the time average of (π/4)·d(t)².
    let steps = 10_000;
    let mean_area = (0..=steps)
        .map(|k| {
            let t = -shutter_s / 2.0 + shutter_s * k as f64 / steps as f64;
            let d = f * 2e-3 / (z - speed * t);
            std::f64::consts::FRAC_PI_4 * d * d
        })
        .sum::<f64>()
        / (steps + 1) as f64;
    let (_, total) = coverage(&t);
    assert!((total - mean_area).abs() < 0.01 * mean_area, "{total} vs {mean_area}");
    // Turning left at 0.5 rad/s the scene swings right: u(t) = cx + f·tan(ω·t), whatever
    // the depth.
    let turning = |dt: f64| Pose2 { x: 0.0, y: 0.0, yaw: (0.5 * dt) as f32 };
    let mut t = Target::new(400, 400, 0);
    let ahead = Drop { u: 200.5, v: 200.0, z_m: 4.0, d_mm: 2.0 };
    streak(&mut t, &cam, &turning, &ahead, shutter_s, [1.0; 3]);
    let swing = f * (0.5 * shutter_s / 2.0).tan();
    let cols: Vec<usize> =
        (0..400).filter(|&x| (0..400).any(|y| t.colour[(y * 400 + x) * 3] > 0.0)).collect();
    let (lo, hi) = (cols[0] as f64, *cols.last().unwrap() as f64 + 1.0);
    assert!(
        (lo - (200.0 - swing)).abs() <= 1.0 && (hi - (201.0 + swing)).abs() <= 1.0,
        "{lo}..{hi}, ±{swing}"
    );
    // A drop that passes the camera during the shutter draws only while in front of it.
    let close = Drop { u: 260.0, v: 160.0, z_m: 0.35, d_mm: 2.0 };
    let mut t = Target::new(400, 400, 0);
    streak(&mut t, &cam, &driving, &close, shutter_s, [1.0; 3]);
    assert!(t.colour.iter().all(|c| c.is_finite() && *c <= 1.0));
}

#[test]
fn the_veil_of_faint_drops_keeps_the_light_of_drawing_every_drop() {
    // 320 × 240 at 186 px focal length, 25 mm/h, 10 ms: a grey scene 20 m away with a
    // wall 1 m away over its lower third (drops behind the wall are hidden there).
    let cam = camera(320, 240, 186.0);
    let drops = drops(&cam, 25.0, &mut SeedStreams::new(3).stream("rain"));
    let scene = || {
        let mut t = Target::new(320, 240, 0);
        t.colour.iter_mut().for_each(|c| *c = 60.0);
        for (k, d) in t.inv_depth.iter_mut().enumerate() {
            *d = if k / 320 >= 160 { 1.0 } else { 1.0 / 20.0 };
        }
        t
    };
    let radiance = [200.0f32; 3];
    let mut exact = scene();
    for drop in &drops {
        streak(&mut exact, &cam, &standing, drop, 10e-3, radiance);
    }
    let mut veiled = scene();
    let canvas = (veiled.colour.as_mut_slice(), veiled.inv_depth.as_slice());
    streaks(canvas, &cam, &standing, &drops, 10e-3, radiance);
    let drawn = drops
        .iter()
        .filter(|d| {
            let motion = ShutterMotion::new(&cam, &standing, 10e-3);
            Path::of(&cam, &motion, d).peak_share >= VEIL_SHARE
        })
        .count();
    assert!(drawn * 3 < drops.len(), "{drawn} of {} drawn: the veil should take most", drops.len());
    // The mean light above and below the wall's edge, and every pixel, against the exact one
    // (the difference to the radiance is 140 DN).
    for rows in [0..160usize, 160..240] {
        let mean = |t: &Target| {
            let v: Vec<f32> = rows
                .clone()
                .flat_map(|y| (0..320).map(move |x| (y, x)))
                .map(|(y, x)| t.colour[(y * 320 + x) * 3])
                .collect();
            f64::from(v.iter().sum::<f32>()) / v.len() as f64
        };
        let (e, v) = (mean(&exact), mean(&veiled));
        assert!(
            (e - v).abs() < 0.02 * (e - 60.0).abs().max(0.05),
            "rows {rows:?}: exact {e}, veiled {v}"
        );
    }
    let worst =
        exact.colour.iter().zip(&veiled.colour).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
    assert!(worst < 0.02 * 140.0, "worst pixel differs by {worst} DN");
}

#[test]
fn streaks_stay_behind_nearer_surfaces_and_drops_fill_the_view_alike() {
    let cam = camera(40, 400, 500.0);
    let mut t = Target::new(40, 400, 0);
    // A wall at 1 m over the lower half: a drop at 2 m is hidden there.
    for y in 200..400 {
        for x in 0..40 {
            t.inv_depth[y * 40 + x] = 1.0;
        }
    }
    let drop = Drop { u: 20.5, v: 200.0, z_m: 2.0, d_mm: 2.0 };
    streak(&mut t, &cam, &standing, &drop, 40e-3, [1.0; 3]);
    assert!((0..200).any(|y| t.colour[(y * 40 + 20) * 3] > 0.0));
    assert!((200..400).all(|y| t.colour[(y * 40 + 20) * 3] == 0.0));
    // The same rate and seed give the same drops; their count follows the volume.
    let cam = camera(320, 240, 186.0);
    let a = drops(&cam, 10.0, &mut SeedStreams::new(1).stream("rain"));
    assert_eq!(a, drops(&cam, 10.0, &mut SeedStreams::new(1).stream("rain")));
    let slope = mp_slope(10.0);
    let per_m3 = 8000.0 / slope * (-slope * 0.5).exp();
    let volume = 320.0 / 186.0 * 240.0 / 186.0 * (125.0 - 0.027) / 3.0;
    assert_eq!(a.len(), (per_m3 * volume).round() as usize);
    let near = a.iter().filter(|d| d.z_m < (0.3f64.powi(3) / 2.0 + 62.5).cbrt()).count();
    // Half the volume lies nearer than the cube root of the mean of z0³ and z1³.
    assert!((near as f64 / a.len() as f64 - 0.5).abs() < 0.01, "{near} of {}", a.len());
    assert!(a.iter().all(|d| (0.5..=6.0).contains(&d.d_mm)));
}
