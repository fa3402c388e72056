//! `joca bench render`'s last table: every light of the world at once (cast shadows, a low sun
//! in a clear sky's light with its disc, veiling glare, tunnels as places) against the default
//! world, so what a user pays for turning them all on is one ratio of one run.

use super::render::{frames_at, imx172_behind_3_6_mm, interleaved_ms};
use anyhow::Result;
use joca_core::sun::{Daylight, SunElevation};
use joca_sim::{CityConfig, Glare, Illumination, SimConfig, Tunnels};

/// Passes over the frames per world, after a first.
const ROUNDS: usize = 7;

/// The world with every light on: the low-sun headroom panel's (`experiments/headroom/
/// low-sun-clear.toml`) with tunnels as places as well.
fn every_light(light: Illumination) -> SimConfig {
    SimConfig {
        illumination: Some(light),
        cast_shadows: true,
        sun_elevation: SunElevation { min_deg: 5.0, max_deg: 20.0, daylight: Daylight::ClearSky },
        sun_disc: true,
        glare: Glare { fraction: 0.02, scale_deg: 1.0 },
        city: CityConfig { tunnels: Tunnels::places(), ..CityConfig::default() },
        ..SimConfig::default()
    }
}

/// Every light at once against the default world, 320×240 on 2 threads, timed in turns
/// ([`interleaved_ms`]). By day and at night
/// the frames are the same instants of the same drive; under the `tunnel` light the drive goes
/// through a tunnel instead of under the switched light, so that row is what the light costs.
/// Then, by day, each light left out in turn: what it adds to the others.
pub(super) fn bench_every_light(times: &[f64], exposure_s: f64) -> Result<()> {
    let camera = imx172_behind_3_6_mm(320, 240);
    let requests = frames_at(times, exposure_s);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build()?;
    let time = |configs: &[SimConfig]| interleaved_ms(&pool, configs, &camera, &requests, ROUNDS);
    println!(
        "\nevery light at once (shadows, a 5-20° clear-sky sun and its disc, glare 2 % at 1°, \
            tunnels as places) against the default world, 320x240, 2 threads, {} frames, best \
            of {ROUNDS} passes taken in turns",
        times.len()
    );
    println!("{:<8} {:>12} {:>12} {:>10}", "light", "default ms", "every ms", "ratio");
    for light in [Illumination::Day, Illumination::Night, Illumination::Tunnel] {
        let default = SimConfig { illumination: Some(light), ..SimConfig::default() };
        let [default, every] = time(&[default, every_light(light)])[..] else {
            unreachable!("two worlds timed")
        };
        println!("{:<8} {default:>12.2} {every:>12.2} {:>9.2}x", light.name(), every / default);
    }
    let every = every_light(Illumination::Day);
    let left_out: [(&str, SimConfig); 5] = [
        ("cast shadows", SimConfig { cast_shadows: false, ..every }),
        ("the low sun (45-55°)", SimConfig { sun_elevation: SunElevation::default(), ..every }),
        ("the sun's disc", SimConfig { sun_disc: false, ..every }),
        ("glare", SimConfig { glare: Glare::default(), ..every }),
        ("tunnels as places", SimConfig { city: CityConfig::default(), ..every }),
    ];
    println!(
        "by day, every light but one, the same frames, best of {ROUNDS} passes taken in turns"
    );
    println!("{:<24} {:>12} {:>12}", "left out", "ms", "vs every");
    let configs: Vec<SimConfig> =
        std::iter::once(every).chain(left_out.iter().map(|(_, c)| *c)).collect();
    let ms = time(&configs);
    for ((name, _), ms_without) in left_out.iter().zip(&ms[1..]) {
        println!("{name:<24} {ms_without:>12.2} {:>11.2}x", ms_without / ms[0]);
    }
    Ok(())
}
