//! `joca bench detector`: inference and a training step at two input sizes, beside PyTorch's
//! numbers for the same network (scripts/bench_detector_pytorch.py) where Python has torch.

use anyhow::Result;

/// Peak single-precision throughput of one core of this machine class (AVX-512: 2 FMA units ×
/// 16 lanes × 2 flops at ~1.8 GHz), GFLOP/s. A reference for the utilisation column only.
const PEAK_GFLOPS_PER_CORE: f64 = 115.0;

pub(super) fn bench_detector(
    repeats: usize,
    (threads, device): (usize, joca_nn::device::DeviceChoice),
    config: joca_nn::detector::DetectorConfig,
    python: &str,
) -> Result<()> {
    use joca_nn::detector::{Precision, forward_flops, time_detector, time_training};
    let engine = joca_nn::Engine::open(device, threads)?;
    // PyTorch's reference and the CPU's peak compare with the CPU only.
    let on_cpu = !engine.device().is_cuda();
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
        .filter(|_| on_cpu)
        .filter(|o| o.status.success())
        .and_then(|o| serde_json::from_slice(&o.stdout).ok());
    println!(
        "detector (width {}{}{}, {} threads, {}), best of {repeats}; training step = forward + \
            loss + backward + AdamW",
        config.width,
        if config.deep { ", deep" } else { "" },
        if config.shared_head { ", shared head" } else { "" },
        threads,
        engine.describe()
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
                if on_cpu { 100.0 * gflops / peak } else { f64::NAN },
                ratio
            );
        }
    }
    // What pre-training can use instead of float32 steps on single frames (`[pretrain]
    // batch` and `precision`): training time per frame, against the float32 single-frame step
    // measured in the same loop.
    println!();
    println!(
        "training time per frame (pre-training's `batch` and `precision`), same threads and \
            device as above"
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
    if !on_cpu {
        println!("(on a GPU: no PyTorch reference and no share of the CPU's peak)");
    } else if reference.is_none() {
        println!(
            "(PyTorch reference not run: `{python} -c \"import torch\"` failed; install \
                torch==2.13.0 or pass --python)"
        );
    }
    println!("(training GFLOP counted as 3x forward: backward costs about twice the forward pass)");
    Ok(())
}
