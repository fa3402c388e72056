//! Qualitative figures from the frames a run saved in `test/`: a grid of the same test scenes as
//! each method's camera saw them (ground truth green, detections red), and an animated GIF of
//! the tunnel transition with the exposure and gain each controller chose.
//!
//! Frames are enlarged with nearest-neighbour sampling so the pixels the detector saw stay
//! visible (at the presets' detector input a frame is 240 to 400 pixels wide).

use crate::ReportError;
use crate::data::RunData;
use crate::plot::{FAMILY, draw_err, register_font, save_png};
use joca_record::{BBox, Showcase, ShowcaseFrame};
use plotters::prelude::*;
use std::path::Path;

/// Detections drawn in figures: score at least this (the metrics use every detection).
pub const DRAW_MIN_SCORE: f32 = 0.3;
/// Frames of the tunnel animation before and after the switch of illumination (10 frames/s).
const ANIMATION_BEFORE: usize = 5;
const ANIMATION_AFTER: usize = 15;
const TRUTH: RGBColor = RGBColor(40, 220, 40);
const DETECTION: RGBColor = RGBColor(240, 40, 40);

/// An RGB canvas.
struct Canvas {
    w: u32,
    h: u32,
    buf: Vec<u8>,
}

impl Canvas {
    fn new(w: u32, h: u32, grey: u8) -> Self {
        Self { w, h, buf: vec![grey; (w * h * 3) as usize] }
    }

    /// Draws `img` scaled by `scale` (nearest neighbour) with its top-left corner at (x0, y0).
    fn blit(&mut self, img: &image::RgbImage, x0: u32, y0: u32, scale: f64) {
        let (tw, th) =
            ((f64::from(img.width()) * scale) as u32, (f64::from(img.height()) * scale) as u32);
        for y in 0..th.min(self.h.saturating_sub(y0)) {
            let sy = ((f64::from(y) / scale) as u32).min(img.height() - 1);
            for x in 0..tw.min(self.w.saturating_sub(x0)) {
                let sx = ((f64::from(x) / scale) as u32).min(img.width() - 1);
                let p = img.get_pixel(sx, sy).0;
                let i = (((y0 + y) * self.w + x0 + x) * 3) as usize;
                self.buf[i..i + 3].copy_from_slice(&p);
            }
        }
    }

    fn draw<F>(&mut self, path: &Path, f: F) -> Result<(), ReportError>
    where
        F: FnOnce(
            &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
        ) -> Result<(), Box<dyn std::error::Error>>,
    {
        register_font();
        let root = BitMapBackend::with_buffer(&mut self.buf, (self.w, self.h)).into_drawing_area();
        f(&root).map_err(|e| draw_err(path, e))?;
        root.present().map_err(|e| draw_err(path, e))
    }
}

/// A frame of a showcase drawn into a tile: the image enlarged to fit `(tw, th)`, boxes on top.
fn draw_frame(
    canvas: &mut Canvas,
    path: &Path,
    run: &RunData,
    frame: &ShowcaseFrame,
    origin: (u32, u32),
    tile: (u32, u32),
) -> Result<(), ReportError> {
    let Some(rel) = &frame.image else { return Ok(()) };
    let file = run.frame_path(rel);
    let img = image::open(&file).map_err(|e| draw_err(&file, e))?.to_rgb8();
    let scale = (f64::from(tile.0) / f64::from(img.width()))
        .min(f64::from(tile.1) / f64::from(img.height()));
    let (w, h) =
        ((f64::from(img.width()) * scale) as u32, (f64::from(img.height()) * scale) as u32);
    let x0 = origin.0 + (tile.0 - w) / 2;
    let y0 = origin.1 + (tile.1 - h) / 2;
    canvas.blit(&img, x0, y0, scale);
    let to_px = |b: &BBox| {
        [
            (
                (x0 as f32 + b.x_min * scale as f32) as i32,
                (y0 as f32 + b.y_min * scale as f32) as i32,
            ),
            (
                (x0 as f32 + b.x_max * scale as f32) as i32,
                (y0 as f32 + b.y_max * scale as f32) as i32,
            ),
        ]
    };
    canvas.draw(path, |root| {
        for t in &frame.boxes {
            root.draw(&Rectangle::new(to_px(&t.bbox), TRUTH.stroke_width(2)))?;
        }
        for d in frame.detections.iter().filter(|d| d.score >= DRAW_MIN_SCORE) {
            root.draw(&Rectangle::new(to_px(&d.bbox), DETECTION.stroke_width(2)))?;
        }
        Ok(())
    })
}

/// Splits `text` into lines of at most about `width` characters at spaces.
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    for word in text.split_whitespace() {
        match lines.last_mut() {
            Some(line) if line.chars().count() + 1 + word.chars().count() <= width => {
                line.push(' ');
                line.push_str(word);
            }
            _ => lines.push(word.to_owned()),
        }
    }
    lines
}

/// Index of the first frame whose ambient level differs from the first frame's (the tunnel
/// switch), if any.
pub(crate) fn switch_index(show: &Showcase) -> Option<usize> {
    let first = show.frames.first()?.ambient;
    show.frames.iter().position(|f| f.ambient != first)
}

/// The frames the grid shows: (column title, showcase name, frame index).
fn grid_columns(run: &RunData) -> Vec<(String, String, usize)> {
    let mut cols = Vec::new();
    for name in ["day", "night"] {
        if let Some(s) = run.showcase(name)
            && let Some(i) = s.frames.iter().rposition(|f| f.image.is_some())
        {
            cols.push((format!("{name}, t = {:.1} s", s.frames[i].time_s), name.to_owned(), i));
        }
    }
    if let Some(s) = run.showcase("tunnel")
        && let Some(k) = switch_index(s)
    {
        let into_dark = s.frames[k].ambient < s.frames[0].ambient;
        let what = if into_dark { "entering tunnel" } else { "leaving tunnel" };
        for (offset, when) in [(-5i64, "0.5 s before"), (3, "0.3 s after")] {
            let i = (k as i64 + offset).clamp(0, s.frames.len() as i64 - 1) as usize;
            cols.push((format!("{what}, {when}"), "tunnel".to_owned(), i));
        }
    }
    cols
}

/// The qualitative grid: one row per run (labelled), one column per showcase scene.
pub fn qualitative_grid(path: &Path, runs: &[(String, &RunData)]) -> Result<(), ReportError> {
    // The columns come from the first run that kept its showcases (a cell restored from its
    // compact results has none; its row stays empty).
    let Some(first) = runs.iter().find(|(_, r)| !r.showcases.is_empty()) else { return Ok(()) };
    let cols = grid_columns(first.1);
    if cols.is_empty() {
        return Ok(());
    }
    let (label_w, head_h, tile, gap) = (200u32, 44u32, (240u32, 160u32), 6u32);
    let w = label_w + cols.len() as u32 * (tile.0 + gap);
    let h = head_h + runs.len() as u32 * (tile.1 + gap) + 28;
    let mut canvas = Canvas::new(w, h, 255);
    for (r, (_, run)) in runs.iter().enumerate() {
        for (c, (_, name, i)) in cols.iter().enumerate() {
            let origin = (label_w + c as u32 * (tile.0 + gap), head_h + r as u32 * (tile.1 + gap));
            // Dark background so letterboxing of other aspect ratios is visible as such.
            canvas.draw(path, |root| {
                root.draw(&Rectangle::new(
                    [
                        (origin.0 as i32, origin.1 as i32),
                        ((origin.0 + tile.0) as i32, (origin.1 + tile.1) as i32),
                    ],
                    RGBColor(40, 40, 40).filled(),
                ))?;
                Ok(())
            })?;
            if let Some(frame) = run.showcase(name).and_then(|s| s.frames.get(*i)) {
                draw_frame(&mut canvas, path, run, frame, origin, tile)?;
            }
        }
    }
    canvas.draw(path, |root| {
        let head = (FAMILY, 15).into_font().color(&BLACK);
        for (c, (title, _, _)) in cols.iter().enumerate() {
            let x = (label_w + c as u32 * (tile.0 + gap)) as i32;
            root.draw(&Text::new(title.clone(), (x + 4, 14), head.clone()))?;
        }
        let label = (FAMILY, 14).into_font().color(&BLACK);
        for (r, (name, run)) in runs.iter().enumerate() {
            let y = (head_h + r as u32 * (tile.1 + gap)) as i32;
            let lines = wrap(name, 24);
            for (i, line) in lines.iter().enumerate() {
                root.draw(&Text::new(line.clone(), (6, y + 6 + 17 * i as i32), label.clone()))?;
            }
            let y = y + 12 + 17 * lines.len() as i32;
            let d = &run.results.design;
            let sub = (FAMILY, 12).into_font().color(&RGBColor(80, 80, 80));
            root.draw(&Text::new(d.sensor.clone(), (6, y), sub.clone()))?;
            root.draw(&Text::new(format!("f {} mm", d.lens_label()), (6, y + 16), sub.clone()))?;
            root.draw(&Text::new(
                format!("mAP {:.3}", run.results.test.map),
                (6, y + 32),
                sub.clone(),
            ))?;
        }
        let foot = (FAMILY, 13).into_font().color(&RGBColor(60, 60, 60));
        root.draw(&Text::new(
            format!(
                "green: ground truth; red: detections with score ≥ {DRAW_MIN_SCORE}; frames \
                enlarged (nearest neighbour)"
            ),
            (6, (h - 22) as i32),
            foot,
        ))?;
        Ok(())
    })?;
    save_png(path, &canvas.buf, canvas.w, canvas.h)
}

/// An animated GIF (10 frames/s, looping) of 2 s of the tunnel showcase around its switch of
/// illumination, one tile per run side by side,
/// each captioned with the exposure and gain its controller chose for that frame.
pub fn tunnel_animation(path: &Path, runs: &[(String, &RunData)]) -> Result<(), ReportError> {
    let shows: Vec<(&String, &RunData, &Showcase)> =
        runs.iter().filter_map(|(l, r)| r.showcase("tunnel").map(|s| (l, *r, s))).collect();
    let Some(len) = shows.iter().map(|s| s.2.frames.len()).min() else { return Ok(()) };
    // 2 s of it: 0.5 s before the switch of illumination and 1.5 s after (the controller's
    // reaction).
    let switch = switch_index(shows[0].2).unwrap_or(0);
    let frames = switch.saturating_sub(ANIMATION_BEFORE)..(switch + ANIMATION_AFTER).min(len);
    let (tile, gap, head, foot) = ((176u32, 118u32), 6u32, 22u32, 40u32);
    let w = shows.len() as u32 * (tile.0 + gap);
    let h = head + tile.1 + foot;
    let mut canvases = Vec::with_capacity(frames.len());
    for k in frames {
        let mut canvas = Canvas::new(w, h, 255);
        for (i, (_, run, show)) in shows.iter().enumerate() {
            let x = i as u32 * (tile.0 + gap);
            canvas.draw(path, |root| {
                root.draw(&Rectangle::new(
                    [(x as i32, head as i32), ((x + tile.0) as i32, (head + tile.1) as i32)],
                    RGBColor(40, 40, 40).filled(),
                ))?;
                Ok(())
            })?;
            draw_frame(&mut canvas, path, run, &show.frames[k], (x, head), tile)?;
        }
        canvas.draw(path, |root| {
            for (i, (label, _, show)) in shows.iter().enumerate() {
                let x = (i as u32 * (tile.0 + gap)) as i32;
                let f = &show.frames[k];
                root.draw(&Text::new(
                    (*label).clone(),
                    (x + 4, 3),
                    (FAMILY, 14).into_font().color(&BLACK),
                ))?;
                let y = (head + tile.1) as i32;
                let text = (FAMILY, 12).into_font().color(&BLACK);
                root.draw(&Text::new(
                    format!("E {:.2} ms   G {:.1} dB", f.settings.exposure_ms, f.settings.gain_db),
                    (x + 4, y + 4),
                    text.clone(),
                ))?;
                root.draw(&Text::new(
                    format!("t {:.1} s   ambient {:.3}", f.time_s, f.ambient),
                    (x + 4, y + 21),
                    text,
                ))?;
            }
            Ok(())
        })?;
        canvases.push(canvas.buf);
    }
    write_gif(path, w, h, &canvases)
}

/// Encodes RGB frames as a looping GIF at 10 frames/s with one palette for the whole animation
/// (NeuQuant on a sample of the frames): sensor noise then changes few palette indices from frame
/// to frame, which keeps the file several times smaller than per-frame palettes.
fn write_gif(path: &Path, w: u32, h: u32, frames: &[Vec<u8>]) -> Result<(), ReportError> {
    let rgba =
        |rgb: &[u8]| rgb.chunks_exact(3).flat_map(|p| [p[0], p[1], p[2], 255]).collect::<Vec<u8>>();
    let sample: Vec<u8> = frames.iter().step_by(5).flat_map(|f| rgba(f)).collect();
    let quant = color_quant::NeuQuant::new(10, 256, &sample);
    let palette = quant.color_map_rgb();
    let mut bytes = Vec::new();
    let mut encoder = gif::Encoder::new(&mut bytes, w as u16, h as u16, &palette)
        .map_err(|e| draw_err(path, e))?;
    encoder.set_repeat(gif::Repeat::Infinite).map_err(|e| draw_err(path, e))?;
    for f in frames {
        let indices: Vec<u8> =
            f.chunks_exact(3).map(|p| quant.index_of(&[p[0], p[1], p[2], 255]) as u8).collect();
        let frame = gif::Frame {
            width: w as u16,
            height: h as u16,
            delay: 10,
            buffer: std::borrow::Cow::Owned(indices),
            ..gif::Frame::default()
        };
        encoder.write_frame(&frame).map_err(|e| draw_err(path, e))?;
    }
    drop(encoder);
    joca_core::fs::write_atomic(path, &bytes)
        .map_err(|source| ReportError::Io { path: path.display().to_string(), source })
}
