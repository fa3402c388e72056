//! `joca bench`: speed of joca's components, printed as a table.
//!
//! Machines here are noisy, so each figure comes with a ratio against a reference measured in the
//! same run on the same input.

use anyhow::Result;
use clap::ValueEnum;
use joca_camera::{Calibration, DynamicSettings, ImageFormation, WHITE_LEVEL};
use joca_core::{FrameRequest, FrameSource, HdrImage, PinholeCamera, SeedStreams};
use joca_sim::{Illumination, SimConfig, Simulator};
use std::hint::black_box;
use std::path::PathBuf;
use std::time::Instant;

mod flow;

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
    /// Preset whose [run] settings `bench step` uses (detector input, threads, weights).
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
    if matches!(args.target, Target::Detector | Target::Step) {
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
        let camera = PinholeCamera {
            width_px: w,
            height_px: h,
            fx_px: 3.6 * w as f64 / 6.2,
            fy_px: 3.6 * h as f64 / 4.65,
            cx_px: w as f64 / 2.0,
            cy_px: h as f64 / 2.0,
            mount_m: [0.43, 0.0, 1.65],
        };
        let requests: Vec<FrameRequest> = times
            .iter()
            .map(|&t| FrameRequest { episode: 1, time_s: t, exposure_s, motion_scale: 1.0 })
            .collect();
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
    Ok(())
}

/// Peak single-precision throughput of one core of this machine class (AVX-512: 2 FMA units ×
/// 16 lanes × 2 flops at ~1.8 GHz), GFLOP/s. A reference for the utilisation column only.
const PEAK_GFLOPS_PER_CORE: f64 = 115.0;

fn bench_detector(
    repeats: usize,
    threads: usize,
    config: joca_nn::detector::DetectorConfig,
    python: &str,
) -> Result<()> {
    use joca_nn::detector::{Precision, forward_flops, time_detector, time_training};
    let engine = joca_nn::Engine::cpu(threads);
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scripts/bench_detector_pytorch.py");
    let mut script_args = vec![script.to_owned(), "--width".into(), config.width.to_string()];
    script_args.extend(["--threads".into(), threads.to_string()]);
    script_args.extend(["--repeats".into(), repeats.to_string()]);
    if config.deep {
        script_args.push("--deep".into());
    }
    if config.shared_head {
        script_args.push("--shared-head".into());
    }
    let reference: Option<serde_json::Value> = std::process::Command::new(python)
        .args(&script_args)
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| serde_json::from_slice(&o.stdout).ok());
    println!(
        "detector (width {}{}{}, {} threads), best of {repeats}; training step = forward + loss + \
            backward + AdamW",
        config.width,
        if config.deep { ", deep" } else { "" },
        if config.shared_head { ", shared head" } else { "" },
        threads
    );
    println!(
        "{:<9} {:<10} {:>9} {:>10} {:>9} {:>12} {:>13}",
        "input", "pass", "ms", "GFLOP", "GFLOP/s", "% of peak", "joca/PyTorch"
    );
    for (h, w) in [(240usize, 320usize), (480, 640)] {
        let (infer, train) = time_detector(&engine, config, h, w, repeats);
        let f = forward_flops(config, h as i64, w as i64) / 1e9;
        let peak = PEAK_GFLOPS_PER_CORE * threads as f64;
        let key = format!("{h}x{w}");
        for (pass, ms, flops, field) in
            [("inference", infer, f, "infer_ms"), ("train step", train, 3.0 * f, "train_ms")]
        {
            let gflops = flops / (ms / 1e3);
            let ratio = reference
                .as_ref()
                .and_then(|r| r[&key][field].as_f64())
                .map_or_else(|| "n/a".to_owned(), |torch_ms| format!("{:.2}", ms / torch_ms));
            println!(
                "{:<9} {:<10} {:>9.2} {:>10.3} {:>9.1} {:>11.1}% {:>13}",
                format!("{w}x{h}"),
                pass,
                ms,
                flops,
                gflops,
                100.0 * gflops / peak,
                ratio
            );
        }
    }
    // What pre-training can use instead of float32 steps on single frames (`[pretrain]
    // batch` and `precision`): training time per frame, against the float32 single-frame step
    // measured in the same loop.
    println!();
    println!(
        "training time per frame (pre-training's `batch` and `precision`), 2 threads as above"
    );
    println!(
        "{:<9} {:<6} {:<10} {:>12} {:>16}",
        "input", "batch", "precision", "ms/frame", "fp32 ×1 / this"
    );
    for (h, w) in [(240usize, 320usize), (480, 640)] {
        let mut base = None;
        for (batch, precision) in
            [(1, Precision::Fp32), (1, Precision::Bf16), (5, Precision::Fp32), (5, Precision::Bf16)]
        {
            let ms = time_training(&engine, config, h, w, repeats, batch, precision);
            let base = *base.get_or_insert(ms);
            println!(
                "{:<9} {:<6} {:<10} {:>12.2} {:>16.2}",
                format!("{w}x{h}"),
                batch,
                format!("{precision:?}").to_lowercase(),
                ms,
                base / ms
            );
        }
    }
    if reference.is_none() {
        println!(
            "(PyTorch reference not run: `{python} -c \"import torch\"` failed; install \
                torch==2.13.0 or pass --python)"
        );
    }
    println!("(training GFLOP counted as 3x forward: backward costs about twice the forward pass)");
    Ok(())
}

fn bench_step(steps: usize, preset: &str) -> Result<()> {
    use joca_nn::detector::Precision;
    use joca_train::{FixedCamera, Method, RunConfig};
    let mut cfg: RunConfig = crate::config::load(preset, None, "run")?;
    cfg.method = Method::Joca;
    crate::commands::run::resolve_weights(&mut cfg);
    let design = FixedCamera::Flir.design();
    let (w, h) = design.resolution(&cfg.input);
    cfg.scoring_precision = Precision::Fp32;
    let b = joca_train::bench_step(&cfg, &design, steps, None)?;
    let total = b.total_ms();
    println!(
        "joint-loop step, method joca, FLIR IMX172 at {w}x{h} (detector input, {} resize), {} \
            threads, mean of {} steps, perturbed frames scored in fp32",
        cfg.input.resampler, cfg.threads, b.steps
    );
    if !Precision::native_bf16() {
        println!(
            "(the default here: scoring_precision = \"bf16\" is fp32 without native bfloat16)"
        );
    }
    println!("{:<46} {:>9} {:>7}", "part", "ms", "share");
    for (name, ms) in [
        ("NeuralAE prediction", b.acc_predict_ms),
        ("render forward + perturbed frames (one grid)", b.render_ms),
        ("form the perturbed frames", b.perturbation_render_ms),
        ("detect + AP50 of the perturbed frames", b.perturbation_detect_ms),
        ("perturbation GA", b.perturbation_ga_ms),
        ("noise sample", b.noise_ms),
        ("differentiable formation", b.formation_ms),
        ("detector forward + loss", b.detector_forward_ms),
        ("backward (detector, formation, NeuralAE)", b.backward_ms),
        ("optimiser updates", b.update_ms),
        ("decode + bookkeeping", b.decode_ms),
    ] {
        println!("{:<46} {:>9.1} {:>6.1}%", name, ms, 100.0 * ms / total);
    }
    println!("{:<46} {:>9.1}", "total per step", total);
    println!("{:<46} {:>9.1}", "sub-frames rendered per step (mean)", b.subframes);
    // Detector training steps on a frame of the same size, same threads, same run. The ratio
    // compares like with like: the mean joint step with the mean detector step (what a run of
    // either costs per step); the best detector step is shown beside it.
    let engine = joca_nn::Engine::cpu(cfg.threads);
    let times = joca_nn::detector::training_step_times(
        &engine,
        cfg.detector,
        h,
        w,
        steps,
        1,
        Precision::Fp32,
    );
    let detector_ms = times.iter().sum::<f64>() / times.len() as f64;
    let best_ms = times.iter().copied().fold(f64::INFINITY, f64::min);
    println!(
        "{:<46} {:>9.1}   (best {:.1})",
        format!("detector training step alone (mean of {})", times.len()),
        detector_ms,
        best_ms
    );
    println!(
        "{:<46} {:>9.2}x  (against the best: {:.2}x)",
        "step / detector training step",
        total / detector_ms,
        total / best_ms
    );
    // The perturbed frames scored in bfloat16 where the CPU has it natively, with every search
    // also scored in float32 (untimed) to count how often the two choose the same member.
    if !Precision::native_bf16() {
        println!(
            "(scoring_precision = \"bf16\" not timed: native bfloat16 needs AVX-512 BF16 and \
             JOCA_CPU_KERNELS=native)"
        );
        return Ok(());
    }
    // The same steps as above (same scenes, same warm-up), so the rows compare like with like.
    cfg.scoring_precision = Precision::Bf16;
    let b = joca_train::bench_step(&cfg, &design, steps, Some(Precision::Fp32))?;
    println!(
        "\nwith scoring_precision = \"bf16\" (the default; native here), the same {} steps, same \
            run",
        b.steps
    );
    println!("{:<46} {:>9.1}", "render forward + perturbed frames (one grid)", b.render_ms);
    println!("{:<46} {:>9.1}", "detect + AP50 of the perturbed frames", b.perturbation_detect_ms);
    println!("{:<46} {:>9.1}", "total per step", b.total_ms());
    println!("{:<46} {:>9.2}x", "step / detector training step", b.total_ms() / detector_ms);
    println!(
        "{:<46} {:>5} of {}",
        "searches choosing the fp32 member", b.searches_agreeing, b.searches_checked
    );
    let n = b.searches_checked.max(1) as f64;
    println!(
        "{:<46} {:>9.4}  (fp32 fitness spread among members: {:.4})",
        "mean fp32 fitness lost by the bf16 choice",
        b.check_regret / n,
        b.check_spread / n
    );
    Ok(())
}
