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
//!
//! `trained = ["runs/grid/cells/joca-calibrated-flir", …]` (before the tables) adds run
//! directories measured with their own design, trained detector and NeuralAE (the `trained`
//! row), tabulated apart (`<scenario>-town<K>-trained.md`); `[panel]` may then be left out. A
//! run's own configuration sets its world, but for `[run] tunnels` (its `kind`: a run trained
//! with the switch measured with tunnels as places); `[run]` may hold nothing else beside
//! `threads` (which the run's own replaces).

mod children;

use crate::config;
use crate::grid::panel::{PanelDesign, PanelFile};
use anyhow::{Context, Result, anyhow, bail};
use joca_camera::AccRanges;
use joca_train::headroom::ladder::LadderConfig;
use joca_train::{RunConfig, Scenario};
use serde::Deserialize;
use std::path::{Path, PathBuf};

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
    /// Run directories measured with their own design, trained detector and NeuralAE.
    #[serde(default)]
    trained: Vec<PathBuf>,
    #[serde(default)]
    panel: Option<PanelFile>,
}

fn standard() -> String {
    "standard".into()
}

/// What a measurement measures.
#[derive(Clone)]
enum Subject {
    /// A design of `[panel]` with the configuration's detector.
    Design,
    /// A run directory: its design, trained detector and NeuralAE.
    Trained(PathBuf),
}

/// One measurement: a design (or a trained run) under a scenario on a town.
struct Measurement {
    design: String,
    subject: Subject,
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
    let designs = match &panel.panel {
        Some(p) => p.resolve(&source)?,
        None => Vec::new(),
    };
    let mut bodies: Vec<(String, String)> = designs
        .iter()
        .map(|d| {
            let table = design_table(&panel, d)?;
            validate(&panel.preset, table.clone(), &source)?;
            Ok((d.id.clone(), written(&table, &d.id)?))
        })
        .collect::<Result<_>>()?;
    let trained = trained_ids(&panel, &source)?;
    for (id, _) in &trained {
        // Its child reads only the ladder; the run's own config.toml sets the rest.
        let mut table = toml::Table::new();
        if let Some(ladder) = &panel.ladder {
            table.insert("ladder".into(), toml::Value::Table(ladder.clone()));
        }
        bodies.push((id.clone(), written(&table, id)?));
    }
    claim(out, &text, file)?;
    let configs = out.join("configs");
    std::fs::create_dir_all(&configs)
        .with_context(|| format!("cannot create {}", configs.display()))?;
    for (id, body) in &bodies {
        let path = configs.join(format!("{id}.toml"));
        joca_core::fs::write_atomic(&path, body.as_bytes())
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    let all = measurements(&panel, &designs, &trained, out);
    let todo: Vec<&Measurement> =
        all.iter().filter(|m| !m.dir.join("headroom.json").is_file()).collect();
    if let Some(t) = &panel.title {
        println!("{t}");
    }
    println!(
        "{} measurements ({} designs × {} scenarios × {} towns), {} to run, {jobs} at a time; \
         logs beside each: {}",
        all.len(),
        designs.len() + trained.len(),
        panel.scenarios.len(),
        panel.towns.len(),
        todo.len(),
        out.display()
    );
    children::run_children(&panel, &configs, &todo, jobs)?;
    let failed: Vec<String> = all
        .iter()
        .filter(|m| !m.dir.join("headroom.json").is_file())
        .map(|m| m.dir.display().to_string())
        .collect();
    for scenario in &panel.scenarios {
        for town in &panel.towns {
            for (trained, suffix) in [(false, ""), (true, "-trained")] {
                let dirs: Vec<PathBuf> = all
                    .iter()
                    .filter(|m| m.scenario == *scenario && m.town == *town)
                    .filter(|m| matches!(m.subject, Subject::Trained(_)) == trained)
                    .map(|m| m.dir.clone())
                    .filter(|d| d.join("headroom.json").is_file())
                    .collect();
                if dirs.is_empty() {
                    continue;
                }
                // The choices per light made on the panel's next town, scored here.
                let other = panel.towns.iter().find(|t| *t != town);
                let chosen_on: Vec<PathBuf> = all
                    .iter()
                    .filter(|m| m.scenario == *scenario && Some(&m.town) == other)
                    .filter(|m| matches!(m.subject, Subject::Trained(_)) == trained)
                    .map(|m| m.dir.clone())
                    .filter(|d| d.join("headroom.json").is_file())
                    .collect();
                let table = out.join(format!("{}-town{town}{suffix}.md", scenario.name()));
                let what = if trained { ", trained runs" } else { "" };
                println!("\n## {}, town {town}{what}\n", scenario.name());
                super::write_table(&dirs, (&chosen_on, false), Some(&table))?;
            }
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

fn measurements(
    panel: &HeadroomPanel,
    designs: &[PanelDesign],
    trained: &[(String, PathBuf)],
    out: &Path,
) -> Vec<Measurement> {
    let subjects: Vec<(String, Subject)> = designs
        .iter()
        .map(|d| (d.id.clone(), Subject::Design))
        .chain(trained.iter().map(|(id, dir)| (id.clone(), Subject::Trained(dir.clone()))))
        .collect();
    let mut all = Vec::new();
    for scenario in &panel.scenarios {
        for town in &panel.towns {
            for (id, subject) in &subjects {
                let dir = out.join(scenario.name()).join(format!("town{town}")).join(id);
                all.push(Measurement {
                    design: id.clone(),
                    subject: subject.clone(),
                    scenario: *scenario,
                    town: *town,
                    dir,
                });
            }
        }
    }
    all
}

/// The trained runs' ids (`trained-<the folder's name>`) and directories; refuses a folder
/// without a run's configuration, two folders of one name, a panel with neither designs nor
/// runs, and a `[run]` that a run's own configuration would override in silence.
fn trained_ids(panel: &HeadroomPanel, source: &str) -> Result<Vec<(String, PathBuf)>> {
    if panel.panel.is_none() && panel.trained.is_empty() {
        bail!("{source}: give [panel] designs, trained = [run directories], or both");
    }
    if panel.trained.is_empty() {
        return Ok(Vec::new());
    }
    if let Some(run) = &panel.run
        && let Some(key) = run.keys().find(|k| !matches!(k.as_str(), "threads" | "tunnels"))
    {
        bail!(
            "{source}: [run] {key} would not reach the trained runs (their own config.toml sets \
             it); with trained = […] [run] may hold only threads and tunnels"
        );
    }
    let tunnels = tunnels_of(panel, source)?;
    let defaults = joca_sim::Tunnels::places();
    if tunnels.count != defaults.count || tunnels.lamp_level != defaults.lamp_level {
        bail!(
            "{source}: [run] tunnels sets its count or lamps: a trained run is measured with \
             the default ones (only the kind reaches it)"
        );
    }
    let mut out: Vec<(String, PathBuf)> = Vec::new();
    for dir in &panel.trained {
        if !dir.join("config.toml").is_file() {
            bail!("{source}: trained holds {}, which is not a run directory", dir.display());
        }
        let name = dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let id = format!("trained-{name}");
        if out.iter().any(|(i, _)| *i == id) {
            bail!("{source}: trained holds two run directories named {name:?}");
        }
        out.push((id, dir.clone()));
    }
    Ok(out)
}

/// The panel's `[run] tunnels` (the default without one).
fn tunnels_of(panel: &HeadroomPanel, source: &str) -> Result<joca_sim::Tunnels> {
    match panel.run.as_ref().and_then(|r| r.get("tunnels")) {
        None => Ok(joca_sim::Tunnels::default()),
        Some(v) => v.clone().try_into().with_context(|| format!("{source}: invalid [run] tunnels")),
    }
}

#[cfg(test)]
mod tests;
