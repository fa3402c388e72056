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
    // A variance estimated below zero (noise under what these frames resolve) is written as 0,
    // so that the table is one `--calibration` accepts; the raw estimate is in the table above.
    let mut notes = Vec::new();
    let mut clamp = |name: &str, channel: &str, v: f64| {
        if v < 0.0 {
            notes.push(format!(
                "# {name} of the {channel} channel was estimated at {v:.4}; written as 0"
            ));
        }
        v.max(0.0)
    };
    let channels = ["red", "green", "blue"];
    let p2: Vec<f64> =
        fits.iter().zip(channels).map(|(f, c)| clamp("σp²", c, f.sigma_p2)).collect();
    let r2: Vec<f64> =
        fits.iter().zip(channels).map(|(f, c)| clamp("σr²", c, f.sigma_r2)).collect();
    let c = Calibration::DEFAULT;
    println!("\n# TOML for --calibration (brightness reference as in docs/design.md):");
    for note in &notes {
        println!("{note}");
    }
    println!("[calibration]");
    println!("pixel_pitch_um = {}", c.pixel_pitch_um);
    println!("exposure_s = {}", c.exposure_s);
    println!("gain_db = {}", args.calibration_gain_db);
    println!("sigma_p2 = [{:.4}, {:.4}, {:.4}]", p2[0], p2[1], p2[2]);
    println!("sigma_r2 = [{:.4}, {:.4}, {:.4}]", r2[0], r2[1], r2[2]);
    Ok(())
}
