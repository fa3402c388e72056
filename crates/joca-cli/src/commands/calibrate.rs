//! `joca calibrate-noise`: photon-transfer estimate of σp², σr² from a frame stack.

use crate::io;
use anyhow::{Context, Result, bail};
use joca_camera::{Calibration, calibrate_noise};
use std::path::PathBuf;

/// Arguments of `joca calibrate-noise`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Directory of ≥ 2 raw 8-bit PNG frames of the same static scene (fixed exposure and gain),
    /// ideally with a range of grey levels (a test chart or a gradient).
    #[arg(long, value_name = "DIR")]
    frames: PathBuf,
    /// Gain the frames were taken at, dB.
    #[arg(long, value_name = "G", default_value_t = Calibration::DEFAULT.gain_db)]
    gain_db: f64,
    /// Gain G0 the parameters are referred to, dB (joca's calibration gain).
    #[arg(long, value_name = "G0", default_value_t = Calibration::DEFAULT.gain_db)]
    calibration_gain_db: f64,
}

/// Runs `joca calibrate-noise`.
pub fn run(args: &Args) -> Result<()> {
    let files = io::png_files(&args.frames)?;
    if files.len() < 2 {
        bail!(
            "{} holds {} PNG frame(s); photon transfer needs at least 2 frames of the same static \
                scene",
            args.frames.display(),
            files.len()
        );
    }
    let frames = files.iter().map(|p| io::read_rgb8(p)).collect::<Result<Vec<_>>>()?;
    let fits = calibrate_noise(&frames, args.gain_db, args.calibration_gain_db)
        .with_context(|| format!("cannot calibrate from {}", args.frames.display()))?;

    println!(
        "photon transfer over {} frames of {}x{} px at {} dB (referred to G0 = {} dB):",
        frames.len(),
        frames[0].width(),
        frames[0].height(),
        args.gain_db,
        args.calibration_gain_db
    );
    println!(
        "{:<8} {:>10} {:>12} {:>10} {:>10} {:>9}",
        "channel", "slope", "intercept", "σp²", "σr²", "pixels"
    );
    for (name, f) in ["red", "green", "blue"].iter().zip(&fits) {
        println!(
            "{:<8} {:>10.4} {:>12.4} {:>10.4} {:>10.4} {:>9}",
            name, f.slope, f.intercept, f.sigma_p2, f.sigma_r2, f.samples
        );
    }
    let c = Calibration::DEFAULT;
    println!("\n# TOML for --calibration (brightness reference as in DESIGN.md):");
    println!("[calibration]");
    println!("pixel_pitch_um = {}", c.pixel_pitch_um);
    println!("exposure_s = {}", c.exposure_s);
    println!("gain_db = {}", args.calibration_gain_db);
    println!(
        "sigma_p2 = [{:.4}, {:.4}, {:.4}]",
        fits[0].sigma_p2, fits[1].sigma_p2, fits[2].sigma_p2
    );
    println!(
        "sigma_r2 = [{:.4}, {:.4}, {:.4}]",
        fits[0].sigma_r2, fits[1].sigma_r2, fits[2].sigma_r2
    );
    Ok(())
}
