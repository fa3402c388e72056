//! `joca train-detector`: pre-train the detector (the paper's frozen-detector pre-training).

use crate::config;
use anyhow::{Context, Result};
use joca_nn::detector::PrecisionExt;
use joca_train::{EvalReport, PretrainConfig, PretrainEvent, evaluate_weights, pretrain};
use std::io::Write;
use std::ops::ControlFlow;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `joca train-detector`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Preset: quick, standard or paper (files in presets/).
    #[arg(long, default_value = "standard")]
    preset: String,
    /// A TOML file whose [pretrain] fields override the preset's.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Override the number of training steps (frames).
    #[arg(long)]
    steps: Option<usize>,
    /// Override the thread count (1 to 64).
    #[arg(long, value_parser = crate::config::count::<1, 64>)]
    threads: Option<usize>,
    /// What the detector trains on: cpu, cuda (the first GPU), cuda:N or auto (a GPU if one is
    /// usable, else the CPU) [default: the configuration's `device`, cpu].
    #[arg(long, value_parser = crate::config::device)]
    device: Option<joca_nn::device::DeviceChoice>,
    /// Where to write the trained weights (safetensors). The run directory (log, checkpoint,
    /// results) is this path with `.run` in place of the extension.
    #[arg(long)]
    out: PathBuf,
    /// Continue the run in the run directory from its last checkpoint.
    #[arg(long)]
    resume: bool,
}

/// Runs `joca train-detector`.
pub fn run(args: &Args) -> Result<()> {
    let mut cfg: PretrainConfig = config::load(&args.preset, args.config.as_deref(), "pretrain")?;
    if let Some(s) = args.steps {
        cfg.steps = s;
    }
    if let Some(t) = args.threads {
        cfg.threads = t;
    }
    if let Some(d) = args.device {
        cfg.device = d;
    }
    // Whether this machine has the device, before a run directory exists (the CPU needs no probe).
    let device = joca_nn::device::resolve(cfg.device, joca_nn::device::probe)
        .context("[pretrain] device or --device")?;
    let run_dir = args.out.with_extension("run");
    let precision = cfg.precision.on_device(device);
    if precision != cfg.precision {
        println!(
            "precision: bf16 asked for, but this CPU has no native bfloat16 (AVX-512 BF16); \
             training in fp32, which is faster here"
        );
    }
    println!(
        "pre-training the detector: {} frames ({} per step, {}), {} frames per random camera, \
            detector input short side {} px (long <= {} px, {}), exposure spread {}, {} threads; \
            run directory {}",
        cfg.steps,
        cfg.batch,
        precision.name(),
        cfg.data.frames_per_design,
        cfg.input.short_px,
        cfg.input.long_max_px,
        cfg.input.resampler,
        cfg.data.exposure_spread,
        cfg.threads,
        run_dir.display()
    );
    let started = Instant::now();
    let mut smoothed = None::<f64>;
    let mut progress = |event: &PretrainEvent| {
        report_progress(event, &started, &mut smoothed);
        ControlFlow::Continue(())
    };
    let report = pretrain(&cfg, &run_dir, &args.out, args.resume, &mut progress)
        .with_context(|| format!("pre-training into {} failed", run_dir.display()))?;
    eprintln!();
    println!(
        "done in {:.1} min; weights written to {}",
        started.elapsed().as_secs_f64() / 60.0,
        args.out.display()
    );
    print_table(&report);
    Ok(())
}

/// Arguments of `joca eval-detector`.
#[derive(Debug, clap::Args)]
pub struct EvalArgs {
    /// Detector weights (safetensors; the architecture is read from the file).
    #[arg(long)]
    weights: PathBuf,
    /// Preset whose [pretrain] evaluation to repeat: quick, standard or paper.
    #[arg(long, default_value = "standard")]
    preset: String,
    /// A TOML file whose [pretrain] fields override the preset's.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Test episodes per light (10 scored frames each); default: the preset's final evaluation.
    #[arg(long)]
    episodes: Option<u64>,
    /// Override the thread count (1 to 64).
    #[arg(long, value_parser = crate::config::count::<1, 64>)]
    threads: Option<usize>,
}

/// Runs `joca eval-detector`.
pub fn run_eval(args: &EvalArgs) -> Result<()> {
    let mut cfg: PretrainConfig = config::load(&args.preset, args.config.as_deref(), "pretrain")?;
    if let Some(e) = args.episodes {
        cfg.eval.final_episodes = Some(e);
    }
    if let Some(t) = args.threads {
        cfg.threads = t;
    }
    println!(
        "scoring {} on the test town: reference camera, AverageAE, {} episodes × 10 frames per \
            light",
        args.weights.display(),
        cfg.final_episodes()
    );
    let report = evaluate_weights(&cfg, &args.weights)
        .with_context(|| format!("cannot score {}", args.weights.display()))?;
    print_table(&report);
    Ok(())
}

/// The final table: scores per light, AP@[.5:.95] and AP50 per class with the number of boxes
/// they rest on.
fn print_table(report: &EvalReport) {
    println!(
        "| light | mAP@[.5:.95] | AP50 | TP ratio | vehicles: AP / AP50 (boxes) | walkers: AP / \
            AP50 (boxes) | signs: AP / AP50 (boxes) | frames |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for (name, s) in [("day", report.day), ("night", report.night)] {
        let mut cells = (0..s.class_map.len()).map(|c| match (s.class_map[c], s.class_ap50[c]) {
            (Some(ap), Some(ap50)) => format!("{ap:.3} / {ap50:.3} ({})", s.class_objects[c]),
            _ => format!("- ({})", s.class_objects[c]),
        });
        let mut cell = || cells.next().unwrap_or_default();
        let (v, w, t) = (cell(), cell(), cell());
        println!(
            "| {name} | {:.3} | {:.3} | {:.3} | {v} | {w} | {t} | {} |",
            s.map, s.ap50, s.tp_ratio, s.frames
        );
    }
}

fn report_progress(event: &PretrainEvent, started: &Instant, smoothed: &mut Option<f64>) {
    match event {
        PretrainEvent::Step { step, of, loss } => {
            let s = smoothed.map_or(loss.total, |v| 0.98 * v + 0.02 * loss.total);
            *smoothed = Some(s);
            if step % 25 == 0 || step == of {
                let elapsed = started.elapsed().as_secs_f64();
                let eta = elapsed / *step as f64 * (*of - *step) as f64;
                eprint!(
                    "\r  frame {step:>6}/{of}  loss {s:.3}  {:.0} ms/frame  ETA {:.0} s   ",
                    1e3 * elapsed / *step as f64,
                    eta
                );
                let _ = std::io::stderr().flush();
            }
        }
        PretrainEvent::Eval(r) => {
            eprintln!();
            let walker = |s: &joca_metrics::TaskScores| {
                s.class_ap(joca_core::Class::Walker).unwrap_or(f64::NAN)
            };
            println!(
                "  test town at step {}: day mAP {:.3} AP50 {:.3} TP ratio {:.3} (walkers {:.3}) \
                    | night mAP {:.3} AP50 {:.3} TP ratio {:.3} (walkers {:.3})",
                r.step,
                r.day.map,
                r.day.ap50,
                r.day.tp_ratio,
                walker(&r.day),
                r.night.map,
                r.night.ap50,
                r.night.tp_ratio,
                walker(&r.night)
            );
        }
        PretrainEvent::Checkpoint { .. } => {}
    }
}
