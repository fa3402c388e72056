//! `joca headroom`: the room any exposure controller has on a design and detector — a run's
//! (from its checkpoint) or a fixed design's with detector weights — and the table of several
//! such measurements paired by design; `--panel` measures every design of a panel file.

mod panel;

use crate::config;
use anyhow::{Context, Result, anyhow, bail};
use joca_train::headroom::ladder::LadderConfig;
use joca_train::headroom::{HeadroomOptions, Subject, headroom, write_headroom};
use joca_train::{DesignSpec, RunConfig, Scenario};
use std::path::{Path, PathBuf};

/// Arguments of `joca headroom`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// A run directory (its best design, trained detector and controller); or, with `--table`,
    /// the folders (or `headroom.json` files) of earlier measurements to tabulate.
    paths: Vec<PathBuf>,
    /// Tabulate earlier measurements: each policy minus AverageAE at mid-grey, paired over them.
    #[arg(long)]
    table: bool,
    /// With `--table`: records of the same designs and detectors on other frames (another
    /// town's), on which a target and a rung per light are chosen and then scored on the
    /// tabulated records' frames (out of sample).
    #[arg(long, value_name = "PATH", num_args = 1.., requires = "table")]
    chosen_on: Vec<PathBuf>,
    /// Measure every design of a panel file (its scenarios, towns, `[run]`, `[ladder]` and
    /// `[panel]`) into `--out`, then tabulate each scenario and town; again to resume.
    #[arg(
        long,
        value_name = "FILE",
        conflicts_with_all = ["table", "design", "config", "scenario", "tunnels"]
    )]
    panel: Option<PathBuf>,
    /// With `--panel`: measurements run at once, each a child process.
    #[arg(long, default_value_t = 1)]
    jobs: usize,
    /// Without a run directory: the preset whose `[run]` the design is measured with.
    #[arg(long, default_value = "standard")]
    preset: String,
    /// A TOML file: `[run]` fields over the preset's (a fixed `design`, `detector_weights`) and
    /// the `[ladder]` table (`top_exposure_gain_ms`, `steps`, `step_stops`, `split`,
    /// `targets_dn`).
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Without a run directory: the design, `SENSOR:FOCAL_MM:X_M:Z_M` (e.g. `IMX287:10:2.14:1.7`).
    #[arg(long)]
    design: Option<String>,
    /// Form the frames under another scenario: calibrated, noise10, noise20, blur2, blur4.
    #[arg(long)]
    scenario: Option<String>,
    /// The test family's town: 0 (the test town) or 2 to 9999.
    #[arg(long, default_value_t = 0)]
    town: u64,
    /// What the `tunnel` light is, instead of the configuration's: `switch` or `places` (its
    /// count and lamps as configured, else the defaults): e.g. a run trained with the switch
    /// tested with tunnels as places.
    #[arg(long, value_parser = joca_sim::TunnelKind::from_name)]
    tunnels: Option<joca_sim::TunnelKind>,
    /// Test episodes (stratified by light) [default: the configuration's].
    #[arg(long)]
    episodes: Option<u64>,
    /// Scored frames per episode [default: the configuration's].
    #[arg(long)]
    frames: Option<usize>,
    /// What the networks compute on: cpu, cuda (the first GPU), cuda:N or auto (a GPU if one is
    /// usable, else the CPU) [default: the configuration's `device`, cpu].
    #[arg(long, value_parser = crate::config::device)]
    device: Option<joca_nn::device::DeviceChoice>,
    /// Where `headroom.json` and `headroom.md` go [default: RUN_DIR/headroom-<scenario>-town<K>;
    /// required without a run directory]; with `--table`, the Markdown file to write.
    #[arg(long)]
    out: Option<PathBuf>,
}

/// Runs `joca headroom`.
pub fn run(args: &Args) -> Result<()> {
    if args.table {
        return table(args);
    }
    if let Some(file) = &args.panel {
        if !args.paths.is_empty() {
            bail!("--panel: the panel file names the designs; give no run directory");
        }
        let Some(out) = &args.out else { bail!("--out: required with --panel") };
        return panel::run(file, out, args.jobs);
    }
    let (ladder, ladder_file) = ladder(args.config.as_deref())?;
    let scenario =
        args.scenario.as_deref().map(Scenario::from_name).transpose().map_err(|e| anyhow!(e))?;
    let options = HeadroomOptions {
        ladder,
        ladder_file,
        scenario,
        town: args.town,
        episodes: args.episodes,
        frames_per_episode: args.frames,
        device: args.device,
        tunnels: args.tunnels,
    };
    let (subject, out) = match args.paths.as_slice() {
        [run_dir] => {
            if args.design.is_some() {
                bail!("--design: give a design or a run directory, not both");
            }
            if let Some(path) = &args.config
                && ladder_only(path)?.is_some()
            {
                bail!(
                    "config file {}: with a run directory only [ladder] is read (the run's own \
                     config.toml sets the rest); remove its other tables",
                    path.display()
                );
            }
            let out = args.out.clone().unwrap_or_else(|| {
                let s = scenario.map_or("run".to_owned(), |s| s.name().to_owned());
                run_dir.join(format!("headroom-{s}-town{}", args.town))
            });
            (Subject::Run(run_dir.clone()), out)
        }
        [] => {
            let (mut table, source) =
                config::load_table_with(&args.preset, args.config.as_deref(), &["ladder"])?;
            let run =
                table.remove("run").with_context(|| format!("{source} has no [run] table"))?;
            let mut cfg: RunConfig =
                run.try_into().with_context(|| format!("invalid [run] in {source}"))?;
            if let Some(d) = &args.design {
                cfg.design = Some(parse_design(d)?);
            }
            crate::commands::run::resolve_weights(&mut cfg);
            let Some(out) = args.out.clone() else {
                bail!("--out: required when measuring a design without a run directory");
            };
            (Subject::Design(Box::new(cfg)), out)
        }
        _ => bail!("give one run directory, or none with --design (several only with --table)"),
    };
    let record = headroom(&subject, &options).context("cannot measure the headroom")?;
    let markdown = joca_report::headroom_markdown(&record);
    write_headroom(&out, &record, &markdown)
        .with_context(|| format!("cannot write {}", out.display()))?;
    print!("{markdown}");
    println!("\nwritten: {}", out.join("headroom.json").display());
    Ok(())
}

/// The `[ladder]` table of the configuration file (defaults without one), and the file's name.
fn ladder(file: Option<&Path>) -> Result<(LadderConfig, String)> {
    let Some(path) = file else {
        return Ok((LadderConfig::default(), "(defaults)".into()));
    };
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read config file {}", path.display()))?;
    let table = read_table(path, &text)?;
    let ladder = match table.get("ladder") {
        None => LadderConfig::default(),
        Some(v) => v
            .clone()
            .try_into()
            .with_context(|| format!("invalid [ladder] in {}", path.display()))?,
    };
    Ok((ladder, path.display().to_string()))
}

fn read_table(path: &Path, text: &str) -> Result<toml::Table> {
    toml::from_str(text).with_context(|| format!("invalid config file {}", path.display()))
}

/// The first top-level table of `path` other than `[ladder]`, if any.
fn ladder_only(path: &Path) -> Result<Option<String>> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read config file {}", path.display()))?;
    Ok(read_table(path, &text)?.keys().find(|k| *k != "ladder").cloned())
}

/// `SENSOR:FOCAL_MM:X_M:Z_M`.
fn parse_design(text: &str) -> Result<DesignSpec> {
    let parts: Vec<&str> = text.split(':').collect();
    let number = |s: &str, what: &str| {
        s.parse::<f64>().map_err(|_| anyhow!("--design: {what} {s:?} is not a number"))
    };
    match parts.as_slice() {
        [sensor, f, x, z] => Ok(DesignSpec {
            sensor: (*sensor).to_owned(),
            focal_length_mm: number(f, "focal length (mm)")?,
            x_m: number(x, "x (m)")?,
            z_m: number(z, "z (m)")?,
            f_number: None,
        }),
        _ => bail!(
            "--design: expected SENSOR:FOCAL_MM:X_M:Z_M (e.g. IMX287:10:2.14:1.7), got {text:?}"
        ),
    }
}

/// `--table`: the paired summary of earlier measurements.
fn table(args: &Args) -> Result<()> {
    if args.paths.is_empty() {
        bail!("--table: give the folders (or headroom.json files) of earlier measurements");
    }
    write_table(&args.paths, (&args.chosen_on, true), args.out.as_deref())
}

/// Reads the records at `paths` (folders or `headroom.json` files), refuses records not measured
/// alike, prints their paired table (and, with `chosen_on`'s records, the choices per light made
/// on those; `strict`: every record must have its subject's there) and writes it to `out`.
fn write_table(
    paths: &[PathBuf],
    (chosen_on, strict): (&[PathBuf], bool),
    out: Option<&Path>,
) -> Result<()> {
    let records = read_alike(paths)?;
    let mut text = joca_report::headroom_summary_markdown(&records);
    if !chosen_on.is_empty() {
        let elsewhere = read_alike(chosen_on)?;
        if strict
            && let Some(r) =
                records.iter().find(|r| !elsewhere.iter().any(|e| joca_report::same_subject(r, e)))
        {
            bail!(
                "--chosen-on: no record of {} (detector {}{}) among its paths",
                r.design.sensor,
                r.detector,
                r.run.as_deref().map(|d| format!(", run {d}")).unwrap_or_default()
            );
        }
        // Every field but the town must match the tabulated records'.
        if let (Some(a), Some(b)) = (records.first(), elsewhere.first())
            && let Some(field) = unlike_but_town(a, b)
        {
            bail!(
                "--chosen-on: its records and the tabulated ones were not measured alike ({field} \
                 differs): a choice made on other frames must be scored in the same world"
            );
        }
        text.push_str(&joca_report::chosen_elsewhere_markdown(&records, &elsewhere));
    }
    if let Some(out) = out {
        joca_core::fs::write_atomic(out, text.as_bytes())
            .with_context(|| format!("cannot write {}", out.display()))?;
    }
    print!("{text}");
    Ok(())
}

/// Reads the records at `paths` (folders or `headroom.json` files), refusing records not
/// measured alike.
fn read_alike(paths: &[PathBuf]) -> Result<Vec<joca_report::HeadroomRecord>> {
    let mut records: Vec<(PathBuf, joca_report::HeadroomRecord)> = Vec::new();
    for p in paths {
        let file = if p.is_dir() { p.join("headroom.json") } else { p.clone() };
        let text = std::fs::read_to_string(&file)
            .with_context(|| format!("cannot read {}", file.display()))?;
        let record: joca_report::HeadroomRecord = serde_json::from_str(&text)
            .with_context(|| format!("{} is not a headroom record", file.display()))?;
        if record.format_version > joca_report::HEADROOM_FORMAT_VERSION {
            bail!(
                "{}: format_version {} is newer than this joca reads ({})",
                file.display(),
                record.format_version,
                joca_report::HEADROOM_FORMAT_VERSION
            );
        }
        if let Some((first, r0)) = records.first()
            && let Some(field) = unlike(r0, &record)
        {
            bail!(
                "{} and {} were not measured alike ({field} differs): a paired table needs one \
                 scenario, town, world, frame count and ladder; tabulate them separately",
                first.display(),
                file.display()
            );
        }
        records.push((file, record));
    }
    Ok(records.into_iter().map(|(_, r)| r).collect())
}

/// The first field in which two records' measurements differ, if any.
fn unlike(
    a: &joca_report::HeadroomRecord,
    b: &joca_report::HeadroomRecord,
) -> Option<&'static str> {
    let town = || (a.town != b.town).then_some("town");
    (a.scenario != b.scenario).then_some("scenario").or_else(town).or_else(|| unlike_but_town(a, b))
}

/// [`unlike`] without the town: the scenario, the world, the frame count and the ladder.
fn unlike_but_town(
    a: &joca_report::HeadroomRecord,
    b: &joca_report::HeadroomRecord,
) -> Option<&'static str> {
    let scenario = (a.scenario != b.scenario).then_some("scenario");
    let frames = || (a.frames != b.frames).then_some("frames");
    let ladder = || (a.ladder != b.ladder).then_some("ladder");
    scenario.or_else(|| a.world.differs(&b.world)).or_else(frames).or_else(ladder)
}
