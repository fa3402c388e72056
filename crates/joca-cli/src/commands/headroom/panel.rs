//! `joca headroom --panel FILE --out DIR`: the headroom of every design of a panel, under each
//! scenario and town the file names, each measurement a child `joca headroom` (at most `--jobs`
//! at once, its output in `<measurement>.log`), then the paired table of each scenario and town.
//! A measurement with its `headroom.json` is done: running the same command again resumes.
//!
//! ```toml
//! title = "Headroom with cast shadows"
//! preset = "standard"            # the preset whose [run] the designs are measured with
//! scenarios = ["calibrated", "noise20"]
//! towns = [0, 2]                 # the test town and a fresh town of the test family
//! episodes = 8                   # optional: test episodes (stratified by light)
//! frames = 25                    # optional: scored frames per episode
//! [run]                          # optional: fields over the preset's [run]
//! cast_shadows = true
//! [ladder]                       # optional: the ladder and AverageAE's targets
//! steps = 14
//! [panel]                        # as an experiment's: designs, from_runs
//! designs = [{ id = "flir", camera = "flir" }]
//! ```

use crate::config;
use crate::grid::panel::{PanelDesign, PanelFile};
use anyhow::{Context, Result, anyhow, bail};
use joca_camera::AccRanges;
use joca_train::headroom::ladder::LadderConfig;
use joca_train::{RunConfig, Scenario};
use serde::Deserialize;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Instant;

/// The folder's copy of the panel file: a second run with another file is refused.
pub const PANEL_COPY: &str = "panel.toml";

/// A headroom panel file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct HeadroomPanel {
    #[serde(default)]
    title: Option<String>,
    #[serde(default = "standard")]
    preset: String,
    scenarios: Vec<Scenario>,
    towns: Vec<u64>,
    #[serde(default)]
    episodes: Option<u64>,
    #[serde(default)]
    frames: Option<usize>,
    #[serde(default)]
    run: Option<toml::Table>,
    #[serde(default)]
    ladder: Option<toml::Table>,
    panel: PanelFile,
}

fn standard() -> String {
    "standard".into()
}

/// One measurement: a design under a scenario on a town.
struct Measurement {
    design: String,
    scenario: Scenario,
    town: u64,
    dir: PathBuf,
}

/// Runs `joca headroom --panel FILE --out DIR [--jobs N]`.
pub fn run(file: &Path, out: &Path, jobs: usize) -> Result<()> {
    if jobs == 0 {
        bail!("--jobs = 0 is invalid: at least 1 measurement at a time");
    }
    let text = std::fs::read_to_string(file)
        .with_context(|| format!("cannot read panel file {}", file.display()))?;
    let panel: HeadroomPanel = toml::from_str(&text)
        .with_context(|| format!("invalid headroom panel file {}", file.display()))?;
    let source = file.display().to_string();
    check(&panel, &source)?;
    let designs = panel.panel.resolve(&source)?;
    let bodies: Vec<(String, String)> = designs
        .iter()
        .map(|d| {
            let table = design_table(&panel, d)?;
            validate(&panel.preset, table.clone(), &source)?;
            Ok((d.id.clone(), written(&table, &d.id)?))
        })
        .collect::<Result<_>>()?;
    claim(out, &text, file)?;
    let configs = out.join("configs");
    std::fs::create_dir_all(&configs)
        .with_context(|| format!("cannot create {}", configs.display()))?;
    for (id, body) in &bodies {
        let path = configs.join(format!("{id}.toml"));
        joca_core::fs::write_atomic(&path, body.as_bytes())
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    let all = measurements(&panel, &designs, out);
    let todo: Vec<&Measurement> =
        all.iter().filter(|m| !m.dir.join("headroom.json").is_file()).collect();
    if let Some(t) = &panel.title {
        println!("{t}");
    }
    println!(
        "{} measurements ({} designs × {} scenarios × {} towns), {} to run, {jobs} at a time; \
         logs beside each: {}",
        all.len(),
        designs.len(),
        panel.scenarios.len(),
        panel.towns.len(),
        todo.len(),
        out.display()
    );
    run_children(&panel, &configs, &todo, jobs)?;
    let failed: Vec<String> = all
        .iter()
        .filter(|m| !m.dir.join("headroom.json").is_file())
        .map(|m| m.dir.display().to_string())
        .collect();
    for scenario in &panel.scenarios {
        for town in &panel.towns {
            let dirs: Vec<PathBuf> = all
                .iter()
                .filter(|m| m.scenario == *scenario && m.town == *town)
                .map(|m| m.dir.clone())
                .filter(|d| d.join("headroom.json").is_file())
                .collect();
            if dirs.is_empty() {
                continue;
            }
            let table = out.join(format!("{}-town{town}.md", scenario.name()));
            println!("\n## {}, town {town}\n", scenario.name());
            super::write_table(&dirs, Some(&table))?;
        }
    }
    if !failed.is_empty() {
        bail!(
            "{} measurement(s) did not finish: {} (their logs: <folder>.log; run the same command \
             again to resume them)",
            failed.len(),
            failed.join(", ")
        );
    }
    Ok(())
}

/// Refuses what a child would refuse only after the others had run: no scenario or town, an
/// invalid town, zero episodes or frames.
fn check(panel: &HeadroomPanel, source: &str) -> Result<()> {
    if panel.scenarios.is_empty() {
        bail!("{source}: scenarios = [] is invalid: name at least one (calibrated, noise20, …)");
    }
    if panel.towns.is_empty() {
        bail!(
            "{source}: towns = [] is invalid: name at least one (0: the test town, or 2 to 9999)"
        );
    }
    if let Some(t) = panel.towns.iter().find(|t| **t == 1 || **t > 9999) {
        bail!(
            "{source}: towns holds {t}: allowed are 0 (the test town) and 2 to 9999 (fresh towns \
             of the test family; 1 is the validation town)"
        );
    }
    for (name, v) in [("scenarios", dup(&panel.scenarios)), ("towns", dup(&panel.towns))] {
        if let Some(v) = v {
            bail!("{source}: {name} lists {v} twice");
        }
    }
    if panel.episodes == Some(0) {
        bail!("{source}: episodes = 0 is invalid: at least 1");
    }
    if panel.frames == Some(0) {
        bail!("{source}: frames = 0 is invalid: at least 1");
    }
    if let Some(run) = &panel.run
        && run.contains_key("design")
    {
        bail!("{source}: [run] design is set by [panel]; remove it from [run]");
    }
    Ok(())
}

fn dup<T: PartialEq + std::fmt::Debug>(items: &[T]) -> Option<String> {
    items.iter().enumerate().find(|(i, a)| items[..*i].contains(a)).map(|(_, a)| format!("{a:?}"))
}

/// Makes `out` this panel's folder: a new one, or one holding the same panel file.
fn claim(out: &Path, text: &str, file: &Path) -> Result<()> {
    let copy = out.join(PANEL_COPY);
    if copy.is_file() {
        let held = std::fs::read_to_string(&copy)
            .with_context(|| format!("cannot read {}", copy.display()))?;
        if held != text {
            bail!(
                "{} holds the measurements of another panel ({} differs from {}); give another \
                 --out, or remove the folder to start again",
                out.display(),
                copy.display(),
                file.display()
            );
        }
        return Ok(());
    }
    if out.exists() && std::fs::read_dir(out).map(|mut d| d.next().is_some()).unwrap_or(true) {
        bail!(
            "{} exists and is not a headroom panel's folder (no {PANEL_COPY}); give a new --out",
            out.display()
        );
    }
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    joca_core::fs::write_atomic(&copy, text.as_bytes())
        .with_context(|| format!("cannot write {}", copy.display()))
}

/// One design's configuration: the panel's `[run]` with the design, and its `[ladder]`.
fn design_table(panel: &HeadroomPanel, d: &PanelDesign) -> Result<toml::Table> {
    let mut run = panel.run.clone().unwrap_or_default();
    let design = toml::Value::try_from(&d.spec)
        .map_err(|e| anyhow!("cannot write design {:?} as TOML: {e}", d.id))?;
    run.insert("design".into(), design);
    let mut table = toml::Table::new();
    table.insert("run".into(), toml::Value::Table(run));
    if let Some(ladder) = &panel.ladder {
        table.insert("ladder".into(), toml::Value::Table(ladder.clone()));
    }
    Ok(table)
}

/// The configuration file a design's child reads.
fn written(table: &toml::Table, id: &str) -> Result<String> {
    Ok(format!(
        "# Written by joca headroom --panel: the panel's [run] and [ladder] with design {id:?}.\n{}",
        toml::to_string(table)?
    ))
}

/// Reads a design's configuration as its child will (over the preset's), so a bad `[run]` or
/// `[ladder]` is refused before anything is written or run, naming the panel file.
fn validate(preset: &str, mut over: toml::Table, source: &str) -> Result<()> {
    let (mut table, _) = config::load_table_with(preset, None, &[])
        .with_context(|| format!("{source}: preset {preset:?}"))?;
    let ladder = over.remove("ladder");
    config::merge_tables(&mut table, over);
    let run = table.remove("run").with_context(|| format!("preset {preset} has no [run]"))?;
    let cfg: RunConfig = run.try_into().with_context(|| format!("{source}: invalid [run]"))?;
    cfg.validate().map_err(|e| anyhow!("{source}: {e}"))?;
    let ladder: LadderConfig = match ladder {
        None => LadderConfig::default(),
        Some(v) => v.try_into().with_context(|| format!("{source}: invalid [ladder]"))?,
    };
    ladder.validate(AccRanges::PAPER, source).map_err(|e| anyhow!("{e}"))?;
    Ok(())
}

fn measurements(panel: &HeadroomPanel, designs: &[PanelDesign], out: &Path) -> Vec<Measurement> {
    let mut all = Vec::new();
    for scenario in &panel.scenarios {
        for town in &panel.towns {
            for d in designs {
                let dir = out.join(scenario.name()).join(format!("town{town}")).join(&d.id);
                all.push(Measurement {
                    design: d.id.clone(),
                    scenario: *scenario,
                    town: *town,
                    dir,
                });
            }
        }
    }
    all
}

/// Runs the measurements as child processes, at most `jobs` at once.
fn run_children(
    panel: &HeadroomPanel,
    configs: &Path,
    todo: &[&Measurement],
    jobs: usize,
) -> Result<()> {
    let exe = std::env::current_exe().context("cannot find the joca executable")?;
    let started = Instant::now();
    let mut queue = todo.iter();
    let mut running: Vec<(String, Child, Instant)> = Vec::new();
    let (mut done, total) = (0usize, todo.len());
    loop {
        while running.len() < jobs {
            let Some(m) = queue.next() else { break };
            let child = spawn(&exe, panel, configs, m, jobs)?;
            let name = format!("{} {} town {}", m.design, m.scenario.name(), m.town);
            running.push((name, child, Instant::now()));
        }
        if running.is_empty() {
            return Ok(());
        }
        std::thread::sleep(std::time::Duration::from_millis(200));
        let mut i = 0;
        while i < running.len() {
            if let Some(status) = running[i].1.try_wait()? {
                let (name, _, t) = running.remove(i);
                done += 1;
                let verdict = if status.success() { "done  " } else { "FAILED" };
                println!(
                    "  [{done:>3}/{total}] {verdict} {name}  ({:.1} min; elapsed {:.1} min)",
                    t.elapsed().as_secs_f64() / 60.0,
                    started.elapsed().as_secs_f64() / 60.0
                );
            } else {
                i += 1;
            }
        }
    }
}

fn spawn(
    exe: &Path,
    panel: &HeadroomPanel,
    configs: &Path,
    m: &Measurement,
    jobs: usize,
) -> Result<Child> {
    let parent = m.dir.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(parent)
        .with_context(|| format!("cannot create {}", parent.display()))?;
    let log_path = parent.join(format!("{}.log", m.design));
    let log = std::fs::File::create(&log_path)
        .with_context(|| format!("cannot create {}", log_path.display()))?;
    let mut command = Command::new(exe);
    if jobs > 1 && std::env::var_os("OMP_WAIT_POLICY").is_none() {
        // As `joca experiment`: libtorch's OpenMP threads would spin on the shared cores.
        command.env("OMP_WAIT_POLICY", "PASSIVE");
    }
    command
        .arg("headroom")
        .arg("--preset")
        .arg(&panel.preset)
        .arg("--config")
        .arg(configs.join(format!("{}.toml", m.design)))
        .arg("--scenario")
        .arg(m.scenario.name())
        .arg("--town")
        .arg(m.town.to_string())
        .arg("--out")
        .arg(&m.dir);
    if let Some(e) = panel.episodes {
        command.arg("--episodes").arg(e.to_string());
    }
    if let Some(f) = panel.frames {
        command.arg("--frames").arg(f.to_string());
    }
    command
        .stdout(Stdio::from(log.try_clone()?))
        .stderr(Stdio::from(log))
        .spawn()
        .with_context(|| format!("cannot start {}", exe.display()))
}
