//! Tests of the result tables, and the results other modules' tests build on.

use super::*;
use joca_record::{DesignSummary, Method, Scenario, TaskScores};

/// A calibrated row of `label` (method `method`) on panel design `design` (empty: none) and
/// seed `seed`, scoring `map`.
pub(crate) fn row(label: &str, method: Method, design: &str, seed: u64, map: f64) -> Row {
    let mut r = results(map, 0.3, false);
    (r.method, r.seed) = (method, seed);
    Row {
        group: "Calibrated".into(),
        label: label.into(),
        cell: format!("{label}-{design}-s{seed}"),
        design: design.into(),
        results: r,
    }
}

pub(crate) fn results(map: f64, tp: f64, optimised: bool) -> RunResults {
    RunResults {
        format_version: joca_record::RESULTS_FORMAT_VERSION,
        method: Method::Joca,
        scenario: Scenario::Calibrated,
        seed: 0,
        design: DesignSummary {
            x_m: 1.35,
            z_m: 1.3,
            focal_length_mm: 5.19,
            sensor: "IMX178".into(),
            sensor_mm: (7.3728, 4.9152),
            pixel_pitch_um: 2.4,
            optimised,
            f_number: None,
        },
        test: TaskScores {
            map,
            ap50: 0.5,
            tp_ratio: tp,
            true_positives: 0,
            visible_180: 0,
            frames: 10,
            class_map: [None; 3],
            class_ap50: [None; 3],
            class_objects: [0; 3],
        },
        test_bands: Vec::new(),
        by_illumination: Default::default(),
        best_fitness: 0.0,
        validation: Vec::new(),
        provenance: None,
        input: None,
        render_scale: Some(0.08),
        source: joca_record::Source::Sim,
        scoring_precision: Some(joca_core::compute::Precision::Fp32),
        cpu_kernels: Some(joca_core::compute::CpuKernels::Native),
        denormals: None,
        cpu: String::new(),
        device: None,
        test_controller: None,
        test_town: None,
        test_detector: None,
        lens: Default::default(),
        weather: Default::default(),
        world: Default::default(),
        aperture: Default::default(),
        perturbation_ties: None,
    }
}

// The paper's Table 1 numbers; 0.318 happens to be close to 1/π.
#[allow(clippy::approx_constant)]
fn table() -> Table {
    let row = |group: &str, label: &str, map, tp, o| Row {
        group: group.into(),
        label: label.into(),
        cell: format!("{label}-{group}"),
        design: String::new(),
        results: results(map, tp, o),
    };
    Table {
        label_header: "Method".into(),
        rows: vec![
            row("Calibrated", "FLIR", 0.318, 0.389, false),
            row("Calibrated", "Basler", 0.289, 0.360, false),
            row("Calibrated", "TaCOS, AverageAE", 0.303, 0.358, true),
            row("Calibrated", "Ours", 0.325, 0.390, true),
            row("Noise×10", "FLIR", 0.263, 0.382, false),
            row("Noise×10", "Ours", 0.296, 0.377, true),
        ],
    }
}

#[test]
fn best_is_bold_and_second_underlined_within_each_group() {
    // The paper's Table 1 marks (calibrated: ours best, FLIR second in both columns).
    let md = table().markdown();
    let lines: Vec<&str> = md.lines().collect();
    assert!(
        lines[2].starts_with("| Calibrated | FLIR | 0.43") || lines[2].contains("<u>0.318</u>"),
        "{md}"
    );
    assert!(lines[2].contains("<u>0.318</u>") && lines[2].contains("<u>0.389</u>"));
    assert!(lines[5].contains("**0.325**") && lines[5].contains("**0.390**"));
    assert!(!lines[3].contains("**") && !lines[3].contains("<u>"));
    assert!(lines[5].contains("1.35 ●") && lines[2].contains("1.35 ○"));
    // The group label appears once; the next group starts its own ranking.
    assert!(lines[3].starts_with("|  | Basler"));
    assert!(lines[6].contains("<u>0.263</u>") && lines[6].contains("**0.382**"));
    assert!(lines[7].contains("**0.296**") && lines[7].contains("<u>0.377</u>"));
}

#[test]
fn real_image_runs_get_the_sensor_only_layout() {
    let mut t = table();
    for r in &mut t.rows {
        r.results.source = joca_record::Source::Folder("/data/waymo".into());
    }
    let md = t.markdown();
    assert!(
        md.starts_with(
            "| Scenario | Method | w×h (mm) | p (µm) | sensor | mAP@[.5:.95] ↑ | AP50 ↑ |"
        ),
        "{md}"
    );
    assert!(
        md.contains("| Calibrated | FLIR | 7.37×4.92 ○ | 2.40 ○ | IMX178 | <u>0.318</u> |"),
        "{md}"
    );
}

#[test]
fn html_spans_groups_and_csv_keeps_full_precision() {
    let t = table();
    let h = t.html();
    assert!(h.contains("<th rowspan=\"4\">Calibrated</th>"));
    assert!(h.contains("<th rowspan=\"2\">Noise×10</th>"));
    assert!(h.contains("<b>0.325</b>"));
    assert!(h.contains("TaCOS, AverageAE"));
    let c = t.csv();
    assert_eq!(c.lines().count(), 7);
    assert!(c.starts_with("scenario,label,cell,seed,method,source,"));
    // The settings columns are empty where the run has no such illumination.
    let row = "Calibrated,\"TaCOS, AverageAE\",\"TaCOS, AverageAE-Calibrated\",0,joca,sim,\
               1.35,1.3,5.19,IMX178,7.3728,4.9152,2.4,true,0.303,0.5,0.358,10,,,,\n";
    assert!(c.contains(row), "{c}");
}

#[test]
fn the_settings_section_names_the_iris_only_where_neural_ae_set_it() {
    use joca_record::{Light, Settings};
    let mut r = results(0.2, 0.3, true);
    let set = |r: &mut RunResults, stops: [Option<f64>; 2]| {
        for (light, (e, g), f_number) in
            [(Light::Day, (12.0, 9.1), stops[0]), (Light::Night, (29.1, 13.4), stops[1])]
        {
            r.by_illumination.entry(light).or_default().settings =
                Some(Settings { exposure_ms: e, gain_db: g, f_number });
        }
    };
    set(&mut r, [None, None]);
    let fixed = crate::settings_markdown(&r);
    assert!(fixed.contains("| day | 12.00 | 9.1 |") && !fixed.contains("iris"), "{fixed}");
    set(&mut r, [Some(7.08), Some(3.93)]);
    let md = crate::settings_markdown(&r);
    assert!(md.starts_with(&fixed), "{md}");
    assert!(
        md.contains("NeuralAE also set the iris (geometric-mean f-number: day f/7.1, night f/3.9)"),
        "{md}"
    );
}
