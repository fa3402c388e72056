//! The sections of a run's report that `joca run` and `joca eval` also print: where the numbers
//! were computed, the settings by light, the tunnel exit, the test's objects by class and distance,
//! the fitness by generation and the perturbation searches' ties.

use crate::data::RunData;
use joca_core::compute::{CpuKernels, Denormals};
use joca_record::{Light, RunResults, Showcase};
use std::fmt::Write as _;

/// Where the numbers were computed: training repeats bit for bit on the same machine type and
/// libtorch kernels, not across types (empty for runs that did not record it).
pub(crate) fn machine_line(r: &RunResults) -> String {
    if r.cpu.is_empty() {
        return String::new();
    }
    let gpu = r.device.as_ref().map_or(String::new(), |d| format!(", the networks on {d}"));
    format!(
        "Computed on {} with libtorch's {} kernels{}{gpu} (numbers repeat on this machine type).",
        r.cpu,
        r.cpu_kernels.unwrap_or(CpuKernels::Native),
        if r.denormals == Some(Denormals::Flush) {
            ", subnormal floats flushed to zero"
        } else {
            ""
        }
    )
}

/// The closed-loop test's settings by illumination: mean exposure, gain, and exposure × linear
/// gain, the last also relative to night (a controller that reacts to light amplifies day far
/// less than night).
pub fn settings_markdown(r: &RunResults) -> String {
    let mut md = String::from(
        "## Exposure and gain during the closed-loop test\n\n| illumination | mean E (ms) | mean \
            G (dB) | mean E × gain (ms) | relative to night | mean frame (DN) | clipped pixels \
            |\n|---|---|---|---|---|---|---|\n",
    );
    let by = &r.by_illumination;
    let night = by.light(Light::Night).and_then(|l| l.exposure_gain_ms);
    for (light, s) in by.settings() {
        let (e, g) = (s.exposure_ms, s.gain_db);
        let record = by.light(light);
        let eg = record.and_then(|l| l.exposure_gain_ms);
        let cell = eg.map_or_else(|| "-".to_owned(), |v| format!("{v:.1}"));
        let relative = match (eg, night) {
            (Some(v), Some(n)) if n > 0.0 => format!("{:.3}", v / n),
            _ => "-".to_owned(),
        };
        let mean =
            record.and_then(|l| l.mean_dn).map_or_else(|| "-".to_owned(), |v| format!("{v:.0}"));
        let clipped = record
            .and_then(|l| l.clipped_share)
            .map_or_else(|| "-".to_owned(), |v| format!("{:.1} %", 100.0 * v));
        let _ = writeln!(
            md,
            "| {light} | {e:.2} | {g:.1} | {cell} | {relative} | {mean} | {clipped} |"
        );
    }
    md.push('\n');
    let stops: Vec<String> = by.f_numbers().map(|(l, n)| format!("{l} f/{n:.1}")).collect();
    if !stops.is_empty() {
        let _ = writeln!(
            md,
            "NeuralAE also set the iris (geometric-mean f-number: {}); exposure × gain above \
                leaves out the iris's light, (16/N)² of the calibration aperture's.\n",
            stops.join(", ")
        );
    }
    md
}

/// Light held this long counts as steady in [`steady_steps`], seconds.
pub const SETTLE_S: f64 = 0.5;

/// Every showcase's frame-to-frame moves of exposure × gain in steady light, stops
/// ([`Showcase::steady_steps_stops`] after [`SETTLE_S`]).
pub fn steady_steps(showcases: &[Showcase]) -> Vec<f64> {
    showcases.iter().flat_map(|s| s.steady_steps_stops(SETTLE_S)).collect()
}

/// The mean of [`steady_steps`], stops a frame (`None` without steady frames).
pub fn steady_mean(showcases: &[Showcase]) -> Option<f64> {
    mean_of(&steady_steps(showcases))
}

fn mean_of(steps: &[f64]) -> Option<f64> {
    (!steps.is_empty()).then(|| steps.iter().sum::<f64>() / steps.len() as f64)
}

/// The controller's answer to the tunnel exit (the largest step of ambient light in the
/// showcases, if one is ≥ 10×): how far exposure × gain fell within 1 s. A controller that keeps
/// the image level takes back about as much as the light rose, or until its range ends. Then how
/// much it moved from frame to frame where the light held still (a zig-zag shows here).
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
    let steady = steady_steps(showcases);
    if let Some(mean) = mean_of(&steady) {
        let _ = writeln!(
            md,
            "Where the light held still (from {SETTLE_S} s after it last changed; {} frame pairs \
                of the showcases), exposure × gain moved {mean:.2} stops a frame on average \
                (at most {:.2}).\n",
            steady.len(),
            steady.iter().copied().fold(0.0, f64::max)
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

pub(crate) fn fitness_markdown(run: &RunData) -> String {
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
    md.push_str(
        "\nEach generation drives its own scenes (all its candidates the same ones), so the \
         numbers move with the scenes' difficulty from one generation to the next as much as \
         with the search's progress: compare candidates within a generation, not generations.\n\n",
    );
    md
}

/// How training's perturbation searches were decided.
pub(crate) fn ties_markdown(r: &RunResults) -> String {
    match r.perturbation_ties {
        Some(t) if t.searches > 0 => format!(
            "Perturbation searches in training: {}; in {} ({:.0} %) two or more members tied for \
             the best score, so the tie-break or the GA's order chose l_GA's target.\n\n",
            t.searches,
            t.tied,
            100.0 * t.share()
        ),
        _ => String::new(),
    }
}
