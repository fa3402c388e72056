//! `joca bench render`: the simulator's frames, and what the lens, the weather, cast shadows,
//! glare and tunnels add to them (all of them at once: [`super::world`]).

use super::best_of;
use anyhow::Result;
use joca_core::optics::Lens;
use joca_core::{FrameRequest, FrameSource, PinholeCamera};
use joca_sim::render::shadow::Shadows;
use joca_sim::{Glare, Illumination, SimConfig, Simulator, Weather};
use std::hint::black_box;
use std::time::Instant;

pub(super) fn bench_render(repeats: usize) -> Result<()> {
    // Frames spread over an episode, so that speeds (and so blur) vary as in training.
    let times: Vec<f64> = (0..repeats).map(|k| 2.0 + k as f64 * 2.3).collect();
    let exposure_s = 10e-3;
    println!(
        "simulator, f = 3.6 mm on IMX172 (81° HFoV), exposure {} ms, {} frames over one \
            episode, best of 3 passes",
        exposure_s * 1e3,
        times.len()
    );
    println!(
        "{:<6} {:<10} {:>8} {:>12} {:>14} {:>14} {:>11} {:>9} {:>16}",
        "light",
        "output",
        "threads",
        "sub/frame",
        "sub-frames/s",
        "blurred ms",
        "frames/s",
        "2t vs 1t",
        "ground truth ms"
    );
    // At night the ground pass adds street-lamp and head-light terms per pixel.
    let cases = [
        (Illumination::Day, 320usize, 240usize),
        (Illumination::Day, 640, 480),
        (Illumination::Night, 320, 240),
    ];
    for (light, w, h) in cases {
        let sim = Simulator::new(SimConfig { illumination: Some(light), ..SimConfig::default() });
        let camera = imx172_behind_3_6_mm(w, h);
        let requests = frames_at(&times, exposure_s);
        let subframes: usize = requests
            .iter()
            .map(|r| sim.render(&camera, r).map_or(0, |f| f.subframes as usize))
            .sum();
        let mut one_thread = 0.0;
        for threads in [1usize, 2] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
            let render_all = || {
                for r in &requests {
                    black_box(sim.render(&camera, r).map(|f| f.boxes.len()).unwrap_or(0));
                }
            };
            // The best of 3 passes over the frames (one pass is as noisy as the machine).
            let secs = best_of(3, || pool.install(render_all));
            let per_frame = secs / requests.len() as f64;
            if threads == 1 {
                one_thread = per_frame;
            }
            // The reference-grid id pass alone (it runs beside the sub-frames in a frame, at the
            // frame's time: the middle of the shutter).
            let t = Instant::now();
            for r in &requests {
                black_box(sim.ground_truth(&camera, r.episode, r.time_s));
            }
            let truth_ms = t.elapsed().as_secs_f64() * 1e3 / requests.len() as f64;
            println!(
                "{:<6} {:<10} {:>8} {:>12.1} {:>14.0} {:>14.2} {:>11.1} {:>8.2}x {:>16.2}",
                light.name(),
                format!("{w}x{h}"),
                threads,
                subframes as f64 / requests.len() as f64,
                subframes as f64 / secs,
                per_frame * 1e3,
                1.0 / per_frame,
                one_thread / per_frame,
                truth_ms
            );
        }
    }
    println!(
        "(the middle sub-frame is rendered once and serves the blur and the sub-frame count; the \
            ground truth is an id pass on the reference grid, 2 mrad a pixel over the same field \
            of view, run beside the sub-frames and timed alone in the last column)"
    );
    bench_optics(&times, exposure_s)?;
    bench_shadows(&times, exposure_s)?;
    bench_glare(&times, exposure_s)?;
    bench_tunnels(&times, exposure_s)?;
    super::world::bench_every_light(&times, exposure_s)
}

/// The bench's camera: an IMX172 (6.2 × 4.65 mm) behind 3.6 mm at the nuScenes-like mount, an
/// ideal pinhole at `w × h` px.
pub(super) fn imx172_behind_3_6_mm(w: usize, h: usize) -> PinholeCamera {
    PinholeCamera::centred((w, h), (3.6 * w as f64 / 6.2, 3.6 * h as f64 / 4.65), [0.43, 0.0, 1.65])
}

/// Milliseconds a frame of `requests` takes a simulator of `config` through `camera` on `pool`,
/// best of 3 passes after a first.
fn ms_per_frame(
    pool: &rayon::ThreadPool,
    config: SimConfig,
    camera: &PinholeCamera,
    requests: &[FrameRequest],
) -> f64 {
    interleaved_ms(pool, &[config], camera, requests, 3)[0]
}

/// Milliseconds a frame of `requests` takes a simulator of each of `configs` through `camera`
/// on `pool`: the best of `rounds` passes each after a first, the worlds' passes taking turns
/// (one pass of each, then again), so that a slow spell of the machine slows every world alike
/// and the ratios of one run hold where a world timed after another would not.
pub(super) fn interleaved_ms(
    pool: &rayon::ThreadPool,
    configs: &[SimConfig],
    camera: &PinholeCamera,
    requests: &[FrameRequest],
    rounds: usize,
) -> Vec<f64> {
    let sims: Vec<Simulator> = configs.iter().map(|c| Simulator::new(*c)).collect();
    let pass = |sim: &Simulator| {
        let t = Instant::now();
        pool.install(|| {
            for r in requests {
                black_box(sim.render(camera, r).map(|f| f.boxes.len()).unwrap_or(0));
            }
        });
        t.elapsed().as_secs_f64()
    };
    sims.iter().for_each(|sim| _ = pass(sim));
    let mut best = vec![f64::INFINITY; sims.len()];
    for _ in 0..rounds {
        for (b, sim) in best.iter_mut().zip(&sims) {
            *b = b.min(pass(sim));
        }
    }
    best.iter().map(|s| s / requests.len() as f64 * 1e3).collect()
}

/// Episode 1's frames at `times` with one exposure.
pub(super) fn frames_at(times: &[f64], exposure_s: f64) -> Vec<FrameRequest> {
    times
        .iter()
        .map(|&t| FrameRequest { episode: 1, time_s: t, exposure_s, motion_scale: 1.0 })
        .collect()
}

/// The lens and the weather against the ideal pinhole in clear air by day: 320×240 on 2
/// threads, the same frames, ratios of one run (the last two cases at night).
fn bench_optics(times: &[f64], exposure_s: f64) -> Result<()> {
    let (w, h) = (320usize, 240usize);
    let pinhole = imx172_behind_3_6_mm(w, h);
    let requests = frames_at(times, exposure_s);
    let lens = |n: f64, focus_m: f64| Some(Lens { focal_length_mm: 3.6, f_number: n, focus_m });
    let (day, night) = (Illumination::Day, Illumination::Night);
    let fog100 = Weather::Fog { visibility_m: 100.0 };
    let cases = [
        ("ideal pinhole, clear", None, Weather::Clear, day),
        (
            "f/16 at its hyperfocal distance",
            Some(Lens::at_hyperfocal(3.6, 16.0, 1.55)),
            Weather::Clear,
            day,
        ),
        ("f/1.4 focused at 5 m", lens(1.4, 5.0), Weather::Clear, day),
        ("f/1.4 focused at 1 m", lens(1.4, 1.0), Weather::Clear, day),
        ("f/1.4 focused at 0.3 m (all blurred)", lens(1.4, 0.3), Weather::Clear, day),
        ("fog, visibility 100 m", None, fog100, day),
        ("rain, 25 mm/h", None, Weather::Rain { rate_mm_h: 25.0 }, day),
        ("night: ideal pinhole, clear", None, Weather::Clear, night),
        ("night: fog 100 m (glow)", None, fog100, night),
    ];
    println!(
        "\nlens and weather, {w}x{h}, 2 threads, the same {} frames (by day unless named), best \
         of 3",
        times.len()
    );
    println!("{:<36} {:>12} {:>12}", "case", "blurred ms", "vs pinhole");
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build()?;
    let mut base = 0.0;
    for (name, lens, weather, illumination) in cases {
        let sim = Simulator::new(SimConfig {
            illumination: Some(illumination),
            weather,
            ..SimConfig::default()
        });
        let camera = PinholeCamera { lens, ..pinhole };
        let render_all = || {
            for r in &requests {
                black_box(sim.render(&camera, r).map(|f| f.boxes.len()).unwrap_or(0));
            }
        };
        let per_frame = best_of(3, || pool.install(render_all)) / requests.len() as f64;
        if base == 0.0 {
            base = per_frame;
        }
        println!("{:<36} {:>12.2} {:>11.2}x", name, per_frame * 1e3, per_frame / base);
    }
    Ok(())
}

/// Cast shadows against none, by day and at night: 320×240 on 2 threads, the same frames, ratios
/// of one run; the first pass (cold: the static city binned for the episode's sun, each face's
/// shadows computed on first sight) and the best of the next three (warm, as every later frame
/// of an episode is); and what binning the static city for one sun costs alone.
fn bench_shadows(times: &[f64], exposure_s: f64) -> Result<()> {
    let camera = imx172_behind_3_6_mm(320, 240);
    let requests = frames_at(times, exposure_s);
    println!(
        "\ncast shadows, 320x240, 2 threads, the same {} frames: first pass, then best of 3",
        times.len()
    );
    println!(
        "{:<8} {:>14} {:>14} {:>10} {:>14} {:>14} {:>10}",
        "light", "first off ms", "first on ms", "ratio", "best off ms", "best on ms", "ratio"
    );
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build()?;
    for light in [Illumination::Day, Illumination::Night] {
        // (first, best) without and with shadows.
        let mut ms = [(0.0, 0.0); 2];
        for (slot, cast_shadows) in ms.iter_mut().zip([false, true]) {
            let config =
                SimConfig { illumination: Some(light), cast_shadows, ..SimConfig::default() };
            let sim = Simulator::new(config);
            let render_all = || {
                for r in &requests {
                    black_box(sim.render(&camera, r).map(|f| f.boxes.len()).unwrap_or(0));
                }
            };
            let per_frame = |secs: f64| secs / requests.len() as f64 * 1e3;
            let t = Instant::now();
            pool.install(render_all);
            let first = per_frame(t.elapsed().as_secs_f64());
            *slot = (first, per_frame(best_of(3, || pool.install(render_all))));
        }
        let [(first_off, off), (first_on, on)] = ms;
        println!(
            "{:<8} {:>14.2} {:>14.2} {:>9.2}x {:>14.2} {:>14.2} {:>9.2}x",
            light.name(),
            first_off,
            first_on,
            first_on / first_off,
            off,
            on,
            on / off
        );
    }
    let sim = Simulator::new(SimConfig::default());
    let sun = sim.episode(1).sun_dir;
    let statics = || {
        sim.city()
            .objects
            .iter()
            .filter(|o| o.motion.is_static())
            .flat_map(|o| o.boxes_at(0.0).map(|(b, _)| b))
    };
    let t = Instant::now();
    let shadows = Shadows::new(statics(), sun);
    let build_ms = t.elapsed().as_secs_f64() * 1e3;
    println!(
        "binning the static city's {} boxes for one sun: {build_ms:.1} ms ({} cell entries)",
        statics().count(),
        shadows.map_or(0, |s| s.entries())
    );
    Ok(())
}

/// Veiling glare (2 %, 1°) against none, by day and at night, at two frame sizes on 2 threads:
/// the same frames, best of 3, ratios of one run.
fn bench_glare(times: &[f64], exposure_s: f64) -> Result<()> {
    let requests = frames_at(times, exposure_s);
    println!("\nveiling glare 2 % at 1°, 2 threads, the same {} frames, best of 3", times.len());
    println!("{:<8} {:<10} {:>12} {:>12} {:>10}", "light", "output", "off ms", "on ms", "ratio");
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build()?;
    let glare = Glare { fraction: 0.02, scale_deg: 1.0 };
    for (light, w, h) in [
        (Illumination::Day, 320, 240),
        (Illumination::Day, 640, 480),
        (Illumination::Night, 320, 240),
    ] {
        let camera = imx172_behind_3_6_mm(w, h);
        let ms = [Glare::default(), glare].map(|glare| {
            let config = SimConfig { illumination: Some(light), glare, ..SimConfig::default() };
            ms_per_frame(&pool, config, &camera, &requests)
        });
        let output = format!("{w}x{h}");
        println!(
            "{:<8} {output:<10} {:>12.2} {:>12.2} {:>9.2}x",
            light.name(),
            ms[0],
            ms[1],
            ms[1] / ms[0]
        );
    }
    Ok(())
}

/// Tunnels as places against the switch, 320×240 on 2 threads, best of 3, ratios of one run: by
/// day and at night the same episodes in a town with six covered blocks (every ground pixel and
/// face asks whether a tunnel covers it); under the `tunnel` light different frames (a drive
/// through a tunnel against the switched light), so that row is what the light costs, not the
/// same frames.
fn bench_tunnels(times: &[f64], exposure_s: f64) -> Result<()> {
    let camera = imx172_behind_3_6_mm(320, 240);
    let requests = frames_at(times, exposure_s);
    println!(
        "\ntunnels as places (6 a town), 320x240, 2 threads, {} frames, best of 3",
        times.len()
    );
    println!("{:<8} {:>12} {:>12} {:>10}", "light", "switch ms", "places ms", "ratio");
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build()?;
    for light in [Illumination::Day, Illumination::Night, Illumination::Tunnel] {
        let ms = [joca_sim::Tunnels::default(), joca_sim::Tunnels::places()].map(|tunnels| {
            let config = SimConfig {
                illumination: Some(light),
                city: joca_sim::CityConfig { tunnels, ..joca_sim::CityConfig::default() },
                ..SimConfig::default()
            };
            ms_per_frame(&pool, config, &camera, &requests)
        });
        println!("{:<8} {:>12.2} {:>12.2} {:>9.2}x", light.name(), ms[0], ms[1], ms[1] / ms[0]);
    }
    Ok(())
}
