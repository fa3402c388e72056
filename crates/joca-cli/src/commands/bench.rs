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

/// What to measure.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum Target {
    /// Image formation (Eq. 2–3) on a 1280×960 RGB frame.
    Formation,
    /// The simulator: sub-frames and motion-blurred frames at 320×240 and 640×480, 1 and 2 threads.
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
    /// Timed repetitions per row (the best is reported).
    #[arg(long, default_value_t = 20)]
    repeats: usize,
    /// Threads for the detector benchmark (libtorch intra-op threads).
    #[arg(long, default_value_t = 2)]
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
    /// Preset whose [run] settings `bench step` uses (render scale, threads, weights).
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
        Target::Flow => bench_flow(args),
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

/// A textured 1920×1280 pair with a known motion (zoom 1 % about the centre plus a shift of
/// (3.3, −1.2) px): the flow benchmark's input.
fn flow_pair() -> (joca_data::flow::Gray, joca_data::flow::Gray, joca_data::flow::Flow) {
    use joca_data::flow::{Flow, Gray};
    let (w, h) = (1920usize, 1280usize);
    let texture = |x: f32, y: f32| {
        128.0
            + 40.0 * (0.11 * x + 0.3 * (0.013 * y).sin()).sin()
            + 30.0 * (0.07 * y + 0.2 * (0.021 * x).cos()).cos()
            + 25.0 * (0.031 * (x + y)).sin() * (0.043 * (x - y)).cos()
    };
    let (cx, cy, k, t) = (w as f32 / 2.0, h as f32 / 2.0, 1.01f32, (3.3f32, -1.2f32));
    let forward = |x: f32, y: f32| (cx + k * (x - cx) + t.0, cy + k * (y - cy) + t.1);
    let inverse = |x: f32, y: f32| (cx + (x - t.0 - cx) / k, cy + (y - t.1 - cy) / k);
    let grid = |f: &dyn Fn(f32, f32) -> f32| {
        Gray::new(w, h, (0..w * h).map(|i| f((i % w) as f32, (i / w) as f32)).collect())
    };
    let i0 = grid(&|x, y| texture(x, y));
    let i1 = grid(&|x, y| {
        let (a, b) = inverse(x, y);
        texture(a, b)
    });
    let truth = Flow::new(
        w,
        h,
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                let (a, b) = forward(x, y);
                [a - x, b - y]
            })
            .collect(),
    );
    (i0, i1, truth)
}

/// The pair `bench flow` measures, as the 8-bit grey values both joca and OpenCV compute on,
/// with its ground truth if known.
struct FlowBenchPair {
    name: String,
    i0: joca_data::flow::Gray,
    i1: joca_data::flow::Gray,
    truth: Option<joca_data::flow::KnownFlow>,
}

impl FlowBenchPair {
    /// `--pair` (with `--gt`/`--gt-disparity`), or the built-in textured pair quantised to 8 bits.
    fn from_args(args: &Args) -> Result<Self> {
        use joca_data::flow::{Gray, read_disparity, read_flo};
        let quantised = |g: &Gray| {
            let data = g.data().iter().map(|v| v.round().clamp(0.0, 255.0)).collect();
            Gray::new(g.width(), g.height(), data)
        };
        let Some(pair) = &args.pair else {
            let (i0, i1, truth) = flow_pair();
            let known = truth.data().iter().map(|&v| Some(v)).collect();
            return Ok(Self {
                name: "1920×1280 textured pair (zoom 1 % + shift)".into(),
                i0: quantised(&i0),
                i1: quantised(&i1),
                truth: Some((truth.width(), truth.height(), known)),
            });
        };
        let (a, b) = (crate::io::read_rgb8(&pair[0])?, crate::io::read_rgb8(&pair[1])?);
        if (a.width(), a.height()) != (b.width(), b.height()) {
            anyhow::bail!(
                "{} and {} differ in size: flow needs frames of one size",
                pair[0].display(),
                pair[1].display()
            );
        }
        let truth = match (&args.gt, &args.gt_disparity) {
            (Some(p), _) => Some(read_flo(p)?),
            (None, Some(p)) => Some(read_disparity(p)?),
            (None, None) => None,
        };
        if let Some((w, h, _)) = &truth
            && (*w, *h) != (a.width(), a.height())
        {
            anyhow::bail!(
                "the ground truth is {w}×{h} but the frames are {}×{}",
                a.width(),
                a.height()
            );
        }
        Ok(Self {
            name: format!(
                "{} → {} ({}×{})",
                pair[0].display(),
                pair[1].display(),
                a.width(),
                a.height()
            ),
            i0: quantised(&Gray::from_rgb8(&a)),
            i1: quantised(&Gray::from_rgb8(&b)),
            truth,
        })
    }

    /// End-point error and share above 3 px of `flow`, if the truth is known.
    fn score(&self, flow: &joca_data::flow::Flow) -> Result<Option<joca_data::flow::FlowAccuracy>> {
        self.truth
            .as_ref()
            .map(|t| joca_data::flow::accuracy(flow, t).map_err(anyhow::Error::msg))
            .transpose()
    }
}

/// One row of the OpenCV reference: preset, threads, best time (ms), flow.
type PeerFlow = (String, usize, f64, joca_data::flow::Flow);

/// OpenCV's DIS on `pair`, per `(preset, threads)`: best time (ms) and its flow, from
/// `scripts/bench_flow_opencv.py` run by `python`; `Err` says why it was not run.
fn opencv_flows(
    pair: &FlowBenchPair,
    python: &str,
    repeats: usize,
    dir: &std::path::Path,
) -> std::result::Result<(String, Vec<PeerFlow>), String> {
    let grey = |g: &joca_data::flow::Gray| -> Result<joca_core::Rgb8Image> {
        let rgb = g.data().iter().flat_map(|&v| [v as u8; 3]).collect();
        Ok(joca_core::Rgb8Image::from_vec(g.width(), g.height(), rgb)?)
    };
    let (p0, p1) = (dir.join("first.png"), dir.join("second.png"));
    for (path, g) in [(&p0, &pair.i0), (&p1, &pair.i1)] {
        grey(g)
            .and_then(|img| crate::io::write_png(path, &img))
            .map_err(|e| format!("cannot write the pair for OpenCV: {e:#}"))?;
    }
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scripts/bench_flow_opencv.py");
    let out = std::process::Command::new(python)
        .arg(script)
        .args([&p0, &p1, &dir.to_path_buf()])
        .args(["--threads", "1", "2", "--repeats", &repeats.to_string()])
        .output()
        .map_err(|e| format!("cannot start {python}: {e}"))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        return Err(format!(
            "`{python} {script}` failed ({}); install opencv-python-headless or pass --python",
            err.lines().last().unwrap_or("no message")
        ));
    }
    let v: serde_json::Value =
        serde_json::from_slice(&out.stdout).map_err(|e| format!("unreadable output: {e}"))?;
    let version = v["version"].as_str().unwrap_or("?").to_owned();
    let rows = v["rows"]
        .as_array()
        .ok_or("no rows in the output")?
        .iter()
        .map(|r| {
            let flo = std::path::Path::new(r["flo"].as_str().ok_or("row without flo")?);
            let (w, h, known) = joca_data::flow::read_flo(flo).map_err(|e| e.to_string())?;
            let data = known.into_iter().map(|v| v.unwrap_or([f32::NAN; 2])).collect();
            Ok((
                r["preset"].as_str().ok_or("row without preset")?.to_owned(),
                r["threads"].as_u64().ok_or("row without threads")? as usize,
                r["ms"].as_f64().ok_or("row without ms")?,
                joca_data::flow::Flow::new(w, h, data),
            ))
        })
        .collect::<std::result::Result<Vec<_>, String>>()?;
    Ok((version, rows))
}

fn bench_flow(args: &Args) -> Result<()> {
    use joca_data::flow::{DisParams, DisPreset, dis};
    let repeats = args.repeats.clamp(1, 5);
    let pair = FlowBenchPair::from_args(args)?;
    let dir = std::env::temp_dir().join(format!("joca-bench-flow-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let reference = opencv_flows(&pair, &args.python, repeats, &dir);
    std::fs::remove_dir_all(&dir).ok();
    println!("DIS optical flow on {}, 8-bit grey, best of {repeats} warm calls", pair.name);
    match &reference {
        Ok((version, _)) => println!("beside OpenCV {version}'s DIS on the same pair and threads"),
        Err(why) => println!("(OpenCV reference not run: {why})"),
    }
    let fmt_acc = |a: &Option<joca_data::flow::FlowAccuracy>| {
        a.as_ref().map_or("-".to_owned(), |a| format!("{:.3} / {:.1}%", a.epe, 100.0 * a.above_3px))
    };
    println!(
        "{:<10} {:>7} {:>10} {:>10} {:>9} {:>18} {:>18}",
        "preset",
        "threads",
        "joca ms",
        "OpenCV ms",
        "ratio",
        "joca EPE / >3px",
        "OpenCV EPE / >3px"
    );
    for (name, preset) in [
        ("ultrafast", DisPreset::UltraFast),
        ("fast", DisPreset::Fast),
        ("medium", DisPreset::Medium),
    ] {
        let params = DisParams::preset(preset);
        let ours = pair.score(&dis(&pair.i0, &pair.i1, &params))?;
        for threads in [1usize, 2] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
            let t = pool.install(|| {
                best_of(repeats, || {
                    black_box(dis(&pair.i0, &pair.i1, &params));
                })
            }) * 1e3;
            let peer = reference.as_ref().ok().and_then(|(_, rows)| {
                rows.iter().find(|r| r.0 == name && r.1 == threads).map(|r| (r.2, &r.3))
            });
            let (peer_ms, ratio, peer_acc) = match peer {
                Some((ms, flow)) => {
                    (format!("{ms:.1}"), format!("{:.2}×", t / ms), fmt_acc(&pair.score(flow)?))
                }
                None => ("-".into(), "-".into(), "-".into()),
            };
            println!(
                "{name:<10} {threads:>7} {t:>10.1} {peer_ms:>10} {ratio:>9} {:>18} {peer_acc:>18}",
                fmt_acc(&ours)
            );
        }
    }
    if pair.truth.is_none() {
        println!("(no ground truth given: pass --gt or --gt-disparity for the error columns)");
    }
    if args.pair.is_some() {
        return Ok(());
    }
    let (i0, _, truth) = flow_pair();
    // Blur: the true flow scaled to a 6-pixel mean smear (13 sub-samples per pixel).
    let (w, h) = (i0.width(), i0.height());
    let rgb: Vec<f32> = i0.data().iter().flat_map(|&v| [v, v * 0.8, v * 0.6]).collect();
    let image = HdrImage::from_vec(w, h, rgb)?;
    let travel = 6.0 / truth.mean_magnitude() as f32;
    println!("\nflow-based motion blur, 1920×1280 RGB, mean smear 6 px");
    println!("{:<8} {:>10} {:>12}", "threads", "ms", "Mpixel/s");
    for threads in [1usize, 2] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
        let t = pool.install(|| {
            best_of(repeats, || {
                black_box(joca_data::blur::motion_blur(&image, &truth, travel));
            })
        });
        println!("{threads:<8} {:>10.1} {:>12.1}", t * 1e3, (w * h) as f64 / t / 1e6);
    }
    Ok(())
}

fn bench_render(repeats: usize) -> Result<()> {
    let sim =
        Simulator::new(SimConfig { illumination: Some(Illumination::Day), ..SimConfig::default() });
    // Frames spread over an episode, so that speeds (and so blur) vary as in training.
    let times: Vec<f64> = (0..repeats).map(|k| 2.0 + k as f64 * 2.3).collect();
    let exposure_s = 10e-3;
    println!(
        "simulator, day, f = 3.6 mm on IMX172 (81° HFoV), exposure {} ms, {} frames over one \
            episode",
        exposure_s * 1e3,
        times.len()
    );
    println!(
        "{:<10} {:>8} {:>12} {:>14} {:>14} {:>11} {:>9} {:>16}",
        "output",
        "threads",
        "sub/frame",
        "sub-frames/s",
        "blurred ms",
        "frames/s",
        "2t vs 1t",
        "ground truth ms"
    );
    for (w, h) in [(320usize, 240usize), (640, 480)] {
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
            pool.install(render_all); // warm up
            let t = Instant::now();
            pool.install(render_all);
            let secs = t.elapsed().as_secs_f64();
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
                "{:<10} {:>8} {:>12.1} {:>14.0} {:>14.2} {:>11.1} {:>8.2}x {:>16.2}",
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
    use joca_train::{FixedCamera, Method, RunConfig};
    let mut cfg: RunConfig = crate::config::load(preset, None, "run")?;
    cfg.method = Method::Joca;
    crate::commands::run::resolve_weights(&mut cfg);
    let design = FixedCamera::Flir.design();
    let (w, h) = design.resolution(cfg.render_scale);
    let b = joca_train::bench_step(&cfg, &design, steps)?;
    let total = b.total_ms();
    println!(
        "joint-loop step, method joca, FLIR IMX172 at {w}x{h} (render scale {}), {} threads, mean \
            of {} steps",
        cfg.render_scale, cfg.threads, b.steps
    );
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
    // One detector training step on a frame of the same size, same threads, same run.
    let engine = joca_nn::Engine::cpu(cfg.threads);
    let detector_ms = joca_nn::detector::time_training(
        &engine,
        cfg.detector,
        h,
        w,
        steps,
        1,
        joca_nn::detector::Precision::Fp32,
    );
    println!(
        "{:<46} {:>9.1}",
        format!("detector training step alone (best of {steps})"),
        detector_ms
    );
    println!("{:<46} {:>9.2}x", "step / detector training step", total / detector_ms);
    Ok(())
}
