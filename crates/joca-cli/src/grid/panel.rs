//! Design panels: an experiment's `[panel]` holds the hardware fixed to a list of designs, so
//! that every variant (controller, ablation) is compared on identical designs.
//!
//! ```toml
//! [panel]
//! designs = [
//!   { id = "flir", camera = "flir" },
//!   { id = "imx546-6mm", sensor = "IMX546", focal_length_mm = 6.0, x_m = 0.43, z_m = 1.65 },
//! ]
//! # Best designs of finished runs (their best_design.json), or every finished cell of an
//! # experiment folder; paths relative to the working directory.
//! from_runs = ["runs/std-input/cells/joca-calibrated-s0", "runs/std-input"]
//! ```
//!
//! A design several runs chose enters the panel once, under the first run's name.

use anyhow::{Context, Result, anyhow, bail};
use joca_report::Manifest;
use joca_train::{DesignSpec, DesignSummary, FixedCamera};
use serde::Deserialize;
use std::path::Path;

/// The most designs one panel may hold.
pub const MAX_DESIGNS: usize = 200;

/// `[panel]` of an experiment file.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PanelFile {
    /// Designs listed in the file.
    #[serde(default)]
    designs: Vec<PanelEntry>,
    /// Run or experiment directories whose best designs join the panel.
    #[serde(default)]
    from_runs: Vec<String>,
}

/// A listed design: a fixed camera by name, or a design by its genes.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PanelEntry {
    id: String,
    #[serde(default)]
    camera: Option<FixedCamera>,
    #[serde(default)]
    sensor: Option<String>,
    #[serde(default)]
    focal_length_mm: Option<f64>,
    #[serde(default)]
    x_m: Option<f64>,
    #[serde(default)]
    z_m: Option<f64>,
    /// Lens f-number with the genes (absent: the calibration's f/16).
    #[serde(default)]
    f_number: Option<f64>,
}

/// One design of a resolved panel.
#[derive(Debug, Clone, PartialEq)]
pub struct PanelDesign {
    /// Its id in cell names (`<variant>-<scenario>-<id>`).
    pub id: String,
    /// The design.
    pub spec: DesignSpec,
}

/// A valid id: letters, digits, '-' or '_'.
pub fn valid_id(id: &str) -> bool {
    !id.is_empty() && id.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
}

impl PanelFile {
    /// The panel's designs, each checked against the catalogue and the design space; errors
    /// name the entry and `source` (the experiment file).
    pub fn resolve(&self, source: &str) -> Result<Vec<PanelDesign>> {
        let mut out: Vec<PanelDesign> = Vec::new();
        for e in &self.designs {
            let what = format!("{source}: [panel] design {:?}", e.id);
            if !valid_id(&e.id) {
                bail!("{what}: the id must be letters, digits, '-' or '_'");
            }
            let spec = e.spec().with_context(|| what.clone())?;
            if let Some(other) = out.iter().find(|d| d.spec == spec) {
                bail!(
                    "{what}: the same design as {:?}; list each design once (a design's cells \
                     would otherwise be run twice under two names)",
                    other.id
                );
            }
            push(&mut out, PanelDesign { id: e.id.clone(), spec }, &what)?;
        }
        for dir in &self.from_runs {
            let what = format!("{source}: [panel] from_runs {dir:?}");
            for design in from_dir(Path::new(dir)).with_context(|| what.clone())? {
                push(&mut out, design, &what)?;
            }
        }
        if out.is_empty() {
            bail!(
                "{source}: [panel] holds no design: list `designs` or name finished runs in \
                 `from_runs`"
            );
        }
        if out.len() > MAX_DESIGNS {
            bail!("{source}: [panel] holds {} designs; at most {MAX_DESIGNS}", out.len());
        }
        Ok(out)
    }
}

impl PanelEntry {
    fn spec(&self) -> Result<DesignSpec> {
        let genes = (&self.sensor, self.focal_length_mm, self.x_m, self.z_m);
        let spec = match (self.camera, genes) {
            (Some(camera), (None, None, None, None)) if self.f_number.is_none() => {
                DesignSpec::of(&camera.design())
            }
            (None, (Some(sensor), Some(f), Some(x), Some(z))) => DesignSpec {
                sensor: sensor.clone(),
                focal_length_mm: f,
                x_m: x,
                z_m: z,
                f_number: self.f_number,
            },
            _ => bail!(
                "give either `camera` (flir or basler) or all of `sensor`, `focal_length_mm`, \
                 `x_m` and `z_m` (and optionally `f_number`)"
            ),
        };
        check(&spec)?;
        Ok(spec)
    }
}

/// `spec` against the catalogue and the design space, naming the field and its range.
fn check(spec: &DesignSpec) -> Result<()> {
    spec.design().map(|_| ()).map_err(|e| anyhow!("{e}"))
}

/// Adds `design` unless the panel holds it already (under any id: a design two runs chose is
/// kept once); two designs under one id are refused.
fn push(out: &mut Vec<PanelDesign>, design: PanelDesign, what: &str) -> Result<()> {
    if out.iter().any(|d| d.spec == design.spec) {
        return Ok(());
    }
    if out.iter().any(|d| d.id == design.id) {
        bail!("{what}: id {:?} names two different designs; ids must be unique", design.id);
    }
    out.push(design);
    Ok(())
}

/// The best design of run directory `dir`, or of every finished cell of experiment `dir`.
fn from_dir(dir: &Path) -> Result<Vec<PanelDesign>> {
    if dir.join(Manifest::FILE).is_file() {
        let manifest = Manifest::load(dir)?;
        let mut out = Vec::new();
        for cell in &manifest.cells {
            let run = Manifest::cell_dir(dir, cell);
            if run.join("best_design.json").is_file() {
                out.push(from_run(&run, &cell.id)?);
            }
        }
        if out.is_empty() {
            bail!("no cell of the experiment {} has finished (no best_design.json)", dir.display());
        }
        return Ok(out);
    }
    let id = dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    Ok(vec![from_run(dir, &id)?])
}

fn from_run(dir: &Path, id: &str) -> Result<PanelDesign> {
    let path = dir.join("best_design.json");
    if !path.is_file() {
        bail!(
            "{} has no best_design.json: not a finished run directory (a run writes it when its \
             training ends)",
            dir.display()
        );
    }
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("cannot read {}", path.display()))?;
    let summary: DesignSummary = serde_json::from_str(&text)
        .with_context(|| format!("{} is not a design summary", path.display()))?;
    let spec = DesignSpec {
        sensor: summary.sensor,
        focal_length_mm: summary.focal_length_mm,
        x_m: summary.x_m,
        z_m: summary.z_m,
        f_number: summary.f_number,
    };
    check(&spec).with_context(|| format!("{}", path.display()))?;
    if !valid_id(id) {
        bail!("{}: the folder name {id:?} is not a valid panel id", dir.display());
    }
    Ok(PanelDesign { id: id.to_owned(), spec })
}
