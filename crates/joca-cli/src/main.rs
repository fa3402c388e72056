//! `joca` — task-driven joint design of camera hardware, auto-exposure and object detector.
//!
//! Each subcommand lives in its own module under `commands/`; this file only declares the
//! command line and dispatches. Errors are reported with their whole cause chain.
#![allow(clippy::print_stdout)]

mod commands;
mod config;
mod draw;
mod grid;
mod io;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// joca answers "which sensor, lens and mount, with which auto-exposure policy, make my detector
/// work best?" by jointly optimising camera hardware (genetic algorithm), a neural exposure/gain
/// controller (DF-Grad) and an object detector through a physically grounded image formation
/// model: exposure, gain, pixel size, shot and read noise, motion blur, clipping.
#[derive(Debug, Parser)]
#[command(name = "joca", version, about, max_term_width = 100)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Jointly optimise camera hardware, NeuralAE and detector, then test the best design.
    Run(commands::run::Args),
    /// Test a run's best design again (trained detector and NeuralAE) on the test town.
    Eval(commands::eval::Args),
    /// The room any exposure controller has: a settings ladder, AverageAE targets and the
    /// per-frame oracle scored on one design and detector (or tabulate several, paired).
    Headroom(commands::headroom::Args),
    /// List the 43-sensor catalogue (pitch, grid, size; field of view for a focal length).
    Sensors(commands::sensors::Args),
    /// Apply image formation (exposure, gain, pixel size, noise, clipping) to a linear image.
    Form(commands::form::Args),
    /// Estimate the noise parameters σp², σr² from frames of a static scene (photon transfer).
    CalibrateNoise(commands::calibrate::Args),
    /// Run detector weights on frames and write COCO detections (score them with `metrics`).
    Detect(commands::detect::Args),
    /// Score COCO-format detections against ground truth (the 12 numbers pycocotools prints).
    Metrics(commands::metrics::Args),
    /// Render frames from the built-in driving simulator, with ground truth and a contact sheet.
    Render(commands::render::Args),
    /// Pre-train the detector on simulator frames from random camera designs (AverageAE).
    TrainDetector(commands::train_detector::Args),
    /// Score detector weights on the test town as pre-training does (reference camera, AverageAE).
    EvalDetector(commands::train_detector::EvalArgs),
    /// Measure the speed of joca's components and print a table.
    Bench(commands::bench::Args),
    /// Run a grid of runs (the paper's tables) locally or on Slurm, and report it.
    Experiment(commands::experiment::Args),
    /// Regenerate report.md, report.html and figures of a run or experiment directory.
    Report(commands::report::Args),
    /// Copy a run's or experiment's compact records (no checkpoints, frames or figures) to a
    /// folder that `joca report` and `joca experiment --reuse` read.
    Export(commands::export::Args),
    /// Dense Inverse Search optical flow between two frames: colour-coded flow and warp check.
    Flow(commands::flow::FlowArgs),
    /// Preview the real-image mode's flow-based motion blur on a folder of consecutive frames.
    Blur(commands::flow::BlurArgs),
    /// Turn KITTI tracking or labelme labels and their frames into the folder format.
    Import(commands::import::Args),
    /// Run or resume one experiment cell (used by `joca experiment` and its Slurm tasks).
    #[command(hide = true)]
    Cell(commands::experiment::CellArgs),
}

/// Keeps glibc from handing freed memory back to the kernel after every tensor: libtorch frees
/// and reallocates megabytes per training step, and with glibc's defaults each step then trims
/// the heap top and faults the pages in again (187 million minor page faults and 11 % of the
/// time in the kernel over a 29-minute pre-training). Measured with `joca bench detector --deep`
/// in one run: training step at 320×240 48.9 → 38.5 ms, inference 12.8 → 9.6 ms.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
#[allow(unsafe_code)]
fn keep_freed_memory() {
    // SAFETY: mallopt only sets allocator parameters; called first thing in main, before any
    // other thread exists. A rejected value (return 0) leaves glibc's default in place.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 1 << 30);
        libc::mallopt(libc::M_TOP_PAD, 64 << 20);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn keep_freed_memory() {}

/// Ends the process quietly, as other command-line tools do, when the reader of its output goes
/// away (`joca flow … | head -1`): Rust ignores SIGPIPE, and `println!` then panics with a stack
/// trace on the closed pipe.
#[cfg(unix)]
#[allow(unsafe_code)]
fn quiet_on_closed_pipe() {
    // SAFETY: restores the default action of one signal, first thing in main, before any other
    // thread exists.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

#[cfg(not(unix))]
fn quiet_on_closed_pipe() {}

fn main() -> ExitCode {
    keep_freed_memory();
    quiet_on_closed_pipe();
    // SAFETY: first thing in main, before any other thread exists and before libtorch runs.
    #[allow(unsafe_code)]
    if let Err(err) = unsafe { joca_nn::kernels::select_from_env() } {
        eprintln!("error: {err}");
        return ExitCode::FAILURE;
    }
    // SAFETY: as above (no other thread yet).
    #[allow(unsafe_code)]
    unsafe {
        joca_nn::device::prepare_process();
    }
    let cli = Cli::parse();
    // Every command runs on a worker of rayon's pool, not on the main thread: a parallel loop
    // started from outside the pool hands its work to a sleeping worker and waits to be woken,
    // which on these small images (the renderer's passes, DIS's sweeps) cost as much as the
    // work; started from a worker, the caller works on it at once.
    let pool = rayon::ThreadPoolBuilder::new()
        .stack_size(MAIN_STACK_BYTES)
        .thread_name(|i| format!("joca-{i}"))
        .build();
    let result = match pool {
        Ok(pool) => pool.install(|| dispatch(cli)),
        Err(err) => Err(anyhow::anyhow!("cannot start the worker threads: {err}")),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err}");
            for cause in err.chain().skip(1) {
                eprintln!("  caused by: {cause}");
            }
            ExitCode::FAILURE
        }
    }
}

/// The stack of the worker threads, as large as a main thread's on Linux.
const MAIN_STACK_BYTES: usize = 8 << 20;

/// Runs the command `cli` names.
fn dispatch(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Run(args) => commands::run::run(&args),
        Command::Eval(args) => commands::eval::run(&args),
        Command::Headroom(args) => commands::headroom::run(&args),
        Command::Sensors(args) => commands::sensors::run(&args),
        Command::Form(args) => commands::form::run(&args),
        Command::CalibrateNoise(args) => commands::calibrate::run(&args),
        Command::Metrics(args) => commands::metrics::run(&args),
        Command::Detect(args) => commands::detect::run(&args),
        Command::Render(args) => commands::render::run(&args),
        Command::TrainDetector(args) => commands::train_detector::run(&args),
        Command::EvalDetector(args) => commands::train_detector::run_eval(&args),
        Command::Bench(args) => commands::bench::run(&args),
        Command::Experiment(args) => commands::experiment::run(&args),
        Command::Report(args) => commands::report::run(&args),
        Command::Export(args) => commands::export::run(&args),
        Command::Cell(args) => commands::experiment::run_cell(&args),
        Command::Flow(args) => commands::flow::run_flow(&args),
        Command::Blur(args) => commands::flow::run_blur(&args),
        Command::Import(args) => commands::import::run(&args),
    }
}
