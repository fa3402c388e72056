//! `joca experiment`: a grid of runs defined by a TOML file (built in: `experiments/*.toml`),
//! each cell a normal run directory, run locally in parallel processes or as a Slurm array; and
//! the hidden `joca cell DIR` that runs or resumes one cell.
//!
//! An experiment file has a `title`, a `label_header`, a list of `scenarios`, an optional `[run]`
//! table shared by all cells, and `[[variant]]`s (`id`, `label`, `run = { … }`). Cell
//! `<variant>-<scenario>`'s configuration is the preset's `[run]`, then the user's `--config`,
//! then the file's `[run]`, then the variant's `run`, then the scenario. It is written to
//! `cells/<id>/cell.toml` once; re-invoking skips finished cells (`results.json` present) and
//! resumes half-written ones from their checkpoint.

use crate::commands::run::execute;
use crate::commands::slurm;
use crate::config;
use anyhow::{Context, Result, anyhow, bail};
use joca_report::{CellSpec, Manifest};
use joca_train::{Method, RunConfig, Scenario, differing_fields};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Instant;

/// The experiments shipped with joca, by name.
pub const EXPERIMENTS: [(&str, &str); 6] = [
    ("table1", include_str!("../../../../experiments/table1.toml")),
    ("ablation", include_str!("../../../../experiments/ablation.toml")),
    ("sweep-weight", include_str!("../../../../experiments/sweep-weight.toml")),
    ("sweep-population", include_str!("../../../../experiments/sweep-population.toml")),
    ("sweep-frequency", include_str!("../../../../experiments/sweep-frequency.toml")),
    ("real", include_str!("../../../../experiments/real.toml")),
];

/// Arguments of `joca experiment`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// A built-in experiment (table1, ablation, sweep-weight, sweep-population, sweep-frequency,
    /// real) or the path of your own experiment TOML file.
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
    /// Cells run at once, each in its own process (each uses the cell's `threads`).
    #[arg(long, default_value_t = 1)]
    jobs: usize,
    /// Print where each cell stands (and the Slurm job's, if one was submitted); run nothing.
    #[arg(long)]
    status: bool,
    /// Submit the missing cells as one Slurm array job instead of running them here.
    #[arg(long)]
    slurm: bool,
    /// Slurm partition [default: the cluster's default].
    #[arg(long, requires = "slurm")]
    partition: Option<String>,
    /// Slurm time limit per cell, e.g. 02:00:00 [default: the partition's].
    #[arg(long, requires = "slurm")]
    time: Option<String>,
    /// Most array tasks running at once.
    #[arg(long, requires = "slurm")]
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

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ExperimentFile {
    title: String,
    label_header: String,
    scenarios: Vec<String>,
    #[serde(default)]
    run: toml::Table,
    /// The grid only makes sense on recorded frames (the real-image mode).
    #[serde(default)]
    needs_recording: bool,
    variant: Vec<Variant>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Variant {
    id: String,
    label: String,
    #[serde(default)]
    run: toml::Table,
}

/// The `[run]` table a cell runs with (`cells/<id>/cell.toml`).
#[derive(Debug, Serialize, Deserialize)]
struct CellFile {
    run: RunConfig,
}

/// A resolved cell.
#[derive(Debug)]
pub struct Cell {
    /// How reports show it.
    pub spec: CellSpec,
    /// Its full configuration.
    pub config: RunConfig,
}

/// A resolved experiment: its name, title and cells.
#[derive(Debug)]
pub struct Experiment {
    /// The manifest reports read.
    pub manifest: Manifest,
    /// Cells in order.
    pub cells: Vec<Cell>,
}

fn name_list(items: &[(&str, &str)]) -> String {
    items.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
}

/// Reads a built-in experiment or a file, and resolves every cell's configuration.
pub fn resolve(name: &str, preset: &str, user_config: Option<&Path>) -> Result<Experiment> {
    let (text, source, short) = match EXPERIMENTS.iter().find(|(n, _)| *n == name) {
        Some((n, t)) => ((*t).to_owned(), format!("experiments/{n}.toml"), (*n).to_owned()),
        None => {
            let path = Path::new(name);
            if !path.is_file() {
                bail!(
                    "unknown experiment {name:?}: not a built-in one ({}) and no such file",
                    name_list(&EXPERIMENTS)
                );
            }
            let t = std::fs::read_to_string(path)
                .with_context(|| format!("cannot read experiment file {name}"))?;
            let stem =
                path.file_stem().map_or("experiment".into(), |s| s.to_string_lossy().into_owned());
            (t, name.to_owned(), stem)
        }
    };
    let file: ExperimentFile =
        toml::from_str(&text).with_context(|| format!("invalid experiment file {source}"))?;
    if file.variant.is_empty() || file.scenarios.is_empty() {
        bail!("{source}: an experiment needs at least one [[variant]] and one scenario");
    }
    let (base, base_source) = config::load_table(preset, user_config)?;
    let base_run = match base.get("run") {
        Some(toml::Value::Table(t)) => t.clone(),
        _ => bail!("{base_source} has no [run] table"),
    };
    check_method(&file.run, &source, "[run]")?;
    let mut cells = Vec::new();
    for scenario in &file.scenarios {
        Scenario::from_name(scenario).map_err(|e| anyhow!("{source}: scenarios: {e}"))?;
    }
    let mut seen = std::collections::HashSet::new();
    for scenario in &file.scenarios {
        for v in &file.variant {
            if !seen.insert((v.id.clone(), scenario.clone())) {
                bail!("{source}: variant id {:?} appears twice; ids must be unique", v.id);
            }
            if v.id.is_empty()
                || !v.id.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
            {
                bail!("{source}: variant id {:?} must be letters, digits, '-' or '_'", v.id);
            }
            check_method(&v.run, &source, &format!("variant {:?}", v.id))?;
            let mut run = base_run.clone();
            config::merge_tables(&mut run, file.run.clone());
            config::merge_tables(&mut run, v.run.clone());
            run.insert("scenario".into(), toml::Value::String(scenario.clone()));
            let config: RunConfig = toml::Value::Table(run).try_into().with_context(|| {
                format!("{source}: variant {:?}, scenario {scenario}: invalid [run] (over {base_source})", v.id)
            })?;
            config
                .validate()
                .with_context(|| format!("{source}: variant {:?}, scenario {scenario}", v.id))?;
            if file.needs_recording && (config.source.is_empty() || config.source == "sim") {
                bail!(
                    "{source} runs on recorded frames: pass --config FILE whose [run] sets source = \"waymo:DIR\" or \"folder:DIR\" (and test_source for held-out frames)"
                );
            }
            let id = format!("{}-{scenario}", v.id);
            cells.push(Cell {
                spec: CellSpec {
                    dir: format!("cells/{id}"),
                    id,
                    label: v.label.clone(),
                    group: scenario_title(scenario),
                },
                config,
            });
        }
    }
    // Rows of a group together: order by scenario as listed, then variant (already so).
    Ok(Experiment {
        manifest: Manifest {
            name: short,
            title: file.title,
            preset: preset.to_owned(),
            label_header: file.label_header,
            cells: cells.iter().map(|c| c.spec.clone()).collect(),
        },
        cells,
    })
}

/// A `method` value in `table` must name a method; the error lists the valid ones.
fn check_method(table: &toml::Table, source: &str, what: &str) -> Result<()> {
    if let Some(m) = table.get("method") {
        let name =
            m.as_str().ok_or_else(|| anyhow!("{source}: {what}: method must be a string"))?;
        Method::from_name(name).map_err(|e| anyhow!("{source}: {what}: {e}"))?;
    }
    Ok(())
}

/// How tables title a scenario (the paper's names).
fn scenario_title(s: &str) -> String {
    match s {
        "calibrated" => "Calibrated".into(),
        "noise10" => "Noise×10".into(),
        "noise20" => "Noise×20".into(),
        "blur2" => "Motion blur×2".into(),
        "blur4" => "Motion blur×4".into(),
        other => other.into(),
    }
}

/// Creates the experiment directory: `experiment.json` and each cell's
/// `cell.toml`. A cell directory that already holds a different configuration is refused.
pub fn prepare(exp: &Experiment, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    for cell in &exp.cells {
        let cell_dir = Manifest::cell_dir(dir, &cell.spec);
        let path = cell_dir.join("cell.toml");
        if path.is_file() {
            let old: CellFile = toml::from_str(&std::fs::read_to_string(&path)?)
                .with_context(|| format!("cannot read {}", path.display()))?;
            if old.run != cell.config {
                bail!(
                    "{} was made with another configuration (fields differ: {}); use another --out, or delete the cell to run it again",
                    path.display(),
                    differing_fields(&old.run, &cell.config).join(", ")
                );
            }
            continue;
        }
        std::fs::create_dir_all(&cell_dir)?;
        let text = toml::to_string(&CellFile { run: cell.config.clone() })?;
        joca_train::write_atomic(&path, &text)?;
    }
    joca_train::write_atomic(
        &dir.join(Manifest::FILE),
        &serde_json::to_string_pretty(&exp.manifest)?,
    )?;
    Ok(())
}

/// Runs `joca experiment`.
pub fn run(args: &Args) -> Result<()> {
    let exp = resolve(&args.name, &args.preset, args.config.as_deref())?;
    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("runs/{}-{}", exp.manifest.name, args.preset)));
    if args.status {
        return print_status(&exp, &dir);
    }
    if args.jobs == 0 {
        bail!("--jobs must be at least 1");
    }
    prepare(&exp, &dir)?;
    let todo: Vec<&Cell> = exp
        .cells
        .iter()
        .filter(|c| Manifest::state(&dir, &c.spec) != joca_report::CellState::Done)
        .collect();
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
                        "follow it with `joca experiment {} --preset {} --out {} --status`; `joca report {}` works at any time",
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
    joca_report::write_experiment_report(&dir)
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
            "{} cell(s) did not finish: {} (their logs: <cell>/cell.log; run the same command again to resume them)",
            failed.len(),
            failed.join(", ")
        );
    }
    Ok(())
}

/// Runs the cells as child processes `joca cell DIR`, at most `jobs` at once; a cell's output
/// goes to its `cell.log`.
fn run_local(dir: &Path, todo: &[&Cell], jobs: usize) -> Result<()> {
    let exe = std::env::current_exe().context("cannot find the joca executable")?;
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
    let mut counts = [0usize; 3];
    for cell in &exp.cells {
        let state = Manifest::state(dir, &cell.spec);
        let cell_dir = Manifest::cell_dir(dir, &cell.spec);
        let (name, extra) = match state {
            joca_report::CellState::Done => {
                counts[0] += 1;
                let extra = std::fs::read_to_string(cell_dir.join("results.json"))
                    .ok()
                    .and_then(|t| serde_json::from_str::<joca_report::Results>(&t).ok())
                    .map(|r| {
                        format!(
                            "mAP {:.3}  TP ratio {:.3}  {}",
                            r.test.map, r.test.tp_ratio, r.design.sensor
                        )
                    })
                    .unwrap_or_default();
                ("done", extra)
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
        println!("  {name:<8} {:<32} {extra}", cell.spec.id);
    }
    println!(
        "{}: {} done, {} partial, {} missing of {}",
        dir.display(),
        counts[0],
        counts[1],
        counts[2],
        exp.cells.len()
    );
    slurm::print_status(dir);
    Ok(())
}

/// Runs `joca cell`: run or resume the cell whose `cell.toml` is in the directory.
pub fn run_cell(args: &CellArgs) -> Result<()> {
    let dir = &args.dir;
    let path = dir.join("cell.toml");
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("cannot read {}", path.display()))?;
    let cell: CellFile =
        toml::from_str(&text).with_context(|| format!("invalid {}", path.display()))?;
    if dir.join("results.json").is_file() {
        println!("{}: already finished", dir.display());
        return Ok(());
    }
    execute(cell.run, dir, true)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_built_in_experiment_resolves_with_every_preset() {
        for (name, _) in EXPERIMENTS {
            for (preset, _) in config::PRESETS {
                let result = resolve(name, preset, None);
                if name == "real" {
                    // Needs a recording; without one it is refused.
                    assert!(result.unwrap_err().to_string().contains("runs on recorded frames"));
                    continue;
                }
                let exp = result.unwrap_or_else(|e| panic!("{name} / {preset}: {e:#}"));
                assert!(!exp.cells.is_empty());
                let ids: std::collections::HashSet<_> =
                    exp.cells.iter().map(|c| &c.spec.id).collect();
                assert_eq!(ids.len(), exp.cells.len(), "{name}: duplicate cell ids");
            }
        }
        let table1 = resolve("table1", "quick", None).unwrap();
        assert_eq!(table1.cells.len(), 20);
        assert_eq!(table1.cells[0].spec.id, "flir-calibrated");
        assert_eq!(table1.cells[0].config.method, Method::FixedNeural);
    }
}
