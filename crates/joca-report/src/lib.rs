//! Reports that read run directories only — they never run anything.
//!
//! [`write_run_report`] turns a `joca run` directory (`results.json`, `events.jsonl`) into
//! `report.md`: the result table laid out like the paper's (camera parameters with optimised or
//! fixed marked, mAP and TP ratio), the exposure and gain the controller chose by illumination,
//! and the hardware GA's best and mean fitness per generation.
//!
//! ```no_run
//! let text = joca_report::write_run_report(std::path::Path::new("runs/quick-joca-calibrated")).unwrap();
//! assert!(text.contains("| method |"));
//! ```
#![deny(missing_docs)]

use serde_json::Value;
use std::fmt::Write as _;
use std::path::Path;
use thiserror::Error;

/// Why a report could not be made.
#[derive(Debug, Error)]
pub enum ReportError {
    /// A run file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// A run file is not what `joca run` writes.
    #[error("{path} is not a joca run file: {reason}")]
    Format {
        /// The file.
        path: String,
        /// What is wrong.
        reason: String,
    },
}

fn read(path: &Path) -> Result<String, ReportError> {
    std::fs::read_to_string(path)
        .map_err(|source| ReportError::Io { path: path.display().to_string(), source })
}

fn num(v: &Value, key: &str) -> f64 {
    v.get(key).and_then(Value::as_f64).unwrap_or(f64::NAN)
}

/// Writes `report.md` into `run_dir` and returns its text.
pub fn write_run_report(run_dir: &Path) -> Result<String, ReportError> {
    let results_path = run_dir.join("results.json");
    let results: Value = serde_json::from_str(&read(&results_path)?).map_err(|e| {
        ReportError::Format { path: results_path.display().to_string(), reason: e.to_string() }
    })?;
    let d = &results["design"];
    let t = &results["test"];
    let mark = if d["optimised"].as_bool().unwrap_or(false) { "optimised" } else { "fixed" };
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# joca run: {} / {}\n",
        results["method"].as_str().unwrap_or("?"),
        results["scenario"].as_str().unwrap_or("?")
    );
    let _ = writeln!(
        md,
        "Camera parameters are {mark}. Test on the test town, closed loop, {} frames; render scale {}.\n",
        t["frames"], results["render_scale"]
    );
    let _ = writeln!(
        md,
        "| method | scenario | x (m) | z (m) | f (mm) | W×H (mm) | p (µm) | sensor | mAP@[.5:.95] | AP50 | TP/All@180° |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|---|---|");
    let _ = writeln!(
        md,
        "| {} | {} | {:.2} | {:.2} | {:.2} | {:.2}×{:.2} | {:.2} | {} | {:.3} | {:.3} | {:.3} |\n",
        results["method"].as_str().unwrap_or("?"),
        results["scenario"].as_str().unwrap_or("?"),
        num(d, "x_m"),
        num(d, "z_m"),
        num(d, "focal_length_mm"),
        d["sensor_mm"][0].as_f64().unwrap_or(f64::NAN),
        d["sensor_mm"][1].as_f64().unwrap_or(f64::NAN),
        num(d, "pixel_pitch_um"),
        d["sensor"].as_str().unwrap_or("?"),
        num(t, "map"),
        num(t, "ap50"),
        num(t, "tp_ratio"),
    );
    if let Some(settings) = results["settings_by_illumination"].as_object() {
        let _ = writeln!(
            md,
            "## Exposure and gain on the test town\n\n| illumination | mean E (ms) | mean G (dB) |\n|---|---|---|"
        );
        for (light, v) in settings {
            let _ = writeln!(
                md,
                "| {light} | {:.2} | {:.1} |",
                v[0].as_f64().unwrap_or(f64::NAN),
                v[1].as_f64().unwrap_or(f64::NAN)
            );
        }
        md.push('\n');
    }
    let events_path = run_dir.join("events.jsonl");
    if let Ok(events) = read(&events_path) {
        let mut rows = Vec::new();
        for line in events.lines() {
            let Ok(v) = serde_json::from_str::<Value>(line) else { continue };
            if let (Some(g), Some(f)) = (v["generation_done"].as_u64(), v["fitness"].as_array()) {
                let f: Vec<f64> = f.iter().filter_map(Value::as_f64).collect();
                if f.is_empty() {
                    continue;
                }
                let best = f.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                rows.push((g, best, f.iter().sum::<f64>() / f.len() as f64));
            }
        }
        if !rows.is_empty() {
            let _ = writeln!(
                md,
                "## Hardware GA fitness (mAP + 1.1 × TP ratio over each candidate's frames)\n\n| generation | best | mean |\n|---|---|---|"
            );
            for (g, best, mean) in rows {
                let _ = writeln!(md, "| {g} | {best:.3} | {mean:.3} |");
            }
        }
    }
    let out = run_dir.join("report.md");
    std::fs::write(&out, &md)
        .map_err(|source| ReportError::Io { path: out.display().to_string(), source })?;
    Ok(md)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn report_from_a_run_directory() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("results.json"),
            r#"{"method":"joca","scenario":"blur4","design":{"x_m":1.35,"z_m":1.3,"focal_length_mm":5.19,"sensor":"IMX178","sensor_mm":[7.3728,4.9152],"pixel_pitch_um":2.4,"optimised":true},
               "test":{"map":0.325,"ap50":0.6,"tp_ratio":0.39,"true_positives":39,"visible_180":100,"frames":1000},
               "settings_by_illumination":{"day":[3.0,12.5]},"best_fitness":0.8,"render_scale":0.08}"#,
        )
        .unwrap();
        std::fs::write(
            dir.path().join("events.jsonl"),
            "{\"step\":0}\n{\"generation_done\":0,\"fitness\":[0.2,0.4]}\nnot json\n",
        )
        .unwrap();
        let md = write_run_report(dir.path()).unwrap();
        assert!(md.contains("| joca | blur4 | 1.35 | 1.30 | 5.19 | 7.37×4.92 | 2.40 | IMX178 | 0.325 | 0.600 | 0.390 |"), "{md}");
        assert!(md.contains("| day | 3.00 | 12.5 |"));
        assert!(md.contains("| 0 | 0.400 | 0.300 |"));
        assert_eq!(std::fs::read_to_string(dir.path().join("report.md")).unwrap(), md);
        let missing = write_run_report(&dir.path().join("nope")).unwrap_err().to_string();
        assert!(missing.contains("results.json"), "{missing}");
    }
}
