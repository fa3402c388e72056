//! `joca run`: the joint optimisation of camera hardware, NeuralAE and detector.

use crate::config;
use anyhow::{Context, Result, anyhow, bail};
use joca_nn::detector::PrecisionExt;
use joca_report::Light;
use joca_train::{Method, RunConfig, RunEvent, RunResults, Scenario, Source, run as run_loop};
use std::io::Write;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `joca run`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Preset: quick, standard or paper (files in presets/).
    #[arg(long, default_value = "quick")]
    preset: String,
    /// Method: joca, tacos-average, fixed-neural, no-ga-loss, fixed-perturbation, frozen-detector.
    #[arg(long)]
    method: Option<String>,
    /// Scenario: calibrated, noise10, noise20, blur2, blur4.
    #[arg(long)]
    scenario: Option<String>,
    /// A TOML file whose [run] fields override the preset's.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Run directory [default: runs/<preset>-<method>-<scenario>].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Continue the run in the run directory from its last checkpoint.
    #[arg(long)]
    resume: bool,
    /// Frames to train on: `sim` (the built-in simulator), or for the real-image mode
    /// `folder:DIR` (the folder format) or `waymo:DIR` (Waymo Open Dataset v2 parquet).
    #[arg(long, value_parser = Source::parse)]
    source: Option<Source>,
    /// Frames to test on in real-image mode [default: the training folder].
    #[arg(long, value_parser = Source::parse)]
    test_source: Option<Source>,
    /// What the networks compute on: cpu, cuda (the first GPU), cuda:N or auto (a GPU if one is
    /// usable, else the CPU) [default: the configuration's `device`, cpu].
    #[arg(long, value_parser = crate::config::device)]
    device: Option<joca_nn::device::DeviceChoice>,
}

/// Runs `joca run`.
pub fn run(args: &Args) -> Result<()> {
    let (mut cfg, source): (RunConfig, String) =
        config::load_with_source(&args.preset, args.config.as_deref(), "run")?;
    if let Some(m) = &args.method {
        cfg.method = Method::from_name(m).map_err(|e| anyhow!(e))?;
    }
    if let Some(s) = &args.scenario {
        cfg.scenario = Scenario::from_name(s).map_err(|e| anyhow!(e))?;
    }
    if let Some(s) = &args.source {
        cfg.source.clone_from(s);
    }
    if let Some(s) = &args.test_source {
        cfg.test_source.clone_from(s);
    }
    if let Some(d) = args.device {
        cfg.device = d;
    }
    // A bad value is refused here, naming the file, before a run directory exists.
    cfg.validate().with_context(|| format!("invalid [run] in {source}"))?;
    // Whether this machine has the device, before a run directory exists (and before any other
    // libtorch call: libtorch looks for its CUDA part once).
    joca_nn::device::resolve(cfg.device, joca_nn::device::probe)
        .with_context(|| format!("[run] device in {source} or --device"))?;
    let real = cfg.source.is_recording();
    let out = args.out.clone().unwrap_or_else(|| {
        let mode = if real { "-real" } else { "" };
        PathBuf::from(format!(
            "runs/{}{mode}-{}-{}",
            args.preset,
            cfg.method.name(),
            cfg.scenario.name()
        ))
    });
    check_run_dir(&out, args.resume)?;
    execute(cfg, &out, args.resume)
}

/// `--out` must be a new or empty folder, or a run directory of joca's (its marker,
/// `joca_core::output`); with `--resume` it must hold a checkpoint. So a mistyped path neither
/// overwrites a folder of other files nor silently starts a fresh run.
fn check_run_dir(out: &Path, resume: bool) -> Result<()> {
    use joca_core::output::{self, Claimed, DirLock, OutputKind};
    if output::check(out, OutputKind::Run)? == Some(Claimed::Earlier) {
        // A run still writing there is named now, before any other message (the run takes the
        // lock again for itself).
        drop(DirLock::acquire(out, "joca run")?);
    }
    if resume && joca_train::CheckpointDir::new(out.join("checkpoint")).existing().is_none() {
        bail!(
            "nothing to resume in {}: it holds no checkpoint (no candidate has finished there); \
             run without --resume to start",
            out.display()
        );
    }
    Ok(())
}

/// Runs (or resumes) `cfg` into `out` with a progress line, prints the result table and writes
/// the run's report. `joca run` and every experiment cell go through here.
pub fn execute(mut cfg: RunConfig, out: &Path, resume: bool) -> Result<()> {
    resolve_weights(&mut cfg);
    println!(
        "joca run: method {}, scenario {}, {} generations x {} candidates x {} steps, detector \
            input short side {} px (long <= {} px, {}), run directory {}",
        cfg.method.name(),
        cfg.scenario.name(),
        cfg.generations,
        cfg.population,
        cfg.steps_per_candidate,
        cfg.input.short_px,
        cfg.input.long_max_px,
        cfg.input.resampler,
        out.display()
    );
    // The CPU needs no probe; any other choice is looked up (`auto` may still be the CPU).
    let device = joca_nn::device::resolve(cfg.device, joca_nn::device::probe)?;
    if !cfg.device.is_cpu() {
        println!(
            "device: {} ({} asked) for the detector, NeuralAE and the differentiable formation; \
                rendering and the 8-bit formation on the CPU",
            joca_nn::device::describe(device),
            cfg.device
        );
    }
    let kernels = joca_nn::kernels::chosen();
    println!(
        "cpu: {}; denormals: {}; kernels: {} ({})",
        joca_train::cpu_description(),
        joca_nn::kernels::denormals().name(),
        kernels.name(),
        match kernels {
            joca_nn::kernels::CpuKernels::Avx2 =>
                "libtorch pinned to its AVX2 paths (JOCA_CPU_KERNELS=avx2): training still \
                 depends on the machine type",
            joca_nn::kernels::CpuKernels::Native =>
                "libtorch's widest paths for this CPU: the numbers repeat on this machine \
                 type, not across types",
        }
    );
    let scoring = cfg.scoring_precision.on_device(device);
    if scoring != cfg.scoring_precision {
        println!(
            "scoring_precision: the perturbed frames are scored in fp32 (bf16 is used only where \
                libtorch computes it natively: AVX-512 BF16 with JOCA_CPU_KERNELS=native)"
        );
    } else {
        let name = scoring.name();
        let why = if scoring == joca_nn::detector::Precision::Bf16 && device.is_cuda() {
            " (on a GPU: native)"
        } else if scoring == joca_nn::detector::Precision::Bf16 {
            " (native on this CPU)"
        } else {
            ""
        };
        println!("scoring_precision: the perturbed frames are scored in {name}{why}");
    }
    let started = Instant::now();
    let generations = cfg.generations;
    // Steps counted from this process's start, so the ETA of a resumed run is right too.
    let mut first_step: Option<usize> = None;
    let mut progress = |e: &RunEvent| {
        match e {
            RunEvent::Step { generation, candidate, candidates, step, of, best } => {
                let done = (generation * candidates + candidate) * of + step;
                let total = generations * candidates * of;
                let first = *first_step.get_or_insert(done.saturating_sub(1));
                let elapsed = started.elapsed().as_secs_f64();
                let rate = elapsed / (done - first).max(1) as f64;
                let eta = rate * (total - done) as f64;
                let best = best.map_or("   -  ".to_owned(), |b| format!("{b:.3}"));
                let filled = (24 * done / total.max(1)).min(24);
                eprint!(
                    "\r  [{}{}] generation {:>2}/{generations}  candidate {:>2}/{candidates}  \
                        step {step:>3}/{of}  best fitness {best}  ETA {}   ",
                    "#".repeat(filled),
                    ".".repeat(24 - filled),
                    generation + 1,
                    candidate + 1,
                    clock(eta)
                );
                let _ = std::io::stderr().flush();
            }
            RunEvent::Candidate { fitness, best, done, of, .. } => {
                // One line per finished candidate stays on screen above the bar.
                eprintln!(
                    "\r  candidate {done:>4}/{of} done: fitness {fitness:.3}, best so far \
                        {best:.3}{:60}",
                    ""
                );
            }
            RunEvent::Testing => eprintln!("\n  testing the best design on the test town…"),
        }
        ControlFlow::Continue(())
    };
    let results = run_loop(&cfg, out, resume, &mut progress)
        .with_context(|| format!("run in {} failed", out.display()))?;
    print_results(&results, started.elapsed().as_secs_f64());
    print_swap(&results, out);
    joca_report::write_run_report(out)
        .with_context(|| format!("cannot write the report of {}", out.display()))?;
    println!("\nreport: {} (and report.html, figures/)", out.join("report.md").display());
    Ok(())
}

/// NeuralAE's test beside AverageAE's on the same design, detector and scenes (the re-test a
/// NeuralAE run ends with), per light: does the learned controller earn its place?
fn print_swap(r: &RunResults, out: &Path) {
    let path = out.join(joca_record::Retest::average_swap(0).results_file());
    let Ok(text) = std::fs::read_to_string(&path) else { return };
    let Ok(swap) = serde_json::from_str::<RunResults>(&text) else { return };
    println!(
        "## The learned controller against AverageAE (mid-grey) on this design and detector\n\n\
         | controller | mAP@[.5:.95] | day | night | tunnel | cycle | day frame (DN) | night frame \
         (DN) | day clipped |\n|---|---|---|---|---|---|---|---|---|"
    );
    for (name, x) in [("NeuralAE (trained)", r), ("AverageAE mid-grey", &swap)] {
        let by = &x.by_illumination;
        let light = |l: Light| by.light(l);
        let map = |l| light(l).and_then(|v| v.scores.map(|s| format!("{:.3}", s.map)));
        let dn = |l| light(l).and_then(|v| v.mean_dn.map(|d| format!("{d:.0}")));
        let clip =
            light(Light::Day).and_then(|v| v.clipped_share.map(|c| format!("{:.1} %", 100.0 * c)));
        let cells = [
            map(Light::Day),
            map(Light::Night),
            map(Light::Tunnel),
            map(Light::Cycle),
            dn(Light::Day),
            dn(Light::Night),
            clip,
        ]
        .map(|c| c.unwrap_or_else(|| "-".into()));
        println!("| {name} | {:.3} | {} |", x.test.map, cells.join(" | "));
    }
    println!();
}

/// Seconds as `1h02m`, `12m05s` or `42s`.
fn clock(seconds: f64) -> String {
    let s = seconds.max(0.0).round() as u64;
    match (s / 3600, s / 60 % 60, s % 60) {
        (0, 0, s) => format!("{s}s"),
        (0, m, s) => format!("{m}m{s:02}s"),
        (h, m, _) => format!("{h}h{m:02}m"),
    }
}

/// Relative weight paths are tried from the working directory, then from the repository root
/// (where the presets' shipped weights live), so `joca run` works from any directory.
pub fn resolve_weights(cfg: &mut RunConfig) {
    if let Some(weights) = cfg.detector_weights.as_mut().filter(|w| !w.exists()) {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(&*weights);
        if root.exists() {
            *weights = root;
        }
    }
}

fn print_results(r: &RunResults, seconds: f64) {
    let d = &r.design;
    let mark = if d.optimised { "optimised" } else { "fixed" };
    println!("\nfinished in {:.1} min\n", seconds / 60.0);
    let mut columns =
        vec![("method", r.method.name().to_owned()), ("scenario", r.scenario.name().to_owned())];
    if r.real_images() {
        // Real-image mode: the recording fixes mount and lens, and has no 180° object count.
        println!("tested on {}\n", r.source);
    } else {
        columns.extend([
            ("x (m)", format!("{:.2}", d.x_m)),
            ("z (m)", format!("{:.2}", d.z_m)),
            ("f (mm)", d.lens_label()),
        ]);
    }
    columns.extend([
        ("sensor", format!("{} ({mark})", d.sensor)),
        ("W×H (mm)", format!("{:.2}×{:.2}", d.sensor_mm.0, d.sensor_mm.1)),
        ("p (µm)", format!("{:.2}", d.pixel_pitch_um)),
        ("mAP@[.5:.95]", format!("{:.3}", r.test.map)),
        ("AP50", format!("{:.3}", r.test.ap50)),
    ]);
    if !r.real_images() {
        columns.push(("TP ratio", format!("{:.3}", r.test.tp_ratio)));
    }
    let row =
        |f: fn(&(&str, String)) -> String| columns.iter().map(f).collect::<Vec<_>>().join(" | ");
    println!("| {} |", row(|c| c.0.to_owned()));
    println!("|{}", "---|".repeat(columns.len()));
    println!("| {} |", row(|c| c.1.clone()));
    println!();
    print!("{}", joca_report::settings_markdown(r));
    print!("{}", joca_report::objects_markdown(r));
}
