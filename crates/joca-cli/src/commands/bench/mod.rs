//! `joca bench`: speed of joca's components, printed as a table.
//!
//! Machines here are noisy, so each figure comes with a ratio against a reference measured in the
//! same run on the same input.

use anyhow::Result;
use clap::ValueEnum;
use joca_camera::{Calibration, DynamicSettings, ImageFormation, WHITE_LEVEL};
use joca_core::{HdrImage, SeedStreams};
use std::hint::black_box;
use std::path::PathBuf;
use std::time::Instant;

mod detector;
mod flow;
mod render;
mod step;
mod world;
use detector::bench_detector;
use render::bench_render;
use step::bench_step;

/// What to measure.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum Target {
    /// Image formation (Eq. 2–3) on a 1280×960 RGB frame.
    Formation,
    /// The simulator: sub-frames and motion-blurred frames at 320×240 and 640×480 by day and at
    /// 320×240 by night, 1 and 2 threads; then the lens, the weather, cast shadows, veiling
    /// glare and tunnels against the ideal pinhole in clear air without them, and every light at
    /// once against the default world.
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
    /// `bench detector` and `bench step`: what the networks compute on: cpu, cuda, cuda:N or
    /// auto [default: cpu; for `step`, the preset's `device`].
    #[arg(long, value_parser = crate::config::device)]
    device: Option<joca_nn::device::DeviceChoice>,
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
    /// `bench step` and `bench checkpoint`: a TOML file whose tables override the preset's, as
    /// `joca run --config` reads it (the world's lights, the detector input, the threads).
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
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
    if let (Some(file), false) =
        (&args.config, matches!(args.target, Target::Step | Target::Checkpoint))
    {
        anyhow::bail!(
            "--config {}: only `bench step` and `bench checkpoint` read a configuration (the \
             preset's [run] with the file's over it)",
            file.display()
        );
    }
    // Every figure a bench prints holds for its machine type only: name it first.
    println!(
        "machine: {}, {} logical CPUs",
        joca_train::cpu_description(),
        std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
    );
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
            let device = args.device.unwrap_or_default();
            bench_detector(args.repeats.max(1), (args.threads, device), config, &args.python)
        }
        Target::Step => {
            bench_step(args.repeats.max(2), (&args.preset, args.config.as_deref()), args.device)
        }
        Target::Flow => flow::bench_flow(args),
        Target::Checkpoint => {
            step::bench_checkpoint(args.repeats.max(1), (&args.preset, args.config.as_deref()))
        }
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
