//! `joca import`: labels of recorded drives (KITTI tracking, labelme) into the folder format.

use crate::io::StagedDir;
use anyhow::{Result, anyhow, bail};
use clap::{Args as ClapArgs, Subcommand};
use joca_data::import::{Import, kitti_tracking, labelme};
use std::path::PathBuf;

/// Arguments of `joca import`.
#[derive(Debug, ClapArgs)]
pub struct Args {
    #[command(subcommand)]
    format: Format,
}

/// The label formats.
#[derive(Debug, Subcommand)]
enum Format {
    /// KITTI tracking: a sequence's label file and its frames (`image_02/<sequence>/`).
    Kitti {
        /// The sequence's label file, e.g. `label_02/0000.txt`.
        #[arg(long, value_name = "FILE")]
        labels: PathBuf,
        /// Its frames, PNG named by frame number, e.g. `image_02/0000/`.
        #[arg(long, value_name = "DIR")]
        images: PathBuf,
        /// Time between frames (KITTI records at 10 Hz).
        #[arg(long, default_value_t = 100.0)]
        frame_interval_ms: f64,
        #[command(flatten)]
        out: Output,
    },
    /// labelme: a folder of one JSON per frame (named by frame number) beside its images.
    Labelme {
        /// The folder of labelme JSON files.
        dir: PathBuf,
        /// Time between frames, as the video was recorded (e.g. 33.3 for 30 frames/s).
        #[arg(long)]
        frame_interval_ms: f64,
        /// Maps a label to a joca class: LABEL=vehicle|walker|traffic_sign|ignore (repeatable;
        /// car, truck, bus, van, pedestrian, person, cyclist and sign map by name).
        #[arg(long = "class", value_name = "LABEL=CLASS")]
        classes: Vec<String>,
        #[command(flatten)]
        out: Output,
    },
}

/// Where the folder goes and what the frames' exposure was.
#[derive(Debug, ClapArgs)]
struct Output {
    /// The folder to write (new, empty, or an earlier import).
    #[arg(long)]
    out: PathBuf,
    /// The recording's exposure time, if known and the same for every frame (otherwise runs
    /// need `[run.real] default_exposure_ms`).
    #[arg(long)]
    exposure_ms: Option<f64>,
}

/// Runs `joca import`.
pub fn run(args: &Args) -> Result<()> {
    // A folder that is not an earlier import is refused before any label is read.
    let (Format::Kitti { out, .. } | Format::Labelme { out, .. }) = &args.format;
    joca_core::output::check(&out.out, joca_core::output::OutputKind::Import)?;
    let (import, out): (Import, &Output) = match &args.format {
        Format::Kitti { labels, images, frame_interval_ms, out } => {
            (kitti_tracking(labels, images, frame_interval_ms / 1e3).map_err(|e| anyhow!(e))?, out)
        }
        Format::Labelme { dir, frame_interval_ms, classes, out } => {
            let classes = classes
                .iter()
                .map(|c| {
                    c.split_once('=')
                        .map(|(l, k)| (l.to_owned(), k.to_owned()))
                        .ok_or_else(|| anyhow!("--class {c:?}: expected LABEL=CLASS"))
                })
                .collect::<Result<Vec<_>>>()?;
            (labelme(dir, frame_interval_ms / 1e3, &classes).map_err(|e| anyhow!(e))?, out)
        }
    };
    let exposure_s = match out.exposure_ms {
        Some(ms) if !(ms > 0.0 && ms <= 10_000.0) => {
            bail!("--exposure-ms = {ms} is invalid: above 0, at most 10000 ms")
        }
        other => other.map(|ms| ms / 1e3),
    };
    // Everything was read and checked above; the folder is written whole or not at all.
    let staged = StagedDir::create(&out.out, joca_core::output::OutputKind::Import)?;
    import.write_folder(staged.path(), exposure_s).map_err(|e| anyhow!(e))?;
    staged.finish()?;
    let ignore = import.boxes.iter().filter(|b| b.class.is_none()).count();
    println!(
        "wrote {} frames with {} objects and {ignore} ignore regions to {} (folder format: \
         --source folder:{})",
        import.frames.len(),
        import.boxes.len() - ignore,
        out.out.display(),
        out.out.display()
    );
    Ok(())
}
