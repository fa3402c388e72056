//! What `joca render` writes besides the frames: COCO annotations with joca's frame fields, the
//! contact sheet and the animation.

use super::Args;
use crate::{draw, io};
use anyhow::Result;
use joca_camera::DynamicSettings;
use joca_core::Rgb8Image;
use joca_core::optics::Lens;
use serde_json::json;
use std::path::Path;

/// Frame `k`'s COCO image entry, with joca's fields (time, settings, lens, fog).
pub(super) fn coco_image(
    args: &Args,
    k: usize,
    image: &Rgb8Image,
    t: f64,
    settings: DynamicSettings,
    visible_180: u32,
    lens: Option<Lens>,
) -> serde_json::Value {
    let mut entry = json!({
        "id": k + 1, "file_name": format!("frames/{k:06}.png"),
        "width": image.width(), "height": image.height(),
        "episode": args.episode, "time_s": t, "timestamp_s": t,
        "exposure_s": settings.exposure_s, "gain_db": settings.gain_db,
        "visible_180": visible_180,
    });
    if let Some(l) = lens {
        entry["f_number"] = json!(l.f_number);
        entry["focus_m"] = json!(l.focus_m);
    }
    if let Some(v) = args.fog_visibility_m {
        entry["fog_visibility_m"] = json!(v);
    }
    if let Some(r) = args.rain_mm_h {
        entry["rain_mm_h"] = json!(r);
    }
    entry
}

/// `annotations.json` (COCO, with joca's frame fields), the contact sheet and the animation.
pub(super) fn write_outputs(
    out: &Path,
    images: Vec<serde_json::Value>,
    annotations: Vec<serde_json::Value>,
    shown: &[Rgb8Image],
    frame_interval_s: f64,
) -> Result<()> {
    let categories: Vec<_> = joca_core::Class::ALL
        .iter()
        .map(|c| json!({"id": c.coco_id(), "name": c.name()}))
        .collect();
    let coco = json!({"images": images, "annotations": annotations, "categories": categories});
    io::write_atomic(
        &out.join("annotations.json"),
        serde_json::to_string_pretty(&coco)?.as_bytes(),
    )?;
    let sheet_frames: Vec<Rgb8Image> =
        shown.iter().step_by(shown.len().div_ceil(16).max(1)).cloned().collect();
    let sheet = draw::tile(&sheet_frames, 4);
    io::write_png(&out.join("contact_sheet.png"), &sheet)?;
    io::write_gif(&out.join("sequence.gif"), shown, (frame_interval_s * 100.0).round() as u16)?;
    Ok(())
}
