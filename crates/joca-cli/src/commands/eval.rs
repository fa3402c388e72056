//! `joca eval`: test a run's best design again from its checkpoint.

use anyhow::{Context, Result, anyhow};
use joca_train::{Scenario, evaluate_run};
use std::path::PathBuf;

/// Arguments of `joca eval`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// A run directory written by `joca run`.
    run_dir: PathBuf,
    /// Scored frames per test episode [default: the run's].
    #[arg(long)]
    frames: Option<usize>,
    /// Test under another scenario: calibrated, noise10, noise20, blur2, blur4.
    #[arg(long)]
    scenario: Option<String>,
}

/// Runs `joca eval`.
pub fn run(args: &Args) -> Result<()> {
    let scenario =
        args.scenario.as_deref().map(Scenario::from_name).transpose().map_err(|e| anyhow!(e))?;
    let r = evaluate_run(&args.run_dir, scenario, args.frames)
        .with_context(|| format!("cannot evaluate {}", args.run_dir.display()))?;
    println!(
        "{} / {}: {} behind {:.2} mm at x {:.2} m, z {:.2} m -> mAP {:.3}, AP50 {:.3}, TP ratio \
            {:.3} over {} frames",
        r.method.name(),
        r.scenario.name(),
        r.design.sensor,
        r.design.focal_length_mm,
        r.design.x_m,
        r.design.z_m,
        r.test.map,
        r.test.ap50,
        r.test.tp_ratio,
        r.test.frames
    );
    println!();
    print!("{}", joca_report::settings_markdown(&r));
    print!("{}", joca_report::objects_markdown(&r));
    Ok(())
}
