//! The folder format for recorded sequences, as a [`joca_core::FrameSource`] (`source.rs`).
//!
//! A folder holds the frames (PNG or JPEG) and one COCO JSON file, `annotations.json`, whose
//! `images` carry, besides COCO's `id`, `file_name`, `width`, `height`:
//! - `timestamp_s` (required): capture time; frames of a sequence are ordered by it;
//! - `exposure_s` (required unless the source is given a default exposure): the recorded
//!   exposure time;
//! - `gain_db` (optional, default: the calibration gain G0);
//! - `sequence` (optional string, default one sequence): which drive the frame belongs to.
//!
//! `annotations` are COCO boxes (`[x, y, w, h]` in recorded pixels); `categories` map to joca's
//! classes by name (`vehicle`/`car`/`truck`/`bus`, `walker`/`pedestrian`/`person`/`cyclist`,
//! `traffic_sign`/`sign`) or by an explicit `"joca_class"` field (`vehicle`, `walker`,
//! `traffic_sign` or `ignore`).
//!
//! Emulation (the paper's real-image experiment): a recorded frame is linearised (a setting,
//! [`Linearize`]), put in calibrated units by `E0·G0 / (E_rec·G_rec)` (linear gains),
//! centre-cropped to the requested camera's aspect ratio and resized bilinearly to its pixel
//! grid; the motion blur of the requested exposure is added along the optical flow to the next
//! frame ([`crate::blur`]). Boxes are cropped and scaled with the image. Image formation then
//! adds the sensor's noise as for simulated frames.

mod coco;
mod source;
pub(crate) use coco::class_named;
pub use coco::inside as path_inside;

use crate::DataError;
use crate::blur::Linearize;
use crate::flow::{DisParams, DisPreset, Gray, dis};
use joca_core::{Annotation, BBox, Class, SourceError};
use serde::Deserialize;
use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::{Component, Path, PathBuf};
use std::sync::{Arc, Mutex};

joca_core::named_enum! {
    /// What to do with a frame that cannot be read or decoded.
    pub enum OnBadFrame("bad-frame policy") {
        /// Leave it out (with a warning) and go on.
        Skip = "skip",
        /// Stop with an error naming the frame.
        Stop = "stop",
    }
}

/// Settings of a [`Recording`].
#[derive(Debug, Clone, PartialEq)]
pub struct FolderConfig {
    /// How 8-bit values map to linear intensity.
    pub linearize: Linearize,
    /// Exposure of frames without `exposure_s`; `None` refuses such frames.
    pub default_exposure_s: Option<f64>,
    /// Calibration exposure E0, s.
    pub calibration_exposure_s: f64,
    /// Calibration gain G0, dB.
    pub calibration_gain_db: f64,
    /// Frames that fail to read.
    pub on_bad_frame: OnBadFrame,
    /// Optical flow for the motion blur.
    pub flow: DisParams,
}

impl Default for FolderConfig {
    fn default() -> Self {
        Self {
            linearize: Linearize::Srgb,
            default_exposure_s: None,
            calibration_exposure_s: 0.005,
            calibration_gain_db: 10.0,
            on_bad_frame: OnBadFrame::Stop,
            flow: DisParams::preset(DisPreset::Medium),
        }
    }
}

/// A recorded frame resized for one camera, with its ground truth moved along.
#[derive(Debug)]
struct Resized {
    image: image::RgbImage,
    boxes: Vec<Annotation>,
    ignore: Vec<Annotation>,
    /// Annotated objects in the whole recorded frame (the TP ratio's denominator).
    visible: u32,
}

/// Where a recorded frame's encoded image is.
#[derive(Debug, Clone)]
pub enum FrameOrigin {
    /// An image file (PNG or JPEG).
    File(PathBuf),
    /// Encoded bytes held in memory (a JPEG from a parquet file), with a label for messages.
    Encoded {
        /// How messages name the frame (file, segment, timestamp).
        label: String,
        /// The encoded image.
        bytes: Arc<Vec<u8>>,
    },
}

impl FrameOrigin {
    /// How messages name the frame.
    pub fn label(&self) -> String {
        match self {
            FrameOrigin::File(p) => p.display().to_string(),
            FrameOrigin::Encoded { label, .. } => label.clone(),
        }
    }

    /// Width and height from the header only (`what` names the frame in the error).
    pub(crate) fn dimensions(&self, what: &str) -> Result<(u32, u32), DataError> {
        use image::{ImageError, ImageReader};
        // Only the header is read: opening a folder must not read every frame in full.
        let size = match self {
            FrameOrigin::File(p) => ImageReader::open(p)
                .and_then(ImageReader::with_guessed_format)
                .map_err(ImageError::IoError)
                .and_then(ImageReader::into_dimensions),
            FrameOrigin::Encoded { bytes, .. } => {
                ImageReader::new(std::io::Cursor::new(bytes.as_slice()))
                    .with_guessed_format()
                    .map_err(ImageError::IoError)
                    .and_then(ImageReader::into_dimensions)
            }
        };
        size.map_err(|source| self.undecodable(what, source))
    }

    /// The decoded image.
    fn decode(&self) -> Result<image::RgbImage, DataError> {
        let image = match self {
            FrameOrigin::File(p) => image::open(p),
            FrameOrigin::Encoded { bytes, .. } => image::load_from_memory(bytes),
        };
        image.map(|i| i.to_rgb8()).map_err(|source| self.undecodable("the frame", source))
    }

    fn undecodable(&self, what: &str, source: image::ImageError) -> DataError {
        DataError::Image { path: PathBuf::from(self.label()), what: what.into(), source }
    }
}

/// One recorded frame.
#[derive(Debug, Clone)]
pub struct RecordedFrame {
    /// Its encoded image.
    pub origin: FrameOrigin,
    /// Capture time, s.
    pub timestamp_s: f64,
    /// Recorded exposure, s.
    pub exposure_s: f64,
    /// Recorded gain, dB.
    pub gain_db: f64,
    /// Size, pixels.
    pub size_px: (u32, u32),
    /// Ground truth in recorded pixels.
    pub boxes: Vec<Annotation>,
    /// Ignore regions in recorded pixels (COCO `iscrowd = 1`).
    pub ignore: Vec<Annotation>,
}

/// Decoded, resized frames and flows, by (sequence, frame, width, height).
type Cache<T> = Mutex<HashMap<(usize, usize, usize, usize), Arc<T>>>;

/// Recorded sequences from a folder, as a frame source.
#[derive(Debug)]
pub struct Recording {
    dir: PathBuf,
    sequences: Vec<Vec<RecordedFrame>>,
    frame_interval_s: f64,
    config: FolderConfig,
    /// `config.linearize` of every 8-bit value.
    linear: [f32; 256],
    frames: Cache<Resized>,
    flows: Cache<crate::flow::Flow>,
    /// Frames left out while opening (with `OnBadFrame::Skip`), with the reason.
    pub skipped: Vec<String>,
}

/// Checks a frame's header against the size its metadata claims.
pub(crate) fn check_header(
    origin: &FrameOrigin,
    claimed: (u32, u32),
    id: impl std::fmt::Display,
) -> Result<(), DataError> {
    let size = origin.dimensions(&format!("frame {id}"))?;
    if size == claimed {
        return Ok(());
    }
    Err(DataError::invalid(
        Path::new(&origin.label()),
        format!(
            "frame {id} is {}×{} but its metadata says {}×{}",
            size.0, size.1, claimed.0, claimed.1
        ),
    ))
}

/// What is wrong in `path` (a content error, no underlying cause), as a frame source's error.
pub(crate) fn bad(path: &Path, reason: impl Into<String>) -> SourceError {
    DataError::invalid(path, reason).into()
}

impl Recording {
    /// A recording from frames grouped by sequence (any order inside a sequence).
    pub(crate) fn from_sequences(
        dir: &Path,
        sequences: Vec<Vec<RecordedFrame>>,
        config: FolderConfig,
        skipped: Vec<String>,
    ) -> Result<Self, SourceError> {
        let mut sequences: Vec<Vec<RecordedFrame>> =
            sequences.into_iter().filter(|s| s.len() >= 2).collect();
        for s in &mut sequences {
            s.sort_by(|a, b| a.timestamp_s.total_cmp(&b.timestamp_s));
        }
        if sequences.is_empty() {
            return Err(
                DataError::invalid(dir, "no sequence with at least 2 readable frames").into()
            );
        }
        let mut gaps: Vec<f64> = sequences
            .iter()
            .flat_map(|s| s.windows(2).map(|w| w[1].timestamp_s - w[0].timestamp_s))
            .collect();
        gaps.sort_by(f64::total_cmp);
        let frame_interval_s = gaps[gaps.len() / 2];
        if frame_interval_s.is_nan() || frame_interval_s <= 0.0 {
            return Err(DataError::invalid(
                dir,
                "frames of a sequence share timestamps; timestamps must increase",
            )
            .into());
        }
        Ok(Self {
            dir: dir.to_owned(),
            sequences,
            frame_interval_s,
            linear: config.linearize.table(),
            config,
            frames: Mutex::default(),
            flows: Mutex::default(),
            skipped,
        })
    }

    /// The sequences, each in time order.
    pub fn sequences(&self) -> &[Vec<RecordedFrame>] {
        &self.sequences
    }

    /// The largest recorded frame size: the design space keeps sensors whose grid fits inside.
    pub fn recording_size_px(&self) -> (u32, u32) {
        self.sequences
            .iter()
            .flatten()
            .fold((0, 0), |a, f| (a.0.max(f.size_px.0), a.1.max(f.size_px.1)))
    }

    /// Frames in all sequences.
    pub fn len(&self) -> usize {
        self.sequences.iter().map(Vec::len).sum()
    }

    /// Whether the source holds no frame (never true for an opened source).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Length of the sequence that episode `episode` plays, s.
    pub fn duration_s(&self, episode: u64) -> f64 {
        let seq = &self.sequences[(episode % self.sequences.len() as u64) as usize];
        seq[seq.len() - 1].timestamp_s - seq[0].timestamp_s
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Frame `k` of sequence `s` cropped to the aspect ratio of `w × h` and resized to it, with
    /// its boxes (those left under the minimum size become ignore regions), its ignore regions,
    /// and the number of annotated objects in the whole recorded frame.
    fn resized(&self, s: usize, k: usize, w: usize, h: usize) -> Result<Arc<Resized>, SourceError> {
        let key = (s, k, w, h);
        if let Some(hit) =
            self.frames.lock().unwrap_or_else(std::sync::PoisonError::into_inner).get(&key)
        {
            return Ok(hit.clone());
        }
        let rec = &self.sequences[s][k];
        let img = rec.origin.decode()?;
        let (rw, rh) = (img.width() as f64, img.height() as f64);
        // Centre crop to the target aspect ratio.
        let target = w as f64 / h as f64;
        let (cw, ch) = if rw / rh > target { (rh * target, rh) } else { (rw, rw / target) };
        let (cx, cy) = ((rw - cw) / 2.0, (rh - ch) / 2.0);
        let crop = image::imageops::crop_imm(
            &img,
            cx.round() as u32,
            cy.round() as u32,
            cw.round() as u32,
            ch.round() as u32,
        )
        .to_image();
        let resized = image::imageops::resize(
            &crop,
            w as u32,
            h as u32,
            image::imageops::FilterType::Triangle,
        );
        let (sx, sy) = (w as f32 / cw as f32, h as f32 / ch as f32);
        let moved = |b: BBox| {
            BBox::new(
                ((b.x_min - cx as f32) * sx).clamp(0.0, w as f32),
                ((b.y_min - cy as f32) * sy).clamp(0.0, h as f32),
                ((b.x_max - cx as f32) * sx).clamp(0.0, w as f32),
                ((b.y_max - cy as f32) * sy).clamp(0.0, h as f32),
            )
        };
        let (mut boxes, mut ignore) = (Vec::new(), Vec::new());
        // Every annotated object inside the crop is a reference object whatever its size after
        // resizing (training applies its own size rule); one cropped away is gone.
        for a in &rec.boxes {
            let bbox = moved(a.bbox);
            if bbox.width() > 0.0 && bbox.height() > 0.0 {
                boxes.push(Annotation { bbox, ..*a });
            }
        }
        ignore.extend(
            rec.ignore
                .iter()
                .map(|a| Annotation::new(moved(a.bbox), a.class))
                .filter(|a| a.bbox.width() > 0.0 && a.bbox.height() > 0.0),
        );
        let entry =
            Arc::new(Resized { image: resized, boxes, ignore, visible: rec.boxes.len() as u32 });
        let mut cache = self.frames.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if cache.len() > 64 {
            cache.clear();
        }
        cache.insert(key, entry.clone());
        Ok(entry)
    }

    fn flow(
        &self,
        s: usize,
        k: usize,
        w: usize,
        h: usize,
    ) -> Result<Arc<crate::flow::Flow>, SourceError> {
        let key = (s, k, w, h);
        if let Some(hit) =
            self.flows.lock().unwrap_or_else(std::sync::PoisonError::into_inner).get(&key)
        {
            return Ok(hit.clone());
        }
        let a = self.resized(s, k, w, h)?;
        let b = self.resized(s, k + 1, w, h)?;
        let gray = |img: &image::RgbImage| Gray::from_rgb_bytes(w, h, img.as_raw());
        let flow = Arc::new(dis(&gray(&a.image), &gray(&b.image), &self.config.flow));
        let mut cache = self.flows.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if cache.len() > 64 {
            cache.clear();
        }
        cache.insert(key, flow.clone());
        Ok(flow)
    }
}
