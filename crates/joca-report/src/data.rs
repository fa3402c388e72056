//! What a report reads from a run directory: `results.json`, `events.jsonl` and
//! `test/showcase.json` (DESIGN.md's run directory). Only the fields reports use are typed;
//! newer fields are ignored, so old reports keep working.

use crate::ReportError;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A camera design as `results.json` stores it.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct Design {
    /// Forward position in the vehicle frame, m.
    pub x_m: f64,
    /// Height, m.
    pub z_m: f64,
    /// Focal length, mm.
    pub focal_length_mm: f64,
    /// Sensor name.
    pub sensor: String,
    /// Sensor width × height, mm.
    pub sensor_mm: (f64, f64),
    /// Pixel pitch, µm.
    pub pixel_pitch_um: f64,
    /// Whether the GA optimised the hardware (else it was fixed).
    pub optimised: bool,
}

impl Design {
    /// Horizontal field of view, radians.
    pub fn hfov_rad(&self) -> f64 {
        2.0 * (self.sensor_mm.0 / (2.0 * self.focal_length_mm)).atan()
    }
}

/// Test-town scores.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct Scores {
    /// COCO mAP@[.5:.95].
    pub map: f64,
    /// AP at IoU 0.5.
    pub ap50: f64,
    /// True positives over objects visible in the 180° field.
    pub tp_ratio: f64,
    /// Frames scored.
    pub frames: u64,
}

/// `results.json`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct Results {
    /// Method name.
    pub method: String,
    /// Scenario name.
    pub scenario: String,
    /// The tested design.
    pub design: Design,
    /// Test scores.
    pub test: Scores,
    /// Mean exposure (ms) and gain (dB) by illumination.
    pub settings_by_illumination: BTreeMap<String, (f64, f64)>,
    /// Output resolution factor.
    pub render_scale: f64,
    /// The test frames' source: `sim` (or empty, older runs), `folder:DIR` or `waymo:DIR`
    /// (real images).
    #[serde(default)]
    pub source: String,
}

impl Results {
    /// Whether the run was tested on recorded frames (the real-image mode).
    pub fn real_images(&self) -> bool {
        self.source.starts_with("folder:") || self.source.starts_with("waymo:")
    }
}

/// Best and mean hardware fitness of one generation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GenerationFitness {
    /// Generation, from 0.
    pub generation: u64,
    /// Best member.
    pub best: f64,
    /// Mean over members.
    pub mean: f64,
}

/// One logged training step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepLog {
    /// Global step.
    pub step: u64,
    /// Detector task loss.
    pub loss: f64,
    /// Exposure used, ms.
    pub exposure_ms: f64,
    /// Gain used, dB.
    pub gain_db: f64,
}

/// A ground-truth or detected box, pixels.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
pub struct Box2 {
    /// Left.
    pub x_min: f32,
    /// Top.
    pub y_min: f32,
    /// Right.
    pub x_max: f32,
    /// Bottom.
    pub y_max: f32,
}

/// A ground-truth object.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
pub struct Truth {
    /// Its box.
    pub bbox: Box2,
}

/// A detection.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
pub struct Detected {
    /// Its box.
    pub bbox: Box2,
    /// Confidence.
    pub score: f32,
}

/// One frame of a showcase sequence.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct ShowFrame {
    /// Simulation time, s.
    pub time_s: f64,
    /// Ambient light relative to daylight.
    pub ambient: f32,
    /// Exposure used, ms.
    pub exposure_ms: f64,
    /// Gain used, dB.
    pub gain_db: f64,
    /// Ground truth.
    pub boxes: Vec<Truth>,
    /// Detections.
    pub detections: Vec<Detected>,
    /// Saved PNG, relative to the run's `test/`.
    pub image: Option<String>,
}

/// A showcase sequence (`test/showcase.json`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct Showcase {
    /// `tunnel`, `day` or `night`.
    pub name: String,
    /// Frame size, pixels.
    pub size_px: (usize, usize),
    /// Frames in order.
    pub frames: Vec<ShowFrame>,
}

/// Everything a report uses from one run directory.
#[derive(Debug, Clone)]
pub struct RunData {
    /// The run directory.
    pub dir: PathBuf,
    /// `results.json`.
    pub results: Results,
    /// Hardware GA fitness per generation.
    pub generations: Vec<GenerationFitness>,
    /// Training steps as logged (every fifth), in step order.
    pub steps: Vec<StepLog>,
    /// Showcase sequences (empty for runs made before they existed).
    pub showcases: Vec<Showcase>,
}

impl RunData {
    /// Reads a finished run directory.
    pub fn load(dir: &Path) -> Result<Self, ReportError> {
        let results_path = dir.join("results.json");
        let results: Results = parse(&results_path, &read(&results_path)?)?;
        let (generations, steps) = match std::fs::read_to_string(dir.join("events.jsonl")) {
            Ok(text) => parse_events(&text),
            Err(_) => (Vec::new(), Vec::new()),
        };
        let show_path = dir.join("test").join("showcase.json");
        let showcases =
            if show_path.exists() { parse(&show_path, &read(&show_path)?)? } else { Vec::new() };
        Ok(Self { dir: dir.to_owned(), results, generations, steps, showcases })
    }

    /// The showcase sequence called `name`.
    pub fn showcase(&self, name: &str) -> Option<&Showcase> {
        self.showcases.iter().find(|s| s.name == name)
    }

    /// Path of a saved showcase frame.
    pub fn frame_path(&self, image: &str) -> PathBuf {
        self.dir.join("test").join(image)
    }
}

pub(crate) fn read(path: &Path) -> Result<String, ReportError> {
    std::fs::read_to_string(path)
        .map_err(|source| ReportError::Io { path: path.display().to_string(), source })
}

pub(crate) fn parse<T: serde::de::DeserializeOwned>(
    path: &Path,
    text: &str,
) -> Result<T, ReportError> {
    serde_json::from_str(text).map_err(|e| ReportError::Format {
        path: path.display().to_string(),
        reason: e.to_string(),
    })
}

/// Generation and step records of `events.jsonl`. A resumed run repeats the candidate it was
/// killed in, so a later record of the same step or generation replaces an earlier one;
/// unparsable lines (a line cut by the kill) are skipped.
fn parse_events(text: &str) -> (Vec<GenerationFitness>, Vec<StepLog>) {
    let mut generations = BTreeMap::new();
    let mut steps = BTreeMap::new();
    for line in text.lines() {
        let Ok(v) = serde_json::from_str::<serde_json::Value>(line) else { continue };
        if let (Some(g), Some(f)) = (v["generation_done"].as_u64(), v["fitness"].as_array()) {
            let f: Vec<f64> = f.iter().filter_map(serde_json::Value::as_f64).collect();
            if !f.is_empty() {
                let best = f.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                let mean = f.iter().sum::<f64>() / f.len() as f64;
                generations.insert(g, GenerationFitness { generation: g, best, mean });
            }
        } else if let (Some(step), Some(loss)) = (v["step"].as_u64(), v["loss"]["total"].as_f64()) {
            steps.insert(
                step,
                StepLog {
                    step,
                    loss,
                    exposure_ms: v["exposure_ms"].as_f64().unwrap_or(f64::NAN),
                    gain_db: v["gain_db"].as_f64().unwrap_or(f64::NAN),
                },
            );
        }
    }
    (generations.into_values().collect(), steps.into_values().collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_keep_the_last_record_of_a_repeated_step() {
        let text = "{\"step\":0,\"loss\":{\"total\":2.0},\"exposure_ms\":5.0,\"gain_db\":1.0}\n\
                    {\"step\":5,\"loss\":{\"total\":1.0},\"exposure_ms\":5.0,\"gain_db\":1.0}\n\
                    {\"step\":5,\"loss\":{\"tot\n\
                    {\"step\":5,\"loss\":{\"total\":0.5},\"exposure_ms\":4.0,\"gain_db\":2.0}\n\
                    {\"generation_done\":0,\"fitness\":[0.2,0.4]}\n";
        let (g, s) = parse_events(text);
        assert_eq!(
            g,
            vec![GenerationFitness { generation: 0, best: 0.4, mean: 0.30000000000000004 }]
        );
        assert_eq!(s.len(), 2);
        assert_eq!((s[1].step, s[1].loss, s[1].exposure_ms), (5, 0.5, 4.0));
    }
}
