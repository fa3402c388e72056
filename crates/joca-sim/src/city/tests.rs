//! Tests of the city: generation, placement, ground and lamps.

use super::*;
use joca_core::{Class, SeedStreams};

fn city() -> City {
    City::generate(&CityConfig::default(), &mut SeedStreams::new(5).stream("city"))
}

#[test]
fn roads_and_zones_are_consistent() {
    let c = city();
    assert_eq!(c.roads_x.len(), 9);
    for w in c.roads_x.windows(2) {
        let gap = w[1].centre_m - w[1].half_width_m() - (w[0].centre_m + w[0].half_width_m());
        assert!((2.0 * SIDEWALK_M + 45.0..=2.0 * SIDEWALK_M + 75.0).contains(&gap), "{gap}");
    }
    // The centre line of a road is asphalt or paint; a block interior is green.
    let r = c.roads_x[3];
    let b = c.roads_y[2].centre_m + c.roads_y[2].half_width_m() + SIDEWALK_M + 10.0;
    let g = c.ground_albedo(r.centre_m + 1.7, b);
    assert!(g[0] < 0.15 && (g[0] - g[2]).abs() < 0.02, "{g:?}");
    let inside = c.ground_albedo(r.centre_m + r.half_width_m() + SIDEWALK_M + 20.0, b);
    assert!(inside[1] > inside[0], "{inside:?}");
}

#[test]
fn city_has_every_class_and_lamp_light() {
    let c = city();
    for class in Class::ALL {
        let count = c.objects.iter().filter(|o| o.class == Some(class)).count();
        assert!(count > 20, "{class:?}: {count}");
    }
    let moving = c.objects.iter().filter(|o| !o.motion.is_static()).count();
    assert!(moving > 100, "{moving}");
    // Somewhere along a kerb there is a lamp pool of about the configured peak.
    let r = c.roads_x[4];
    let peak = (0..(c.extent_m as usize))
        .map(|y| c.lamp_irradiance(r.centre_m + r.half_width_m() + 0.6 + 1.45, y as f32))
        .fold(0.0f32, f32::max);
    assert!((0.8 * LAMP_PEAK..=2.0 * LAMP_PEAK).contains(&peak), "{peak}");
}

#[test]
fn generation_is_deterministic_per_seed() {
    let a = city();
    let b = city();
    assert_eq!(a.objects, b.objects);
    let other = City::generate(&CityConfig::default(), &mut SeedStreams::new(6).stream("city"));
    assert_ne!(a.objects.len(), 0);
    assert_ne!(a.objects, other.objects);
}

fn count(c: &City, class: Class) -> usize {
    c.objects.iter().filter(|o| o.class == Some(class)).count()
}

#[test]
fn walker_density_scales_walkers_and_nothing_else() {
    let base = city();
    let dense = City::generate(
        &CityConfig::default().with_walker_density(3.0),
        &mut SeedStreams::new(5).stream("city"),
    );
    let (w1, w3) = (count(&base, Class::Walker), count(&dense, Class::Walker));
    // Sidewalk walkers are Σ round(3 · 1.2 · U(0, 2)) per edge against Σ round(1.2 · U(0, 2));
    // crossings go from 35 % to every intersection.
    let ratio = w3 as f64 / w1 as f64;
    assert!((2.5..3.5).contains(&ratio), "{w1} → {w3}");
    assert_eq!(count(&base, Class::Vehicle), count(&dense, Class::Vehicle));
    assert_eq!(base.roads_x, dense.roads_x);
    // Density 1 is the default city, drawn identically.
    let same = City::generate(
        &CityConfig::default().with_walker_density(1.0),
        &mut SeedStreams::new(5).stream("city"),
    );
    assert_eq!(same.objects, base.objects);
}

#[test]
fn sign_density_adds_signs_to_the_same_town() {
    let base = city();
    let dense = City::generate(
        &CityConfig::default().with_sign_density(2.0),
        &mut SeedStreams::new(5).stream("city"),
    );
    let (s1, s2) = (count(&base, Class::TrafficSign), count(&dense, Class::TrafficSign));
    // Each approach has a sign with probability 0.45, then 0.9: twice as many, within the
    // binomial spread of a town's approaches.
    let ratio = s2 as f64 / s1 as f64;
    assert!((1.6..2.4).contains(&ratio), "{s1} → {s2}");
    // Everything drawn before is the same town: the extra signs (and poles) come last.
    assert_eq!(dense.objects[..base.objects.len()], base.objects[..]);
    assert_eq!(dense.objects.len() - base.objects.len(), 2 * (s2 - s1));
    // A sign on every approach at 1/0.45 times the default; beyond it the rest stand along
    // the blocks: 5 × 0.45 = 2.25 signs per approach.
    let full = City::generate(
        &CityConfig::default().with_sign_density(1.0 / 0.45),
        &mut SeedStreams::new(5).stream("city"),
    );
    let approaches = 4 * full.roads_per_axis().pow(2);
    assert_eq!(count(&full, Class::TrafficSign), approaches);
    let denser = City::generate(
        &CityConfig::default().with_sign_density(5.0),
        &mut SeedStreams::new(5).stream("city"),
    );
    assert_eq!(denser.objects[..full.objects.len()], full.objects[..]);
    let per_approach = count(&denser, Class::TrafficSign) as f64 / approaches as f64;
    assert!((2.1..2.4).contains(&per_approach), "{per_approach}");
}
