//! What a report reads from a run directory: `results.json`, `events.jsonl` and
//! `test/showcase.json` (docs/design.md's run directory), in the record types `joca-train` writes
//! them with (`joca_record`).

use crate::ReportError;
use crate::event_log::{GenerationFitness, StepLog, parse_events, wall_of, warm_start_of};
use joca_record::{Retest, RunResults, Showcase};
use std::path::{Path, PathBuf};

/// Everything a report uses from one run directory.
#[derive(Debug, Clone)]
pub struct RunData {
    /// The run directory.
    pub dir: PathBuf,
    /// The folder of the test the showcases come from, inside `dir` (`test`, or a re-test's
    /// `test-<tags>`).
    pub test_dir: String,
    /// `results.json`.
    pub results: RunResults,
    /// Hardware GA fitness per generation.
    pub generations: Vec<GenerationFitness>,
    /// Training steps as logged (every fifth), in step order.
    pub steps: Vec<StepLog>,
    /// Showcase sequences (empty for runs made before they existed).
    pub showcases: Vec<Showcase>,
    /// `events.jsonl` lines (1-based) that could not be read and were left out.
    pub skipped_events: Vec<usize>,
    /// NeuralAE's warm start, where the run had one.
    pub warm_start: Option<joca_record::WarmStartRecord>,
    /// Wall time by part of the run, seconds, summed over the processes that recorded it
    /// (`events.jsonl`; empty for runs made before it was recorded).
    pub wall: Vec<(joca_record::RunPhase, f64)>,
}

impl RunData {
    /// Reads a finished run directory.
    pub fn load(dir: &Path) -> Result<Self, ReportError> {
        let results_path = dir.join("results.json");
        let results: RunResults = parse(&results_path, &read(&results_path)?)?;
        results.check_version().map_err(|reason| ReportError::Format {
            path: results_path.display().to_string(),
            reason,
        })?;
        let events_path = dir.join("events.jsonl");
        let bytes = match std::fs::read(&events_path) {
            Ok(bytes) => bytes,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
            Err(source) => {
                return Err(ReportError::Io { path: events_path.display().to_string(), source });
            }
        };
        let (generations, steps, skipped_events) = parse_events(&bytes);
        let warm_start = warm_start_of(&bytes);
        let wall = wall_of(&bytes);
        let show_path = dir.join("test").join("showcase.json");
        let showcases =
            if show_path.exists() { parse(&show_path, &read(&show_path)?)? } else { Vec::new() };
        Ok(Self {
            dir: dir.to_owned(),
            test_dir: "test".into(),
            results,
            generations,
            steps,
            showcases,
            skipped_events,
            warm_start,
            wall,
        })
    }

    /// The run's test repeated with another controller on the same design and detector
    /// (`results-<tag>.json` and `test-<tag>/`, as `joca eval --controller` and a NeuralAE run's
    /// own end write them), without training records (nor showcases where its test folder is
    /// gone, as in compact records); `None` where the run has none.
    pub fn retest(dir: &Path, retest: &Retest) -> Result<Option<Self>, ReportError> {
        Self::retest_tag(dir, &retest.to_string())
    }

    /// [`Self::retest`] by the tag of its files, `results-<tag>.json`.
    pub fn retest_tag(dir: &Path, tag: &str) -> Result<Option<Self>, ReportError> {
        let results_path = dir.join(format!("results-{tag}.json"));
        let show_path = dir.join(format!("test-{tag}")).join("showcase.json");
        if !results_path.exists() {
            return Ok(None);
        }
        let results: RunResults = parse(&results_path, &read(&results_path)?)?;
        results.check_version().map_err(|reason| ReportError::Format {
            path: results_path.display().to_string(),
            reason,
        })?;
        Ok(Some(Self {
            dir: dir.to_owned(),
            test_dir: format!("test-{tag}"),
            results,
            generations: Vec::new(),
            steps: Vec::new(),
            // Compact records (results only) have no showcases: what needs them is left out.
            showcases: if show_path.exists() {
                parse(&show_path, &read(&show_path)?)?
            } else {
                Vec::new()
            },
            skipped_events: Vec::new(),
            warm_start: None,
            wall: Vec::new(),
        }))
    }

    /// A sentence naming the `events.jsonl` lines left out, if any.
    pub fn skipped_events_note(&self) -> Option<String> {
        let lines = &self.skipped_events;
        let (first, more) = (lines.iter().take(8), lines.len().saturating_sub(8));
        let mut list = first.map(ToString::to_string).collect::<Vec<_>>().join(", ");
        if more > 0 {
            list.push_str(&format!(" and {more} more"));
        }
        (!lines.is_empty()).then(|| {
            format!(
                "{}: {} line(s) could not be read and are left out of the figures (line {list}; a \
                 run killed while writing leaves one cut line per resume)",
                self.dir.join("events.jsonl").display(),
                lines.len()
            )
        })
    }

    /// The showcase sequence called `name`.
    pub fn showcase(&self, name: &str) -> Option<&Showcase> {
        self.showcases.iter().find(|s| s.name == name)
    }

    /// Path of a saved showcase frame.
    pub fn frame_path(&self, image: &str) -> PathBuf {
        self.dir.join(&self.test_dir).join(image)
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

#[cfg(test)]
mod tests {
    use super::*;
    use joca_record::Light;

    #[test]
    fn results_of_an_unknown_layout_are_refused_and_older_ones_read() {
        let dir = tempfile::tempdir().unwrap();
        let mut value = serde_json::to_value(crate::table::tests::results(0.2, 0.3, true)).unwrap();
        let path = dir.path().join("results.json");
        // Written before the field existed: version 0, read.
        value.as_object_mut().unwrap().remove("format_version");
        std::fs::write(&path, value.to_string()).unwrap();
        assert_eq!(RunData::load(dir.path()).unwrap().results.format_version, 0);
        // A newer layout: refused, naming the file and both versions.
        value["format_version"] = 11.into();
        std::fs::write(&path, value.to_string()).unwrap();
        let e = RunData::load(dir.path()).unwrap_err().to_string();
        assert!(e.contains("results.json") && e.contains("format_version 11 is newer"), "{e}");
        assert!(e.contains("0 to 10"), "{e}");
        // Layout 2 (lens, weather, f-number) is read.
        value["format_version"] = 2.into();
        value["weather"] = "fog:300".into();
        std::fs::write(&path, value.to_string()).unwrap();
        let r = RunData::load(dir.path()).unwrap().results;
        assert_eq!((r.format_version, r.weather.to_string()), (2, "fog:300".to_owned()));
        // Layout 3 (the iris set by NeuralAE) is read.
        value["format_version"] = 3.into();
        value["lens"] = "thin".into();
        value["aperture"] = "dynamic".into();
        value["f_number_by_illumination"] = serde_json::json!({ "day": 8.0, "night": 1.4 });
        value["settings_by_illumination"] =
            serde_json::json!({ "day": [5.0, 3.0], "night": [40.0, 20.0] });
        std::fs::write(&path, value.to_string()).unwrap();
        let r = RunData::load(dir.path()).unwrap().results;
        assert_eq!((r.format_version, r.aperture.to_string()), (3, "dynamic".to_owned()));
        let stops: Vec<_> = r.by_illumination.f_numbers().collect();
        assert_eq!(stops, [(Light::Day, 8.0), (Light::Night, 1.4)]);
        assert_eq!(r.layout_version(), 3);
        // Layout 4 (cast shadows) is read.
        value["format_version"] = 4.into();
        value["cast_shadows"] = true.into();
        std::fs::write(&path, value.to_string()).unwrap();
        let r = RunData::load(dir.path()).unwrap().results;
        assert_eq!((r.format_version, r.world.cast_shadows, r.layout_version()), (4, true, 4));
        // The report's "Test on …" line names the light (a low sun too).
        value["sun_elevation"] = serde_json::json!({ "min_deg": 10.0, "max_deg": 20.0 });
        std::fs::write(&path, value.to_string()).unwrap();
        let r = RunData::load(dir.path()).unwrap().results;
        assert!(
            r.conditions_note().ends_with(", the sun casting shadows, the sun at 10–20° elevation")
        );
        // Layout 5 (veiling glare) is read and named.
        value["format_version"] = 5.into();
        value["glare"] = serde_json::json!({ "fraction": 0.02, "scale_deg": 1.5 });
        value["sun_disc"] = true.into();
        std::fs::write(&path, value.to_string()).unwrap();
        let r = RunData::load(dir.path()).unwrap().results;
        assert_eq!((r.format_version, r.layout_version()), (5, 5));
        let note = r.conditions_note();
        assert!(
            note.ends_with(", the sun's disc in the sky, veiling glare 2 % (scale 1.5°)"),
            "{note}"
        );
        // Layout 6 (the networks on a GPU) is read, and the report's machine line names it.
        value["format_version"] = 6.into();
        value["cpu"] = "AMD EPYC (AVX2, FMA)".into();
        value["device"] = "cuda:0: NVIDIA H100 80GB HBM3, 79.2 GiB, driver CUDA 13.0".into();
        std::fs::write(&path, value.to_string()).unwrap();
        let r = RunData::load(dir.path()).unwrap().results;
        assert_eq!((r.format_version, r.layout_version()), (6, 6));
        let line = crate::sections::machine_line(&r);
        assert!(
            line.contains("AMD EPYC (AVX2, FMA)")
                && line.contains("networks on cuda:0: NVIDIA H100"),
            "{line}"
        );
        // Layout 7 (tunnels as places) is read and named; the defaults fill a partial table.
        value["format_version"] = 7.into();
        value["tunnels"] = serde_json::json!({ "kind": "places", "count": 4 });
        std::fs::write(&path, value.to_string()).unwrap();
        let r = RunData::load(dir.path()).unwrap().results;
        assert_eq!((r.format_version, r.layout_version()), (7, 7));
        let note = r.conditions_note();
        assert!(
            note.contains(", tunnels as places (4 covered blocks a town, lamps at 0.01"),
            "{note}"
        );
        // Layout 8 (a clear sky's daylight) is read and named.
        value["format_version"] = 8.into();
        value["sun_elevation"] =
            serde_json::json!({ "min_deg": 5.0, "max_deg": 20.0, "daylight": "clear-sky" });
        std::fs::write(&path, value.to_string()).unwrap();
        let r = RunData::load(dir.path()).unwrap().results;
        assert_eq!((r.format_version, r.layout_version()), (8, 8));
        let note = r.conditions_note();
        assert!(note.contains("the sun at 5–20° elevation (clear-sky daylight)"), "{note}");
        // Layout 9 (tunnel drives in one direction) is read and named.
        value["format_version"] = 9.into();
        value["tunnels"] = serde_json::json!({ "kind": "places", "drives": "leaving" });
        std::fs::write(&path, value.to_string()).unwrap();
        let r = RunData::load(dir.path()).unwrap().results;
        assert_eq!((r.format_version, r.layout_version()), (9, 9));
        let note = r.conditions_note();
        assert!(note.contains("lamps at 0.01 of daylight, drives leaving)"), "{note}");
        // Layout 10 (dark streets) is read and named.
        value["format_version"] = 10.into();
        value["dark_streets"] = true.into();
        std::fs::write(&path, value.to_string()).unwrap();
        let r = RunData::load(dir.path()).unwrap().results;
        assert_eq!((r.format_version, r.layout_version()), (10, 10));
        let note = r.conditions_note();
        assert!(note.contains(", the street lamps dark at night"), "{note}");
    }
}
