//! Result tables laid out like the paper's Tables 1 and 3–6: rows grouped (by scenario), camera
//! parameters with optimised (●, green in HTML) or fixed (○) marked, then mAP@[.5:.95] and
//! TP/All@180°, best of each group in bold and second underlined. Markdown, HTML and CSV are
//! three views of one [`Table`].

use joca_record::{Light, RunResults};
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
            let light = |l: Light| r.results.by_illumination.light(l);
            let exposure_ms = |l: Light| light(l)?.settings.map(|s| s.exposure_ms);
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
                opt(exposure_ms(Light::Day)),
                opt(exposure_ms(Light::Night)),
                opt(light(Light::Day).and_then(|l| l.exposure_gain_ms)),
                opt(light(Light::Night).and_then(|l| l.exposure_gain_ms)),
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
pub(crate) mod tests;
