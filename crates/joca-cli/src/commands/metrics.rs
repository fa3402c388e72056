//! `joca metrics`: COCO box evaluation of result files, as pycocotools prints it.

use anyhow::{Context, Result, anyhow, bail};
use joca_metrics::{CocoEvaluator, GroundTruth, STAT_NAMES, ScoredBox};
use serde_json::Value;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Arguments of `joca metrics`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Ground truth: a COCO file with `images`, `annotations` (bbox, category_id, area,
    /// iscrowd) and `categories`.
    #[arg(long)]
    gt: PathBuf,
    /// Detections: a COCO results file, a JSON list of {image_id, category_id, bbox, score}.
    #[arg(long)]
    dt: PathBuf,
}

fn read_json(path: &Path) -> Result<Value> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{} is not valid JSON", path.display()))
}

fn field<'a>(v: &'a Value, name: &str, what: &str, path: &Path) -> Result<&'a Value> {
    v.get(name).ok_or_else(|| anyhow!("{}: {what} has no field `{name}`", path.display()))
}

fn number(v: &Value, name: &str, what: &str, path: &Path) -> Result<f64> {
    field(v, name, what, path)?
        .as_f64()
        .ok_or_else(|| anyhow!("{}: `{name}` of {what} is not a number", path.display()))
}

fn bbox(v: &Value, what: &str, path: &Path) -> Result<[f64; 4]> {
    let b = field(v, "bbox", what, path)?.as_array().filter(|a| a.len() == 4).ok_or_else(|| {
        anyhow!("{}: `bbox` of {what} must be [x, y, width, height]", path.display())
    })?;
    let mut out = [0.0; 4];
    for (o, x) in out.iter_mut().zip(b) {
        *o = x
            .as_f64()
            .ok_or_else(|| anyhow!("{}: `bbox` of {what} holds a non-number", path.display()))?;
    }
    if out[2] < 0.0 || out[3] < 0.0 {
        bail!("{}: `bbox` of {what} has a negative width or height", path.display());
    }
    Ok(out)
}

/// Runs `joca metrics`.
pub fn run(args: &Args) -> Result<()> {
    let gt = read_json(&args.gt)?;
    let dt = read_json(&args.dt)?;
    let mut eval = CocoEvaluator::default();
    let images = field(&gt, "images", "the file", &args.gt)?
        .as_array()
        .ok_or_else(|| anyhow!("{}: `images` is not a list", args.gt.display()))?;
    let mut image_ids = BTreeSet::new();
    for (i, img) in images.iter().enumerate() {
        let id = number(img, "id", &format!("images[{i}]"), &args.gt)? as u64;
        image_ids.insert(id);
        eval.add_image(id, vec![], vec![]);
    }
    let categories: BTreeSet<u32> = field(&gt, "categories", "the file", &args.gt)?
        .as_array()
        .ok_or_else(|| anyhow!("{}: `categories` is not a list", args.gt.display()))?
        .iter()
        .enumerate()
        .map(|(i, c)| number(c, "id", &format!("categories[{i}]"), &args.gt).map(|v| v as u32))
        .collect::<Result<_>>()?;
    let annotations = field(&gt, "annotations", "the file", &args.gt)?
        .as_array()
        .ok_or_else(|| anyhow!("{}: `annotations` is not a list", args.gt.display()))?;
    for (i, a) in annotations.iter().enumerate() {
        let what = format!("annotations[{i}]");
        let image = number(a, "image_id", &what, &args.gt)? as u64;
        let b = bbox(a, &what, &args.gt)?;
        let g = GroundTruth {
            bbox: b,
            category: number(a, "category_id", &what, &args.gt)? as u32,
            area: a.get("area").and_then(Value::as_f64).unwrap_or(b[2] * b[3]),
            crowd: a.get("iscrowd").and_then(Value::as_u64).unwrap_or(0) == 1,
        };
        eval.add_image(image, vec![g], vec![]);
    }
    let results = dt.as_array().ok_or_else(|| {
        anyhow!("{}: a results file is a JSON list of detections", args.dt.display())
    })?;
    for (i, d) in results.iter().enumerate() {
        let what = format!("detection {i}");
        let image = number(d, "image_id", &what, &args.dt)? as u64;
        if !image_ids.contains(&image) {
            bail!(
                "{}: {what} refers to image {image}, which {} does not have",
                args.dt.display(),
                args.gt.display()
            );
        }
        let category = number(d, "category_id", &what, &args.dt)? as u32;
        if !categories.contains(&category) {
            continue; // pycocotools evaluates the ground truth's categories only
        }
        let s = ScoredBox::new(
            bbox(d, &what, &args.dt)?,
            category,
            number(d, "score", &what, &args.dt)?,
        );
        eval.add_image(image, vec![], vec![s]);
    }
    let summary = eval.evaluate();
    for (name, value) in STAT_NAMES.iter().zip(summary.stats) {
        let kind = if name.starts_with("AP") { "Average Precision" } else { "Average Recall" };
        println!(" {kind:<18} {} = {value:.3}", &name[2..]);
    }
    for (c, ap) in &summary.per_category_ap {
        let ap50 = summary.per_category_ap50.get(c).copied().unwrap_or(-1.0);
        println!(" category {c}: AP@[.50:.95] = {ap:.3}  AP50 = {ap50:.3}");
    }
    Ok(())
}
