//! Reports that read run directories only — they never run anything.
//!
//! [`write_run_report`] turns one `joca run` directory into `report.md`, `report.html` and
//! `figures/`; [`write_experiment_report`] does the same for an experiment directory (a grid of
//! run directories described by its `experiment.json`, see [`Manifest`]) and adds
//! `results.csv`. Tables are laid out like the paper's (camera parameters with optimised or fixed
//! marked; mAP and TP ratio with the best of each group in bold and the second underlined).
//! Figures (PNG, and a GIF): hardware-GA fitness per generation, exposure and gain against the
//! illumination level over the tunnel test sequence, training loss, a qualitative grid of the same
//! test scenes through each camera, a top view of each design's mount and field of view, and an
//! animation of the tunnel transition.
//!
//! ```no_run
//! let run = std::path::Path::new("runs/quick-joca-calibrated");
//! let text = joca_report::write_run_report(run).unwrap();
//! assert!(text.contains("| Scenario |"));
//! ```
#![deny(missing_docs)]

mod controls;
mod data;
mod detector_start;
mod event_log;
mod experiment;
mod figures;
mod frames;
mod headroom;
mod headroom_elsewhere;
mod html;
mod paired;
mod plot;
mod pulls;
mod retests;
mod sections;
mod seeds;
mod steadiness;
mod summary;
mod swap;
mod table;
mod walltime;

pub use data::RunData;
pub use event_log::{GenerationFitness, StepLog};
pub use experiment::{
    CellSpec, CellState, Manifest, write_experiment_report, write_experiment_report_with,
};
pub use figures::write_figures;

pub use frames::DRAW_MIN_SCORE;
pub use headroom::{REFERENCE_POLICY, headroom_markdown, headroom_summary_markdown};
pub use headroom_elsewhere::{chosen_elsewhere_markdown, same_subject};
pub use joca_record::{
    DesignSummary, HEADROOM_FORMAT_VERSION, HeadroomRecord, Light, RunResults, Showcase,
    ShowcaseFrame,
};
use sections::{fitness_markdown, machine_line, ties_markdown};
pub use sections::{light_step_markdown, objects_markdown, settings_markdown};
pub use seeds::{mean_interval, t_975};
pub use table::{Row, Table};

use joca_record::Retest;
use std::fmt::Write as _;
use std::path::Path;
use thiserror::Error;

/// Why a report could not be made.
#[derive(Debug, Error)]
pub enum ReportError {
    /// A run file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// A run file is not what `joca run` writes.
    #[error("{path} is not a joca run file: {reason}")]
    Format {
        /// The file.
        path: String,
        /// What is wrong.
        reason: String,
    },
    /// An experiment's finished cells were computed by different joca commits.
    #[error(
        "the cells of {experiment} were computed by different joca commits ({cells}): a table \
         mixing them compares code as well as methods; re-run the stale cells, or pass \
         --mixed-commits to report them together anyway"
    )]
    MixedCommits {
        /// The experiment directory.
        experiment: String,
        /// Each commit and the cells it computed.
        cells: String,
    },
    /// A cell lacks the results file a report was asked to read (`--results TAG`).
    #[error(
        "cell {cell} has no {file} (--results {tag}): re-test it there (`joca eval`, or the grid's \
         [follow_up]), or report without --results"
    )]
    MissingResults {
        /// The cell.
        cell: String,
        /// The file it lacks.
        file: String,
        /// The tag asked for.
        tag: String,
    },
    /// A figure could not be drawn or encoded.
    #[error("cannot draw {path}: {reason}")]
    Draw {
        /// The figure or image.
        path: String,
        /// What failed.
        reason: String,
    },
}

/// A figure of a report: file relative to the report's directory, and its caption.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    /// Section it belongs to (the group it compares, e.g. a scenario).
    pub section: String,
    /// Path relative to the report directory.
    pub file: String,
    /// Caption (Markdown-free text).
    pub caption: String,
}

fn io_err(path: &Path, source: std::io::Error) -> ReportError {
    ReportError::Io { path: path.display().to_string(), source }
}

const SWAP_LABEL: &str = "AverageAE, same design and detector";

/// How `joca report` writes a report.
#[derive(Debug, Clone, Default)]
pub struct ReportOptions {
    /// Report an experiment's cells of different joca commits together (refused otherwise).
    pub mixed_commits: bool,
    /// Write the tables only: no `figures/`, and report.md and report.html without them (a
    /// `figures/` folder an earlier report wrote is left as it was).
    pub no_figures: bool,
    /// An experiment's rows from each cell's `results-<tag>.json` (a follow-up town's
    /// `town2`, a swap's `average-127.5`, …) instead of its `results.json`; a finished cell
    /// without it is refused, named.
    pub results: Option<String>,
    /// Other experiment directories whose finished cells join the report: each keeps its own
    /// run directory, and its labels end in ` (<directory name>)`, so a variant that two
    /// experiments ran (on another machine type, at another commit) pairs with this one's on the
    /// same scenario, design and seed.
    pub with: Vec<std::path::PathBuf>,
}

/// Writes `report.md`, `report.html` and `figures/` into the run directory `run_dir` and
/// returns the Markdown.
pub fn write_run_report(run_dir: &Path) -> Result<String, ReportError> {
    write_run_report_with(run_dir, &ReportOptions::default())
}

/// [`write_run_report`] as `options` say (`mixed_commits` does not apply to one run).
pub fn write_run_report_with(
    run_dir: &Path,
    options: &ReportOptions,
) -> Result<String, ReportError> {
    let run = RunData::load(run_dir)?;
    let r = &run.results;
    let title = format!("joca run: {} / {}", r.method.name(), r.scenario.name());
    // Does the learned controller earn its place? AverageAE at mid-grey driving the same
    // design with the same detector, where the run (or `joca eval --controller average`) tested it.
    let swap = RunData::retest(run_dir, &Retest::average_swap(0))?;
    let cell = run_dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let mut rows = vec![Row {
        group: r.scenario.name().to_owned(),
        label: r.method.name().to_owned(),
        cell: cell.clone(),
        design: String::new(),
        results: r.clone(),
    }];
    let mut runs = vec![(r.method.name().to_owned(), &run)];
    if let Some(s) = &swap {
        rows.push(Row {
            group: r.scenario.name().to_owned(),
            label: SWAP_LABEL.to_owned(),
            cell,
            design: String::new(),
            results: s.results.clone(),
        });
        runs.push((SWAP_LABEL.to_owned(), s));
    }
    let table = Table { label_header: "Method".into(), rows };
    let figures = if options.no_figures {
        Vec::new()
    } else {
        let caption = format!("{} / {}", r.method.name(), r.scenario.name());
        write_figures(run_dir, "", &caption, &runs)?
    };
    let mut md = format!("# {title}\n\n");
    let tested_on = if r.real_images() {
        format!(
            "recorded frames ({}; only the sensor is designed, the recording fixes mount and lens)",
            r.source
        )
    } else {
        format!("the test town{}", r.conditions_note())
    };
    let _ = writeln!(
        md,
        "Camera parameters marked ● were optimised, ○ fixed. Test on {tested_on}, closed loop, {} \
            frames; {}.\n",
        r.test.frames,
        r.input_note()
    );
    let machine = machine_line(r);
    if !machine.is_empty() {
        let _ = writeln!(md, "{machine}\n");
    }
    if let Some(note) = run.skipped_events_note() {
        let _ = writeln!(md, "{note}.\n");
    }
    md.push_str(&table.markdown());
    let _ = writeln!(md, "\nAP50 {:.3}.\n", r.test.ap50);
    md.push_str(&settings_markdown(r));
    md.push_str(&light_step_markdown(&run.showcases));
    if let Some(w) = &run.warm_start {
        let time = w.warm_start_s.map_or_else(String::new, |s| format!(", {s:.0} s"));
        let _ = writeln!(
            md,
            "Before DF-Grad NeuralAE imitated AverageAE for {} frames (imitation loss {:.3} in \
                the first quarter, {:.3} in the last{time}).\n",
            w.warm_start_frames, w.imitation_loss_first, w.imitation_loss_last
        );
    }
    if let Some(line) = walltime::run_sentence(&run) {
        let _ = writeln!(md, "{line}");
    }
    if let Some(s) = &swap {
        let _ = writeln!(
            md,
            "The same design and detector driven by AverageAE at mid-grey (`{}`):\n",
            s.test_dir
        );
        md.push_str(&settings_markdown(&s.results).replacen("## ", "### ", 1));
        md.push_str(&light_step_markdown(&s.showcases));
    }
    md.push_str(&objects_markdown(r));
    md.push_str(&pulls::pulls_markdown(&run.steps));
    md.push_str(&fitness_markdown(&run));
    md.push_str(&ties_markdown(r));
    md.push_str(&figures_markdown(&figures));
    write_text(&run_dir.join("report.md"), &md)?;
    let body = format!(
        "<p>Camera parameters marked <span class=\"opt\">●</span> were optimised, <span \
            class=\"fix\">○</span> fixed. Test on {}, closed loop, {} frames; {}; \
            AP50 {:.3}.</p>\n<p>{}</p>\n{}",
        table::escape(&tested_on),
        r.test.frames,
        table::escape(&r.input_note()),
        r.test.ap50,
        table::escape(&machine),
        table.html()
    );
    let page = html::page(&title, &body, run_dir, &figures)?;
    write_text(&run_dir.join("report.html"), &page)?;
    Ok(md)
}

fn figures_markdown(figures: &[Figure]) -> String {
    let mut md = String::new();
    if !figures.is_empty() {
        md.push_str("## Figures\n\n");
    }
    for f in figures {
        let _ = writeln!(md, "![{}]({})\n\n*{}*\n", f.file, f.file, f.caption);
    }
    md
}

fn write_text(path: &Path, text: &str) -> Result<(), ReportError> {
    joca_core::fs::write_atomic(path, text.as_bytes()).map_err(|e| io_err(path, e))
}
