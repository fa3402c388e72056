//! The Middlebury colour coding of optical flow (Baker et al., IJCV 2011): hue is the direction,
//! saturation the length relative to the longest vector.

use super::Flow;

/// The colour wheel: red → yellow → green → cyan → blue → magenta → red, with the Middlebury
/// segment lengths (15, 6, 4, 11, 13, 6).
fn wheel() -> Vec<[f32; 3]> {
    let mut w = Vec::with_capacity(55);
    let segments: [(usize, [f32; 3], [f32; 3]); 6] = [
        (15, [255.0, 0.0, 0.0], [255.0, 255.0, 0.0]),
        (6, [255.0, 255.0, 0.0], [0.0, 255.0, 0.0]),
        (4, [0.0, 255.0, 0.0], [0.0, 255.0, 255.0]),
        (11, [0.0, 255.0, 255.0], [0.0, 0.0, 255.0]),
        (13, [0.0, 0.0, 255.0], [255.0, 0.0, 255.0]),
        (6, [255.0, 0.0, 255.0], [255.0, 0.0, 0.0]),
    ];
    for (n, a, b) in segments {
        for i in 0..n {
            let t = i as f32 / n as f32;
            w.push([a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t]);
        }
    }
    w
}

/// RGB8 pixels (row-major) colour-coding `flow`; vectors of length `max_length` (default: the
/// 99th percentile of the lengths, so a few outliers do not wash the picture out) and longer are
/// fully saturated.
pub fn colour_code(flow: &Flow, max_length: Option<f32>) -> Vec<u8> {
    let wheel = wheel();
    let n = wheel.len() as f32;
    let mut lengths: Vec<f32> = flow.data().iter().map(|v| v[0].hypot(v[1])).collect();
    lengths.sort_by(f32::total_cmp);
    let p99 = lengths.get(lengths.len() * 99 / 100).copied().unwrap_or(0.0);
    let scale = max_length.unwrap_or(p99).max(1e-6);
    let mut out = Vec::with_capacity(flow.data().len() * 3);
    for v in flow.data() {
        let r = (v[0].hypot(v[1]) / scale).min(1.0);
        let a = (-v[1]).atan2(-v[0]) / std::f32::consts::PI; // -1..1
        let fk = (a + 1.0) / 2.0 * (n - 1.0);
        let k0 = fk.floor() as usize % wheel.len();
        let k1 = (k0 + 1) % wheel.len();
        let f = fk - fk.floor();
        for (a, b) in wheel[k0].iter().zip(&wheel[k1]) {
            let col = ((1.0 - f) * a + f * b) / 255.0;
            let col = 1.0 - r * (1.0 - col);
            out.push((255.0 * col).round() as u8);
        }
    }
    out
}
