//! Drawing on 8-bit frames for contact sheets: box outlines and tiling.

use joca_core::{Annotation, Class, Rgb8Image};

/// Outline colour of a class.
pub fn class_colour(class: Class) -> [u8; 3] {
    match class {
        Class::Vehicle => [255, 70, 60],
        Class::Walker => [60, 255, 90],
        Class::TrafficSign => [70, 170, 255],
    }
}

/// Draws each box's outline in its class colour, 1 px wide, inside the frame; ignore regions
/// (`dashed`) with every other pixel.
pub fn draw_boxes(frame: &mut Rgb8Image, boxes: &[Annotation], dashed: bool) {
    let (w, h) = (frame.width() as i64, frame.height() as i64);
    for a in boxes {
        let c = class_colour(a.class);
        let x0 = (a.bbox.x_min.floor() as i64).clamp(0, w - 1);
        let y0 = (a.bbox.y_min.floor() as i64).clamp(0, h - 1);
        let x1 = ((a.bbox.x_max.ceil() as i64) - 1).clamp(0, w - 1);
        let y1 = ((a.bbox.y_max.ceil() as i64) - 1).clamp(0, h - 1);
        let width = frame.width();
        let data = frame.data_mut();
        let mut put = |x: i64, y: i64| {
            if !dashed || (x + y) % 2 == 0 {
                let i = (y as usize * width + x as usize) * 3;
                data[i..i + 3].copy_from_slice(&c);
            }
        };
        for x in x0..=x1 {
            put(x, y0);
            put(x, y1);
        }
        for y in y0..=y1 {
            put(x0, y);
            put(x1, y);
        }
    }
}

/// Tiles equally sized frames into a grid of `columns`, 4 px apart on a dark background.
pub fn tile(frames: &[Rgb8Image], columns: usize) -> Rgb8Image {
    let Some(first) = frames.first() else { return Rgb8Image::zeros(1, 1) };
    let (fw, fh) = (first.width(), first.height());
    let gap = 4;
    let columns = columns.clamp(1, frames.len());
    let rows = frames.len().div_ceil(columns);
    let (w, h) = (columns * fw + (columns + 1) * gap, rows * fh + (rows + 1) * gap);
    let mut sheet =
        Rgb8Image::from_vec(w, h, vec![24; w * h * 3]).unwrap_or_else(|_| Rgb8Image::zeros(w, h));
    for (k, f) in frames.iter().enumerate() {
        let (ox, oy) = (gap + (k % columns) * (fw + gap), gap + (k / columns) * (fh + gap));
        for y in 0..fh.min(f.height()) {
            let src = &f.data()[y * f.width() * 3..(y * f.width() + fw.min(f.width())) * 3];
            let start = ((oy + y) * w + ox) * 3;
            sheet.data_mut()[start..start + src.len()].copy_from_slice(src);
        }
    }
    sheet
}
