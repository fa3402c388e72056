//! `joca eval`: test a run's best design again from its checkpoint.

use anyhow::{Context, Result, anyhow};
use clap::ValueEnum;
use joca_train::{EvalOptions, Scenario, TestController, evaluate_run};
use std::path::PathBuf;

/// Which detector the test uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Detector {
    /// The run's own trained detector.
    Trained,
    /// The weights the run's detector started from.
    Start,
}

/// Arguments of `joca eval`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// A run directory written by `joca run`.
    run_dir: PathBuf,
    /// Scored frames per test episode [default: the run's].
    #[arg(long)]
    frames: Option<usize>,
    /// Test under another scenario: calibrated, noise10, noise20, blur2, blur4.
    #[arg(long)]
    scenario: Option<String>,
    /// Test episodes, stratified by light (day, night, tunnel, cycle in turn) [default: the run's].
    #[arg(long)]
    episodes: Option<u64>,
    /// Drive another town of the test family: 0 is the run's test town; 2 to 9999 are fresh
    /// towns of the same kind that no run trains, validates or tests on, to check a result on
    /// other scenes; results go to `results-town<K>.json` and `test-town<K>/`.
    #[arg(long, default_value_t = 0)]
    town: u64,
    /// Drive the trained design with another controller: `trained` (the run's own), `average`
    /// (AverageAE at mid-grey) or `average:DN` (AverageAE holding the frame mean at DN). The
    /// design is still the one the run's own controller chose; results go to
    /// `results-<controller>.json` and `test-<controller>/`.
    #[arg(long, default_value = "trained")]
    controller: String,
    /// Test with another detector: `trained` (the run's own) or `start` (the weights the run's
    /// detector started from, its config's `detector_weights`, as that file is now), on the
    /// design chosen with the trained one (NeuralAE keeps its trained weights but reads that
    /// detector's features); results go to `results-detector-start.json` and
    /// `test-detector-start/`.
    #[arg(long, value_enum, default_value_t = Detector::Trained)]
    detector: Detector,
    /// What the networks compute on: cpu, cuda (the first GPU), cuda:N or auto (a GPU if one is
    /// usable, else the CPU) [default: the run's `device`, cpu].
    #[arg(long, value_parser = crate::config::device)]
    device: Option<joca_nn::device::DeviceChoice>,
}

/// Runs `joca eval`.
pub fn run(args: &Args) -> Result<()> {
    let scenario =
        args.scenario.as_deref().map(Scenario::from_name).transpose().map_err(|e| anyhow!(e))?;
    let controller =
        TestController::from_name(&args.controller).map_err(|e| anyhow!("--controller: {e}"))?;
    let options = EvalOptions {
        scenario,
        frames_per_episode: args.frames,
        episodes: args.episodes,
        town: args.town,
        controller,
        start_detector: args.detector == Detector::Start,
        device: args.device,
    };
    let (r, test_dir) = evaluate_run(&args.run_dir, &options)
        .with_context(|| format!("cannot evaluate {}", args.run_dir.display()))?;
    let mut with = r.test_controller.map_or(String::new(), |c| format!(" with {}", c.name()));
    if let Some(weights) = &r.test_detector {
        with.push_str(&format!(" with the detector of {weights}"));
    }
    println!(
        "{} / {}{with}: {} behind {:.2} mm at x {:.2} m, z {:.2} m -> mAP {:.3}, AP50 {:.3}, TP ratio \
            {:.3} over {} frames",
        r.method.name(),
        r.scenario.name(),
        r.design.sensor,
        r.design.focal_length_mm,
        r.design.x_m,
        r.design.z_m,
        r.test.map,
        r.test.ap50,
        r.test.tp_ratio,
        r.test.frames
    );
    println!();
    print!("{}", joca_report::settings_markdown(&r));
    print!("{}", joca_report::objects_markdown(&r));
    let show_path = test_dir.join("showcase.json");
    let text = std::fs::read_to_string(&show_path)
        .with_context(|| format!("cannot read {}", show_path.display()))?;
    let showcases: Vec<joca_train::Showcase> = serde_json::from_str(&text)
        .with_context(|| format!("cannot parse {}", show_path.display()))?;
    println!();
    print!("{}", joca_report::light_step_markdown(&showcases));
    Ok(())
}
