//! Slurm scale-out for `joca experiment --slurm`: the grid's missing cells become one
//! `sbatch --array` job whose task i runs `joca cell <experiment>/cells/<cell i>`.
//!
//! Each task writes its cell's results atomically (`results.json` appears last), so a task that
//! Slurm requeues and runs twice finishes or resumes the same cell harmlessly. Without Slurm
//! accounting, job records vanish from `squeue` some minutes after they end, so the truth about
//! a cell is always its run directory, never the queue. The job script calls this very `joca`
//! executable by its absolute path: on a cluster it must live on a file system the nodes share,
//! like the experiment directory.

use crate::grid::{Cell, Experiment};
use anyhow::{Context, Result, bail};
use std::path::Path;
use std::process::Command;

/// Submission options.
#[derive(Debug, Clone, Default)]
pub struct Options {
    /// `--partition`.
    pub partition: Option<String>,
    /// `--time`.
    pub time: Option<String>,
    /// Most tasks at once (`--array=…%K`).
    pub max_parallel: Option<usize>,
}

/// Single-quotes `s` for bash.
fn quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', "'\\''"))
}

/// The batch script for `todo`.
fn script(dir: &Path, exp: &Experiment, todo: &[&Cell], options: &Options) -> Result<String> {
    let exe = std::env::current_exe().context("cannot find the joca executable")?;
    let threads = todo.iter().map(|c| c.config.threads).max().unwrap_or(1);
    let mut s = String::from("#!/bin/bash\n");
    s.push_str(&format!("#SBATCH --job-name=joca-{}\n", exp.manifest.name));
    s.push_str(&format!("#SBATCH --cpus-per-task={threads}\n"));
    s.push_str(&format!("#SBATCH --output={}/slurm/%A_%a.log\n", dir.display()));
    if let Some(p) = &options.partition {
        s.push_str(&format!("#SBATCH --partition={p}\n"));
    }
    if let Some(t) = &options.time {
        s.push_str(&format!("#SBATCH --time={t}\n"));
    }
    s.push_str("#SBATCH --requeue\nset -euo pipefail\ncells=(");
    for c in todo {
        s.push_str(&quote(&c.spec.dir));
        s.push(' ');
    }
    s.push_str(")\n");
    s.push_str(&format!(
        "exec {} cell {}/\"${{cells[$SLURM_ARRAY_TASK_ID]}}\"\n",
        quote(&exe.display().to_string()),
        quote(&dir.display().to_string())
    ));
    Ok(s)
}

/// Submits the cells in `todo` as one array job and returns its id (`None` if nothing to do).
pub fn submit(
    dir: &Path,
    exp: &Experiment,
    todo: &[&Cell],
    options: &Options,
) -> Result<Option<String>> {
    if todo.is_empty() {
        return Ok(None);
    }
    // Absolute paths: the tasks do not start in this directory on every cluster.
    let dir =
        std::fs::canonicalize(dir).with_context(|| format!("cannot resolve {}", dir.display()))?;
    let slurm_dir = dir.join("slurm");
    std::fs::create_dir_all(&slurm_dir)?;
    let script_path = slurm_dir.join("job.sh");
    joca_train::write_atomic(&script_path, &script(&dir, exp, todo, options)?)?;
    let mut array = format!("0-{}", todo.len() - 1);
    if let Some(k) = options.max_parallel {
        if k == 0 {
            bail!("--max-parallel must be at least 1");
        }
        array.push_str(&format!("%{k}"));
    }
    let output = Command::new("sbatch")
        .arg("--parsable")
        .arg(format!("--array={array}"))
        .arg(&script_path)
        .output();
    let output = match output {
        Ok(o) => o,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => bail!(
            "Slurm is not reachable: `sbatch` is not on PATH. Install Slurm's client (Debian: \
             slurm-client) and set SLURM_CONF to your cluster's slurm.conf, or run without \
             --slurm to run the cells here"
        ),
        Err(e) => return Err(e).context("cannot run sbatch"),
    };
    if !output.status.success() {
        bail!(
            "Slurm refused the job: sbatch exited with {} and said: {}(is slurmctld running and \
                SLURM_CONF pointing at it?)",
            output.status,
            String::from_utf8_lossy(&output.stderr)
        );
    }
    let id =
        String::from_utf8_lossy(&output.stdout).trim().split(';').next().unwrap_or("").to_owned();
    if id.is_empty() {
        bail!("sbatch printed no job id");
    }
    let record = serde_json::json!({
        "job_id": id,
        "cells": todo.iter().map(|c| c.spec.id.clone()).collect::<Vec<_>>(),
    });
    joca_train::write_atomic(
        &slurm_dir.join("submitted.json"),
        &serde_json::to_string_pretty(&record)?,
    )?;
    Ok(Some(id))
}

/// Tasks of `job` still in the queue (pending or running), or `None` if `squeue` cannot be asked.
fn queued(job: &str) -> Option<usize> {
    let out = Command::new("squeue").args(["-h", "-r", "-j", job, "-o", "%i %t"]).output().ok()?;
    if !out.status.success() {
        // An id Slurm has already forgotten is an error for squeue: nothing is queued.
        return Some(0);
    }
    Some(String::from_utf8_lossy(&out.stdout).lines().filter(|l| !l.trim().is_empty()).count())
}

/// Waits until `job` has left the queue, printing how many tasks remain when that changes.
pub fn wait(job: &str) -> Result<()> {
    let mut last = usize::MAX;
    loop {
        let Some(n) = queued(job) else { bail!("cannot run squeue to follow job {job}") };
        if n == 0 {
            println!("Slurm job {job} has left the queue");
            return Ok(());
        }
        if n != last {
            println!("  Slurm job {job}: {n} task(s) pending or running");
            last = n;
        }
        std::thread::sleep(std::time::Duration::from_secs(2));
    }
}

/// Prints the submitted job's queue state, if a job was submitted into `dir`.
pub fn print_status(dir: &Path) {
    let Ok(text) = std::fs::read_to_string(dir.join("slurm").join("submitted.json")) else {
        return;
    };
    let Ok(v) = serde_json::from_str::<serde_json::Value>(&text) else { return };
    let id = v["job_id"].as_str().unwrap_or("?");
    match queued(id) {
        Some(0) => println!("Slurm job {id}: no task queued or running"),
        Some(n) => println!("Slurm job {id}: {n} task(s) pending or running"),
        None => println!("Slurm job {id}: squeue is not reachable from here"),
    }
}
