//! `joca detect`: run a detector weights file on 8-bit frames and write COCO detections, so that
//! `joca metrics` can score them with all 12 COCO numbers (AP by object size included).

use crate::io::read_rgb8;
use anyhow::{Context, Result, anyhow, bail};
use joca_nn::AdamConfig;
use joca_nn::Engine;
use joca_nn::detector::{DetectorConfig, DetectorModel};
use serde::Deserialize;
use std::collections::HashSet;
use std::path::PathBuf;

/// Arguments of `joca detect`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Detector weights (from `joca train-detector`, or a run's checkpoint/detector.safetensors).
    #[arg(long)]
    weights: PathBuf,
    /// A COCO file listing the frames (`images[].id`, `file_name` relative to its folder), e.g.
    /// the annotations.json that `joca render` writes.
    #[arg(long)]
    images: PathBuf,
    /// Output: a COCO results list (`image_id`, `category_id`, `bbox`, `score`).
    #[arg(long)]
    out: PathBuf,
    /// Detector width, 4 to 128; by default the one the weights file was saved with (as are the
    /// class count and the stride-32 stage).
    #[arg(long, value_parser = clap::value_parser!(i64).range(4..=128))]
    width: Option<i64>,
    /// libtorch threads, 1 to 64.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u64).range(1..=64))]
    threads: u64,
    /// What the detector runs on: cpu, cuda (the first GPU), cuda:N or auto.
    #[arg(long, default_value = "cpu", value_parser = crate::config::device)]
    device: joca_nn::device::DeviceChoice,
}

#[derive(Debug, Deserialize)]
struct Images {
    images: Vec<Image>,
}

#[derive(Debug, Deserialize)]
struct Image {
    id: u64,
    file_name: String,
}

/// Runs `joca detect`.
pub fn run(args: &Args) -> Result<()> {
    // First: libtorch looks for its CUDA part once, before anything else asks it.
    let engine = Engine::open(args.device, usize::try_from(args.threads)?)?;
    let mut config = DetectorConfig::of_weights(&args.weights)
        .with_context(|| format!("cannot load {}", args.weights.display()))?;
    config.width = args.width.unwrap_or(config.width);
    let text = std::fs::read_to_string(&args.images)
        .with_context(|| format!("cannot read {}", args.images.display()))?;
    let list: Images = serde_json::from_str(&text).with_context(|| {
        format!("{} is not a COCO file with an images list", args.images.display())
    })?;
    let root = args.images.parent().map(PathBuf::from).unwrap_or_default();
    // Every frame is checked before the detector starts: inside the list's folder (the folder
    // source's rule: relative, no `..`, no symbolic link out), and each id once.
    let mut seen = HashSet::new();
    let mut paths = Vec::with_capacity(list.images.len());
    for image in &list.images {
        if !seen.insert(image.id) {
            bail!("{}: image id {} is listed twice", args.images.display(), image.id);
        }
        let path = joca_data::folder::path_inside(&root, &image.file_name)
            .map_err(|e| anyhow!("{}: image {}: {e}", args.images.display(), image.id))?;
        paths.push(path);
    }
    let mut model = DetectorModel::new(&engine, config, AdamConfig::DETECTOR);
    model
        .load_weights(&args.weights)
        .with_context(|| format!("cannot load {}", args.weights.display()))?;
    let mut out = Vec::new();
    let mut diverged = Vec::new();
    for (image, path) in list.images.iter().zip(&paths) {
        let frame = read_rgb8(path)?;
        let found = model.detect(&frame);
        if found.is_empty() && model.diverges_on(&frame) {
            diverged.push(path.display().to_string());
        }
        for d in found {
            let b = d.bbox;
            out.push(serde_json::json!({
                "image_id": image.id,
                "category_id": d.class.coco_id(),
                "bbox": [b.x_min, b.y_min, b.x_max - b.x_min, b.y_max - b.y_min],
                "score": d.score,
            }));
        }
    }
    crate::io::write_atomic(&args.out, serde_json::to_string(&out)?.as_bytes())?;
    println!("{} detections on {} frames: {}", out.len(), list.images.len(), args.out.display());
    if let Some(first) = diverged.first() {
        eprintln!(
            "warning: the detector's outputs were NaN or infinite on {} of {} frames (first: \
             {first}), which therefore have no detections: {} overflow in the forward pass \
             (weights far outside a trained network's range)",
            diverged.len(),
            list.images.len(),
            args.weights.display()
        );
    }
    Ok(())
}
