//! `joca sensors`: the sensor catalogue as a table, CSV or JSON.

use super::parse_resolution;
use anyhow::{Context, Result};
use clap::ValueEnum;
use joca_camera::{DesignSpace, Sensor, catalogue};
use serde::Serialize;

/// Output format.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum Format {
    /// Aligned columns for reading.
    Table,
    /// Comma-separated values with a header row.
    Csv,
    /// A JSON array of objects.
    Json,
}

/// Arguments of `joca sensors`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Table)]
    format: Format,
    /// Keep only sensors whose pixel grid fits inside WIDTHxHEIGHT (e.g. a dataset's 1920x1280).
    #[arg(long, value_name = "WxH")]
    fits: Option<String>,
    /// Also show the horizontal and vertical field of view behind a lens of this focal length (mm,
    /// 1 to 10 as in the design space).
    #[arg(long, value_name = "F")]
    focal_mm: Option<f64>,
}

#[derive(Debug, Serialize)]
struct Row<'a> {
    #[serde(flatten)]
    sensor: &'a Sensor,
    #[serde(skip_serializing_if = "Option::is_none")]
    hfov_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    vfov_deg: Option<f64>,
}

/// Runs `joca sensors`.
pub fn run(args: &Args) -> Result<()> {
    let space = DesignSpace::synthetic();
    let focal =
        args.focal_mm.map(|f| space.focal_length_mm.check("--focal-mm", f, " mm")).transpose()?;
    let space = match &args.fits {
        Some(text) => {
            let (w, h) = parse_resolution(text).context("invalid --fits")?;
            space.restricted_to_recording(w, h)?
        }
        None => space,
    };
    let rows: Vec<Row<'_>> = space
        .sensors
        .iter()
        .map(|&i| {
            let sensor = &catalogue::catalogue()[i];
            Row {
                sensor,
                hfov_deg: focal.map(|f| sensor.hfov_rad(f).to_degrees()),
                vfov_deg: focal.map(|f| sensor.vfov_rad(f).to_degrees()),
            }
        })
        .collect();
    match args.format {
        Format::Json => println!("{}", serde_json::to_string_pretty(&rows)?),
        Format::Csv => print_csv(&rows),
        Format::Table => print_table(&rows, focal),
    }
    Ok(())
}

fn print_csv(rows: &[Row<'_>]) {
    let fov = rows.first().is_some_and(|r| r.hfov_deg.is_some());
    let mut header =
        "index,manufacturer,sensor,pixel_pitch_um,res_x,res_y,width_mm,height_mm,shutter"
            .to_owned();
    if fov {
        header.push_str(",hfov_deg,vfov_deg");
    }
    println!("{header}");
    for r in rows {
        let s = r.sensor;
        let mut line = format!(
            "{},{},{},{},{},{},{},{},{}",
            s.index,
            s.manufacturer,
            s.name,
            s.pixel_pitch_um,
            s.res_x,
            s.res_y,
            s.width_mm,
            s.height_mm,
            shutter_name(s)
        );
        if let (Some(h), Some(v)) = (r.hfov_deg, r.vfov_deg) {
            line.push_str(&format!(",{h:.2},{v:.2}"));
        }
        println!("{line}");
    }
}

fn print_table(rows: &[Row<'_>], focal: Option<f64>) {
    let mut header = format!(
        "{:>3}  {:<11} {:<11} {:>8} {:>11} {:>15} {:<8}",
        "#", "maker", "sensor", "pitch µm", "grid px", "size mm", "shutter"
    );
    if let Some(f) = focal {
        header.push_str(&format!("  {:>8} {:>8}", format!("HFoV@{f}"), "VFoV"));
    }
    println!("{header}");
    for r in rows {
        let s = r.sensor;
        let mut line = format!(
            "{:>3}  {:<11} {:<11} {:>8.2} {:>11} {:>15} {:<8}",
            s.index,
            s.manufacturer,
            s.name,
            s.pixel_pitch_um,
            format!("{}x{}", s.res_x, s.res_y),
            format!("{:.2}x{:.2}", s.width_mm, s.height_mm),
            shutter_name(s)
        );
        if let (Some(h), Some(v)) = (r.hfov_deg, r.vfov_deg) {
            line.push_str(&format!("  {h:>7.1}° {v:>7.1}°"));
        }
        println!("{line}");
    }
    println!("{} sensors", rows.len());
}

fn shutter_name(s: &Sensor) -> &'static str {
    match s.shutter {
        joca_camera::Shutter::Global => "global",
        joca_camera::Shutter::Rolling => "rolling",
    }
}
