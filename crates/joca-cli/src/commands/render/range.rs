//! The in-frame dynamic range of a scene: how far apart its bright and dark parts are before the
//! camera exposes it.

use joca_core::HdrImage;

/// Radiance below this (calibrated DN) counts as this when a ratio is taken: a pixel that dark
/// is far below any sensor's read noise at any setting the ACC allows.
const FLOOR_DN: f32 = 1e-3;

/// The ratio of the 99.5th to the 0.5th percentile of the frame's radiance (the mean of its
/// three channels, calibrated DN, after the shutter's averaging and before exposure, gain, noise
/// and clipping), in decibels (20·log10). Percentiles rather than the extremes, so that a
/// handful of lamp or sky pixels does not set the figure.
pub fn radiance_range_db(hdr: &HdrImage) -> f64 {
    let mut luma: Vec<f32> =
        hdr.data().chunks_exact(3).map(|p| ((p[0] + p[1] + p[2]) / 3.0).max(FLOOR_DN)).collect();
    if luma.is_empty() {
        return 0.0;
    }
    luma.sort_by(f32::total_cmp);
    let at = |q: f64| luma[((luma.len() - 1) as f64 * q).round() as usize];
    20.0 * (f64::from(at(0.995)) / f64::from(at(0.005))).log10()
}

/// `median (p10 to p90)` of `values`, for the closing line.
pub fn spread(values: &[f64]) -> String {
    if values.is_empty() {
        return "none".into();
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    format!(
        "median {:.1} dB ({:.1} to {:.1} dB, 10th to 90th percentile)",
        at(0.5),
        at(0.1),
        at(0.9)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_range_is_the_percentile_ratio_in_decibels() {
        // 1000 pixels: 10 at 0.01 DN, 980 at 1 DN, 10 at 1000 DN. The 0.5th percentile (index
        // 5) is 0.01 and the 99.5th (index 994) 1000: 100 dB.
        let mut data = vec![1.0f32; 3000];
        data[..30].fill(0.01);
        data[2970..].fill(1000.0);
        let hdr = HdrImage::from_vec(1000, 1, data).unwrap();
        assert!((radiance_range_db(&hdr) - 100.0).abs() < 1e-5);
        // A uniform frame has none; a black one is floored, not infinite.
        let flat = HdrImage::from_vec(10, 10, vec![5.0; 300]).unwrap();
        assert_eq!(radiance_range_db(&flat), 0.0);
        let black = HdrImage::from_vec(10, 10, vec![0.0; 300]).unwrap();
        assert_eq!(radiance_range_db(&black), 0.0);
        assert_eq!(
            spread(&[3.0, 1.0, 2.0]),
            "median 2.0 dB (1.0 to 3.0 dB, 10th to 90th percentile)"
        );
    }
}
