//! Cast shadows against geometry's closed forms and the reference ray test.

use super::*;

fn sun_at(elevation_deg: f32, azimuth_deg: f32) -> [f32; 3] {
    let (e, a) = (elevation_deg.to_radians(), azimuth_deg.to_radians());
    [e.cos() * a.cos(), e.cos() * a.sin(), e.sin()]
}

/// A 10 m cube standing on the ground at the origin.
fn cube() -> OrientedBox {
    OrientedBox { centre: V3::new(0.0, 0.0, 5.0), half: V3::new(5.0, 5.0, 5.0), yaw: 0.0 }
}

#[test]
fn a_wall_casts_a_shadow_of_height_over_tan_elevation() {
    // Sun from +x at 30°: the cube's shadow on the ground runs from its −x face to
    // 10 / tan 30° = 17.32 m beyond it.
    let s = Shadows::new([cube()], sun_at(30.0, 0.0)).unwrap();
    let length = 10.0 / 30f32.to_radians().tan();
    for d in [0.1, 5.0, length - 0.05] {
        assert!(s.shadowed(V3::new(-5.0 - d, 0.0, 0.0)), "{d} m behind");
    }
    assert!(!s.shadowed(V3::new(-5.0 - length - 0.05, 0.0, 0.0)));
    // Sideways the shadow is as wide as the cube.
    assert!(s.shadowed(V3::new(-8.0, 4.9, 0.0)));
    assert!(!s.shadowed(V3::new(-8.0, 5.1, 0.0)));
    // In front of the lit face, nothing.
    assert!(!s.shadowed(V3::new(6.0, 0.0, 0.0)));
}

#[test]
fn lit_faces_are_lit_and_faces_turned_away_are_not() {
    let s = Shadows::new([cube()], sun_at(40.0, 20.0)).unwrap();
    // The top and the +x face see the sun; the −x face does not.
    assert!(!s.shadowed(V3::new(1.0, 2.0, 10.0)));
    assert!(!s.shadowed(V3::new(5.0, 1.0, 3.0)));
    assert!(s.shadowed(V3::new(-5.0, 1.0, 3.0)));
}

#[test]
fn a_facade_is_shadowed_up_to_the_height_the_geometry_gives() {
    // A 20 m tower 10 m east of a 10 m wide facade; sun from the east at 45°: the
    // facade's shadow line lies at 20 − 10·tan 45° = 10 m.
    let tower =
        OrientedBox { centre: V3::new(15.0, 0.0, 10.0), half: V3::new(5.0, 5.0, 10.0), yaw: 0.0 };
    let s = Shadows::new([tower], sun_at(45.0, 0.0)).unwrap();
    assert!(s.shadowed(V3::new(0.0, 0.0, 9.9)));
    assert!(!s.shadowed(V3::new(0.0, 0.0, 10.1)));
}

#[test]
fn a_rotated_box_matches_the_reference_ray_test() {
    // Every point of a grid against OrientedBox::ray_hit, for a box turned 0.7 rad.
    let b = OrientedBox { centre: V3::new(3.0, -2.0, 2.0), half: V3::new(4.0, 1.5, 2.0), yaw: 0.7 };
    let sun = sun_at(25.0, 130.0);
    let s = Shadows::new([b], sun).unwrap();
    let dir = V3::new(sun[0], sun[1], sun[2]);
    let mut disagree = 0;
    for i in 0..60 {
        for j in 0..60 {
            let p = V3::new(-20.0 + i as f32 * 0.7 + 0.013, -20.0 + j as f32 * 0.7 + 0.029, 0.0);
            let reference = b.ray_hit(p, dir, 1e4).is_some();
            disagree += usize::from(reference != s.shadowed(p));
            disagree += usize::from(reference != s.ground_shadowed(p.x, p.y));
        }
    }
    assert_eq!(disagree, 0);
}

#[test]
fn no_shadows_from_a_sun_at_the_horizon_or_from_nothing() {
    assert!(Shadows::new([cube()], sun_at(0.5, 0.0)).is_none());
    assert!(Shadows::new([], sun_at(50.0, 0.0)).is_none());
    assert!(Shadows::new([cube()], [0.0, 0.0, 0.0]).is_none());
}

#[test]
fn a_ground_line_is_in_shadow_where_its_points_are() {
    // Three boxes, one raised off the ground (a sign plate), lines in several directions: the
    // stretches found once per line against the point test at 0.05 m steps.
    let boxes = [
        cube(),
        OrientedBox { centre: V3::new(12.0, 6.0, 2.0), half: V3::new(2.0, 0.5, 2.0), yaw: 0.4 },
        OrientedBox { centre: V3::new(-4.0, 14.0, 2.5), half: V3::new(0.05, 0.4, 0.4), yaw: 1.1 },
    ];
    let s = Shadows::new(boxes, sun_at(35.0, 200.0)).unwrap();
    let mut seen = Vec::new();
    let (mut inside, mut steps) = (0, 0);
    let lines = [
        ([-30.0, 0.5], [1.0, 0.0]),
        ([5.0, -30.0], [0.1, 1.0]),
        ([-30.0, -20.0], [0.8, 0.6]),
        ([-20.0, 14.3], [1.0, 0.02]),
    ];
    for (stamp, (origin, dir)) in lines.into_iter().enumerate() {
        let mut stretches = Vec::new();
        s.ground_line((origin, dir), (0.0, 60.0), (&mut seen, stamp as u32 + 1), &mut stretches);
        for i in 0..1200 {
            let x = 0.013 + i as f32 * 0.05;
            let p = V3::new(origin[0] + x * dir[0], origin[1] + x * dir[1], 0.0);
            let found = stretches.iter().any(|&(lo, hi)| lo <= x && x <= hi);
            assert_eq!(found, s.shadowed(p), "line {stamp} at {x}");
            inside += usize::from(found);
            steps += 1;
        }
    }
    assert!(inside > 100 && inside < steps - 100, "{inside} of {steps} in shadow");
}

/// The polygons a face's shadows are drawn with against the slab test of every point: towers,
/// a wall straddling the face's plane and a raised plate, around a facade of a box turned
/// 0.3 rad, for several suns; the facade's own box casts nothing on it.
#[test]
fn a_face_is_shadowed_where_the_slab_test_says() {
    let own =
        OrientedBox { centre: V3::new(0.0, 0.0, 8.0), half: V3::new(4.0, 10.0, 8.0), yaw: 0.3 };
    let others = [
        OrientedBox { centre: V3::new(14.0, 3.0, 12.0), half: V3::new(3.0, 4.0, 12.0), yaw: 0.1 },
        OrientedBox { centre: V3::new(5.0, -9.0, 3.0), half: V3::new(4.0, 0.5, 3.0), yaw: 1.2 },
        OrientedBox { centre: V3::new(9.0, 6.0, 5.0), half: V3::new(0.1, 1.0, 0.8), yaw: -0.4 },
    ];
    let (f, l) = own.axes();
    // The facade facing the box's forward axis: u along its left axis, v up.
    let up = V3::new(0.0, 0.0, 1.0);
    let face = FacePlane {
        origin: own.centre + f * own.half.x - l * own.half.y - up * own.half.z,
        ua: l,
        va: up,
        n: f,
        size: [2.0 * own.half.y, 2.0 * own.half.z],
    };
    let (mut shadowed, mut points) = (0, 0);
    for (elevation, azimuth) in [(30.0, 10.0), (50.0, 40.0), (20.0, -30.0), (65.0, 0.0)] {
        let boxes = std::iter::once(own).chain(others);
        let s = Shadows::new(boxes, sun_at(elevation, azimuth)).unwrap();
        let me = s.caster_of(&own);
        assert_eq!(me, Some(0));
        let (mut seen, mut polygons) = (Vec::new(), Vec::new());
        s.face_shadows(&face, me, (&mut seen, 1), &mut polygons);
        for i in 0..80 {
            for j in 0..64 {
                let (u, v) = (0.013 + i as f32 * 0.25, 0.021 + j as f32 * 0.25);
                let p = face.origin + face.ua * u + face.va * v;
                let reference = s.shadowed_except(p, me);
                let drawn = polygons.iter().any(|q| q.contains([u, v]));
                assert_eq!(drawn, reference, "sun {elevation}°/{azimuth}° at u {u}, v {v}");
                assert!(!s.shadowed_except(p, None) || reference, "its own box shadows it");
                shadowed += usize::from(drawn);
                points += 1;
            }
        }
    }
    assert!(shadowed > points / 20 && shadowed < points / 2, "{shadowed} of {points}");
}
