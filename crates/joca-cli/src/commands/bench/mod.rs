//! `joca bench`: speed of joca's components, printed as a table.
//!
//! Machines here are noisy, so each figure comes with a ratio against a reference measured in the
//! same run on the same input.

use anyhow::Result;
use clap::ValueEnum;
use joca_camera::{Calibration, DynamicSettings, ImageFormation, WHITE_LEVEL};
use joca_core::optics::Lens;
use joca_core::{FrameRequest, FrameSource, HdrImage, PinholeCamera, SeedStreams};
use joca_sim::{Illumination, SimConfig, Simulator, Weather};
use std::hint::black_box;
use std::path::PathBuf;
use std::time::Instant;

mod detector;
mod flow;
mod step;
use detector::bench_detector;
use step::bench_step;

/// What to measure.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum Target {
    /// Image formation (Eq. 2–3) on a 1280×960 RGB frame.
    Formation,
    /// The simulator: sub-frames and motion-blurred frames at 320×240 and 640×480 by day and at
    /// 320×240 by night, 1 and 2 threads.
    Render,
    /// The detector: inference and training step at 320×240 and 640×480, against PyTorch.
    Detector,
    /// One step of the joint loop (method joca) broken down by part, on the FLIR camera.
    Step,
    /// DIS optical flow on a 1920×1280 pair (each preset, 1 and 2 threads) and flow-based blur.
    Flow,
    /// A run's checkpoint (the preset's detector and NeuralAE with their optimisers): writing
    /// its files, their SHA-256 digests, and verifying them.
    Checkpoint,
}

/// Arguments of `joca bench`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Component to measure.
    #[arg(value_enum)]
    target: Target,
    /// Timed repetitions per row (the best is reported), 1 to 10000.
    #[arg(long, default_value_t = 20, value_parser = crate::config::count::<1, 10000>)]
    repeats: usize,
    /// Threads for the detector benchmark (libtorch intra-op threads), 1 to 64.
    #[arg(long, default_value_t = 2, value_parser = crate::config::count::<1, 64>)]
    threads: usize,
    /// `bench detector`: the variant with the stride-32 stage (`detector.deep`, the shipped
    /// weights' architecture).
    #[arg(long)]
    deep: bool,
    /// `bench detector`: one hidden layer shared by the three heads (`detector.shared_head`).
    #[arg(long)]
    shared_head: bool,
    /// Python interpreter for the references: torch for `bench detector`, opencv-python-headless
    /// for `bench flow` (each is skipped, with a message, where it cannot be imported).
    #[arg(long, default_value = "python3")]
    python: String,
    /// Preset whose [run] settings `bench step` and `bench checkpoint` use (detector input,
    /// threads, weights).
    #[arg(long, default_value = "quick")]
    preset: String,
    /// `bench flow`: a pair of frames to measure on (same size) instead of the built-in one.
    #[arg(long, num_args = 2, value_names = ["FIRST", "SECOND"])]
    pair: Option<Vec<PathBuf>>,
    /// `bench flow` with --pair: ground-truth flow (.flo) for the error columns.
    #[arg(long, value_name = "FLO", conflicts_with = "gt_disparity", requires = "pair")]
    gt: Option<PathBuf>,
    /// `bench flow` with --pair: ground-truth disparity (.npy or .pfm) of a rectified pair,
    /// first = left; the true flow is (−d, 0).
    #[arg(long, value_name = "FILE", requires = "pair")]
    gt_disparity: Option<PathBuf>,
}

/// Runs `joca bench`.
pub fn run(args: &Args) -> Result<()> {
    if matches!(args.target, Target::Detector | Target::Step | Target::Checkpoint) {
        println!(
            "libtorch CPU kernels: {} (JOCA_CPU_KERNELS; the PyTorch reference inherits them); \
             subnormal floats: {} (JOCA_DENORMALS)",
            joca_nn::kernels::chosen().name(),
            joca_nn::kernels::denormals().name()
        );
    }
    match args.target {
        Target::Formation => bench_formation(args.repeats.max(1)),
        Target::Render => bench_render(args.repeats.max(1)),
        Target::Detector => {
            let config = joca_nn::detector::DetectorConfig {
                deep: args.deep,
                shared_head: args.shared_head,
                ..Default::default()
            };
            bench_detector(args.repeats.max(1), args.threads, config, &args.python)
        }
        Target::Step => bench_step(args.repeats.max(2), &args.preset),
        Target::Flow => flow::bench_flow(args),
        Target::Checkpoint => step::bench_checkpoint(args.repeats.max(1), &args.preset),
    }
}

/// Best wall time of `repeats` runs of `f`, seconds.
fn best_of(repeats: usize, mut f: impl FnMut()) -> f64 {
    f(); // warm caches and the allocator
    (0..repeats)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

fn bench_formation(repeats: usize) -> Result<()> {
    let (w, h) = (1280, 960);
    let mut i0 = HdrImage::zeros(w, h);
    for (k, v) in i0.data_mut().iter_mut().enumerate() {
        *v = ((k * 7919) % 240) as f32 + 0.5;
    }
    let formation = ImageFormation::new(Calibration::DEFAULT)?;
    let settings = DynamicSettings::new(6e-3, 12.0);
    let streams = SeedStreams::new(0);
    let mpix = (w * h) as f64 / 1e6;

    let full = best_of(repeats, || {
        black_box(formation.form(&i0, settings, 2.4, &mut streams.stream("bench")));
    });
    let parallel = best_of(repeats, || {
        black_box(formation.form_parallel(&i0, settings, 2.4, &mut streams.stream("bench")));
    });
    let normals = best_of(repeats, || {
        black_box(ImageFormation::standard_normals(w, h, 42));
    });
    // The deterministic part alone: scale, clip, round (what formation costs without noise).
    let params = formation.params(settings, 2.4);
    let mut out = vec![0u8; w * h * 3];
    let deterministic = best_of(repeats, || {
        for (d, &s) in out.iter_mut().zip(i0.data()) {
            *d = ((s * params.intensity_scale).clamp(0.0, WHITE_LEVEL) + 0.5) as u8;
        }
        black_box(&out);
    });

    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    println!("image formation, {w}x{h} RGB ({mpix:.2} Mpixel), best of {repeats}");
    println!("{:<44} {:>9} {:>11} {:>9}", "variant", "ms", "Mpixel/s", "vs full");
    let row = |name: &str, s: f64| {
        println!("{:<44} {:>9.2} {:>11.1} {:>8.2}x", name, s * 1e3, mpix / s, full / s);
    };
    row("full formation, 1 thread", full);
    row(&format!("full formation, rayon ({threads} threads)"), parallel);
    row("normal samples only (3 per pixel), 1 thread", normals);
    row("scale+clip+round only (no noise), 1 thread", deterministic);
    Ok(())
}

fn bench_render(repeats: usize) -> Result<()> {
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
    bench_optics(&times, exposure_s)
}

/// The bench's camera: an IMX172 (6.2 × 4.65 mm) behind 3.6 mm at the nuScenes-like mount, an
/// ideal pinhole at `w × h` px.
fn imx172_behind_3_6_mm(w: usize, h: usize) -> PinholeCamera {
    PinholeCamera::centred((w, h), (3.6 * w as f64 / 6.2, 3.6 * h as f64 / 4.65), [0.43, 0.0, 1.65])
}

/// Episode 1's frames at `times` with one exposure.
fn frames_at(times: &[f64], exposure_s: f64) -> Vec<FrameRequest> {
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
