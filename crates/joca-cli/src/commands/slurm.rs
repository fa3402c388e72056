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

/// The batch script: only bash, every value single-quoted. Slurm's options go on `sbatch`'s
/// command line ([`sbatch_args`]), never into `#SBATCH` lines, where a newline in a value would
/// start a command the compute node runs.
fn script(dir: &Path, exe: &Path, cells: &[&str]) -> String {
    let mut s = String::from("#!/bin/bash\nset -euo pipefail\n");
    s.push_str(&cells_array(cells));
    s.push_str(&format!(
        "exec {} cell {}/\"${{cells[$SLURM_ARRAY_TASK_ID]}}\"\n",
        quote(&exe.display().to_string()),
        quote(&dir.display().to_string())
    ));
    s
}

/// The script's line (or lines: a cell may hold newlines) that sets the bash array `cells`.
fn cells_array(cells: &[&str]) -> String {
    let mut s = String::from("cells=(");
    for c in cells {
        s.push_str(&quote(c));
        s.push(' ');
    }
    s.push_str(")\n");
    s
}

/// Whether `time` is in one of Slurm's `--time` formats: minutes, minutes:seconds,
/// hours:minutes:seconds, days-hours, days-hours:minutes, days-hours:minutes:seconds, or
/// UNLIMITED / INFINITE.
fn slurm_time(time: &str) -> bool {
    if ["unlimited", "infinite"].contains(&time.to_ascii_lowercase().as_str()) {
        return true;
    }
    let digits = |p: &str| !p.is_empty() && p.len() <= 6 && p.bytes().all(|b| b.is_ascii_digit());
    let rest = match time.split_once('-') {
        Some((days, rest)) if digits(days) => rest,
        Some(_) => return false,
        None => time,
    };
    let parts: Vec<&str> = rest.split(':').collect();
    (1..=3).contains(&parts.len()) && parts.iter().all(|p| digits(p))
}

/// `sbatch`'s options for an array of `tasks` tasks of `threads` threads each, logging into
/// `dir/slurm/`: each its own argument (no shell, no script line), the partition and the time
/// checked against Slurm's formats first.
fn sbatch_args(
    name: &str,
    threads: usize,
    tasks: usize,
    dir: &Path,
    options: &Options,
) -> Result<Vec<String>> {
    let mut array = format!("0-{}", tasks - 1);
    if let Some(k) = options.max_parallel {
        if k == 0 {
            bail!("--max-parallel must be at least 1");
        }
        array.push_str(&format!("%{k}"));
    }
    // The job's name is a label: anything but letters, digits, '.', '_' and '-' becomes '_'.
    let label: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() || "._-".contains(c) { c } else { '_' })
        .take(64)
        .collect();
    let mut args = vec![
        "--parsable".to_owned(),
        format!("--array={array}"),
        format!("--job-name=joca-{label}"),
        format!("--cpus-per-task={threads}"),
        format!("--output={}/slurm/%A_%a.log", dir.display()),
        "--requeue".to_owned(),
    ];
    if let Some(p) = &options.partition {
        let ok =
            !p.is_empty() && p.chars().all(|c| c.is_ascii_alphanumeric() || "_.,-".contains(c));
        if !ok {
            bail!(
                "--partition {p:?} is invalid: one or more partition names of letters, digits, \
                 '_', '.' and '-', separated by commas"
            );
        }
        args.push(format!("--partition={p}"));
    }
    if let Some(t) = &options.time {
        if !slurm_time(t) {
            bail!(
                "--time {t:?} is invalid: Slurm's formats are minutes, minutes:seconds, \
                 hours:minutes:seconds, days-hours, days-hours:minutes, days-hours:minutes:seconds \
                 (e.g. 02:00:00 or 1-12) or UNLIMITED"
            );
        }
        args.push(format!("--time={t}"));
    }
    Ok(args)
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
    let threads = todo.iter().map(|c| c.config.threads).max().unwrap_or(1);
    let args = sbatch_args(&exp.manifest.name, threads, todo.len(), &dir, options)?;
    let exe = std::env::current_exe().context("cannot find the joca executable")?;
    let slurm_dir = dir.join("slurm");
    std::fs::create_dir_all(&slurm_dir)?;
    let script_path = slurm_dir.join("job.sh");
    let cells: Vec<&str> = todo.iter().map(|c| c.spec.dir.as_str()).collect();
    joca_train::write_atomic(&script_path, &script(&dir, &exe, &cells))?;
    let output = Command::new("sbatch").args(&args).arg(&script_path).output();
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Hostile names, folders and cells reach bash as the very strings, never as commands.
    #[test]
    fn every_value_reaches_bash_as_itself_and_slurm_options_stay_out_of_the_script() {
        let hostile = [
            "plain",
            "it's",
            "a\n#SBATCH --wrap=touch pwned\nrm -rf ~",
            "$(touch pwned) `id` ${HOME} \\ \"q\" ; | & < >",
            "tab\there * ? [x]",
        ];
        let dir = Path::new("/tmp/exp with space/and'quote");
        let exe = Path::new("/opt/j o/joca");
        assert_eq!(through_bash(dir, exe, &hostile), hostile);
    }

    /// The cells of `script(dir, exe, cells)` as bash runs them: the whole script, once per
    /// array task, with `exec` replaced by a function that prints its arguments (each checked:
    /// the executable, `cell`, the folder), and the script parsed by `bash -n`.
    fn through_bash(dir: &Path, exe: &Path, cells: &[&str]) -> Vec<String> {
        let text = script(dir, exe, cells);
        // sbatch reads `#SBATCH` lines only before the first command: the script's second line.
        assert_eq!(text.lines().nth(1), Some("set -euo pipefail"), "{text}");
        assert!(Command::new("bash").arg("-n").arg("-c").arg(&text).status().unwrap().success());
        let probe = format!("exec() {{ printf '%s\\0' \"$@\"; }}\n{text}");
        let (exe, folder) = (exe.display().to_string(), format!("{}/", dir.display()));
        (0..cells.len())
            .map(|task| {
                let out = Command::new("bash")
                    .arg("-c")
                    .arg(&probe)
                    .env("SLURM_ARRAY_TASK_ID", task.to_string())
                    .output()
                    .unwrap();
                assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
                let args: Vec<String> = String::from_utf8(out.stdout)
                    .unwrap()
                    .split_terminator('\0')
                    .map(str::to_owned)
                    .collect();
                assert_eq!(args.len(), 3, "{args:?}");
                assert_eq!((args[0].as_str(), args[1].as_str()), (exe.as_str(), "cell"));
                args[2].strip_prefix(&folder).expect("the folder, then the cell").to_owned()
            })
            .collect()
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
        /// Any strings (bash strings hold no NUL) as cells, folder and executable reach bash as
        /// themselves.
        #[test]
        fn arbitrary_strings_reach_bash_as_themselves(
            cells in proptest::collection::vec("[^\u{0}]{0,24}", 1..5),
            dir in "[^\u{0}]{1,24}",
            exe in "[^\u{0}]{1,24}",
        ) {
            let cells: Vec<&str> = cells.iter().map(String::as_str).collect();
            proptest::prop_assert_eq!(through_bash(Path::new(&dir), Path::new(&exe), &cells), cells);
        }
    }

    #[test]
    fn partitions_and_times_outside_slurms_formats_are_refused_naming_them() {
        let dir = Path::new("/x");
        let with = |partition: Option<&str>, time: Option<&str>| Options {
            partition: partition.map(str::to_owned),
            time: time.map(str::to_owned),
            max_parallel: None,
        };
        for t in ["30", "30:00", "02:00:00", "1-12", "1-12:30", "2-00:00:00", "UNLIMITED"] {
            assert!(sbatch_args("e", 1, 2, dir, &with(None, Some(t))).is_ok(), "{t}");
        }
        for t in ["", "2h", "1:2:3:4", "02:00:00\n#SBATCH --wrap=x", "-5", "1-"] {
            let e = sbatch_args("e", 1, 2, dir, &with(None, Some(t))).unwrap_err().to_string();
            assert!(e.contains("--time") && e.contains("02:00:00"), "{e}");
        }
        assert!(sbatch_args("e", 1, 2, dir, &with(Some("gpu,cpu-long"), None)).is_ok());
        for p in ["", "gpu\n#SBATCH --wrap=x", "a b", "x;id"] {
            let e = sbatch_args("e", 1, 2, dir, &with(Some(p), None)).unwrap_err().to_string();
            assert!(e.contains("--partition") && e.contains("separated by commas"), "{e}");
        }
        let args = sbatch_args("bad\nname $(id)", 2, 3, dir, &with(None, None)).unwrap();
        assert!(args.contains(&"--job-name=joca-bad_name___id_".to_owned()), "{args:?}");
        assert!(args.contains(&"--array=0-2".to_owned()) && args.contains(&"--requeue".to_owned()));
    }
}
