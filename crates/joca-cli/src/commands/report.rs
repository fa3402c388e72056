//! `joca report`: regenerate the report of a run or an experiment from its saved files.

use anyhow::{Context, Result, bail};
use joca_core::output::{self, OutputKind};
use std::path::PathBuf;

/// Arguments of `joca report`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// A finished run directory or an experiment directory (joca's marker names which).
    dir: PathBuf,
    /// Report an experiment whose cells were computed by different joca commits (refused
    /// otherwise, naming each commit's cells).
    #[arg(long)]
    mixed_commits: bool,
    /// Write the tables only (report.md, report.html, results.csv), no figures: for records
    /// that are committed or shared.
    #[arg(long)]
    no_figures: bool,
    /// An experiment's rows from each cell's `results-TAG.json` (e.g. `town2` for a follow-up
    /// town, `average-127.5` for the AverageAE re-test) instead of its `results.json`; a
    /// finished cell without the file is refused, named.
    #[arg(long, value_name = "TAG")]
    results: Option<String>,
    /// Another experiment directory whose finished cells join this experiment's report
    /// (repeatable): its labels end in ` (<its directory name>)` and its variants pair with
    /// this experiment's on the same scenario, design and seed — the same variant run on
    /// another machine type, say. The report is written into DIR only.
    #[arg(long, value_name = "EXPERIMENT_DIR")]
    with: Vec<PathBuf>,
}

/// Runs `joca report`.
pub fn run(args: &Args) -> Result<()> {
    let dir = &args.dir;
    let options = joca_report::ReportOptions {
        mixed_commits: args.mixed_commits,
        no_figures: args.no_figures,
        results: args.results.clone(),
        with: args.with.clone(),
    };
    for other in &args.with {
        if output::marked_kind(other) != Some(OutputKind::Experiment) {
            bail!(
                "--with {}: not an experiment directory of joca's (no {} marker naming one); \
                 --with takes the directory `joca experiment --out` wrote or `joca export` made",
                other.display(),
                output::MARKER
            );
        }
    }
    // Reports are written only into folders joca marked as its own (joca_core::output).
    match output::marked_kind(dir) {
        Some(OutputKind::Experiment) => {
            joca_report::write_experiment_report_with(dir, &options)
                .with_context(|| format!("cannot write the report of {}", dir.display()))?;
        }
        Some(OutputKind::Run) if args.results.is_some() || !args.with.is_empty() => bail!(
            "--results and --with apply to an experiment directory; {} is a run directory",
            dir.display()
        ),
        Some(OutputKind::Run) if dir.join("results.json").is_file() => {
            joca_report::write_run_report_with(dir, &options)
                .with_context(|| format!("cannot write the report of {}", dir.display()))?;
            if let Some(note) =
                joca_report::RunData::load(dir).ok().and_then(|r| r.skipped_events_note())
            {
                eprintln!("warning: {note}");
            }
        }
        Some(OutputKind::Run) => bail!(
            "{} is a run directory that has not finished its test (no results.json): nothing to \
             report yet (`joca run --resume` continues it)",
            dir.display()
        ),
        _ => bail!(
            "{} is neither a run directory nor an experiment directory of joca's (no {} marker \
             naming one); a folder joca wrote before markers existed is marked with `printf \
             'joca-output run\\n' > {}/{}` (or `experiment`)",
            dir.display(),
            output::MARKER,
            dir.display(),
            output::MARKER
        ),
    }
    // Written by joca: an export's next refresh replaces them without asking.
    crate::io::extend_inventory(dir, &["report.md", "report.html", "results.csv", "figures"])?;
    let (md, html) = (dir.join("report.md"), dir.join("report.html"));
    if args.no_figures {
        println!("wrote {} and {} (no figures)", md.display(), html.display());
    } else {
        println!(
            "wrote {}, {} and {}",
            md.display(),
            html.display(),
            dir.join("figures").display()
        );
    }
    Ok(())
}
