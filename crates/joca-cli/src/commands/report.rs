//! `joca report`: regenerate the report of a run or an experiment from its saved files.

use anyhow::{Context, Result, bail};
use std::path::PathBuf;

/// Arguments of `joca report`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// A run directory (with results.json) or an experiment directory (with experiment.json).
    dir: PathBuf,
}

/// Runs `joca report`.
pub fn run(args: &Args) -> Result<()> {
    let dir = &args.dir;
    if dir.join(joca_report::Manifest::FILE).is_file() {
        joca_report::write_experiment_report(dir)
            .with_context(|| format!("cannot write the report of {}", dir.display()))?;
    } else if dir.join("results.json").is_file() {
        joca_report::write_run_report(dir)
            .with_context(|| format!("cannot write the report of {}", dir.display()))?;
    } else {
        bail!(
            "{} is neither a finished run directory (no results.json) nor an experiment \
             directory (no {}); a run that has not finished its test has nothing to report yet \
             (`joca run --resume` continues it)",
            dir.display(),
            joca_report::Manifest::FILE
        );
    }
    println!(
        "wrote {}, {} and {}",
        dir.join("report.md").display(),
        dir.join("report.html").display(),
        dir.join("figures").display()
    );
    Ok(())
}
