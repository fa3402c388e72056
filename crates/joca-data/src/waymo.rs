//! Waymo Open Dataset v2 (parquet) as a [`Recording`].
//!
//! `DIR/camera_image/*.parquet` rows give, per segment, frame and camera, the JPEG
//! (`[CameraImageComponent].image`) and the exposure in seconds
//! (`[CameraImageComponent].rolling_shutter_params.shutter`); `DIR/camera_box/*.parquet` rows
//! give the 2D boxes (`[CameraBoxComponent].box.center.x/.y`, `.box.size.x/.y`, pixels) and
//! their `[CameraBoxComponent].type` (1 vehicle, 2 pedestrian, 3 sign, 4 cyclist; cyclists count
//! as walkers, other types are ignored). Rows join on `key.segment_context_name`,
//! `key.frame_timestamp_micros` and `key.camera_name`; one camera is kept (FRONT_LEFT = 2 by
//! default, the paper's). Each segment is a sequence. The kept camera's JPEGs are held in memory
//! (about 60 MB per 20 s segment).

use crate::DataError;
use crate::folder::{FolderConfig, FrameOrigin, OnBadFrame, RecordedFrame, Recording, bad};
use joca_core::{Annotation, BBox, Class, SourceError};
use parquet::file::reader::{FileReader, SerializedFileReader};
use parquet::record::Field;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

const SEGMENT: &str = "key.segment_context_name";
const TIMESTAMP: &str = "key.frame_timestamp_micros";
const CAMERA: &str = "key.camera_name";
const IMAGE: &str = "[CameraImageComponent].image";
const SHUTTER: &str = "[CameraImageComponent].rolling_shutter_params.shutter";
const CENTER_X: &str = "[CameraBoxComponent].box.center.x";
const CENTER_Y: &str = "[CameraBoxComponent].box.center.y";
const SIZE_X: &str = "[CameraBoxComponent].box.size.x";
const SIZE_Y: &str = "[CameraBoxComponent].box.size.y";
const TYPE: &str = "[CameraBoxComponent].type";

/// The camera of the paper's real-image experiment.
pub const FRONT_LEFT: i64 = 2;

fn parquet_files(dir: &Path) -> Result<Vec<PathBuf>, SourceError> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(DataError::io(dir, "list the folder"))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "parquet"))
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(bad(dir, "no .parquet files"));
    }
    Ok(files)
}

/// A row as column name → value, borrowed from the reader (JPEG bytes are not copied).
type Row<'a> = HashMap<&'a str, &'a Field>;

/// Calls `f` on every row of `path` restricted to `columns` (each must exist). Rows are streamed:
/// a camera_image file holds every camera's JPEGs and only the kept camera's are copied.
fn for_each_row(
    path: &Path,
    columns: &[&str],
    mut f: impl FnMut(&Row<'_>) -> Result<(), SourceError>,
) -> Result<(), SourceError> {
    let file = std::fs::File::open(path).map_err(DataError::io(path, "open"))?;
    let reader = SerializedFileReader::new(file).map_err(DataError::parquet(path))?;
    let schema = reader.metadata().file_metadata().schema_descr_ptr();
    let fields = schema.root_schema().get_fields();
    let mut projected = Vec::new();
    for &c in columns {
        let field = fields.iter().find(|f| f.name() == c).ok_or_else(|| {
            bad(
                path,
                format!(
                    "no column `{c}` (is this a Waymo Open Dataset v2 file of the right component?)"
                ),
            )
        })?;
        projected.push(field.clone());
    }
    let projection = parquet::schema::types::Type::group_type_builder("schema")
        .with_fields(projected)
        .build()
        .map_err(DataError::parquet(path))?;
    let iter = reader.get_row_iter(Some(projection)).map_err(DataError::parquet(path))?;
    for row in iter {
        let row = row.map_err(DataError::parquet(path))?;
        let fields: Row<'_> = row.get_column_iter().map(|(n, v)| (n.as_str(), v)).collect();
        f(&fields)?;
    }
    Ok(())
}

fn int(row: &Row<'_>, c: &str, path: &Path) -> Result<i64, SourceError> {
    match row.get(c).copied() {
        Some(Field::Byte(v)) => Ok(i64::from(*v)),
        Some(Field::Short(v)) => Ok(i64::from(*v)),
        Some(Field::Int(v)) => Ok(i64::from(*v)),
        Some(Field::Long(v)) => Ok(*v),
        Some(Field::UByte(v)) => Ok(i64::from(*v)),
        Some(Field::UShort(v)) => Ok(i64::from(*v)),
        Some(Field::UInt(v)) => Ok(i64::from(*v)),
        other => Err(bad(path, format!("column `{c}`: expected an integer, found {other:?}"))),
    }
}

fn float(row: &Row<'_>, c: &str, path: &Path) -> Result<f64, SourceError> {
    match row.get(c).copied() {
        Some(Field::Float(v)) => Ok(f64::from(*v)),
        Some(Field::Double(v)) => Ok(*v),
        other => Err(bad(path, format!("column `{c}`: expected a number, found {other:?}"))),
    }
}

fn text(row: &Row<'_>, c: &str, path: &Path) -> Result<String, SourceError> {
    match row.get(c).copied() {
        Some(Field::Str(v)) => Ok(v.clone()),
        Some(Field::Bytes(v)) => Ok(String::from_utf8_lossy(v.data()).into_owned()),
        other => Err(bad(path, format!("column `{c}`: expected a string, found {other:?}"))),
    }
}

impl Recording {
    /// Opens a Waymo v2 directory (`camera_image/`, `camera_box/`) keeping camera `camera_name`.
    pub fn open_waymo(
        dir: &Path,
        camera_name: i64,
        config: FolderConfig,
    ) -> Result<Self, SourceError> {
        // Boxes by (segment, timestamp).
        let mut boxes: HashMap<(String, i64), Vec<Annotation>> = HashMap::new();
        for path in parquet_files(&dir.join("camera_box"))? {
            let cols = [SEGMENT, TIMESTAMP, CAMERA, CENTER_X, CENTER_Y, SIZE_X, SIZE_Y, TYPE];
            for_each_row(&path, &cols, |row| {
                if int(row, CAMERA, &path)? != camera_name {
                    return Ok(());
                }
                let class = match int(row, TYPE, &path)? {
                    1 => Class::Vehicle,
                    2 | 4 => Class::Walker,
                    3 => Class::TrafficSign,
                    _ => return Ok(()),
                };
                let (cx, cy) = (float(row, CENTER_X, &path)?, float(row, CENTER_Y, &path)?);
                let (w, h) = (float(row, SIZE_X, &path)?, float(row, SIZE_Y, &path)?);
                let bbox = BBox::new(
                    (cx - w / 2.0) as f32,
                    (cy - h / 2.0) as f32,
                    (cx + w / 2.0) as f32,
                    (cy + h / 2.0) as f32,
                );
                let key = (text(row, SEGMENT, &path)?, int(row, TIMESTAMP, &path)?);
                boxes.entry(key).or_default().push(Annotation::new(bbox, class));
                Ok(())
            })?;
        }
        let mut sequences: BTreeMap<String, Vec<RecordedFrame>> = BTreeMap::new();
        let mut skipped = Vec::new();
        for path in parquet_files(&dir.join("camera_image"))? {
            for_each_row(&path, &[SEGMENT, TIMESTAMP, CAMERA, IMAGE, SHUTTER], |row| {
                if int(row, CAMERA, &path)? != camera_name {
                    return Ok(());
                }
                let segment = text(row, SEGMENT, &path)?;
                let micros = int(row, TIMESTAMP, &path)?;
                let label = format!(
                    "{} (segment {segment}, timestamp {micros} µs, camera {camera_name})",
                    path.display()
                );
                let bytes = match row.get(IMAGE).copied() {
                    Some(Field::Bytes(b)) => b.data().to_vec(),
                    other => {
                        return Err(bad(
                            &path,
                            format!("column `{IMAGE}`: expected JPEG bytes, found {other:?}"),
                        ));
                    }
                };
                let shutter = float(row, SHUTTER, &path)?;
                let exposure_s = if shutter > 0.0 {
                    shutter
                } else {
                    config.default_exposure_s.ok_or_else(|| {
                        bad(
                            &path,
                            format!(
                                "{label} has no usable exposure ({SHUTTER} = {shutter}); set a \
                                 default exposure (--default-exposure-ms)"
                            ),
                        )
                    })?
                };
                let origin = FrameOrigin::Encoded { label: label.clone(), bytes: Arc::new(bytes) };
                // The size comes from the JPEG's header; a frame that does not decode is handled
                // as configured.
                let size = match origin.dimensions("the JPEG") {
                    Ok(size) => size,
                    Err(e) => match config.on_bad_frame {
                        OnBadFrame::Stop => return Err(e.into()),
                        OnBadFrame::Skip => {
                            skipped.push(e.with_causes());
                            return Ok(());
                        }
                    },
                };
                sequences.entry(segment.clone()).or_default().push(RecordedFrame {
                    origin,
                    timestamp_s: micros as f64 * 1e-6,
                    exposure_s,
                    gain_db: config.calibration_gain_db,
                    size_px: size,
                    boxes: boxes.remove(&(segment, micros)).unwrap_or_default(),
                    ignore: Vec::new(),
                });
                Ok(())
            })?;
        }
        Self::from_sequences(dir, sequences.into_values().collect(), config, skipped)
    }
}
