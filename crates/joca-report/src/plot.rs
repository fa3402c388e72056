//! Line charts and the field-of-view diagram, drawn with `plotters` into RGB buffers and saved
//! as PNG. Text uses the DejaVu Sans font compiled into the binary (fonts/), so figures look
//! the same on a machine without any system font.

use crate::ReportError;
use joca_record::DesignSummary;
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::path::Path;
use std::sync::Once;

/// DejaVu Sans (Bitstream Vera licence, see fonts/LICENSE): the one font of every figure.
static FONT: &[u8] = include_bytes!("../fonts/DejaVuSans.ttf");
/// The family name figures ask for.
pub(crate) const FAMILY: &str = "sans-serif";

/// Registers the bundled font once per process.
pub(crate) fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bytes are a valid TrueType font compiled in; a failure would only lose text.
        let _ = plotters::style::register_font(FAMILY, FontStyle::Normal, FONT);
    });
}

/// Colours of series, in order (colour-blind-safe Okabe–Ito palette).
pub(crate) const PALETTE: [RGBColor; 8] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(120, 120, 120),
    RGBColor(0, 0, 0),
];

/// One line of a chart.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// Palette index.
    pub colour: usize,
    /// Dashed instead of solid.
    pub dashed: bool,
    /// Points (x, y).
    pub points: Vec<(f64, f64)>,
}

/// One panel of a stacked chart.
#[derive(Debug, Clone)]
pub struct Panel {
    /// Y axis title, with unit.
    pub y_label: String,
    /// Lines.
    pub series: Vec<Series>,
}

pub(crate) fn draw_err(path: &Path, e: impl std::fmt::Display) -> ReportError {
    ReportError::Draw { path: path.display().to_string(), reason: e.to_string() }
}

/// Saves an RGB buffer as PNG, atomically (`joca_core::fs::write_atomic`).
pub(crate) fn save_png(path: &Path, buf: &[u8], w: u32, h: u32) -> Result<(), ReportError> {
    use image::ImageEncoder as _;
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    let mut bytes = Vec::new();
    PngEncoder::new_with_quality(&mut bytes, CompressionType::Best, FilterType::Adaptive)
        .write_image(buf, w, h, image::ExtendedColorType::Rgb8)
        .map_err(|e| draw_err(path, e))?;
    joca_core::fs::write_atomic(path, &bytes)
        .map_err(|source| ReportError::Io { path: path.display().to_string(), source })
}

fn bounds(points: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = points
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let pad = ((hi - lo) * 0.08).max(1e-3 * hi.abs().max(1.0));
    (lo - pad, hi + pad)
}

/// Panels stacked vertically over one x axis, each with its own legend; saved as PNG.
pub fn stacked_chart(
    path: &Path,
    title: &str,
    x_label: &str,
    panels: &[Panel],
    size: (u32, u32),
) -> Result<(), ReportError> {
    register_font();
    let (w, h) = size;
    let mut buf = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| draw_err(path, e))?;
        let root = root.titled(title, (FAMILY, 20)).map_err(|e| draw_err(path, e))?;
        let xs =
            panels.iter().flat_map(|p| p.series.iter().flat_map(|s| s.points.iter().map(|p| p.0)));
        let integer_x = panels
            .iter()
            .flat_map(|p| p.series.iter().flat_map(|s| s.points.iter()))
            .all(|p| p.0.fract() == 0.0);
        let (x0, x1) = bounds(xs);
        let areas = root.split_evenly((panels.len().max(1), 1));
        for (area, panel) in areas.iter().zip(panels) {
            let ys = panel.series.iter().flat_map(|s| s.points.iter().map(|p| p.1));
            let (y0, y1) = bounds(ys);
            let mut chart = ChartBuilder::on(area)
                .margin(8)
                .x_label_area_size(36)
                .y_label_area_size(64)
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(|e| draw_err(path, e))?;
            let mut mesh = chart.configure_mesh();
            if integer_x {
                // Generations: whole-number ticks only.
                mesh.x_labels(((x1 - x0).round() as usize + 1).clamp(2, 13)).x_label_formatter(
                    &|x| {
                        if (x - x.round()).abs() < 1e-6 { format!("{x:.0}") } else { String::new() }
                    },
                );
            }
            mesh.x_desc(x_label)
                .y_desc(panel.y_label.as_str())
                .label_style((FAMILY, 13))
                .axis_desc_style((FAMILY, 14))
                .light_line_style(RGBColor(235, 235, 235))
                .draw()
                .map_err(|e| draw_err(path, e))?;
            for s in &panel.series {
                let colour = PALETTE[s.colour % PALETTE.len()];
                let style = colour.stroke_width(2);
                let points =
                    s.points.iter().copied().filter(|p| p.0.is_finite() && p.1.is_finite());
                let anno = if s.dashed {
                    chart.draw_series(DashedLineSeries::new(points, 6, 4, style))
                } else {
                    chart.draw_series(LineSeries::new(points, style))
                }
                .map_err(|e| draw_err(path, e))?;
                let dashed = s.dashed;
                anno.label(s.label.as_str()).legend(move |(x, y)| {
                    let end = if dashed { x + 10 } else { x + 22 };
                    PathElement::new(vec![(x, y), (end, y)], colour.stroke_width(2))
                });
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .label_font((FAMILY, 12))
                .background_style(WHITE.mix(0.85))
                .border_style(RGBColor(160, 160, 160))
                .draw()
                .map_err(|e| draw_err(path, e))?;
        }
        root.present().map_err(|e| draw_err(path, e))?;
    }
    save_png(path, &buf, w, h)
}

/// Top-down view of the vehicle with each design's mount position and horizontal field of view
/// (the supplementary's FoV figure). Forward is up; the vehicle frame's origin is x = 0.
pub fn fov_diagram(path: &Path, designs: &[(String, DesignSummary)]) -> Result<(), ReportError> {
    register_font();
    let (w, h) = (760u32, 720u32);
    let range_m = 16.0;
    let mut buf = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| draw_err(path, e))?;
        let root = root
            .titled("Camera mount and horizontal field of view (top view)", (FAMILY, 20))
            .map_err(|e| draw_err(path, e))?;
        let mut chart = ChartBuilder::on(&root)
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(56)
            .build_cartesian_2d(-12.0..12.0, -2.0..(range_m + 4.0))
            .map_err(|e| draw_err(path, e))?;
        chart
            .configure_mesh()
            .x_desc("lateral position (m, left negative)")
            .y_desc("forward position x (m, vehicle frame)")
            .label_style((FAMILY, 13))
            .axis_desc_style((FAMILY, 14))
            .light_line_style(RGBColor(238, 238, 238))
            .draw()
            .map_err(|e| draw_err(path, e))?;
        // The ego vehicle: a 1.9 m wide body from 1.0 m behind the origin to 3.7 m ahead of it.
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(-0.95, -1.0), (0.95, 3.7)],
                RGBColor(200, 200, 200).filled(),
            )))
            .map_err(|e| draw_err(path, e))?;
        for (i, (label, d)) in designs.iter().enumerate() {
            let colour = PALETTE[i % PALETTE.len()];
            let half = d.hfov_rad() / 2.0;
            let apex = (0.0, d.x_m);
            let arc: Vec<(f64, f64)> = (0..=40)
                .map(|k| {
                    let a = -half + 2.0 * half * f64::from(k) / 40.0;
                    (range_m * a.sin(), d.x_m + range_m * a.cos())
                })
                .collect();
            let mut outline = vec![apex];
            outline.extend(arc.iter().copied());
            outline.push(apex);
            chart
                .draw_series(std::iter::once(Polygon::new(
                    outline.clone(),
                    colour.mix(0.12).filled(),
                )))
                .map_err(|e| draw_err(path, e))?;
            chart
                .draw_series(std::iter::once(PathElement::new(outline, colour.stroke_width(2))))
                .map_err(|e| draw_err(path, e))?
                .label(format!(
                    "{label}: x {:.2} m, z {:.2} m, f {:.2} mm, {}, HFoV {:.0}°",
                    d.x_m,
                    d.z_m,
                    d.focal_length_mm,
                    d.sensor,
                    d.hfov_rad().to_degrees()
                ))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 22, y)], colour.stroke_width(3))
                });
            chart
                .draw_series(std::iter::once(Circle::new(apex, 4, colour.filled())))
                .map_err(|e| draw_err(path, e))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerLeft)
            .label_font((FAMILY, 12))
            .background_style(WHITE.mix(0.9))
            .border_style(RGBColor(160, 160, 160))
            .draw()
            .map_err(|e| draw_err(path, e))?;
        root.present().map_err(|e| draw_err(path, e))?;
    }
    save_png(path, &buf, w, h)
}
