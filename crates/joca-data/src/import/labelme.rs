//! labelme JSON (one file per frame beside its image) into an [`Import`].

use super::*;

#[derive(Debug, Deserialize)]
#[serde(rename_all = "camelCase")]
struct LabelmeFile {
    image_path: String,
    image_width: u32,
    image_height: u32,
    #[serde(default)]
    shapes: Vec<LabelmeShape>,
}

#[derive(Debug, Deserialize)]
struct LabelmeShape {
    label: String,
    points: Vec<[f64; 2]>,
    #[serde(default = "polygon")]
    shape_type: String,
}

fn polygon() -> String {
    "polygon".into()
}

/// The bounds of a labelme shape, `[x0, y0, x1, y1]`.
fn shape_bounds(s: &LabelmeShape) -> Result<[f64; 4], String> {
    let bounds = |points: &[[f64; 2]]| {
        points
            .iter()
            .fold([f64::INFINITY, f64::INFINITY, -f64::INFINITY, -f64::INFINITY], |b, p| {
                [b[0].min(p[0]), b[1].min(p[1]), b[2].max(p[0]), b[3].max(p[1])]
            })
    };
    match (s.shape_type.as_str(), s.points.as_slice()) {
        ("polygon", p) if p.len() >= 3 => Ok(bounds(p)),
        ("rectangle", p) if p.len() == 2 => Ok(bounds(p)),
        ("circle", [c, e]) => {
            let r = (e[0] - c[0]).hypot(e[1] - c[1]);
            Ok([c[0] - r, c[1] - r, c[0] + r, c[1] + r])
        }
        (kind @ ("polygon" | "rectangle" | "circle"), p) => {
            Err(format!("a {kind} with {} points is malformed", p.len()))
        }
        (kind, _) => Err(format!(
            "shape type {kind:?} has no area; only polygon, rectangle and circle shapes are \
             objects"
        )),
    }
}

/// Reads a folder of labelme JSON files, one per frame, named by frame number (the frames
/// `frame_interval_s` apart), into one sequence named after the folder. Labels map to joca's
/// classes by `classes` (label → `vehicle`, `walker`, `traffic_sign` or `ignore`) first, then by
/// the folder format's names (car, truck, bus, van, pedestrian, person, cyclist, sign, …).
pub fn labelme(
    dir: &Path,
    frame_interval_s: f64,
    classes: &[(String, String)],
) -> Result<Import, DataError> {
    check_interval(frame_interval_s, dir)?;
    for (label, class) in classes {
        if !matches!(class.as_str(), "vehicle" | "walker" | "traffic_sign" | "ignore") {
            return Err(err(
                dir,
                None,
                format!(
                    "--class {label}={class}: the class must be vehicle, walker, traffic_sign or ignore"
                ),
            ));
        }
    }
    let class_of = |label: &str| -> Option<Option<Class>> {
        match classes.iter().find(|(l, _)| l == label) {
            Some((_, c)) => class_named(c),
            None => class_named(label),
        }
    };
    let sequence = dir
        .canonicalize()
        .ok()
        .and_then(|d| d.file_name().and_then(|s| s.to_str()).map(str::to_owned))
        .unwrap_or_else(|| "sequence".into());
    let files = numbered(dir, &["json"])?;
    let first = files[0].0;
    let mut import = Import::default();
    for (n, json_path) in &files {
        let text = std::fs::read_to_string(json_path).map_err(DataError::io(json_path, "read"))?;
        let file: LabelmeFile =
            serde_json::from_str(&text).map_err(DataError::json(json_path, "a labelme file"))?;
        let rel = Path::new(&file.image_path);
        let plain = rel.components().all(|c| matches!(c, std::path::Component::Normal(_)));
        if rel.is_absolute() || !plain {
            return Err(err(
                json_path,
                None,
                format!("imagePath {:?} must name a file beside the JSON", file.image_path),
            ));
        }
        let source = json_path.with_file_name(rel);
        let size = dimensions(&source)?;
        if size != (file.image_width, file.image_height) {
            return Err(err(
                json_path,
                None,
                format!(
                    "imageWidth × imageHeight {}×{} but {} is {}×{}",
                    file.image_width,
                    file.image_height,
                    source.display(),
                    size.0,
                    size.1
                ),
            ));
        }
        let frame = import.frames.len();
        // The path relative to the JSON, kept whole: `a/000000.png` and `b/000000.png` stay two
        // files.
        let name: Vec<String> =
            rel.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
        import.frames.push(ImportedFrame {
            source: source.clone(),
            file_name: format!("frames/{sequence}/{}", name.join("/")),
            width: size.0,
            height: size.1,
            timestamp_s: (n - first) as f64 * frame_interval_s,
            sequence: sequence.clone(),
        });
        for (k, shape) in file.shapes.iter().enumerate() {
            let at =
                |why: String| err(json_path, None, format!("shape {k} ({:?}): {why}", shape.label));
            let class = class_of(&shape.label).ok_or_else(|| {
                at(format!(
                    "label {:?} is not a joca class; map it with --class {}=vehicle (or walker, \
                     traffic_sign, ignore)",
                    shape.label, shape.label
                ))
            })?;
            let bbox = shape_bounds(shape).and_then(|b| coco_box(b, size)).map_err(at)?;
            import.boxes.push(ImportedBox { frame, bbox, label: shape.label.clone(), class });
        }
    }
    Ok(import)
}
