//! The detector's input: one size for every design, and what resizing to it does to the noise.
//!
//! A perception stack runs its detector at the input size its compute allows and resizes every
//! camera's frames to it. The paper's detector (torchvision's Faster R-CNN, as its predecessor
//! TaCOS uses it) scales every image so that its short side is 800 px and its long side at most
//! 1333 px, aspect kept, bilinearly and without anti-aliasing. [`DetectorInput`] is that rule
//! with the numbers a preset chooses, so a sensor's pixel count buys no detector resolution.
//!
//! The sensor forms its frame on its native grid (Eq. 3 per native pixel, independent noise);
//! the resize then combines native pixels with weights `w`. Over a region where the signal is
//! smooth, an input pixel's noise variance is the native pixel's times `Σw²`. The resize is
//! separable, so `Σw²` at input pixel `(x, y)` is the product of a per-column and a per-row
//! factor ([`Resampler::variance_factors`]); image formation applies it at the input size
//! instead of forming every native pixel (`ImageFormation::on_native_grid`). The taps follow
//! the two resamplers' definitions:
//!
//! - [`Resampler::Bilinear`]: PyTorch's `interpolate(mode="bilinear", align_corners=False)`
//!   without anti-aliasing (the paper's detector transform): output index `d` samples the
//!   native coordinate `s = max((d + ½)·r − ½, 0)` with `r = n_in / n_out`, from pixels
//!   `⌊s⌋` and `⌊s⌋ + 1` (clamped to the last) with weights `1 − λ` and `λ`, `λ = s − ⌊s⌋`. At
//!   any downscale only two taps per axis contribute: the noise barely averages.
//! - [`Resampler::Area`]: the mean over the output pixel's footprint `[d·r, (d + 1)·r)` on the
//!   native grid, each native pixel weighted by its overlap (an ISP that bins or area-averages;
//!   OpenCV's `INTER_AREA` when downscaling): `Σw² ≈ 1/r` per axis.

use crate::CameraError;
use serde::{Deserialize, Serialize};

/// How frames are resized from the sensor's grid to the detector's input.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Resampler {
    /// Two-tap linear interpolation per axis, no anti-aliasing (the paper's detector transform).
    #[default]
    Bilinear,
    /// Overlap-weighted mean over each output pixel's footprint (binning).
    Area,
}

impl Resampler {
    /// The names a configuration may use.
    pub const NAMES: &'static str = "bilinear, area";

    /// The taps `(native index, weight)` of every output index, resizing `n_in` samples to
    /// `n_out`. The weights of each output sum to 1.
    pub fn taps(self, n_in: usize, n_out: usize) -> Vec<Vec<(usize, f64)>> {
        assert!(n_in > 0 && n_out > 0, "a resize needs samples on both sides");
        let r = n_in as f64 / n_out as f64;
        (0..n_out)
            .map(|d| match self {
                Resampler::Bilinear => {
                    let s = ((d as f64 + 0.5) * r - 0.5).max(0.0);
                    let i0 = (s.floor() as usize).min(n_in - 1);
                    let i1 = (i0 + 1).min(n_in - 1);
                    let l = if i1 == i0 { 0.0 } else { s - i0 as f64 };
                    if l == 0.0 { vec![(i0, 1.0)] } else { vec![(i0, 1.0 - l), (i1, l)] }
                }
                Resampler::Area => {
                    let (a, b) = (d as f64 * r, (d + 1) as f64 * r);
                    let first = a.floor() as usize;
                    let last = ((b.ceil() as usize).min(n_in)).max(first + 1);
                    (first..last)
                        .map(|i| {
                            let overlap = (b.min(i as f64 + 1.0) - a.max(i as f64)).max(0.0);
                            (i, overlap / r)
                        })
                        .filter(|&(_, w)| w > 0.0)
                        .collect()
                }
            })
            .collect()
    }

    /// `Σw²` of every output index: the factor on a native pixel's noise variance along one
    /// axis when `n_in` samples are resized to `n_out`.
    pub fn variance_factors(self, n_in: usize, n_out: usize) -> Vec<f64> {
        self.taps(n_in, n_out).iter().map(|t| t.iter().map(|&(_, w)| w * w).sum()).collect()
    }

    /// Resizes an interleaved image of `channels` values per pixel from `w_in × h_in` to
    /// `w_out × h_out` with these taps (rows first, then columns; in `f64`). This is the
    /// explicit resize that the variance factors summarise; image formation does not call it.
    pub fn resize(
        self,
        image: &[f32],
        (w_in, h_in): (usize, usize),
        (w_out, h_out): (usize, usize),
        channels: usize,
    ) -> Vec<f32> {
        assert_eq!(image.len(), w_in * h_in * channels, "one value per pixel channel");
        let (tx, ty) = (self.taps(w_in, w_out), self.taps(h_in, h_out));
        // Columns of every input row first.
        let mut rows = vec![0.0f64; w_out * h_in * channels];
        for y in 0..h_in {
            for (x, taps) in tx.iter().enumerate() {
                for c in 0..channels {
                    rows[(y * w_out + x) * channels + c] = taps
                        .iter()
                        .map(|&(i, w)| w * f64::from(image[(y * w_in + i) * channels + c]))
                        .sum();
                }
            }
        }
        let mut out = vec![0.0f32; w_out * h_out * channels];
        for (y, taps) in ty.iter().enumerate() {
            for x in 0..w_out {
                for c in 0..channels {
                    let v: f64 =
                        taps.iter().map(|&(j, w)| w * rows[(j * w_out + x) * channels + c]).sum();
                    out[(y * w_out + x) * channels + c] = v as f32;
                }
            }
        }
        out
    }
}

impl std::fmt::Display for Resampler {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Resampler::Bilinear => "bilinear",
            Resampler::Area => "area",
        })
    }
}

/// The largest short side an input may have, px (the paper's detector uses 800).
pub const MAX_INPUT_SHORT_PX: usize = 1024;
/// The largest long side an input may have, px (the paper's detector allows 1333).
pub const MAX_INPUT_LONG_PX: usize = 2048;
/// The smallest short side an input may have, px.
pub const MIN_INPUT_SHORT_PX: usize = 16;

/// The detector's input size rule: short side `short_px`, long side at most `long_max_px`,
/// aspect ratio kept, and how frames are resized to it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DetectorInput {
    /// Short side of the input, pixels (unless the long side's cap makes it shorter).
    pub short_px: usize,
    /// Longest allowed long side, pixels.
    pub long_max_px: usize,
    /// How a sensor's frames are resized to the input.
    #[serde(default)]
    pub resampler: Resampler,
}

impl DetectorInput {
    /// The paper's detector input: short side 800 px, long side ≤ 1333 px, bilinear.
    pub const PAPER: DetectorInput =
        DetectorInput { short_px: 800, long_max_px: 1333, resampler: Resampler::Bilinear };

    /// Checks both sides: the short side from [`MIN_INPUT_SHORT_PX`] to [`MAX_INPUT_SHORT_PX`],
    /// the long side from the short side to [`MAX_INPUT_LONG_PX`]. `field` prefixes the names
    /// in the error (e.g. `run.input`).
    pub fn validate(&self, field: &str) -> Result<(), CameraError> {
        let range = |name: &str, v: usize, min: usize, max: usize| {
            if (min..=max).contains(&v) {
                Ok(())
            } else {
                Err(CameraError::OutOfRange {
                    field: format!("{field}.{name}"),
                    value: v as f64,
                    min: min as f64,
                    max: max as f64,
                    unit: " px",
                })
            }
        };
        range("short_px", self.short_px, MIN_INPUT_SHORT_PX, MAX_INPUT_SHORT_PX)?;
        range("long_max_px", self.long_max_px, self.short_px, MAX_INPUT_LONG_PX)
    }

    /// The input size `(width, height)` for a frame of `native_w × native_h` pixels: scaled by
    /// `min(short_px / short side, long_max_px / long side)` and rounded, at least 1 px.
    pub fn size_for(&self, native_w: usize, native_h: usize) -> (usize, usize) {
        let (short, long) = (native_w.min(native_h) as f64, native_w.max(native_h) as f64);
        let scale = (self.short_px as f64 / short).min(self.long_max_px as f64 / long);
        let side = |n: usize| ((n as f64 * scale).round() as usize).max(1);
        (side(native_w), side(native_h))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sum_sq(t: &[(usize, f64)]) -> f64 {
        t.iter().map(|&(_, w)| w * w).sum()
    }

    #[test]
    fn bilinear_taps_follow_pytorchs_source_index() {
        // 10 → 4: r = 2.5, s = (d + ½)·2.5 − ½ = 0.75, 3.25, 5.75, 8.25.
        let t = Resampler::Bilinear.taps(10, 4);
        let expected = [(0, 0.75), (3, 0.25), (5, 0.75), (8, 0.25)];
        for (taps, (i, l)) in t.iter().zip(expected) {
            assert_eq!(taps.len(), 2);
            assert_eq!(taps[0].0, i);
            assert!((taps[0].1 - (1.0 - l)).abs() < 1e-12 && (taps[1].1 - l).abs() < 1e-12);
        }
        // Upscaling 2 → 4: s = −0.25 (clamped to 0), 0.25, 0.75, 1.25 (clamped tap).
        let up = Resampler::Bilinear.taps(2, 4);
        assert_eq!(up[0], vec![(0, 1.0)]);
        assert_eq!(up[1], vec![(0, 0.75), (1, 0.25)]);
        assert_eq!(up[3], vec![(1, 1.0)]);
    }

    #[test]
    fn variance_factors_match_closed_forms() {
        // Bilinear at an even integer ratio samples half-way between two pixels: Σw² = ½; at an
        // odd one it lands on a pixel: Σw² = 1, whatever the ratio.
        for f in Resampler::Bilinear.variance_factors(4000, 500) {
            assert!((f - 0.5).abs() < 1e-12);
        }
        for f in Resampler::Bilinear.variance_factors(3500, 500) {
            assert!((f - 1.0).abs() < 1e-12);
        }
        // Area at an integer ratio r is the block mean: Σw² = 1/r.
        for f in Resampler::Area.variance_factors(4000, 400) {
            assert!((f - 0.1).abs() < 1e-12);
        }
        // Area at r = 1.5: footprints of 1 + ½ pixels, Σw² = (1 + ¼)/2.25.
        let f = Resampler::Area.variance_factors(3, 2);
        assert!((f[0] - 1.25 / 2.25).abs() < 1e-12 && (f[1] - 1.25 / 2.25).abs() < 1e-12);
    }

    #[test]
    fn taps_sum_to_one_and_stay_in_range() {
        for r in [Resampler::Bilinear, Resampler::Area] {
            for (n_in, n_out) in [(4000, 320), (1280, 320), (640, 427), (480, 500), (7, 3)] {
                for t in r.taps(n_in, n_out) {
                    let s: f64 = t.iter().map(|&(_, w)| w).sum();
                    assert!((s - 1.0).abs() < 1e-9, "{r} {n_in}->{n_out}: {t:?}");
                    assert!(t.iter().all(|&(i, w)| i < n_in && w > 0.0));
                    assert!(sum_sq(&t) <= 1.0 + 1e-12);
                }
            }
        }
    }

    #[test]
    fn resize_of_a_ramp_is_the_ramp_at_the_sample_points() {
        // A linear ramp v(i) = i resized bilinearly gives the source coordinate itself.
        let ramp: Vec<f32> = (0..10).map(|i| i as f32).collect();
        let out = Resampler::Bilinear.resize(&ramp, (10, 1), (4, 1), 1);
        for (v, s) in out.iter().zip([0.75, 3.25, 5.75, 8.25]) {
            assert!((v - s).abs() < 1e-6);
        }
        // Area: the footprint's centre.
        let out = Resampler::Area.resize(&ramp, (10, 1), (5, 1), 1);
        for (d, v) in out.iter().enumerate() {
            assert!((v - (2 * d) as f32 - 0.5).abs() < 1e-6);
        }
    }

    #[test]
    fn input_size_keeps_aspect_and_caps_the_long_side() {
        let input = DetectorInput { short_px: 240, long_max_px: 400, resampler: Resampler::Area };
        assert_eq!(input.size_for(4000, 3000), (320, 240));
        assert_eq!(input.size_for(1280, 960), (320, 240));
        assert_eq!(input.size_for(3849, 1929), (400, 200));
        assert_eq!(input.size_for(2840, 2840), (240, 240));
        assert_eq!(input.size_for(640, 480), (320, 240));
        assert_eq!(DetectorInput::PAPER.size_for(4000, 3000), (1067, 800));
    }

    #[test]
    fn bad_sizes_are_refused_naming_the_field() {
        let ok = DetectorInput { short_px: 240, long_max_px: 400, resampler: Resampler::Bilinear };
        assert!(ok.validate("run.input").is_ok());
        let e = DetectorInput { short_px: 0, ..ok }.validate("run.input").unwrap_err();
        assert_eq!(e.to_string(), "run.input.short_px = 0 is out of range: allowed 16 to 1024 px");
        let e = DetectorInput { long_max_px: 200, ..ok }.validate("run.input").unwrap_err();
        assert_eq!(
            e.to_string(),
            "run.input.long_max_px = 200 is out of range: allowed 240 to 2048 px"
        );
        let e = DetectorInput { long_max_px: 5000, ..ok }.validate("x").unwrap_err();
        assert!(e.to_string().starts_with("x.long_max_px = 5000"));
    }
}
