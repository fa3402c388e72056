//! What the city's objects are made of: vehicles (their paints and shapes), walkers and
//! building facades, drawn from the town's random stream.

use super::*;

pub(super) const PAINTS: [Rgb; 9] = [
    [0.72, 0.72, 0.70],  // white
    [0.04, 0.04, 0.045], // black
    [0.45, 0.46, 0.47],  // silver
    [0.22, 0.22, 0.23],  // grey
    [0.50, 0.05, 0.04],  // red
    [0.05, 0.10, 0.40],  // blue
    [0.06, 0.22, 0.10],  // green
    [0.62, 0.48, 0.08],  // yellow
    [0.30, 0.18, 0.10],  // brown
];

pub(super) fn random_vehicle(rng: &mut impl Rng, motion: Motion) -> Object {
    let paint = PAINTS[rng.random_range(0..PAINTS.len())];
    let kind = rng.random::<f32>();
    if kind < 0.72 {
        build::vehicle(
            rng.random_range(3.9..4.9),
            rng.random_range(1.7..1.9),
            rng.random_range(1.4..1.6),
            paint,
            motion,
        )
    } else if kind < 0.9 {
        build::vehicle(
            rng.random_range(4.8..5.4),
            rng.random_range(1.9..2.0),
            rng.random_range(1.9..2.3),
            paint,
            motion,
        )
    } else {
        build::vehicle(rng.random_range(6.5..9.0), 2.4, rng.random_range(2.8..3.4), paint, motion)
    }
}

pub(super) fn random_walker(rng: &mut impl Rng, motion: Motion) -> Object {
    const CLOTHES: [Rgb; 8] = [
        [0.05, 0.05, 0.06],
        [0.55, 0.08, 0.08],
        [0.08, 0.15, 0.45],
        [0.6, 0.6, 0.58],
        [0.12, 0.3, 0.12],
        [0.55, 0.45, 0.2],
        [0.35, 0.35, 0.38],
        [0.6, 0.3, 0.1],
    ];
    const SKIN: [Rgb; 4] =
        [[0.6, 0.45, 0.36], [0.45, 0.32, 0.24], [0.3, 0.2, 0.15], [0.55, 0.42, 0.3]];
    let top = CLOTHES[rng.random_range(0..CLOTHES.len())];
    let trousers = CLOTHES[rng.random_range(0..CLOTHES.len())];
    let skin = SKIN[rng.random_range(0..SKIN.len())];
    build::walker(rng.random_range(1.5..1.95), top, trousers, skin, motion)
}

pub(super) fn facade(rng: &mut impl Rng) -> Material {
    const WALLS: [Rgb; 6] = [
        [0.55, 0.48, 0.38],
        [0.40, 0.40, 0.42],
        [0.42, 0.20, 0.14],
        [0.68, 0.67, 0.64],
        [0.16, 0.17, 0.19],
        [0.50, 0.36, 0.25],
    ];
    Material::Facade {
        wall: WALLS[rng.random_range(0..WALLS.len())],
        glass: [0.07, 0.09, 0.11],
        pitch_u_m: rng.random_range(2.8..4.2),
        pitch_v_m: rng.random_range(3.0..3.6),
        lit_seed: rng.random(),
    }
}
