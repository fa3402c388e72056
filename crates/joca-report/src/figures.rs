//! The figures of a run or experiment report: GA fitness, the tunnel's settings, the task
//! loss, the qualitative frames, the field-of-view diagram and the tunnel animation.

use crate::{DRAW_MIN_SCORE, Figure, ReportError, RunData, frames, io_err, plot};
use joca_record::{DesignSummary, Showcase, ShowcaseFrame};
use std::path::Path;

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
    line_figure(
        dir,
        file,
        what,
        (&format!("Hardware GA fitness per generation (new scenes each) — {what}"), "generation"),
        plot::Panel { y_label: "fitness = mAP + 1.1 × TP ratio".into(), series: fitness },
        format!(
            "Fitness of the hardware GA's candidates per generation (solid: best, dashed: mean; \
             {what}). Each generation drives new scenes (its candidates the same ones), so the \
             curves rise and fall with the scenes' difficulty as much as with the search's \
             progress: read the spread within a generation, not a trend across them. A \
             fixed-camera method drives its one camera as many times per generation as \
             the GA has candidates, so every method trains on as many frames."
        ),
    )
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
                    series: series(|f| f.settings.exposure_ms),
                },
                plot::Panel { y_label: "gain (dB)".into(), series: series(|f| f.settings.gain_db) },
                // On the ambient panel's log scale: a controller that keeps the image level
                // moves this by as much as the ambient light moves, the other way.
                plot::Panel {
                    y_label: "exposure × gain, log10 (ms)".into(),
                    series: series(|f| f.settings.exposure_gain_ms().log10()),
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
    line_figure(
        dir,
        file,
        what,
        (&format!("Detector task loss during joint training — {what}"), "training step"),
        plot::Panel { y_label: "task loss (moving average of 20 logs)".into(), series: losses },
        format!(
            "The detector's task loss (focal heat-map + size + offset) during joint training, \
             logged every fifth step, moving average over 20 logs; {what}."
        ),
    )
}

/// One 900×480 panel of `panel`'s series as `file` (None, and nothing drawn, without series).
fn line_figure(
    dir: &Path,
    file: &str,
    what: &str,
    (title, x_label): (&str, &str),
    panel: plot::Panel,
    caption: String,
) -> Result<Option<Figure>, ReportError> {
    if panel.series.is_empty() {
        return Ok(None);
    }
    plot::stacked_chart(&dir.join(file), title, x_label, &[panel], (900, 480))?;
    Ok(Some(Figure { section: what.to_owned(), file: file.to_owned(), caption }))
}
