//! `joca bench step`: one step of the joint loop (method joca) on the FLIR camera, broken down
//! by part.

use anyhow::{Context, Result};
use joca_train::RunConfig;
use std::path::Path;

/// The `[run]` configuration of `preset` with `file`'s over it, method `joca`, the detector's
/// weights resolved and every field checked (a bad value is refused naming the file), and a
/// label of where it came from.
fn run_config(
    (preset, file): (&str, Option<&Path>),
    device: Option<joca_nn::device::DeviceChoice>,
) -> Result<(RunConfig, String)> {
    let (mut cfg, source): (RunConfig, String) =
        crate::config::load_with_source(preset, file, "run")?;
    cfg.method = joca_train::Method::Joca;
    if let Some(d) = device {
        cfg.device = d;
    }
    crate::commands::run::resolve_weights(&mut cfg);
    cfg.validate().with_context(|| format!("invalid [run] in {source}"))?;
    Ok((cfg, source))
}

pub(super) fn bench_step(
    steps: usize,
    config: (&str, Option<&Path>),
    device: Option<joca_nn::device::DeviceChoice>,
) -> Result<()> {
    use joca_nn::detector::Precision;
    use joca_train::FixedCamera;
    let (mut cfg, source) = run_config(config, device)?;
    let design = FixedCamera::Flir.design();
    let (w, h) = design.resolution(&cfg.input);
    cfg.scoring_precision = Precision::Fp32;
    let b = joca_train::bench_step(&cfg, &design, steps, None)?;
    let total = b.total_ms();
    println!(
        "joint-loop step, method joca, FLIR IMX172 at {w}x{h} (detector input, {} resize), {} \
            threads, networks on {}, mean of {} steps, perturbed frames scored in fp32; {source}",
        cfg.input.resampler, cfg.threads, cfg.device, b.steps
    );
    if !joca_nn::detector::native_bf16() {
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
    let engine = joca_nn::Engine::open(cfg.device, cfg.threads)?;
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
    if !joca_nn::detector::native_bf16() && cfg.device.is_cpu() {
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

/// `joca bench checkpoint`: what proving a checkpoint (SHA-256 of every file, written last and
/// checked before a resume or an eval) costs beside writing it.
pub(super) fn bench_checkpoint(repeats: usize, config: (&str, Option<&Path>)) -> Result<()> {
    let (cfg, source) = run_config(config, None)?;
    let dir = tempfile_dir()?;
    let t = joca_train::bench_checkpoint(&cfg, &dir, repeats);
    let _ = std::fs::remove_dir_all(&dir);
    let t = t?;
    println!(
        "checkpoint of a run of {source} (detector, NeuralAE, both optimisers): {:.1} MB, best \
            of {repeats}",
        t.bytes as f64 / 1e6
    );
    println!("{:<44} {:>9}", "part", "ms");
    println!("{:<44} {:>9.1}", "write the files", t.write_ms);
    println!(
        "{:<44} {:>9.1}  ({:.1} % of the write)",
        "SHA-256 of every file (digests.json)",
        t.digest_ms,
        100.0 * t.digest_ms / t.write_ms
    );
    println!(
        "{:<44} {:>9.1}  ({:.1} % of the write)",
        "verify before --resume / eval",
        t.verify_ms,
        100.0 * t.verify_ms / t.write_ms
    );
    Ok(())
}

/// A fresh folder under the system's temporary directory.
fn tempfile_dir() -> Result<std::path::PathBuf> {
    let dir = std::env::temp_dir().join(format!("joca-bench-checkpoint-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    Ok(dir)
}
