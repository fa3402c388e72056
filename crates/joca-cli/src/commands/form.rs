//! `joca form`: preview what a camera setting does to a scene.

use crate::io;
use anyhow::{Context, Result};
use joca_camera::{AccRanges, Calibration, DynamicSettings, ImageFormation, sensor_by_name};
use joca_core::SeedStreams;
use joca_core::units::s_from_ms;
use std::path::PathBuf;

/// Arguments of `joca form`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Linear input image taken as I0, what the calibration camera records at E0, G0 (8-bit PNG:
    /// values in DN; 16-bit PNG: value/257 DN). It keeps its resolution.
    #[arg(long)]
    input: PathBuf,
    /// Exposure time, milliseconds (0.1 to 50).
    #[arg(long, value_name = "E")]
    exposure_ms: f64,
    /// Analogue gain, dB of amplitude (1 to 30).
    #[arg(long, value_name = "G")]
    gain_db: f64,
    /// Catalogue sensor whose pixel pitch scales the collected light by (p/p0)² (`joca sensors`).
    #[arg(long, value_name = "NAME")]
    sensor: String,
    /// Multiply the calibrated noise variances σp², σr² by N, 0 to 1000 (the "noise ×N"
    /// scenarios).
    #[arg(long, value_name = "N", default_value_t = 1.0)]
    noise_scale: f64,
    /// Seed of the noise realisation.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// TOML file with a `[calibration]` table (as printed by `joca calibrate-noise`);
    /// defaults to the reference calibration of docs/design.md.
    #[arg(long, value_name = "FILE")]
    calibration: Option<PathBuf>,
    /// Output 8-bit PNG.
    #[arg(long)]
    out: PathBuf,
}

/// Runs `joca form`.
pub fn run(args: &Args) -> Result<()> {
    let ranges = AccRanges::PAPER;
    let exposure_s = s_from_ms(args.exposure_ms);
    ranges.exposure_s.check("--exposure-ms", exposure_s, " s")?;
    ranges.gain_db.check("--gain-db", args.gain_db, " dB")?;
    let sensor = sensor_by_name(&args.sensor).context("invalid --sensor")?;
    let calibration = match &args.calibration {
        Some(path) => io::read_calibration(path)?,
        None => Calibration::DEFAULT,
    };
    let formation = ImageFormation::new(calibration)?
        .with_noise_scale(args.noise_scale)
        .context("invalid --noise-scale")?;
    let i0 = io::read_linear(&args.input)?;
    let settings = DynamicSettings::new(exposure_s, args.gain_db);
    let mut rng = SeedStreams::new(args.seed).stream("form");
    let frame = formation.form_parallel(&i0, settings, sensor.pixel_pitch_um, &mut rng);
    io::write_png(&args.out, &frame)?;

    let params = formation.params(settings, sensor.pixel_pitch_um);
    let saturated = frame.data().iter().filter(|&&v| v == 255).count() as f64;
    let black = frame.data().iter().filter(|&&v| v == 0).count() as f64;
    let n = frame.data().len().max(1) as f64;
    println!(
        "{}: {}x{} px, I = I0 x {:.4} ({} at {:.2} ms, {:.1} dB, {} um pitch)",
        args.out.display(),
        frame.width(),
        frame.height(),
        params.intensity_scale,
        sensor.name,
        args.exposure_ms,
        args.gain_db,
        sensor.pixel_pitch_um
    );
    println!(
        "mean {:.1} DN (input {:.1} DN), {:.2} % saturated, {:.2} % black",
        frame.mean(),
        i0.mean(),
        100.0 * saturated / n,
        100.0 * black / n
    );
    Ok(())
}
