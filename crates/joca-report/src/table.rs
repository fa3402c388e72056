//! Result tables laid out like the paper's Tables 1 and 3–6: rows grouped (by scenario), camera
//! parameters with optimised (●, green in HTML) or fixed (○) marked, then mAP@[.5:.95] and
//! TP/All@180°, best of each group in bold and second underlined. Markdown, HTML and CSV are
//! three views of one [`Table`].

use joca_record::RunResults;
use std::fmt::Write as _;

/// One row: a method (or sweep value) in one group.
#[derive(Debug, Clone)]
pub struct Row {
    /// Group label (the scenario).
    pub group: String,
    /// Row label (the method or the sweep value).
    pub label: String,
    /// Cell id (the run directory's name), for the CSV.
    pub cell: String,
    /// The panel design the cell's hardware was fixed to (its id); empty outside a panel.
    pub design: String,
    /// The run's results.
    pub results: RunResults,
}

/// A result table.
#[derive(Debug, Clone)]
pub struct Table {
    /// Header of the label column ("Method", "Weight", …).
    pub label_header: String,
    /// Rows in display order; rows of a group are contiguous.
    pub rows: Vec<Row>,
}

/// Rank of a value among its group: 0 best, 1 second, else none.
fn rank(values: &[f64], v: f64) -> Option<usize> {
    let mut distinct: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    distinct.sort_by(|a, b| b.total_cmp(a));
    distinct.dedup();
    distinct.iter().position(|&x| x == v).filter(|&r| r < 2)
}

#[derive(Clone, Copy)]
enum Style {
    Markdown,
    Html,
}

/// A camera parameter marked optimised (●, green in HTML) or fixed (○).
fn mark(style: Style, optimised: bool, v: String) -> String {
    match (style, optimised) {
        (Style::Markdown, true) => format!("{v} ●"),
        (Style::Markdown, false) => format!("{v} ○"),
        (Style::Html, true) => format!("{v} <span class=\"opt\">●</span>"),
        (Style::Html, false) => format!("{v} <span class=\"fix\">○</span>"),
    }
}

fn emphasise(style: Style, text: String, rank: Option<usize>) -> String {
    match (style, rank) {
        (Style::Markdown, Some(0)) => format!("**{text}**"),
        (Style::Markdown, Some(1)) => format!("<u>{text}</u>"),
        (Style::Html, Some(0)) => format!("<b>{text}</b>"),
        (Style::Html, Some(1)) => format!("<u>{text}</u>"),
        _ => text,
    }
}

impl Table {
    /// Groups in order of first appearance.
    pub fn groups(&self) -> Vec<String> {
        let mut out: Vec<String> = Vec::new();
        for r in &self.rows {
            if !out.contains(&r.group) {
                out.push(r.group.clone());
            }
        }
        out
    }

    fn group_values(&self, group: &str, f: fn(&RunResults) -> f64) -> Vec<f64> {
        self.rows.iter().filter(|r| r.group == group).map(|r| f(&r.results)).collect()
    }

    /// A score of `row`, to 3 decimals, bold if best and underlined if second in its group.
    fn scored(&self, style: Style, row: &Row, f: fn(&RunResults) -> f64) -> String {
        let v = f(&row.results);
        emphasise(style, format!("{v:.3}"), rank(&self.group_values(&row.group, f), v))
    }

    /// Whether every row was tested on recorded frames: then the real-image layout of the
    /// paper's Table 2 is used (only the sensor is designed; mAP and AP50, since a recording has
    /// no 180° object count).
    pub fn real_images(&self) -> bool {
        !self.rows.is_empty() && self.rows.iter().all(|r| r.results.real_images())
    }

    fn cells(&self, style: Style) -> Vec<Vec<String>> {
        if self.real_images() {
            return self.real_cells(style);
        }
        let mark = |optimised: bool, v: String| mark(style, optimised, v);
        self.rows
            .iter()
            .map(|r| {
                let d = &r.results.design;
                let o = d.optimised;
                vec![
                    r.group.clone(),
                    r.label.clone(),
                    mark(o, format!("{:.2}", d.x_m)),
                    mark(o, format!("{:.2}", d.z_m)),
                    mark(o, d.lens_label()),
                    mark(o, format!("{:.2}×{:.2}", d.sensor_mm.0, d.sensor_mm.1)),
                    mark(o, format!("{:.2}", d.pixel_pitch_um)),
                    d.sensor.clone(),
                    self.scored(style, r, |x| x.test.map),
                    self.scored(style, r, |x| x.test.tp_ratio),
                ]
            })
            .collect()
    }

    fn real_cells(&self, style: Style) -> Vec<Vec<String>> {
        let mark = |optimised: bool, v: String| mark(style, optimised, v);
        self.rows
            .iter()
            .map(|r| {
                let d = &r.results.design;
                vec![
                    r.group.clone(),
                    r.label.clone(),
                    mark(d.optimised, format!("{:.2}×{:.2}", d.sensor_mm.0, d.sensor_mm.1)),
                    mark(d.optimised, format!("{:.2}", d.pixel_pitch_um)),
                    d.sensor.clone(),
                    self.scored(style, r, |x| x.test.map),
                    self.scored(style, r, |x| x.test.ap50),
                ]
            })
            .collect()
    }

    fn headers(&self) -> Vec<String> {
        if self.real_images() {
            return vec![
                "Scenario".into(),
                self.label_header.clone(),
                "w×h (mm)".into(),
                "p (µm)".into(),
                "sensor".into(),
                "mAP@[.5:.95] ↑".into(),
                "AP50 ↑".into(),
            ];
        }
        vec![
            "Scenario".into(),
            self.label_header.clone(),
            "x (m)".into(),
            "z (m)".into(),
            "f (mm)".into(),
            "w×h (mm)".into(),
            "p (µm)".into(),
            "sensor".into(),
            "mAP@[.5:.95] ↑".into(),
            "TP/All@180° ↑".into(),
        ]
    }

    /// The table as Markdown.
    pub fn markdown(&self) -> String {
        let mut md = String::new();
        let _ = writeln!(md, "| {} |", self.headers().join(" | "));
        let _ = writeln!(md, "|{}", "---|".repeat(self.headers().len()));
        let mut last_group = String::new();
        for mut row in self.cells(Style::Markdown) {
            if row[0] == last_group {
                row[0].clear();
            } else {
                last_group.clone_from(&row[0]);
            }
            let _ = writeln!(md, "| {} |", row.join(" | "));
        }
        md
    }

    /// The table as an HTML `<table>`, groups as row spans.
    pub fn html(&self) -> String {
        let mut h = String::from("<table>\n<thead><tr>");
        for head in self.headers() {
            let _ = write!(h, "<th>{}</th>", escape(&head));
        }
        h.push_str("</tr></thead>\n<tbody>\n");
        let cells = self.cells(Style::Html);
        let mut i = 0;
        while i < cells.len() {
            let group = &cells[i][0];
            let n = cells[i..].iter().take_while(|r| &r[0] == group).count();
            for (j, row) in cells[i..i + n].iter().enumerate() {
                h.push_str(if j == 0 { "<tr class=\"first\">" } else { "<tr>" });
                if j == 0 {
                    let _ = write!(h, "<th rowspan=\"{n}\">{}</th>", escape(group));
                }
                let _ = write!(h, "<td class=\"label\">{}</td>", escape(&row[1]));
                for cell in &row[2..] {
                    // Cells hold our own markup (b, u, span) around numbers only.
                    let _ = write!(h, "<td>{cell}</td>");
                }
                h.push_str("</tr>\n");
            }
            i += n;
        }
        h.push_str("</tbody>\n</table>\n");
        h
    }

    /// The table as CSV, with every number at full precision.
    pub fn csv(&self) -> String {
        let mut c = String::from(
            "scenario,label,cell,seed,method,source,x_m,z_m,focal_length_mm,sensor,sensor_w_mm,\
             sensor_h_mm,pixel_pitch_um,optimised,map,ap50,tp_ratio,test_frames,\
             exposure_ms_day,exposure_ms_night,exposure_gain_day,exposure_gain_night\n",
        );
        for r in &self.rows {
            let d = &r.results.design;
            let t = &r.results.test;
            let _ = writeln!(
                c,
                "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
                csv_field(&r.group),
                csv_field(&r.label),
                csv_field(&r.cell),
                r.results.seed,
                csv_field(r.results.method.name()),
                csv_field(&r.results.source.to_string()),
                d.x_m,
                d.z_m,
                d.focal_length_mm,
                csv_field(&d.sensor),
                d.sensor_mm.0,
                d.sensor_mm.1,
                d.pixel_pitch_um,
                d.optimised,
                t.map,
                t.ap50,
                t.tp_ratio,
                t.frames,
                opt(r.results.settings_by_illumination.get("day").map(|s| s.0)),
                opt(r.results.settings_by_illumination.get("night").map(|s| s.0)),
                opt(r.results.exposure_gain_by_illumination.get("day").copied()),
                opt(r.results.exposure_gain_by_illumination.get("night").copied()),
            );
        }
        c
    }
}

fn opt(v: Option<f64>) -> String {
    v.map_or_else(String::new, |v| v.to_string())
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

/// Escapes text for HTML.
pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use joca_record::{DesignSummary, Method, Scenario, TaskScores};

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
            test_by_illumination: Default::default(),
            settings_by_illumination: Default::default(),
            exposure_gain_by_illumination: Default::default(),
            mean_dn_by_illumination: Default::default(),
            best_fitness: 0.0,
            validation: Vec::new(),
            input: None,
            render_scale: Some(0.08),
            source: joca_record::Source::Sim,
            scoring_precision: Some(joca_core::compute::Precision::Fp32),
            cpu_kernels: Some(joca_core::compute::CpuKernels::Native),
            denormals: None,
            cpu: String::new(),
            test_controller: None,
            lens: Default::default(),
            weather: Default::default(),
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
}
