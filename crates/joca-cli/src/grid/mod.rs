//! Experiment grids: a TOML file (built in: `experiments/*.toml`) resolved into cells, each a
//! full `[run]` configuration, and written to `cells/<id>/cell.toml`. `joca experiment` runs the
//! cells locally (`commands/experiment.rs`) or as a Slurm array (`commands/slurm.rs`).
//!
//! An experiment file has a `title`, a `label_header`, a list of `scenarios`, an optional `[run]`
//! table shared by all cells, and `[[variant]]`s (`id`, `label`, `run = { … }`). Cell
//! `<variant>-<scenario>`'s configuration is the preset's `[run]`, then the user's `--config`,
//! then the file's `[run]`, then the variant's `run`, then the scenario. It is written to
//! `cells/<id>/cell.toml` once; a cell directory holding another configuration is refused.
//! With a `[panel]` of designs ([`panel`]) every variant runs on every design with the hardware
//! held fixed (`run.design`), as cell `<variant>-<scenario>-<design>`.

mod cache;
mod checks;
mod order;
pub mod panel;

use crate::config;
use anyhow::{Context, Result, anyhow, bail};
use joca_core::output::{self, OutputKind};
use joca_record::Retest;
use joca_report::{CellSpec, Manifest};
use joca_train::{RunConfig, differing_fields};
use panel::{PanelDesign, PanelFile, valid_id};
use serde::{Deserialize, Serialize};
use std::path::Path;

pub use cache::{REUSED, reuse};
pub use checks::real_cell_dir;
use checks::{check_method, check_scenarios, check_unique_ids};
pub use order::{check_first, order_cells};

/// The experiments shipped with joca, by name.
pub const EXPERIMENTS: [(&str, &str); 11] = [
    ("table1", include_str!("../../../../experiments/table1.toml")),
    ("ablation", include_str!("../../../../experiments/ablation.toml")),
    ("sweep-weight", include_str!("../../../../experiments/sweep-weight.toml")),
    ("sweep-population", include_str!("../../../../experiments/sweep-population.toml")),
    ("sweep-frequency", include_str!("../../../../experiments/sweep-frequency.toml")),
    ("real", include_str!("../../../../experiments/real.toml")),
    ("controllers", include_str!("../../../../experiments/controllers.toml")),
    ("ablation-panel", include_str!("../../../../experiments/ablation-panel.toml")),
    ("perturbation-panel", include_str!("../../../../experiments/perturbation-panel.toml")),
    ("aperture", include_str!("../../../../experiments/aperture.toml")),
    ("fog", include_str!("../../../../experiments/fog.toml")),
];

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
    /// Designs every variant runs on, hardware held fixed.
    #[serde(default)]
    panel: Option<PanelFile>,
    /// Tests run after each cell's run, kept beside its results.
    #[serde(default)]
    follow_up: FollowUp,
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

/// Tests run after a cell's run (`[follow_up]` of an experiment file), kept beside its results.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FollowUp {
    /// Towns of the test family every cell is also tested on, 2 to 9999 (`joca eval --town`):
    /// its own controller, and a NeuralAE cell's AverageAE (mid-grey) too.
    #[serde(default)]
    pub towns: Vec<u64>,
    /// Test each cell that trains its detector again with the detector weights it started from
    /// (`joca eval --detector start`), on the test town and each of `towns`: what training the
    /// detector changed on that design and those scenes, beside the frozen-detector variant.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub starting_detector: bool,
}

impl FollowUp {
    /// Refuses the test town, the validation town and towns past the family, naming `source`.
    fn check(&self, source: &str) -> Result<()> {
        for &t in &self.towns {
            joca_train::check_town(t).map_err(|e| anyhow!("{source}: [follow_up] towns: {e}"))?;
            if t == 0 {
                bail!("{source}: [follow_up] towns: 0 is the test town every cell is tested on");
            }
        }
        Ok(())
    }

    /// The tests a cell of configuration `config` runs after its run (what `joca eval` writes
    /// as `results-<tag>.json`): each town with the cell's controller, and for a NeuralAE cell
    /// with AverageAE at mid-grey too; with `starting_detector`, for a cell that trains its
    /// detector from weights, that detector swapped back on the test town and each town.
    pub fn tests(&self, config: &RunConfig) -> Vec<Retest> {
        let mut tests = Vec::new();
        for &town in &self.towns {
            tests.push(Retest::town(town));
            if config.method.neural() {
                tests.push(Retest::average_swap(town));
            }
        }
        if self.starting_detector
            && config.method.trains_detector()
            && config.detector_weights.is_some()
        {
            let towns = std::iter::once(0).chain(self.towns.iter().copied());
            tests.extend(towns.map(Retest::start_detector));
        }
        tests
    }

    /// Whether there is none (then `cell.toml` leaves the table out).
    pub fn is_empty(&self) -> bool {
        self.towns.is_empty() && !self.starting_detector
    }
}

/// The `[run]` table a cell runs with, and its follow-up tests (`cells/<id>/cell.toml`).
#[derive(Debug, Serialize, Deserialize)]
pub struct CellFile {
    pub run: RunConfig,
    #[serde(default, skip_serializing_if = "FollowUp::is_empty")]
    pub follow_up: FollowUp,
}

/// A resolved cell.
#[derive(Debug)]
pub struct Cell {
    /// How reports show it.
    pub spec: CellSpec,
    /// Its full configuration.
    pub config: RunConfig,
    /// Its follow-up tests.
    pub follow_up: FollowUp,
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

/// Most seeds per cell (`--seeds`).
pub const MAX_SEEDS: u64 = 100;

/// Reads a built-in experiment or a file, and resolves every cell's configuration, `seeds`
/// times: with more than one seed, cell `<variant>-<scenario>-s<k>` runs with the resolved
/// `seed` + k, so every variant of a scenario meets the same seeds.
pub fn resolve(
    name: &str,
    preset: &str,
    user_config: Option<&Path>,
    seeds: u64,
) -> Result<Experiment> {
    if !(1..=MAX_SEEDS).contains(&seeds) {
        bail!("--seeds = {seeds} is invalid: 1 to {MAX_SEEDS} seeds per cell");
    }
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
    file.follow_up.check(&source)?;
    let mut cells = Vec::new();
    check_scenarios(&file.scenarios, &source)?;
    let designs: Vec<Option<PanelDesign>> = match &file.panel {
        Some(p) => p.resolve(&source)?.into_iter().map(Some).collect(),
        None => vec![None],
    };
    let mut seen = std::collections::HashSet::new();
    for scenario in &file.scenarios {
        for v in &file.variant {
            if !seen.insert((v.id.clone(), scenario.clone())) {
                bail!("{source}: variant id {:?} appears twice; ids must be unique", v.id);
            }
            if !valid_id(&v.id) {
                bail!("{source}: variant id {:?} must be letters, digits, '-' or '_'", v.id);
            }
            check_method(&v.run, &source, &format!("variant {:?}", v.id))?;
            if file.panel.is_some()
                && (v.run.contains_key("design") || file.run.contains_key("design"))
            {
                bail!(
                    "{source}: variant {:?} sets `design`, but the [panel] fixes the designs",
                    v.id
                );
            }
            let mut run = base_run.clone();
            config::merge_tables(&mut run, file.run.clone());
            config::merge_tables(&mut run, v.run.clone());
            run.insert("scenario".into(), toml::Value::String(scenario.clone()));
            let config: RunConfig = toml::Value::Table(run).try_into().with_context(|| {
                format!(
                    "{source}: variant {:?}, scenario {scenario}: invalid [run] (over \
                    {base_source})",
                    v.id
                )
            })?;
            config
                .validate()
                .with_context(|| format!("{source}: variant {:?}, scenario {scenario}", v.id))?;
            if file.needs_recording && !config.source.is_recording() {
                bail!(
                    "{source} runs on recorded frames: pass --config FILE whose [run] sets source \
                        = \"waymo:DIR\" or \"folder:DIR\" (and test_source for held-out frames)"
                );
            }
            for design in &designs {
                let config =
                    RunConfig { design: design.as_ref().map(|d| d.spec.clone()), ..config.clone() };
                config.validate().with_context(|| {
                    let d = design.as_ref().map_or(String::new(), |d| format!(" {:?}", d.id));
                    format!("{source}: variant {:?}, scenario {scenario}, panel design{d}", v.id)
                })?;
                let at = Place { variant: v, scenario, design: design.as_ref() };
                cells.extend(seed_cells(&at, &config, seeds, &file.follow_up));
            }
        }
    }
    check_unique_ids(&cells, &source)?;
    // Rows of a group together: order by scenario as listed, then variant (already so).
    Ok(Experiment {
        manifest: Manifest {
            name: short,
            title: file.title,
            preset: preset.to_owned(),
            seeds,
            label_header: file.label_header,
            cells: cells.iter().map(|c| c.spec.clone()).collect(),
        },
        cells,
    })
}

/// Where a cell sits in the grid: its variant, scenario and panel design.
struct Place<'a> {
    variant: &'a Variant,
    scenario: &'a str,
    design: Option<&'a PanelDesign>,
}

/// The `seeds` cells of one place, seed k of `config.seed + k` (ids end in `-s<k>` when there
/// are several).
fn seed_cells(at: &Place<'_>, config: &RunConfig, seeds: u64, follow_up: &FollowUp) -> Vec<Cell> {
    let (v, scenario) = (at.variant, at.scenario);
    let base = match at.design {
        Some(d) => format!("{}-{scenario}-{}", v.id, d.id),
        None => format!("{}-{scenario}", v.id),
    };
    (0..seeds)
        .map(|k| {
            let id = if seeds == 1 { base.clone() } else { format!("{base}-s{k}") };
            let config = RunConfig { seed: config.seed.wrapping_add(k), ..config.clone() };
            let spec = CellSpec {
                dir: format!("cells/{id}"),
                id,
                label: v.label.clone(),
                group: scenario_title(scenario),
                seed: config.seed,
                design: at.design.map(|d| d.id.clone()).unwrap_or_default(),
                towns: follow_up.towns.clone(),
                follow_ups: follow_up.tests(&config).iter().map(ToString::to_string).collect(),
            };
            Cell { spec, config, follow_up: follow_up.clone() }
        })
        .collect()
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

/// Fills the experiment directory (claimed by the caller, `joca_core::output`):
/// `experiment.json` and each cell's `cell.toml`, each cell marked as a run directory. A cell
/// directory that already holds a different configuration is refused.
pub fn prepare(exp: &Experiment, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    for cell in &exp.cells {
        let cell_dir = Manifest::cell_dir(dir, &cell.spec);
        real_cell_dir(dir, &cell_dir)?;
        // The cells of joca's own experiment folder are joca's (older ones had no marker).
        if output::marked_kind(&cell_dir) != Some(OutputKind::Run) {
            output::mark(&cell_dir, OutputKind::Run)?;
        }
        let path = cell_dir.join("cell.toml");
        if path.is_file() {
            let old: CellFile = toml::from_str(&std::fs::read_to_string(&path)?)
                .with_context(|| format!("cannot read {}", path.display()))?;
            // Fields the method does not read (AverageAE's perturbation search) may differ.
            let (old_run, new_run) = (old.run.as_read(), cell.config.as_read());
            if old_run != new_run {
                bail!(
                    "{} was made with another configuration (fields differ: {}); use another \
                        --out, or delete the cell to run it again",
                    path.display(),
                    differing_fields(&old_run, &new_run).join(", ")
                );
            }
            // The same run with other follow-up tests: they are added, the run kept.
            if old.follow_up == cell.follow_up {
                continue;
            }
        }
        let (run, follow_up) = (cell.config.clone(), cell.follow_up.clone());
        let text = toml::to_string(&CellFile { run, follow_up })?;
        joca_train::write_atomic(&path, &text)?;
    }
    joca_train::write_atomic(
        &dir.join(Manifest::FILE),
        &serde_json::to_string_pretty(&exp.manifest)?,
    )?;
    Ok(())
}

#[cfg(test)]
mod tests;
