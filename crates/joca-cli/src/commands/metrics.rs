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

/// An id: a whole, non-negative number (pycocotools refuses `1.5`; `1.0` is the id 1).
fn id(v: &Value, name: &str, what: &str, path: &Path) -> Result<u64> {
    let x = number(v, name, what, path)?;
    if !(x >= 0.0 && x.fract() == 0.0 && x <= u32::MAX as f64) {
        bail!("{}: `{name}` of {what} is {x}, not a whole non-negative id", path.display());
    }
    Ok(x as u64)
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
        let id = id(img, "id", &format!("images[{i}]"), &args.gt)?;
        image_ids.insert(id);
        eval.add_image(id, vec![], vec![]);
    }
    let categories: BTreeSet<u32> = field(&gt, "categories", "the file", &args.gt)?
        .as_array()
        .ok_or_else(|| anyhow!("{}: `categories` is not a list", args.gt.display()))?
        .iter()
        .enumerate()
        .map(|(i, c)| id(c, "id", &format!("categories[{i}]"), &args.gt).map(|v| v as u32))
        .collect::<Result<_>>()?;
    let annotations = field(&gt, "annotations", "the file", &args.gt)?
        .as_array()
        .ok_or_else(|| anyhow!("{}: `annotations` is not a list", args.gt.display()))?;
    // pycocotools evaluates the declared images and categories only: ground truth elsewhere
    // is left out (with a warning here), so a file with nothing else scores -1.
    let mut undeclared = 0;
    for (i, a) in annotations.iter().enumerate() {
        let what = format!("annotations[{i}]");
        let image = id(a, "image_id", &what, &args.gt)?;
        let category = id(a, "category_id", &what, &args.gt)? as u32;
        let b = bbox(a, &what, &args.gt)?;
        if !image_ids.contains(&image) || !categories.contains(&category) {
            undeclared += 1;
            continue;
        }
        let g = GroundTruth {
            bbox: b,
            category,
            area: a.get("area").and_then(Value::as_f64).unwrap_or(b[2] * b[3]),
            crowd: a.get("iscrowd").and_then(Value::as_u64).unwrap_or(0) == 1,
            distance_m: None,
        };
        eval.add_image(image, vec![g], vec![]);
    }
    if undeclared > 0 {
        eprintln!(
            "warning: {}: {undeclared} annotation(s) on an image or category the file does not \
             declare are left out, as pycocotools does",
            args.gt.display()
        );
    }
    let results = dt.as_array().ok_or_else(|| {
        anyhow!("{}: a results file is a JSON list of detections", args.dt.display())
    })?;
    for (i, d) in results.iter().enumerate() {
        let what = format!("detection {i}");
        let image = id(d, "image_id", &what, &args.dt)?;
        if !image_ids.contains(&image) {
            bail!(
                "{}: {what} refers to image {image}, which {} does not have",
                args.dt.display(),
                args.gt.display()
            );
        }
        let category = id(d, "category_id", &what, &args.dt)? as u32;
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
