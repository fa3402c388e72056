//! The folder format's annotation file: a COCO `annotations.json` whose images also carry
//! `timestamp_s`, `exposure_s`, `gain_db` and `sequence`, read and checked into a
//! [`Recording`]: categories mapped to joca's classes, boxes with area inside their image, file
//! names inside the folder.

use super::*;

#[derive(Debug, Deserialize)]
struct CocoFile {
    images: Vec<CocoImage>,
    #[serde(default)]
    annotations: Vec<CocoAnnotation>,
    categories: Vec<CocoCategory>,
}

#[derive(Debug, Deserialize)]
struct CocoImage {
    id: u64,
    file_name: String,
    width: u32,
    height: u32,
    timestamp_s: Option<f64>,
    exposure_s: Option<f64>,
    gain_db: Option<f64>,
    sequence: Option<String>,
}

#[derive(Debug, Deserialize)]
struct CocoAnnotation {
    image_id: u64,
    bbox: [f32; 4],
    category_id: u64,
    #[serde(default)]
    iscrowd: u8,
}

#[derive(Debug, Deserialize)]
struct CocoCategory {
    id: u64,
    name: String,
    joca_class: Option<String>,
}

/// The joca class a category or label name stands for: `Some(Some(class))`, `Some(None)` for
/// `ignore`, `None` for a name joca does not know. Case and spaces do not matter.
pub(crate) fn class_named(name: &str) -> Option<Option<Class>> {
    Some(match name.to_ascii_lowercase().replace(' ', "_").as_str() {
        "vehicle" | "car" | "truck" | "bus" | "van" => Some(Class::Vehicle),
        "walker" | "pedestrian" | "person" | "cyclist" => Some(Class::Walker),
        "traffic_sign" | "sign" => Some(Class::TrafficSign),
        "ignore" => None,
        _ => return None,
    })
}

/// Maps a category to a joca class (`Ok(None)`: ignored).
fn class_of(c: &CocoCategory) -> Result<Option<Class>, String> {
    class_named(c.joca_class.as_deref().unwrap_or(&c.name)).ok_or_else(|| {
        format!(
            "category {} {:?} is not a joca class; name it vehicle, walker or traffic_sign (or \
                car, truck, bus, pedestrian, person, cyclist, sign), or add \"joca_class\": \
                \"vehicle\" | \"walker\" | \"traffic_sign\" | \"ignore\"",
            c.id, c.name
        )
    })
}

/// A COCO box `[x, y, w, h]` must have a positive size and lie inside its `w × h` image (up to
/// one pixel of rounding at the border).
fn check_box([x, y, w, h]: [f32; 4], (width, height): (u32, u32)) -> Result<(), String> {
    if ![x, y, w, h].iter().all(|v| v.is_finite()) || w <= 0.0 || h <= 0.0 {
        return Err("needs finite coordinates and a width and height above 0".into());
    }
    let slack = 1.0;
    if x < -slack || y < -slack || x + w > width as f32 + slack || y + h > height as f32 + slack {
        return Err(format!("reaches outside the {width}×{height} image"));
    }
    Ok(())
}

/// Recorded capture times, in seconds: finite and within ±1e10 s (Unix time or time since the
/// recording's start both fit).
pub const TIMESTAMP_RANGE_S: (f64, f64) = (-1e10, 1e10);
/// Recorded exposure times, in seconds: above 0 and at most 10 s.
pub const EXPOSURE_RANGE_S: (f64, f64) = (0.0, 10.0);
/// Recorded gains, in dB: −20 to 60 dB (every catalogue sensor's analog and digital gain fit).
pub const GAIN_RANGE_DB: (f64, f64) = (-20.0, 60.0);

/// An image's recorded timestamp, exposure and gain must be finite and in range (NaN is out of
/// every range); the error names the image, the field, the value and the range.
fn check_settings(img: &CocoImage, default_exposure_s: Option<f64>) -> Result<(), String> {
    let fields = [
        ("timestamp_s", img.timestamp_s, TIMESTAMP_RANGE_S, true),
        ("exposure_s", img.exposure_s.or(default_exposure_s), EXPOSURE_RANGE_S, false),
        ("gain_db", img.gain_db, GAIN_RANGE_DB, true),
    ];
    for (field, value, (lo, hi), closed) in fields {
        let Some(v) = value else { continue };
        let inside = if closed { (lo..=hi).contains(&v) } else { v > lo && v <= hi };
        if !inside {
            let from = if closed { "from" } else { "above" };
            let (v, lo, hi) = (short(v), short(lo), short(hi));
            return Err(format!(
                "image {} ({}) has {field} = {v}; allowed {from} {lo} to {hi}",
                img.id, img.file_name
            ));
        }
    }
    Ok(())
}

/// A number as a message shows it: plain, or in exponent form where plain would be long.
fn short(v: f64) -> String {
    if v != 0.0 && !(1e-4..1e6).contains(&v.abs()) { format!("{v:e}") } else { format!("{v}") }
}

/// `dir/name`, where `name` (an annotation's `file_name`) must stay inside `dir`: relative, with
/// no `..`, and not leading out through a symbolic link. A recording's annotation file is input
/// like any other, and nothing outside the dataset folder is opened on its word.
pub fn inside(dir: &Path, name: &str) -> Result<PathBuf, String> {
    let rel = Path::new(name);
    let plain = rel.components().all(|c| matches!(c, Component::Normal(_) | Component::CurDir));
    if name.is_empty() || rel.is_absolute() || !plain {
        return Err(format!(
            "file_name {name:?} is not a path inside the dataset folder (relative, without `..`)"
        ));
    }
    let path = dir.join(rel);
    // A missing file is reported by the header check; an existing one must resolve inside.
    if let (Ok(root), Ok(real)) = (dir.canonicalize(), path.canonicalize())
        && !real.starts_with(&root)
    {
        return Err(format!(
            "file_name {name:?} leads outside the dataset folder, to {} (a symbolic link)",
            real.display()
        ));
    }
    // Opening a FIFO or a device would block or never end: only regular files are frames.
    if path.exists() && !path.is_file() {
        return Err(format!(
            "file_name {name:?} is not a regular file (a FIFO, a device or a folder): frames are \
             read from files only"
        ));
    }
    Ok(path)
}

impl Recording {
    /// Opens `dir/annotations.json` and checks every frame's header.
    pub fn open(dir: &Path, config: FolderConfig) -> Result<Self, SourceError> {
        let json_path = dir.join("annotations.json");
        let text =
            std::fs::read_to_string(&json_path).map_err(DataError::io(&json_path, "read"))?;
        let coco: CocoFile = serde_json::from_str(&text)
            .map_err(DataError::json(&json_path, "a COCO annotations file"))?;
        let mut classes = HashMap::new();
        for c in &coco.categories {
            classes.insert(c.id, class_of(c).map_err(|e| bad(&json_path, e))?);
        }
        let mut boxes: HashMap<u64, Vec<Annotation>> = HashMap::new();
        let mut crowds: HashMap<u64, Vec<Annotation>> = HashMap::new();
        let mut sizes: HashMap<u64, (u32, u32)> = HashMap::new();
        for img in &coco.images {
            if sizes.insert(img.id, (img.width, img.height)).is_some() {
                return Err(bad(&json_path, format!("image id {} is declared twice", img.id)));
            }
        }
        for a in &coco.annotations {
            let size = sizes.get(&a.image_id).copied().ok_or_else(|| {
                bad(
                    &json_path,
                    format!("an annotation has image_id {} that no image declares", a.image_id),
                )
            })?;
            check_box(a.bbox, size).map_err(|why| {
                bad(
                    &json_path,
                    format!("an annotation of image {}: bbox {:?} {why}", a.image_id, a.bbox),
                )
            })?;
            let class = *classes.get(&a.category_id).ok_or_else(|| {
                bad(
                    &json_path,
                    format!(
                        "an annotation of image {} has category_id {} that no category declares",
                        a.image_id, a.category_id
                    ),
                )
            })?;
            let [x, y, w, h] = a.bbox;
            let bbox = BBox::new(x, y, x + w, y + h);
            match class {
                Some(class) => {
                    let list = if a.iscrowd == 0 { &mut boxes } else { &mut crowds };
                    list.entry(a.image_id).or_default().push(Annotation::new(bbox, class));
                }
                // A region of an `ignore` category (KITTI's DontCare) is not scored for any
                // class: an ignore region of each.
                None => crowds
                    .entry(a.image_id)
                    .or_default()
                    .extend(Class::ALL.iter().map(|&c| Annotation::new(bbox, c))),
            }
        }
        let mut sequences: BTreeMap<String, Vec<RecordedFrame>> = BTreeMap::new();
        let mut skipped = Vec::new();
        let mut files = HashSet::new();
        for img in &coco.images {
            let path = inside(dir, &img.file_name).map_err(|e| bad(&json_path, e))?;
            // `a/./b.png` and `a/b.png` are one file: compare the normalised relative path.
            let normal: PathBuf = Path::new(&img.file_name).components().collect();
            if !files.insert(normal) {
                return Err(bad(
                    &json_path,
                    format!(
                        "image {}: file_name {:?} is already another image's; each frame is one \
                         file",
                        img.id, img.file_name
                    ),
                ));
            }
            check_settings(img, config.default_exposure_s).map_err(|e| bad(&json_path, e))?;
            let timestamp_s = img.timestamp_s.ok_or_else(|| {
                bad(
                    &json_path,
                    format!(
                        "image {} ({}) has no timestamp_s; every frame needs its capture time \
                         in seconds",
                        img.id, img.file_name
                    ),
                )
            })?;
            let exposure_s = img.exposure_s.or(config.default_exposure_s).ok_or_else(|| {
                bad(
                    &json_path,
                    format!(
                        "image {} ({}) has no exposure_s: add the recorded exposure time in \
                         seconds to each image, or set a default exposure \
                         (--default-exposure-ms) if the whole recording used one",
                        img.id, img.file_name
                    ),
                )
            })?;
            let origin = FrameOrigin::File(path);
            if let Err(why) = check_header(&origin, (img.width, img.height), img.id) {
                match config.on_bad_frame {
                    OnBadFrame::Stop => return Err(why.into()),
                    OnBadFrame::Skip => {
                        skipped.push(why.with_causes());
                        continue;
                    }
                }
            }
            sequences.entry(img.sequence.clone().unwrap_or_default()).or_default().push(
                RecordedFrame {
                    origin,
                    timestamp_s,
                    exposure_s,
                    gain_db: img.gain_db.unwrap_or(config.calibration_gain_db),
                    size_px: (img.width, img.height),
                    boxes: boxes.remove(&img.id).unwrap_or_default(),
                    ignore: crowds.remove(&img.id).unwrap_or_default(),
                },
            );
        }
        Self::from_sequences(dir, sequences.into_values().collect(), config, skipped)
    }
}
