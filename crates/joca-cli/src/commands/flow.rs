//! `joca flow` (DIS optical flow between two frames) and `joca blur` (preview of the real-image
//! mode's flow-based motion blur on a folder of frames).

use crate::io::{read_rgb8, write_png};
use anyhow::{Context, Result, anyhow, bail};
use joca_core::output::{self, OutputKind};
use joca_core::{HdrImage, Rgb8Image};
use joca_data::blur::{Linearize, motion_blur, samples_for};
use joca_data::flow::{
    DisParams, DisPreset, Flow, Gray, accuracy, colour_code, dis, read_disparity, read_flo,
};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `joca flow`.
#[derive(Debug, clap::Args)]
pub struct FlowArgs {
    /// The reference frame I0.
    first: PathBuf,
    /// The next frame I1 (same size).
    second: PathBuf,
    /// Colour-coded flow (Middlebury wheel: hue = direction, saturation = length).
    #[arg(long)]
    out: PathBuf,
    /// DIS preset: ultrafast, fast or medium.
    #[arg(long, default_value = "medium")]
    preset: String,
    /// Also write I1 warped back onto I0 by the flow (I1(x + u(x))) to this PNG.
    #[arg(long, value_name = "PNG")]
    warped: Option<PathBuf>,
    /// Also write the flow as a Middlebury .flo file (OpenCV's readOpticalFlow reads it).
    #[arg(long, value_name = "FILE")]
    flo: Option<PathBuf>,
    /// Ground-truth flow (.flo): print the end-point error and the share of pixels off by more
    /// than 3 px, over the pixels where the truth is known.
    #[arg(long, value_name = "FLO", conflicts_with = "gt_disparity")]
    gt: Option<PathBuf>,
    /// Ground-truth disparity of a rectified stereo pair, first = left (.npy or .pfm): the
    /// true flow is (−d, 0); scored as --gt.
    #[arg(long, value_name = "FILE")]
    gt_disparity: Option<PathBuf>,
}

/// Arguments of `joca blur`.
#[derive(Debug, clap::Args)]
pub struct BlurArgs {
    /// A folder of consecutive frames (PNG or JPEG, sorted by name).
    frames: PathBuf,
    /// Exposure time to emulate, milliseconds (above 0 to 1000).
    #[arg(long)]
    exposure_ms: f64,
    /// Time between the recorded frames, milliseconds, above 0 to 10000 (Waymo: 100).
    #[arg(long, default_value_t = 100.0)]
    frame_interval_ms: f64,
    /// Motion-blur multiplier of the scenario, 0 to 100 (blur2 = 2, blur4 = 4).
    #[arg(long, default_value_t = 1.0)]
    blur_scale: f64,
    /// How the 8-bit values map to linear intensity: srgb or none.
    #[arg(long, default_value = "srgb")]
    linearize: String,
    /// DIS preset for the flow: ultrafast, fast or medium.
    #[arg(long, default_value = "fast")]
    preset: String,
    /// Output folder for the blurred frames.
    #[arg(long)]
    out: PathBuf,
}

fn preset(name: &str) -> Result<DisParams> {
    Ok(DisParams::preset(DisPreset::from_name(name).map_err(|e| anyhow!(e))?))
}

/// `I1(x + u(x))`: the second frame pulled back onto the first by the flow.
fn warp_back(i1: &Rgb8Image, flow: &Flow) -> Rgb8Image {
    let (w, h) = (i1.width(), i1.height());
    let channels: Vec<Gray> = (0..3)
        .map(|c| {
            Gray::new(w, h, i1.data().iter().skip(c).step_by(3).map(|&v| f32::from(v)).collect())
        })
        .collect();
    let mut out = Rgb8Image::zeros(w, h);
    for (k, px) in out.data_mut().chunks_exact_mut(3).enumerate() {
        let (x, y) = ((k % w) as f32, (k / w) as f32);
        let u = flow.data()[k];
        for c in 0..3 {
            px[c] = channels[c].sample(x + u[0], y + u[1]).round().clamp(0.0, 255.0) as u8;
        }
    }
    out
}

/// Mean absolute difference of two frames, DN.
fn mean_abs_diff(a: &Rgb8Image, b: &Rgb8Image) -> f64 {
    a.data().iter().zip(b.data()).map(|(&x, &y)| f64::from(x.abs_diff(y))).sum::<f64>()
        / a.data().len().max(1) as f64
}

/// Runs `joca flow`.
pub fn run_flow(args: &FlowArgs) -> Result<()> {
    let params = preset(&args.preset)?;
    let outputs = [Some(&args.out), args.warped.as_ref(), args.flo.as_ref()];
    let inputs =
        [Some(&args.first), Some(&args.second), args.gt.as_ref(), args.gt_disparity.as_ref()];
    for out in outputs.into_iter().flatten() {
        if let Some(input) = inputs.into_iter().flatten().find(|i| same_file(i, out)) {
            bail!(
                "{} is an input of this command ({}); choose another output path",
                out.display(),
                input.display()
            );
        }
    }
    let a = read_rgb8(&args.first)?;
    let b = read_rgb8(&args.second)?;
    if (a.width(), a.height()) != (b.width(), b.height()) {
        bail!(
            "{} is {}×{} but {} is {}×{}: flow needs frames of one size",
            args.first.display(),
            a.width(),
            a.height(),
            args.second.display(),
            b.width(),
            b.height()
        );
    }
    // Ground truth is read (and checked) before the flow is computed, so a bad file costs
    // nothing.
    let truth = match (&args.gt, &args.gt_disparity) {
        (Some(p), _) => Some(read_flo(p)?),
        (None, Some(p)) => Some(read_disparity(p)?),
        (None, None) => None,
    };
    if let Some((w, h, _)) = &truth
        && (*w, *h) != (a.width(), a.height())
    {
        bail!("the ground truth is {w}×{h} but the frames are {}×{}", a.width(), a.height());
    }
    let started = Instant::now();
    let flow = dis(&Gray::from_rgb8(&a), &Gray::from_rgb8(&b), &params);
    let ms = started.elapsed().as_secs_f64() * 1e3;
    let colours = Rgb8Image::from_vec(a.width(), a.height(), colour_code(&flow, None))?;
    let warped = warp_back(&b, &flow);
    // Every check that can fail comes before the first file is written.
    let acc = truth.as_ref().map(|t| accuracy(&flow, t).map_err(|e| anyhow!(e))).transpose()?;
    println!(
        "{}×{} frames, preset {}: mean displacement {:.2} px, {:.0} ms",
        a.width(),
        a.height(),
        args.preset,
        flow.mean_magnitude(),
        ms
    );
    println!(
        "mean |I0 − I1| = {:.2} DN without motion compensation, {:.2} DN with I1 warped by the \
         flow",
        mean_abs_diff(&a, &b),
        mean_abs_diff(&a, &warped)
    );
    if let Some(acc) = acc {
        println!(
            "against the ground truth: end-point error {:.3} px, {:.2} % of pixels off by more \
             than 3 px ({} known pixels)",
            acc.epe,
            100.0 * acc.above_3px,
            acc.known
        );
    }
    // All outputs or none: a later one that cannot be written leaves no earlier one behind.
    let mut files = vec![(args.out.as_path(), crate::io::png_bytes(&colours)?)];
    if let Some(path) = &args.warped {
        files.push((path.as_path(), crate::io::png_bytes(&warped)?));
    }
    if let Some(path) = &args.flo {
        files.push((path.as_path(), joca_data::flow::flo_bytes(&flow)));
    }
    crate::io::write_all_or_none(&files)?;
    if let Some(path) = &args.flo {
        println!("flow field: {}", path.display());
    }
    println!("flow: {}", args.out.display());
    Ok(())
}

/// Whether `a` and `b` name one existing file (or folder).
fn same_file(a: &Path, b: &Path) -> bool {
    matches!((a.canonicalize(), b.canonicalize()), (Ok(x), Ok(y)) if x == y)
}

fn frames_in(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot list directory {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| ["png", "jpg", "jpeg"].contains(&e.to_ascii_lowercase().as_str()))
        })
        .collect();
    files.sort();
    Ok(files)
}

/// Runs `joca blur`.
pub fn run_blur(args: &BlurArgs) -> Result<()> {
    let params = preset(&args.preset)?;
    let lin = Linearize::from_name(&args.linearize).map_err(|e| anyhow!(e))?;
    let max_blur = crate::config::MAX_BLUR_SCALE;
    for (flag, value, max, closed) in [
        ("--exposure-ms", args.exposure_ms, 1000.0, false),
        ("--frame-interval-ms", args.frame_interval_ms, 10_000.0, false),
        ("--blur-scale", args.blur_scale, max_blur, true),
    ] {
        let inside = value <= max && if closed { value >= 0.0 } else { value > 0.0 };
        if !inside {
            let from = if closed { "from" } else { "above" };
            bail!("{flag} = {value:?} is out of range: allowed {from} 0 to {max}");
        }
    }
    if same_file(&args.frames, &args.out) {
        bail!("--out {} is the input folder; choose another folder", args.out.display());
    }
    // A new or empty folder, or an earlier `joca blur` output: never a user's folder of frames.
    output::check(&args.out, OutputKind::Blur)?;
    let files = frames_in(&args.frames)?;
    if files.len() < 2 {
        bail!(
            "{} holds {} frame(s); blur needs at least 2 consecutive frames",
            args.frames.display(),
            files.len()
        );
    }
    let table = lin.table();
    let travel = (args.exposure_ms / args.frame_interval_ms * args.blur_scale) as f32;
    output::claim(&args.out, OutputKind::Blur)?;
    let mut next = read_rgb8(&files[0])?;
    for (k, pair) in files.windows(2).enumerate() {
        let frame = next;
        next = read_rgb8(&pair[1])?;
        if (frame.width(), frame.height()) != (next.width(), next.height()) {
            bail!("{} and {} differ in size", pair[0].display(), pair[1].display());
        }
        let flow = dis(&Gray::from_rgb8(&frame), &Gray::from_rgb8(&next), &params);
        let linear = HdrImage::from_vec(
            frame.width(),
            frame.height(),
            frame.data().iter().map(|&v| table[usize::from(v)]).collect(),
        )?;
        let blurred = motion_blur(&linear, &flow, travel);
        let stored: Vec<u8> = blurred.data().iter().map(|&v| lin.to_stored(v)).collect();
        let name =
            pair[0].file_stem().map_or(format!("{k:04}"), |s| s.to_string_lossy().into_owned());
        let out = args.out.join(format!("{name}.png"));
        write_png(&out, &Rgb8Image::from_vec(frame.width(), frame.height(), stored)?)?;
        let longest = flow.data().iter().map(|v| v[0].hypot(v[1])).fold(0.0f32, f32::max) * travel;
        println!(
            "{}: mean flow {:.2} px/frame → mean smear {:.2} px (longest {:.1} px, {} sub-samples \
                there)",
            pair[0].display(),
            flow.mean_magnitude(),
            flow.mean_magnitude() * f64::from(travel),
            longest,
            samples_for(longest)
        );
    }
    println!(
        "{} blurred frames in {} (the last frame has no successor to measure motion)",
        files.len() - 1,
        args.out.display()
    );
    Ok(())
}
