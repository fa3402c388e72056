//! `joca render`: frames from the built-in simulator through image formation, with COCO ground
//! truth, a contact sheet and an animation.

use crate::{draw, io};
use anyhow::{Context, Result, bail};
use joca_camera::{
    AccRanges, AverageAe, Calibration, CameraDesign, DesignSpace, DetectorInput, DynamicSettings,
    ImageFormation, sensor_by_name,
};
use joca_core::optics::{CALIBRATION_F_NUMBER, Lens};
use joca_core::units::{ms_from_s, s_from_ms};
use joca_core::{FrameRequest, FrameSource, PinholeCamera, SeedStreams};
use joca_sim::{Glare, Simulator, Weather};
use serde_json::json;
use std::path::PathBuf;

mod choices;
mod outputs;
mod range;
mod world;
pub use choices::{Light, ResamplerArg};
use outputs::{coco_image, write_outputs};
use world::sim_config;

/// Arguments of `joca render`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Seed of the city map.
    #[arg(long, default_value_t = 0)]
    map_seed: u64,
    /// Episode of that map (start pose, route, speed profile, sun).
    #[arg(long, default_value_t = 0)]
    episode: u64,
    /// Illumination schedule [default: drawn per episode].
    #[arg(long, value_enum)]
    illumination: Option<Light>,
    /// Catalogue sensor (`joca sensors`).
    #[arg(long, default_value = "IMX172")]
    sensor: String,
    /// Lens focal length, mm (1 to 10).
    #[arg(long, default_value_t = 3.6)]
    focal_mm: f64,
    /// Camera position forward of the vehicle centre, m (0 to 2.4).
    #[arg(long, default_value_t = 0.43)]
    x: f64,
    /// Camera height above the ground, m (1.3 to 1.7).
    #[arg(long, default_value_t = 1.65)]
    z: f64,
    /// Detector input short side, px: the frame is the sensor's grid resized to it (aspect
    /// kept, long side at most --long-max-px).
    #[arg(long, default_value_t = 240)]
    short_px: usize,
    /// Detector input long side at most this, px.
    #[arg(long, default_value_t = 400)]
    long_max_px: usize,
    /// How the sensor's grid is resized to the input: bilinear (the paper's detector
    /// transform) or area (binning); sets how much of the native pixels' noise remains.
    #[arg(long, value_enum, default_value_t = ResamplerArg::Bilinear)]
    resampler: ResamplerArg,
    /// Lens f-number, 1 to 32: defocus and diffraction by depth, and (16/N)² the light of the
    /// calibration's f/16. Without it: an ideal pinhole at f/16's light (the paper's model).
    #[arg(long)]
    f_number: Option<f64>,
    /// Focus distance, m (beyond the focal length), with --f-number [default: the hyperfocal
    /// distance for a one-pixel circle of confusion].
    #[arg(long, requires = "f_number")]
    focus_m: Option<f64>,
    /// Fog of this visibility, m (10 to 100000; Koschmieder's law) [default: clear air].
    #[arg(long)]
    fog_visibility_m: Option<f64>,
    /// Rain of this rate, mm/h (0.1 to 200; Marshall–Palmer drops: extinction and streaks)
    /// [default: none].
    #[arg(long, conflicts_with = "fog_visibility_m")]
    rain_mm_h: Option<f64>,
    /// Fixed exposure time, ms (0.1 to 50); without it AverageAE controls exposure and gain.
    #[arg(long, requires = "gain_db")]
    exposure_ms: Option<f64>,
    /// Fixed gain, dB (1 to 30), with --exposure-ms.
    #[arg(long, requires = "exposure_ms")]
    gain_db: Option<f64>,
    /// Use AverageAE (the default when no fixed exposure is given).
    #[arg(long, conflicts_with = "exposure_ms")]
    auto_exposure: bool,
    /// Number of frames.
    #[arg(long, default_value_t = 16)]
    frames: usize,
    /// Time of the first frame in the episode, s.
    #[arg(long, default_value_t = 1.0)]
    start_s: f64,
    /// Ego top speed, m/s.
    #[arg(long, default_value_t = 15.0)]
    max_speed_mps: f64,
    /// Motion during the shutter × this factor, 0 to 100 (the "motion blur ×N" scenarios).
    #[arg(long, default_value_t = 1.0)]
    blur_scale: f64,
    /// Noise variances × this factor, 0 to 1000 (the "noise ×N" scenarios).
    #[arg(long, default_value_t = 1.0)]
    noise_scale: f64,
    /// Let the sun cast shadows (buildings, vehicles, walkers, posts on the ground, facades and
    /// each other).
    #[arg(long)]
    shadows: bool,
    /// The sun's elevation, degrees above the horizon (2 to 90) [default: drawn per episode
    /// from 45 to 55].
    #[arg(long)]
    sun_elevation_deg: Option<f32>,
    /// How the sun's and the sky's light follow its elevation: `constant` (the same levels at
    /// any elevation) or `clear-sky` (a cloudless sky's: both fall as the sun sinks).
    #[arg(long, default_value = "constant", value_parser = joca_core::sun::Daylight::from_name)]
    daylight: joca_core::sun::Daylight,
    /// The sun in the sky by day: the sky brighter towards it, its disc where the camera sees it
    /// (with a low `--sun-elevation-deg`).
    #[arg(long)]
    sun: bool,
    /// Streets whose lamps stay dark at night: only the cars' lights, the lit windows and the
    /// night sky light the street (the same town).
    #[arg(long)]
    dark_streets: bool,
    /// The lens's veiling glare: the share of the light spread over the sensor, 0 to below 1
    /// [default: 0, none].
    #[arg(long, default_value_t = 0.0)]
    glare: f32,
    /// The glare spread's angular scale θ0, degrees (0.1 to 20).
    #[arg(long, default_value_t = Glare::DEFAULT_SCALE_DEG)]
    glare_scale_deg: f32,
    /// The `tunnel` light: `switch` (the whole frame's light switches) or `places` (covered
    /// road blocks in the town, a tunnel episode driving through one in daylight).
    #[arg(long, default_value = "switch", value_parser = joca_sim::TunnelKind::from_name)]
    tunnels: joca_sim::TunnelKind,
    /// Covered road blocks in the town (1 to 16; with `--tunnels places`).
    #[arg(long, default_value_t = joca_sim::Tunnels::DEFAULT_COUNT)]
    tunnel_count: u32,
    /// The tunnel lamps' level on the road, relative to daylight (above 0 to 0.1).
    #[arg(long, default_value_t = joca_sim::Tunnels::DEFAULT_LAMP_LEVEL)]
    tunnel_lamp_level: f32,
    /// Which way a `tunnel` drive passes its tunnel: `both` (entering or leaving at random),
    /// `entering` or `leaving` (with `--tunnels places`).
    #[arg(long, default_value = "both", value_parser = joca_sim::TunnelDrives::from_name)]
    tunnel_drives: joca_sim::TunnelDrives,
    /// Seed of the noise.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
}

/// The checked flags: the sensor, the detector input and the fixed settings (None: AverageAE).
fn checked(
    args: &Args,
) -> Result<(&'static joca_camera::Sensor, DetectorInput, Option<DynamicSettings>)> {
    let space = DesignSpace::synthetic();
    let sensor = sensor_by_name(&args.sensor).context("invalid --sensor")?;
    space.x_m.check("--x", args.x, " m")?;
    space.z_m.check("--z", args.z, " m")?;
    space.focal_length_mm.check("--focal-mm", args.focal_mm, " mm")?;
    let input = DetectorInput {
        short_px: args.short_px,
        long_max_px: args.long_max_px,
        resampler: args.resampler.into(),
    };
    input.validate("--input").map_err(|e| {
        anyhow::anyhow!("{}", e.to_string().replace("--input.", "--").replace('_', "-"))
    })?;
    if !(0.0..=joca_train::MAX_SPEED_MPS).contains(&args.max_speed_mps) {
        bail!(
            "--max-speed-mps = {:?} is out of range: allowed 0 to {}",
            args.max_speed_mps,
            joca_train::MAX_SPEED_MPS
        );
    }
    if !(0.0..=crate::config::MAX_BLUR_SCALE).contains(&args.blur_scale) {
        bail!(
            "--blur-scale = {:?} is out of range: allowed 0 to {}",
            args.blur_scale,
            crate::config::MAX_BLUR_SCALE
        );
    }
    if args.frames == 0 {
        bail!("--frames must be at least 1");
    }
    let ranges = AccRanges::PAPER;
    let fixed = match (args.exposure_ms, args.gain_db) {
        (Some(e), Some(g)) => {
            ranges.exposure_s.check("--exposure-ms", s_from_ms(e), " s")?;
            ranges.gain_db.check("--gain-db", g, " dB")?;
            Some(DynamicSettings::new(s_from_ms(e), g))
        }
        _ => None,
    };
    Ok((sensor, input, fixed))
}

/// The lens (`None`: the ideal pinhole) and the weather the flags ask for, checked.
fn optics(args: &Args, sensor: &joca_camera::Sensor) -> Result<(Option<Lens>, Weather)> {
    let lens = match args.f_number {
        Some(n) => {
            let hyperfocal = Lens::at_hyperfocal(args.focal_mm, n, sensor.pixel_pitch_um);
            let lens = Lens { focus_m: args.focus_m.unwrap_or(hyperfocal.focus_m), ..hyperfocal };
            lens.check().map_err(|e| anyhow::anyhow!("--{}", e.replace('_', "-")))?;
            Some(lens)
        }
        None => None,
    };
    let weather = match (args.fog_visibility_m, args.rain_mm_h) {
        (Some(visibility_m), _) => Weather::Fog { visibility_m },
        (None, Some(rate_mm_h)) => Weather::Rain { rate_mm_h },
        (None, None) => Weather::Clear,
    };
    weather.check().map_err(|e| {
        let flag = e.replace("fog visibility_m", "fog-visibility-m");
        anyhow::anyhow!("--{}", flag.replace("rain rate_mm_h", "rain-mm-h"))
    })?;
    Ok((lens, weather))
}

/// Runs `joca render`.
pub fn run(args: &Args) -> Result<()> {
    let (sensor, input, fixed) = checked(args)?;
    let (lens, weather) = optics(args, sensor)?;
    let design = CameraDesign {
        x_m: args.x,
        z_m: args.z,
        focal_length_mm: args.focal_mm,
        sensor_index: sensor.index,
        f_number: lens.map_or(CALIBRATION_F_NUMBER, |l| l.f_number),
    };
    let camera = PinholeCamera { lens, ..design.pinhole(&input) };
    let config = sim_config(args, weather)?;
    let last = args.start_s + (args.frames - 1) as f64 * config.frame_interval_s;
    if args.start_s < 0.0 || last > config.episode_s {
        bail!(
            "frames from {} s to {last:.1} s fall outside the {} s episode",
            args.start_s,
            config.episode_s
        );
    }
    let sim = Simulator::new(config);
    let formation = ImageFormation::new(Calibration::DEFAULT)?
        .with_noise_scale(args.noise_scale)
        .context("invalid --noise-scale")?
        .with_resampler(input.resampler)
        .with_f_number(lens.map_or(CALIBRATION_F_NUMBER, |l| l.f_number))?
        .for_sensor(sensor);
    let ae = AverageAe::new(AccRanges::PAPER);
    let streams = SeedStreams::new(args.seed);
    // Written in full or not at all: a full disk or a kill leaves the earlier output (or none).
    let staged = io::StagedDir::create(&args.out, joca_core::output::OutputKind::Render)?;
    let out = staged.path().to_owned();
    let frames_dir = out.join("frames");

    let episode = sim.episode(args.episode);
    print_header(args, &episode, sensor, &camera, &design);
    println!(
        "{:>6} {:>7} {:>8} {:>7} {:>9} {:>6} {:>6} {:>5} {:>4} {:>8}",
        "frame", "t s", "E ms", "G dB", "mean DN", "speed", "boxes", "180°", "sub", "range dB"
    );
    let mut settings = fixed.unwrap_or(DynamicSettings::new(
        Calibration::DEFAULT.exposure_s,
        Calibration::DEFAULT.gain_db,
    ));
    let mut images = Vec::new();
    let mut annotations = Vec::new();
    let mut shown = Vec::new();
    let mut ranges = Vec::new();
    for k in 0..args.frames {
        let t = args.start_s + k as f64 * sim.frame_interval_s();
        let request = FrameRequest {
            episode: args.episode,
            time_s: t,
            exposure_s: settings.exposure_s,
            motion_scale: args.blur_scale,
        };
        let frame = sim.render(&camera, &request).map_err(|e| anyhow::anyhow!(e))?;
        let image = formation.form_parallel(
            &frame.hdr,
            settings,
            sensor.pixel_pitch_um,
            &mut streams.indexed("render-noise", k as u64),
        );
        let name = format!("{k:06}.png");
        io::write_png(&frames_dir.join(&name), &image)?;
        let sub = frame.subframes;
        ranges.push(range::radiance_range_db(&frame.hdr));
        println!(
            "{:>6} {:>7.2} {:>8.2} {:>7.1} {:>9.1} {:>6.1} {:>6} {:>5} {:>4} {:>8.1}",
            k,
            t,
            ms_from_s(settings.exposure_s),
            settings.gain_db,
            image.mean(),
            episode.ego.speed_at(t),
            frame.boxes.len(),
            frame.visible_180,
            sub,
            ranges[k]
        );
        images.push(coco_image(args, k, &image, t, settings, frame.visible_180, lens));
        // Ignore regions go out as COCO crowd regions, so that pycocotools, `joca metrics` and a
        // folder recording treat them as joca does.
        let all = frame.boxes.iter().map(|a| (a, 0)).chain(frame.ignore.iter().map(|a| (a, 1)));
        for (a, crowd) in all {
            annotations.push(json!({
                "id": annotations.len() + 1, "image_id": k + 1, "category_id": a.class.coco_id(),
                "bbox": a.bbox.to_xywh(), "area": a.bbox.area(), "iscrowd": crowd,
            }));
        }
        let mut boxed = image.clone();
        draw::draw_boxes(&mut boxed, &frame.boxes, false);
        draw::draw_boxes(&mut boxed, &frame.ignore, true);
        shown.push(boxed);
        if fixed.is_none() {
            settings = ae.step(settings, &image);
        }
    }
    write_outputs(&out, images, annotations, &shown, sim.frame_interval_s())?;
    staged.finish()?;
    println!(
        "in-frame dynamic range (the scene's radiance before exposure, 99.5th over 0.5th \
         percentile): {}",
        range::spread(&ranges)
    );
    println!(
        "wrote {} frames, annotations.json, contact_sheet.png and sequence.gif to {}",
        args.frames,
        args.out.display()
    );
    Ok(())
}

/// The run's first lines: the scene, the design, its lens and the weather.
fn print_header(
    args: &Args,
    episode: &joca_sim::Episode,
    sensor: &joca_camera::Sensor,
    camera: &PinholeCamera,
    design: &CameraDesign,
) {
    let sun = episode.sun_dir;
    println!(
        "map {} episode {} ({}, sun {:.1}° high{}{}), {} {}x{} px, f = {} mm (HFoV {:.1}°), \
         mount x = {} m z = {} m",
        args.map_seed,
        args.episode,
        episode.illumination.name(),
        sun[2].asin().to_degrees(),
        if args.daylight.is_constant() { "" } else { " in a clear sky's light" },
        match (args.shadows, args.sun) {
            (false, false) => "",
            (true, false) => ", casting shadows",
            (false, true) => ", its disc drawn",
            (true, true) => ", its disc drawn, casting shadows",
        },
        sensor.name,
        camera.width_px,
        camera.height_px,
        args.focal_mm,
        design.hfov_rad().to_degrees(),
        args.x,
        args.z
    );
    if let Some(l) = camera.lens {
        println!("lens f/{} focused at {:.2} m", l.f_number, l.focus_m);
    }
    if args.dark_streets {
        println!("the street lamps stay dark at night");
    }
    if let Some(m) = episode.mouth {
        let (verb, level) = (if m.entering { "enters" } else { "leaves" }, args.tunnel_lamp_level);
        println!(
            "drives through a tunnel: {verb} it at {:.2} s (lamps {level} of daylight)",
            m.time_s
        );
    }
    if !args.daylight.is_constant() {
        let [beam, sky] = args.daylight.levels(sun[2].clamp(-1.0, 1.0).asin());
        println!(
            "{} daylight: the sun's beam {beam:.3} and the sky's light {sky:.3} of their levels \
             at {}°",
            args.daylight,
            joca_core::sun::REFERENCE_ELEVATION_DEG
        );
    }
    if args.glare > 0.0 {
        println!(
            "veiling glare: {} % of the light spread, scale {}°",
            args.glare * 100.0,
            args.glare_scale_deg
        );
    }
    if let Some(v) = args.fog_visibility_m {
        println!("fog: visibility {v} m");
    }
    if let Some(r) = args.rain_mm_h {
        println!("rain: {r} mm/h");
    }
}
