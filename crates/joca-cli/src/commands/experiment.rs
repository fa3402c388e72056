//! `joca experiment`: a grid of runs defined by a TOML file (built in: `experiments/*.toml`),
//! each cell a normal run directory, run locally in parallel processes or as a Slurm array; and
//! the hidden `joca cell DIR` that runs or resumes one cell.
//!
//! The grid and its cells are resolved by `crate::grid`. Re-invoking skips finished cells
//! (`results.json` present) and resumes half-written ones from their checkpoint.

use crate::commands::run::execute;
use crate::commands::slurm;
use crate::grid::{Cell, CellFile, Experiment, check_first, order_cells, prepare, resolve};
use anyhow::{Context, Result, bail};
use joca_core::output::{self, DirLock, OutputKind};
use joca_report::Manifest;
use joca_train::RunConfig;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Instant;

/// Arguments of `joca experiment`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// A built-in experiment (table1, ablation, sweep-weight, sweep-population, sweep-frequency,
    /// real, controllers, ablation-panel, perturbation-panel, aperture, fog) or the path of your own experiment TOML file.
    name: String,
    /// Preset of every cell: quick, standard or paper.
    #[arg(long, default_value = "quick")]
    preset: String,
    /// A TOML file whose [run] fields override the preset's in every cell.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Experiment directory [default: runs/<name>-<preset>].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Runs of every cell, with seeds seed, seed + 1, …: tables then show mean ± 95 % interval
    /// over seeds and ours paired with each baseline (1 to 100).
    #[arg(long, default_value_t = 1)]
    seeds: u64,
    /// Cells run at once, each in its own process (each uses the cell's `threads`), 1 to 64.
    #[arg(long, default_value_t = 1, value_parser = crate::config::count::<1, 64>)]
    jobs: usize,
    /// The order cells run in: `grid` (the file's: variants, then scenarios, then designs),
    /// `design` (a panel's designs in the file's order, each design's cells together, and seeds
    /// in turn: an interrupted grid leaves whole designs to pair) or `seed` (every cell of seed s
    /// before any of seed s + 1).
    #[arg(long, default_value = "grid", value_parser = ["grid", "design", "seed"])]
    order: String,
    /// Cells to run before all others, in this order (ids as `--status` lists them,
    /// comma-separated or repeated): the cells a comparison needs first. The rest follow
    /// `--order`; a finished cell named here is skipped as any other.
    #[arg(long, value_name = "ID", value_delimiter = ',')]
    first: Vec<String>,
    /// Print where each cell stands (and the Slurm job's, if one was submitted); run nothing.
    #[arg(long, conflicts_with = "prepare")]
    status: bool,
    /// Report cells computed by different joca commits together (refused otherwise).
    #[arg(long)]
    mixed_commits: bool,
    /// Finished cells to take instead of running them again: experiment or run directories,
    /// exports (`joca export`) or a folder holding them (`runs`). A cell is taken when its record
    /// names this joca's commit and the cell's configuration (`provenance.config_sha256`); the
    /// copy's `reused.json` says from where.
    #[arg(long, value_name = "DIR")]
    reuse: Vec<PathBuf>,
    /// Write every cell's configuration (cells/<id>/cell.toml) and the manifest, check the
    /// finished cells against the grid, and run nothing: for `joca cell DIR` run by hand or by
    /// another scheduler.
    #[arg(long, conflicts_with = "slurm")]
    prepare: bool,
    /// Submit the missing cells as one Slurm array job instead of running them here.
    #[arg(long)]
    slurm: bool,
    /// Slurm partition [default: the cluster's default].
    #[arg(long, requires = "slurm")]
    partition: Option<String>,
    /// Slurm time limit per cell, e.g. 02:00:00 [default: the partition's].
    #[arg(long, requires = "slurm")]
    time: Option<String>,
    /// Most array tasks running at once (1 to 100000).
    #[arg(long, requires = "slurm", value_parser = crate::config::count::<1, 100000>)]
    max_parallel: Option<usize>,
    /// With --slurm: wait until the job has left the queue, then write the report.
    #[arg(long, requires = "slurm")]
    wait: bool,
}

/// Arguments of the hidden `joca cell`.
#[derive(Debug, clap::Args)]
pub struct CellArgs {
    /// The cell's run directory (holding cell.toml).
    dir: PathBuf,
}

/// Runs `joca experiment`.
pub fn run(args: &Args) -> Result<()> {
    let exp = resolve(&args.name, &args.preset, args.config.as_deref(), args.seeds)?;
    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("runs/{}-{}", exp.manifest.name, args.preset)));
    if args.status {
        return print_status(&exp, &dir);
    }
    check_first(&exp, &args.first)?;
    // A new or empty folder, or an experiment of joca's; one `joca experiment` at a time.
    output::claim(&dir, OutputKind::Experiment)?;
    let _lock = DirLock::acquire(&dir, "joca experiment")?;
    prepare(&exp, &dir)?;
    let all: Vec<&Cell> = exp.cells.iter().collect();
    let reused = crate::grid::reuse(&dir, &all, &args.reuse)?;
    if !args.reuse.is_empty() {
        println!("{} cell(s) reused", reused.len());
    }
    if args.prepare {
        return print_status(&exp, &dir);
    }
    complete_reports(&dir, &exp)?;
    let mut todo: Vec<&Cell> = exp
        .cells
        .iter()
        .filter(|c| Manifest::state(&dir, &c.spec) != joca_report::CellState::Done)
        .collect();
    order_cells(&mut todo, &exp, &args.order, &args.first);
    println!(
        "experiment {} (preset {}): {} cells, {} to run, in {}",
        exp.manifest.name,
        args.preset,
        exp.cells.len(),
        todo.len(),
        dir.display()
    );
    if args.slurm {
        let options = slurm::Options {
            partition: args.partition.clone(),
            time: args.time.clone(),
            max_parallel: args.max_parallel,
        };
        let job = slurm::submit(&dir, &exp, &todo, &options)?;
        match job {
            None => println!("nothing to submit: every cell is finished"),
            Some(id) => {
                println!("submitted Slurm job {id} ({} array tasks)", todo.len());
                if !args.wait {
                    println!(
                        "follow it with `joca experiment {} --preset {} --out {} --status`; `joca \
                            report {}` works at any time",
                        args.name,
                        args.preset,
                        dir.display(),
                        dir.display()
                    );
                    return Ok(());
                }
                slurm::wait(&id)?;
            }
        }
    } else {
        run_local(&dir, &todo, args.jobs)?;
    }
    let failed: Vec<&str> = exp
        .cells
        .iter()
        .filter(|c| Manifest::state(&dir, &c.spec) != joca_report::CellState::Done)
        .map(|c| c.spec.id.as_str())
        .collect();
    let options =
        joca_report::ReportOptions { mixed_commits: args.mixed_commits, ..Default::default() };
    joca_report::write_experiment_report_with(&dir, &options)
        .with_context(|| format!("cannot write the report of {}", dir.display()))?;
    println!(
        "\n{}",
        std::fs::read_to_string(dir.join("report.md"))?
            .lines()
            .take_while(|l| !l.starts_with("## "))
            .collect::<Vec<_>>()
            .join("\n")
    );
    println!(
        "report: {} (and report.html, results.csv, figures/)",
        dir.join("report.md").display()
    );
    if !failed.is_empty() {
        bail!(
            "{} cell(s) did not finish: {} (their logs: <cell>/cell.log; run the same command \
                again to resume them)",
            failed.len(),
            failed.join(", ")
        );
    }
    Ok(())
}

/// Writes the run report of every finished cell that lacks one (a cell killed between its
/// `results.json` and its report); compact cells (no `events.jsonl`) have none by design.
fn complete_reports(dir: &Path, exp: &Experiment) -> Result<()> {
    for cell in &exp.cells {
        let cell_dir = Manifest::cell_dir(dir, &cell.spec);
        if cell_dir.join("results.json").is_file()
            && cell_dir.join("events.jsonl").is_file()
            && !cell_dir.join("report.md").is_file()
        {
            joca_report::write_run_report(&cell_dir)
                .with_context(|| format!("cannot write the report of {}", cell_dir.display()))?;
            println!("  wrote the missing report of {}", cell.spec.id);
        }
    }
    Ok(())
}

/// Runs the cells as child processes `joca cell DIR`, at most `jobs` at once; a cell's output
/// goes to its `cell.log`.
fn run_local(dir: &Path, todo: &[&Cell], jobs: usize) -> Result<()> {
    let exe = super::own_executable()?;
    let started = Instant::now();
    let mut queue = todo.iter();
    let mut running: Vec<(String, Child, Instant)> = Vec::new();
    let (mut done, total) = (0usize, todo.len());
    loop {
        while running.len() < jobs {
            let Some(cell) = queue.next() else { break };
            let cell_dir = Manifest::cell_dir(dir, &cell.spec);
            let log = std::fs::OpenOptions::new()
                .create(true)
                .append(true)
                .open(cell_dir.join("cell.log"))
                .with_context(|| format!("cannot open {}", cell_dir.join("cell.log").display()))?;
            let mut command = Command::new(&exe);
            if jobs > 1 && std::env::var_os("OMP_WAIT_POLICY").is_none() {
                // libtorch's OpenMP threads spin while waiting for work; with several cells
                // sharing the cores that spinning takes the time the others need.
                command.env("OMP_WAIT_POLICY", "PASSIVE");
            }
            let child = command
                .arg("cell")
                .arg(&cell_dir)
                .stdout(Stdio::from(log.try_clone()?))
                .stderr(Stdio::from(log))
                .spawn()
                .with_context(|| format!("cannot start {} cell", exe.display()))?;
            running.push((cell.spec.id.clone(), child, Instant::now()));
        }
        if running.is_empty() {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(200));
        let mut i = 0;
        while i < running.len() {
            if let Some(status) = running[i].1.try_wait()? {
                let (id, _, t) = running.remove(i);
                done += 1;
                let verdict = if status.success() { "done  " } else { "FAILED" };
                println!(
                    "  [{done:>3}/{total}] {verdict} {id}  ({:.1} min; elapsed {:.1} min)",
                    t.elapsed().as_secs_f64() / 60.0,
                    started.elapsed().as_secs_f64() / 60.0
                );
            } else {
                i += 1;
            }
        }
    }
    Ok(())
}

/// Prints where each cell stands.
fn print_status(exp: &Experiment, dir: &Path) -> Result<()> {
    if !dir.join(Manifest::FILE).is_file() {
        println!("{}: not started (no {})", dir.display(), Manifest::FILE);
        return Ok(());
    }
    let mut counts = [0usize; 5];
    for cell in &exp.cells {
        let state = Manifest::state(dir, &cell.spec);
        let cell_dir = Manifest::cell_dir(dir, &cell.spec);
        let (name, extra) = match state {
            joca_report::CellState::Done => {
                counts[0] += 1;
                let extra = std::fs::read_to_string(cell_dir.join("results.json"))
                    .ok()
                    .and_then(|t| serde_json::from_str::<joca_train::RunResults>(&t).ok())
                    .map(|r| {
                        format!(
                            "mAP {:.3}  TP ratio {:.3}  {}",
                            r.test.map, r.test.tp_ratio, r.design.sensor
                        )
                    })
                    .unwrap_or_default();
                let extra = if cell_dir.join(crate::grid::REUSED).is_file() {
                    format!("{extra}  (reused: {})", crate::grid::REUSED)
                } else {
                    extra
                };
                ("done", extra)
            }
            _ if let Some(holder) = output::lock_holder(&cell_dir) => {
                counts[3] += 1;
                ("running", holder)
            }
            joca_report::CellState::Partial => {
                counts[1] += 1;
                let n = std::fs::read_to_string(cell_dir.join("events.jsonl"))
                    .map(|t| t.lines().filter(|l| l.contains("\"candidate\"")).count())
                    .unwrap_or(0);
                ("partial", format!("{n} candidates logged; resumes from its checkpoint"))
            }
            joca_report::CellState::Missing => {
                counts[2] += 1;
                ("missing", String::new())
            }
        };
        let (name, extra) = match stale_fields(&cell_dir, cell) {
            Some(fields) => {
                counts[4] += 1;
                ("stale", format!("its cell.toml differs from the grid in {fields}; {extra}"))
            }
            None => (name, extra),
        };
        println!("  {name:<8} {:<32} {extra}", cell.spec.id);
    }
    println!(
        "{}: {} done, {} running, {} partial, {} missing of {}{}",
        dir.display(),
        counts[0],
        counts[3],
        counts[1],
        counts[2],
        exp.cells.len(),
        if counts[4] > 0 {
            format!(
                " ({} stale: made with another configuration, refused until moved away)",
                counts[4]
            )
        } else {
            String::new()
        }
    );
    slurm::print_status(dir);
    Ok(())
}

/// The fields in which a cell's `cell.toml` differs from the grid's configuration for it, as
/// `prepare` compares them; `None` when it matches or is not written yet.
fn stale_fields(cell_dir: &Path, cell: &Cell) -> Option<String> {
    let text = std::fs::read_to_string(cell_dir.join("cell.toml")).ok()?;
    let old: CellFile = toml::from_str(&text).ok()?;
    let fields = joca_train::differing_fields(&old.run.as_read(), &cell.config.as_read());
    (!fields.is_empty()).then(|| fields.join(", "))
}

/// Runs `joca cell`: run or resume the cell whose `cell.toml` is in the directory.
pub fn run_cell(args: &CellArgs) -> Result<()> {
    let dir = &args.dir;
    // The cell's folder and the `cells` folder above it are real folders, not links.
    let exp = dir.parent().and_then(Path::parent).unwrap_or(dir);
    crate::grid::real_cell_dir(exp, dir)?;
    let path = dir.join("cell.toml");
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("cannot read {}", path.display()))?;
    let cell: CellFile =
        toml::from_str(&text).with_context(|| format!("invalid {}", path.display()))?;
    if dir.join("results.json").is_file() {
        println!("{}: run already finished", dir.display());
        if !dir.join("report.md").is_file() {
            // Killed between its results and its report: the report is all that is missing.
            joca_report::write_run_report(dir)
                .with_context(|| format!("cannot write the report of {}", dir.display()))?;
        }
    } else {
        execute(cell.run.clone(), dir, true)?;
    }
    follow_up(dir, &cell.follow_up, &cell.run)
}

/// Runs the cell's follow-up tests it lacks ([`crate::grid::FollowUp::tests`]).
fn follow_up(dir: &Path, follow_up: &crate::grid::FollowUp, config: &RunConfig) -> Result<()> {
    for test in follow_up.tests(config) {
        if dir.join(test.results_file()).is_file() {
            continue;
        }
        let options = joca_train::EvalOptions {
            town: test.town,
            controller: test.controller,
            start_detector: test.start_detector,
            ..Default::default()
        };
        let (r, _) = joca_train::evaluate_run(dir, &options)
            .with_context(|| format!("follow-up test {test} of {}", dir.display()))?;
        println!("{}: {test}: mAP {:.3}", dir.display(), r.test.map);
    }
    Ok(())
}
