//! Flow-based motion blur for recorded frames (the real-image mode's emulation of a longer
//! shutter).
//!
//! A recorded frame is (nearly) sharp; the optical flow `v(x)` says how far the scene at `x`
//! moves between consecutive frames. With exposure `E`, frame interval `Δt` and the scenario's
//! blur factor `b`, the scene moves `d(x) = v(x) · E/Δt · b` while the shutter is open, and the
//! blurred frame is the average over the shutter interval, centred on the frame time:
//! `B(x) = ∫_{-1/2}^{1/2} I(x + t·d(x)) dt`. The integral is taken by the midpoint rule with
//! `n = 2⌈|d|⌉ + 1` bilinear samples (two per pixel of travel), so long smears stay smooth and
//! still pixels cost one sample. Blur is applied to linear intensities (calibrated DN), before
//! image formation adds noise.

use crate::flow::Flow;
use joca_core::HdrImage;
use rayon::prelude::*;

/// Sub-samples used for a travel of `length` pixels.
pub fn samples_for(length: f32) -> usize {
    2 * length.ceil().max(0.0) as usize + 1
}

fn sample_rgb(image: &HdrImage, x: f32, y: f32) -> [f32; 3] {
    let (w, h) = (image.width(), image.height());
    let x = x.clamp(0.0, (w - 1) as f32);
    let y = y.clamp(0.0, (h - 1) as f32);
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (a, b, c, d) =
        (image.pixel(x0, y0), image.pixel(x1, y0), image.pixel(x0, y1), image.pixel(x1, y1));
    let mut out = [0.0; 3];
    for k in 0..3 {
        out[k] =
            (a[k] * (1.0 - fx) + b[k] * fx) * (1.0 - fy) + (c[k] * (1.0 - fx) + d[k] * fx) * fy;
    }
    out
}

/// `image` blurred along `flow` scaled by `travel_per_flow` (= E/Δt × blur factor).
pub fn motion_blur(image: &HdrImage, flow: &Flow, travel_per_flow: f32) -> HdrImage {
    let (w, h) = (image.width(), image.height());
    assert_eq!((flow.width(), flow.height()), (w, h), "motion_blur: flow and image differ in size");
    let mut out = HdrImage::zeros(w, h);
    out.data_mut().par_chunks_mut(w * 3).enumerate().for_each(|(y, row)| {
        for x in 0..w {
            let v = flow.at(x, y);
            let d = [v[0] * travel_per_flow, v[1] * travel_per_flow];
            let n = samples_for(d[0].hypot(d[1]));
            let mut sum = [0.0f32; 3];
            for k in 0..n {
                let t = (k as f32 + 0.5) / n as f32 - 0.5;
                let p = sample_rgb(image, x as f32 + t * d[0], y as f32 + t * d[1]);
                for c in 0..3 {
                    sum[c] += p[c];
                }
            }
            for c in 0..3 {
                row[x * 3 + c] = sum[c] / n as f32;
            }
        }
    });
    out
}

/// How 8-bit recorded values map to linear intensity (0–255 scale) before blur and formation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Linearize {
    /// The values are sRGB-encoded (IEC 61966-2-1 transfer curve): decode them. Right for
    /// JPEGs from a camera pipeline (Waymo's are).
    Srgb,
    /// The values are already linear (raw or linear exports): use them as they are.
    None,
}

impl Linearize {
    /// Parses `srgb` or `none`.
    pub fn from_name(name: &str) -> Result<Self, String> {
        match name {
            "srgb" => Ok(Self::Srgb),
            "none" => Ok(Self::None),
            _ => Err(format!("unknown linearisation {name:?}; valid: srgb, none")),
        }
    }

    /// Linear value (0–255) of an 8-bit stored value.
    pub fn to_linear(self, v: u8) -> f32 {
        match self {
            Self::None => f32::from(v),
            Self::Srgb => {
                let c = f32::from(v) / 255.0;
                let l = if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) };
                255.0 * l
            }
        }
    }

    /// [`Linearize::to_linear`] of every 8-bit value: frames are linearised by lookup, not by a
    /// `powf` per sub-pixel.
    pub fn table(self) -> [f32; 256] {
        std::array::from_fn(|v| self.to_linear(v as u8))
    }

    /// Stored 8-bit value of a linear value (0–255), rounded and clipped.
    pub fn to_stored(self, v: f32) -> u8 {
        let l = (v / 255.0).clamp(0.0, 1.0);
        let c = match self {
            Self::None => l,
            Self::Srgb => {
                if l <= 0.003_130_8 {
                    12.92 * l
                } else {
                    1.055 * l.powf(1.0 / 2.4) - 0.055
                }
            }
        };
        (255.0 * c).round() as u8
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn srgb_round_trips_and_matches_the_standard_at_mid_grey() {
        for v in 0..=255u8 {
            assert_eq!(Linearize::Srgb.to_stored(Linearize::Srgb.to_linear(v)), v);
        }
        // sRGB 128 is 21.6 % linear (IEC 61966-2-1).
        assert!((Linearize::Srgb.to_linear(128) / 255.0 - 0.2158).abs() < 1e-3);
        assert_eq!(Linearize::None.to_linear(77), 77.0);
    }

    use super::*;

    #[test]
    fn still_pixels_are_unchanged_and_sample_counts_grow_with_travel() {
        let mut img = HdrImage::zeros(5, 4);
        img.set_pixel(2, 1, [10.0, 20.0, 30.0]);
        let out = motion_blur(&img, &Flow::zeros(5, 4), 1.0);
        assert_eq!(out, img);
        assert_eq!((samples_for(0.0), samples_for(0.3), samples_for(2.0)), (1, 3, 5));
    }
}
