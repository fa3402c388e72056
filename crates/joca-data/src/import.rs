//! Importers from the label formats recorded drives come with into joca's folder format
//! ([`crate::folder`]): KITTI tracking labels and labelme JSON.
//!
//! - **KITTI tracking** (Geiger et al., "Are we ready for autonomous driving?", the devkit's
//!   `readme.txt`): one text file per sequence, a line per object and frame:
//!   `frame track_id type truncated occluded alpha left top right bottom h w l x y z rotation_y
//!   [score]`, boxes in pixels of `image_02/<sequence>/<frame:06>.png`. Car, Van, Truck and Tram
//!   are vehicles, Pedestrian, Person_sitting and Cyclist walkers; DontCare and Misc regions are
//!   ignore regions (`iscrowd`). Any other type is refused.
//! - **labelme** (Wada, labelme): one JSON per frame with `imagePath`, `imageWidth`,
//!   `imageHeight` and `shapes` (`label`, `points`, `shape_type`); a shape's box is the bounds of
//!   its points (a circle's: centre ± radius). Labels map to joca's classes by name as the
//!   folder format's categories do, or by the caller's table.
//!
//! Frames are ordered by the number their file name carries (`000042.png`, `00000100.json`);
//! a gap in the numbering is refused, because the frame interval, and so the motion blur a
//! longer exposure is emulated with, would be wrong across it. Timestamps are the frame number
//! times the frame interval, from the first frame.

use crate::DataError;
use crate::folder::class_named;
use joca_core::Class;
use serde::Deserialize;
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

mod labelme;
pub use labelme::labelme;

fn err(path: &Path, line: Option<usize>, reason: impl Into<String>) -> DataError {
    DataError::invalid_at(path, line, reason)
}

/// One frame of an import.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportedFrame {
    /// The image file to copy.
    pub source: PathBuf,
    /// Its name in the folder format (relative to the folder).
    pub file_name: String,
    /// Image size, pixels.
    pub width: u32,
    /// Image size, pixels.
    pub height: u32,
    /// Capture time from the sequence's first frame, seconds.
    pub timestamp_s: f64,
    /// The sequence (drive) it belongs to.
    pub sequence: String,
}

/// One labelled region: `[x, y, w, h]` in pixels of its frame.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportedBox {
    /// Index into [`Import::frames`].
    pub frame: usize,
    /// COCO box `[x, y, w, h]`.
    pub bbox: [f64; 4],
    /// The label as the source names it.
    pub label: String,
    /// The joca class; `None`: an ignore region.
    pub class: Option<Class>,
}

/// Frames and boxes read from a source format, ready to be written as the folder format.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Import {
    /// Frames in time order.
    pub frames: Vec<ImportedFrame>,
    /// Labelled regions.
    pub boxes: Vec<ImportedBox>,
}

impl Import {
    /// The folder format's `annotations.json`: a COCO file whose images carry `timestamp_s`,
    /// `sequence` and, where given, `exposure_s` (without it, runs need `[run.real]
    /// default_exposure_ms`). One category per label, with its `joca_class`; ignore regions are
    /// `iscrowd: 1`.
    pub fn annotations_json(&self, exposure_s: Option<f64>) -> Value {
        let mut labels: BTreeMap<&str, Option<Class>> = BTreeMap::new();
        for b in &self.boxes {
            labels.entry(&b.label).or_insert(b.class);
        }
        let ids: BTreeMap<&str, usize> =
            labels.keys().enumerate().map(|(i, &name)| (name, i + 1)).collect();
        let categories: Vec<Value> = labels
            .iter()
            .map(|(&name, class)| {
                json!({
                    "id": ids[name],
                    "name": name,
                    "joca_class": class.map_or("ignore", Class::name),
                })
            })
            .collect();
        let images: Vec<Value> = self
            .frames
            .iter()
            .enumerate()
            .map(|(i, f)| {
                let mut image = json!({
                    "id": i + 1,
                    "file_name": f.file_name,
                    "width": f.width,
                    "height": f.height,
                    "timestamp_s": f.timestamp_s,
                    "sequence": f.sequence,
                });
                if let (Some(e), Some(o)) = (exposure_s, image.as_object_mut()) {
                    o.insert("exposure_s".into(), json!(e));
                }
                image
            })
            .collect();
        let annotations: Vec<Value> = self
            .boxes
            .iter()
            .enumerate()
            .map(|(i, b)| {
                json!({
                    "id": i + 1,
                    "image_id": b.frame + 1,
                    "category_id": ids[b.label.as_str()],
                    "bbox": b.bbox,
                    "area": b.bbox[2] * b.bbox[3],
                    "iscrowd": u8::from(b.class.is_none()),
                })
            })
            .collect();
        json!({ "images": images, "annotations": annotations, "categories": categories })
    }
}

impl Import {
    /// Writes the folder format into `dir` (which should be new or empty): every frame copied to
    /// its `file_name`, and `annotations.json` (see [`Import::annotations_json`]).
    /// Two frames with one `file_name` (two labelled frames naming one picture) are refused
    /// before anything is copied: one would overwrite the other under the other's labels.
    pub fn write_folder(&self, dir: &Path, exposure_s: Option<f64>) -> Result<(), DataError> {
        let mut names = std::collections::HashMap::new();
        for f in &self.frames {
            if let Some(first) = names.insert(f.file_name.as_str(), &f.source) {
                return Err(err(
                    &f.source,
                    None,
                    format!(
                        "is imported as {} like {}: two frames would be one file",
                        f.file_name,
                        first.display()
                    ),
                ));
            }
        }
        // A FIFO or device among the frames would block the copy for good: refused first.
        if let Some(f) = self.frames.iter().find(|f| !f.source.is_file()) {
            return Err(not_a_file(&f.source));
        }
        for f in &self.frames {
            let to = dir.join(&f.file_name);
            if let Some(parent) = to.parent() {
                std::fs::create_dir_all(parent)
                    .map_err(DataError::io(parent, "create the folder"))?;
            }
            std::fs::copy(&f.source, &to)
                .map_err(DataError::io(&f.source, format!("copy to {}", to.display())))?;
        }
        let path = dir.join("annotations.json");
        let text = serde_json::to_string_pretty(&self.annotations_json(exposure_s))
            .map_err(DataError::json(&path, "serialisable as COCO JSON"))?;
        joca_core::fs::write_atomic(&path, text.as_bytes()).map_err(DataError::io(&path, "write"))
    }
}

/// Files of `dir` with one of `extensions` whose stem is a frame number, in number order;
/// refuses an empty folder and a gap in the numbering.
fn numbered(dir: &Path, extensions: &[&str]) -> Result<Vec<(u64, PathBuf)>, DataError> {
    let entries = std::fs::read_dir(dir).map_err(DataError::io(dir, "list the folder"))?;
    let mut files: Vec<(u64, PathBuf)> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| extensions.iter().any(|x| x.eq_ignore_ascii_case(e)))
        })
        .filter_map(|p| {
            let stem = p.file_stem()?.to_str()?;
            let digits = !stem.is_empty() && stem.bytes().all(|b| b.is_ascii_digit());
            digits.then(|| stem.parse().ok().map(|n| (n, p.clone()))).flatten()
        })
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(err(
            dir,
            None,
            format!("no frames: no {} file named by its frame number", extensions.join("/")),
        ));
    }
    for pair in files.windows(2) {
        let (a, b) = (&pair[0], &pair[1]);
        if b.0 == a.0 {
            return Err(err(
                dir,
                None,
                format!("frame {} twice: {} and {}", a.0, a.1.display(), b.1.display()),
            ));
        }
        if b.0 != a.0 + 1 {
            return Err(err(
                dir,
                None,
                format!(
                    "frames {} to {} are missing between {} and {}: a gap in the numbering \
                     (the frame interval, and so the emulated motion blur, would be wrong \
                     across it); import the parts on either side as separate sequences",
                    a.0 + 1,
                    b.0 - 1,
                    a.1.display(),
                    b.1.display()
                ),
            ));
        }
    }
    if let Some((_, p)) = files.iter().find(|(_, p)| !p.is_file()) {
        return Err(not_a_file(p));
    }
    Ok(files)
}

/// A FIFO, device or folder where a frame or label file should be: opening it could block for
/// good, so it is refused.
fn not_a_file(path: &Path) -> DataError {
    err(
        path,
        None,
        "is not a regular file (a FIFO, a device or a folder): frames and labels are read from \
         files only",
    )
}

fn dimensions(path: &Path) -> Result<(u32, u32), DataError> {
    if !path.is_file() {
        return Err(not_a_file(path));
    }
    image::image_dimensions(path).map_err(|source| DataError::Image {
        path: path.to_path_buf(),
        what: "the image".into(),
        source,
    })
}

/// A box `[x0, y0, x1, y1]` (pixels) must be finite, of positive size, and inside the `w × h`
/// image up to one pixel of rounding; returns it as COCO `[x, y, w, h]`.
fn coco_box([x0, y0, x1, y1]: [f64; 4], (w, h): (u32, u32)) -> Result<[f64; 4], String> {
    if ![x0, y0, x1, y1].iter().all(|v| v.is_finite()) || x1 <= x0 || y1 <= y0 {
        return Err(format!(
            "box {:?} has no area (left < right and top < bottom)",
            [x0, y0, x1, y1]
        ));
    }
    let slack = 1.0;
    if x0 < -slack || y0 < -slack || x1 > f64::from(w) + slack || y1 > f64::from(h) + slack {
        return Err(format!("box {:?} reaches outside the {w}×{h} image", [x0, y0, x1, y1]));
    }
    Ok([x0, y0, x1 - x0, y1 - y0])
}

fn check_interval(frame_interval_s: f64, what: &Path) -> Result<(), DataError> {
    if frame_interval_s.is_finite() && frame_interval_s > 0.0 && frame_interval_s <= 10.0 {
        Ok(())
    } else {
        Err(err(
            what,
            None,
            format!("frame interval {frame_interval_s} s: allowed above 0 to 10 s"),
        ))
    }
}

/// KITTI object types and what joca makes of them (`None`: an ignore region).
const KITTI_TYPES: [(&str, Option<Class>); 9] = [
    ("Car", Some(Class::Vehicle)),
    ("Van", Some(Class::Vehicle)),
    ("Truck", Some(Class::Vehicle)),
    ("Tram", Some(Class::Vehicle)),
    ("Pedestrian", Some(Class::Walker)),
    ("Person_sitting", Some(Class::Walker)),
    ("Cyclist", Some(Class::Walker)),
    ("Misc", None),
    ("DontCare", None),
];

/// Reads a KITTI tracking label file (`labels`, e.g. `label_02/0000.txt`) with the frames of
/// its sequence (`images`, e.g. `image_02/0000/`, PNG named `<frame:06>.png`), the frames
/// `frame_interval_s` apart (KITTI: 0.1 s). The sequence is named after the label file; frames
/// are written as `frames/<sequence>/<file>`.
pub fn kitti_tracking(
    labels: &Path,
    images: &Path,
    frame_interval_s: f64,
) -> Result<Import, DataError> {
    check_interval(frame_interval_s, labels)?;
    let sequence = labels.file_stem().and_then(|s| s.to_str()).unwrap_or("sequence").to_owned();
    let files = numbered(images, &["png"])?;
    let first = files[0].0;
    let mut import = Import::default();
    let mut index: BTreeMap<u64, usize> = BTreeMap::new();
    for (n, path) in &files {
        let (width, height) = dimensions(path)?;
        let name = path.file_name().and_then(|s| s.to_str()).unwrap_or_default();
        index.insert(*n, import.frames.len());
        import.frames.push(ImportedFrame {
            source: path.clone(),
            file_name: format!("frames/{sequence}/{name}"),
            width,
            height,
            timestamp_s: (n - first) as f64 * frame_interval_s,
            sequence: sequence.clone(),
        });
    }
    let text = std::fs::read_to_string(labels).map_err(DataError::io(labels, "read"))?;
    for (k, line) in text.lines().enumerate() {
        let at = Some(k + 1);
        let fields: Vec<&str> = line.split_whitespace().collect();
        if fields.is_empty() {
            continue;
        }
        if !(17..=18).contains(&fields.len()) {
            return Err(err(
                labels,
                at,
                format!(
                    "{} fields; a KITTI tracking label has 17 (frame track_id type truncated \
                     occluded alpha left top right bottom h w l x y z rotation_y) or 18 (and a \
                     score)",
                    fields.len()
                ),
            ));
        }
        let frame: u64 = fields[0]
            .parse()
            .map_err(|_| err(labels, at, format!("frame {:?} is not a frame number", fields[0])))?;
        let kind = fields[2];
        let class =
            KITTI_TYPES.iter().find(|(t, _)| *t == kind).map(|(_, c)| *c).ok_or_else(|| {
                let known: Vec<&str> = KITTI_TYPES.iter().map(|(t, _)| *t).collect();
                err(labels, at, format!("unknown type {kind:?}; KITTI's are {}", known.join(", ")))
            })?;
        let mut corners = [0.0f64; 4];
        for (c, text) in corners.iter_mut().zip(&fields[6..10]) {
            *c = text
                .parse()
                .map_err(|_| err(labels, at, format!("box coordinate {text:?} is not a number")))?;
        }
        let &i = index.get(&frame).ok_or_else(|| {
            err(
                labels,
                at,
                format!("frame {frame} has labels but {} has no {frame:06}.png", images.display()),
            )
        })?;
        let f = &import.frames[i];
        let bbox = coco_box(corners, (f.width, f.height)).map_err(|why| err(labels, at, why))?;
        import.boxes.push(ImportedBox { frame: i, bbox, label: kind.to_ascii_lowercase(), class });
    }
    Ok(import)
}
