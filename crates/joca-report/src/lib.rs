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

mod data;
mod experiment;
mod frames;
mod html;
mod plot;
mod seeds;
mod table;

pub use data::{GenerationFitness, RunData, StepLog};
pub use experiment::{CellSpec, CellState, Manifest, write_experiment_report};
pub use frames::DRAW_MIN_SCORE;
pub use joca_record::{DesignSummary, RunResults, Showcase, ShowcaseFrame};
pub use seeds::{mean_interval, t_975};
pub use table::{Row, Table};

use joca_core::units::linear_from_db;
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

/// Moving average over `window` points (the loss is logged every fifth step and is noisy).
fn smooth(points: &[(f64, f64)], window: usize) -> Vec<(f64, f64)> {
    (0..points.len())
        .map(|i| {
            let lo = i.saturating_sub(window - 1);
            let part = &points[lo..=i];
            (points[i].0, part.iter().map(|p| p.1).sum::<f64>() / part.len() as f64)
        })
        .collect()
}

/// Draws the figures comparing `runs` (label, run) into `dir/figures/`, file names prefixed
/// with `prefix`, and returns them with captions. Figures whose data no run has are left out.
pub fn write_figures(
    dir: &Path,
    prefix: &str,
    what: &str,
    runs: &[(String, &RunData)],
) -> Result<Vec<Figure>, ReportError> {
    let fig_dir = dir.join("figures");
    std::fs::create_dir_all(&fig_dir).map_err(|e| io_err(&fig_dir, e))?;
    let mut figures = Vec::new();
    let name = |stem: &str, ext: &str| format!("figures/{prefix}{stem}.{ext}");

    figures.extend(fitness_figure(dir, &name("fitness", "png"), what, runs)?);
    let tunnel: Vec<(usize, &String, &Showcase)> = runs
        .iter()
        .enumerate()
        .filter_map(|(i, (l, r))| r.showcase("tunnel").map(|s| (i, l, s)))
        .collect();
    figures.extend(settings_figure(dir, &name("settings", "png"), what, &tunnel)?);
    figures.extend(loss_figure(dir, &name("loss", "png"), what, runs)?);

    if runs.iter().any(|(_, r)| !r.showcases.is_empty()) {
        let file = name("frames", "png");
        frames::qualitative_grid(&dir.join(&file), runs)?;
        figures.push(Figure {
            section: what.to_owned(),
            file,
            caption: format!(
                "The same test scenes through each method's camera and controller ({what}): \
                    ground truth in green, detections with score ≥ {DRAW_MIN_SCORE} in red."
            ),
        });
    }

    let designs: Vec<(String, DesignSummary)> =
        runs.iter().map(|(l, r)| (l.clone(), r.results.design.clone())).collect();
    let file = name("fov", "png");
    plot::fov_diagram(&dir.join(&file), &designs)?;
    figures.push(Figure {
        section: what.to_owned(),
        file,
        caption: format!(
            "Top view of each design's mount position and horizontal field of view \
            on the ego vehicle ({what}); the mount height z is in the legend."
        ),
    });

    if !tunnel.is_empty() {
        let file = name("tunnel", "gif");
        frames::tunnel_animation(&dir.join(&file), runs)?;
        figures.push(Figure {
            section: what.to_owned(),
            file,
            caption: format!(
                "Animation (10 frames/s) of the tunnel transition through each \
                method's camera, with the exposure and gain its controller chose ({what})."
            ),
        });
    }
    Ok(figures)
}

/// Writes `report.md`, `report.html` and `figures/` into the run directory `run_dir` and
/// returns the Markdown.
pub fn write_run_report(run_dir: &Path) -> Result<String, ReportError> {
    let run = RunData::load(run_dir)?;
    let r = &run.results;
    let title = format!("joca run: {} / {}", r.method.name(), r.scenario.name());
    let table = Table {
        label_header: "Method".into(),
        rows: vec![Row {
            group: r.scenario.name().to_owned(),
            label: r.method.name().to_owned(),
            cell: run_dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
            results: r.clone(),
        }],
    };
    let figures = write_figures(
        run_dir,
        "",
        &format!("{} / {}", r.method.name(), r.scenario.name()),
        &[(r.method.name().to_owned(), &run)],
    )?;
    let mut md = format!("# {title}\n\n");
    let tested_on = if r.real_images() {
        format!(
            "recorded frames ({}; only the sensor is designed, the recording fixes mount and lens)",
            r.source
        )
    } else {
        "the test town".to_owned()
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
    md.push_str(&objects_markdown(r));
    md.push_str(&fitness_markdown(&run));
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

/// Where the numbers were computed: training repeats bit for bit on the same machine type and
/// libtorch kernels, not across types (empty for runs that did not record it).
fn machine_line(r: &RunResults) -> String {
    if r.cpu.is_empty() {
        return String::new();
    }
    format!(
        "Computed on {} with libtorch's {} kernels{} (numbers repeat on this machine type).",
        r.cpu,
        if r.cpu_kernels.is_empty() { "native" } else { &r.cpu_kernels },
        if r.denormals == "flush" { ", subnormal floats flushed to zero" } else { "" }
    )
}

/// The closed-loop test's settings by illumination: mean exposure, gain, and exposure × linear
/// gain, the last also relative to night (a controller that reacts to light amplifies day far
/// less than night).
pub fn settings_markdown(r: &RunResults) -> String {
    let mut md = String::from(
        "## Exposure and gain during the closed-loop test\n\n| illumination | mean E (ms) | mean \
            G (dB) | mean E × gain (ms) | relative to night | mean frame (DN) |\n\
            |---|---|---|---|---|---|\n",
    );
    let night = r.exposure_gain_by_illumination.get("night").copied();
    for (light, (e, g)) in &r.settings_by_illumination {
        let eg = r.exposure_gain_by_illumination.get(light);
        let cell = eg.map_or_else(|| "-".to_owned(), |v| format!("{v:.1}"));
        let relative = match (eg, night) {
            (Some(v), Some(n)) if n > 0.0 => format!("{:.3}", v / n),
            _ => "-".to_owned(),
        };
        let mean = r
            .mean_dn_by_illumination
            .get(light)
            .map_or_else(|| "-".to_owned(), |v| format!("{v:.0}"));
        let _ = writeln!(md, "| {light} | {e:.2} | {g:.1} | {cell} | {relative} | {mean} |");
    }
    md.push('\n');
    md
}

/// The controller's answer to the tunnel exit (the largest step of ambient light in the
/// showcases, if one is ≥ 10×): how far exposure × gain fell within 1 s. A controller that keeps
/// the image level takes back about as much as the light rose, or until its range ends.
pub fn light_step_markdown(showcases: &[Showcase]) -> String {
    let steps = showcases.iter().filter_map(|s| Some((s, s.light_step(10.0, 1.0)?)));
    let mut md = String::new();
    for (s, step) in steps {
        let _ = writeln!(
            md,
            "After the light step of the `{}` sequence (ambient ×{:.0} at {:.1} s), exposure × \
                gain fell {:.1}× within {} s.\n",
            s.name, step.rise, step.time_s, step.fall, step.window_s
        );
    }
    md
}

/// What the test's scores rest on: reference objects and AP per class, and AP50 and recall at
/// IoU 0.5 per distance band.
pub fn objects_markdown(r: &RunResults) -> String {
    let t = &r.test;
    let mut md = format!(
        "## Test objects ({} frames)\n\n| class | reference objects | AP@[.5:.95] | AP50 \
            |\n|---|---|---|---|\n",
        t.frames
    );
    let num = |v: Option<f64>| v.map_or_else(|| "-".to_owned(), |v| format!("{v:.3}"));
    for (i, class) in joca_record::Class::ALL.iter().enumerate() {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} |",
            class.name(),
            t.class_objects[i],
            num(t.class_map[i]),
            num(t.class_ap50[i])
        );
    }
    // Recordings without depth have no object in any band: no table.
    if r.test_bands.iter().any(|b| b.class_objects.iter().sum::<u64>() > 0) {
        md.push_str(
            "\n| distance (m) | vehicles | walkers | signs | AP50 | recall at IoU 0.5 \
                |\n|---|---|---|---|---|---|\n",
        );
        for b in &r.test_bands {
            let [v, w, s] = b.class_objects;
            let _ = writeln!(
                md,
                "| {:.0}–{:.0} | {v} | {w} | {s} | {} | {} |",
                b.from_m,
                b.to_m,
                num(b.ap50),
                num(b.recall50)
            );
        }
    }
    md.push('\n');
    md
}

fn fitness_markdown(run: &RunData) -> String {
    if run.generations.is_empty() {
        return String::new();
    }
    let mut md = String::from(
        "## Hardware GA fitness (mAP + 1.1 × TP ratio over each candidate's frames)\n\n| \
            generation | best | mean |\n|---|---|---|\n",
    );
    for g in &run.generations {
        let _ = writeln!(md, "| {} | {:.3} | {:.3} |", g.generation, g.best, g.mean);
    }
    md.push('\n');
    md
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

/// The hardware GA's best and mean fitness per generation (None: no run logged a generation).
fn fitness_figure(
    dir: &Path,
    file: &str,
    what: &str,
    runs: &[(String, &RunData)],
) -> Result<Option<Figure>, ReportError> {
    let mut fitness = Vec::new();
    for (i, (label, run)) in runs.iter().enumerate() {
        if run.generations.is_empty() {
            continue;
        }
        let g = &run.generations;
        if g.iter().all(|g| g.best == g.mean) {
            // One candidate per generation (a fixed camera): best and mean coincide.
            fitness.push(plot::Series {
                label: format!("{label} (one candidate)"),
                colour: i,
                dashed: false,
                points: g.iter().map(|g| (g.generation as f64, g.best)).collect(),
            });
            continue;
        }
        fitness.push(plot::Series {
            label: format!("{label} (best)"),
            colour: i,
            dashed: false,
            points: g.iter().map(|g| (g.generation as f64, g.best)).collect(),
        });
        fitness.push(plot::Series {
            label: format!("{label} (mean)"),
            colour: i,
            dashed: true,
            points: g.iter().map(|g| (g.generation as f64, g.mean)).collect(),
        });
    }
    if !fitness.is_empty() {
        let file = file.to_owned();
        plot::stacked_chart(
            &dir.join(&file),
            &format!("Hardware GA fitness per generation — {what}"),
            "generation",
            &[plot::Panel { y_label: "fitness = mAP + 1.1 × TP ratio".into(), series: fitness }],
            (900, 480),
        )?;
        return Ok(Some(Figure {
            section: what.to_owned(),
            file,
            caption: format!(
                "Fitness of the hardware GA's candidates per generation (solid: best, dashed: \
                 mean; {what}). Each candidate is trained and scored on its own k frames, so the \
                 curves are noisy; a fixed-camera method drives its one camera as many times per \
                 generation as the GA has candidates, so every method trains on as many frames."
            ),
        }));
    }
    Ok(None)
}

/// Exposure, gain and their product through the tunnel showcase (None: no run has it).
fn settings_figure(
    dir: &Path,
    file: &str,
    what: &str,
    tunnel: &[(usize, &String, &Showcase)],
) -> Result<Option<Figure>, ReportError> {
    if let Some((_, _, first)) = tunnel.first() {
        let light = plot::Series {
            label: "ambient light".into(),
            colour: 7,
            dashed: false,
            points: first.frames.iter().map(|f| (f.time_s, f64::from(f.ambient).log10())).collect(),
        };
        let series = |value: fn(&ShowcaseFrame) -> f64| {
            tunnel
                .iter()
                .map(|(i, l, s)| plot::Series {
                    label: (*l).clone(),
                    colour: *i,
                    dashed: false,
                    points: s.frames.iter().map(|f| (f.time_s, value(f))).collect(),
                })
                .collect::<Vec<_>>()
        };
        let file = file.to_owned();
        plot::stacked_chart(
            &dir.join(&file),
            &format!("Exposure and gain through a tunnel transition (test town) — {what}"),
            "time (s)",
            &[
                plot::Panel {
                    y_label: "ambient, log10 (0 = daylight)".into(),
                    series: vec![light],
                },
                plot::Panel {
                    y_label: "exposure time (ms)".into(),
                    series: series(|f| f.exposure_ms),
                },
                plot::Panel { y_label: "gain (dB)".into(), series: series(|f| f.gain_db) },
                // On the ambient panel's log scale: a controller that keeps the image level
                // moves this by as much as the ambient light moves, the other way.
                plot::Panel {
                    y_label: "exposure × gain, log10 (ms)".into(),
                    series: series(|f| (f.exposure_ms * linear_from_db(f.gain_db)).log10()),
                },
            ],
            (900, 1060),
        )?;
        return Ok(Some(Figure {
            section: what.to_owned(),
            file,
            caption: format!(
                "What each exposure controller chose, frame by frame, while driving through an \
                    abrupt change of illumination on the test town (closed loop: each frame's \
                    settings come from the previous frame; {what}). The last panel, exposure × \
                    linear gain on the ambient panel's log scale, falls by as much as the light \
                    rises when a controller keeps the image level."
            ),
        }));
    }
    Ok(None)
}

/// The detector's task loss during joint training (None: no run logged a step).
fn loss_figure(
    dir: &Path,
    file: &str,
    what: &str,
    runs: &[(String, &RunData)],
) -> Result<Option<Figure>, ReportError> {
    let mut losses = Vec::new();
    for (i, (label, run)) in runs.iter().enumerate() {
        if run.steps.is_empty() {
            continue;
        }
        let raw: Vec<(f64, f64)> = run.steps.iter().map(|s| (s.step as f64, s.loss)).collect();
        losses.push(plot::Series {
            label: label.clone(),
            colour: i,
            dashed: false,
            points: smooth(&raw, 20),
        });
    }
    if !losses.is_empty() {
        let file = file.to_owned();
        plot::stacked_chart(
            &dir.join(&file),
            &format!("Detector task loss during joint training — {what}"),
            "training step",
            &[plot::Panel {
                y_label: "task loss (moving average of 20 logs)".into(),
                series: losses,
            }],
            (900, 480),
        )?;
        return Ok(Some(Figure {
            section: what.to_owned(),
            file,
            caption: format!(
                "The detector's task loss (focal heat-map + size + offset) during \
                joint training, logged every fifth step, moving average over 20 logs; {what}."
            ),
        }));
    }
    Ok(None)
}
