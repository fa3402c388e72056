//! Flow-based motion blur for recorded frames (the real-image mode's emulation of a longer
//! shutter).
//!
//! A recorded frame is (nearly) sharp; the optical flow `v(x)` says how far the scene at `x`
//! moves between consecutive frames. With exposure `E`, frame interval `Δt` and the scenario's
//! blur factor `b`, the scene point at `x` moves `d(x) = v(x) · E/Δt · b` while the shutter is
//! open, centred on the frame time: it passes `x + t·d(x)` for `t ∈ [−1/2, 1/2]`.
//!
//! The blur **scatters**: each pixel's light is spread along its own path, by the midpoint rule
//! with `n = 2⌈|d|⌉ + 1` positions (two per pixel of travel) splatted bilinearly, each carrying
//! `1/n` of the pixel; every output pixel is the light it received over the weight it received
//! (a pixel nothing reaches keeps its value). A moving object so smears over the still
//! background beside it, as a sensor sees it; gathering along each pixel's own flow instead
//! would leave a still pixel next to a passing car untouched. Where the flow is uniform the two
//! agree exactly (the splat weights of one shift sum to one at every pixel): the box filter
//! `B(x) = ∫ I(x − t·d) dt` along the motion. Blur is applied to linear intensities
//! (calibrated DN), before image formation adds noise. Rows are splatted in fixed bands into
//! their own buffers, added in band order: the result does not depend on the thread count.

use crate::flow::Flow;
use joca_core::HdrImage;
use rayon::prelude::*;

/// Sub-samples used for a travel of `length` pixels.
pub fn samples_for(length: f32) -> usize {
    2 * length.ceil().max(0.0) as usize + 1
}

/// Rows per band of the scatter (fixed, so the summation order is too).
const BAND_ROWS: usize = 32;

/// `image` blurred along `flow` scaled by `travel_per_flow` (= E/Δt × blur factor).
pub fn motion_blur(image: &HdrImage, flow: &Flow, travel_per_flow: f32) -> HdrImage {
    let (w, h) = (image.width(), image.height());
    assert_eq!((flow.width(), flow.height()), (w, h), "motion_blur: flow and image differ in size");
    let travel = |x: usize, y: usize| {
        let v = flow.at(x, y);
        [v[0] * travel_per_flow, v[1] * travel_per_flow]
    };
    // Each band splats into a buffer of its rows and the rows its paths reach: light and weight
    // per pixel, [r, g, b, w].
    let bands: Vec<(usize, Vec<[f32; 4]>)> = (0..h.div_ceil(BAND_ROWS))
        .into_par_iter()
        .map(|band| {
            let rows = band * BAND_ROWS..((band + 1) * BAND_ROWS).min(h);
            let reach = rows
                .clone()
                .flat_map(|y| (0..w).map(move |x| (x, y)))
                .map(|(x, y)| travel(x, y)[1].abs())
                .fold(0.0f32, f32::max);
            let margin = (0.5 * reach).ceil() as usize + 1;
            let top = rows.start.saturating_sub(margin);
            let bottom = (rows.end + margin).min(h);
            let mut acc = vec![[0.0f32; 4]; (bottom - top) * w];
            for y in rows {
                for x in 0..w {
                    let d = travel(x, y);
                    let n = samples_for(d[0].hypot(d[1]));
                    let p = image.pixel(x, y);
                    let share = 1.0 / n as f32;
                    for k in 0..n {
                        let t = (k as f32 + 0.5) / n as f32 - 0.5;
                        splat(
                            &mut acc,
                            w,
                            top,
                            bottom,
                            x as f32 + t * d[0],
                            y as f32 + t * d[1],
                            p,
                            share,
                        );
                    }
                }
            }
            (top, acc)
        })
        .collect();
    let mut sum = vec![[0.0f32; 4]; w * h];
    for (top, acc) in &bands {
        for (s, a) in sum[top * w..top * w + acc.len()].iter_mut().zip(acc) {
            for c in 0..4 {
                s[c] += a[c];
            }
        }
    }
    let mut out = image.clone();
    for (o, s) in out.data_mut().chunks_exact_mut(3).zip(&sum) {
        if s[3] > 1e-6 {
            for c in 0..3 {
                o[c] = s[c] / s[3];
            }
        }
    }
    out
}

/// Adds `p · share` (and the weight `share`) at `(x, y)` bilinearly into `acc`, which holds rows
/// `top..bottom` of a `w`-wide image; what falls outside the image is lost.
/// `x.floor()` for |x| < 2³¹ without the libm call baseline x86-64 makes for it (this runs
/// four times per splatted sample).
#[inline(always)]
fn floor(x: f32) -> f32 {
    let t = x as i32 as f32;
    if t > x { t - 1.0 } else { t }
}

#[allow(clippy::too_many_arguments)]
fn splat(
    acc: &mut [[f32; 4]],
    w: usize,
    top: usize,
    bottom: usize,
    x: f32,
    y: f32,
    p: [f32; 3],
    share: f32,
) {
    let (x0, y0) = (floor(x), floor(y));
    let (fx, fy) = (x - x0, y - y0);
    for (dy, wy) in [(0i64, 1.0 - fy), (1, fy)] {
        for (dx, wx) in [(0i64, 1.0 - fx), (1, fx)] {
            let (xi, yi) = (x0 as i64 + dx, y0 as i64 + dy);
            let weight = wx * wy * share;
            if weight <= 0.0 || xi < 0 || xi >= w as i64 || yi < top as i64 || yi >= bottom as i64 {
                continue;
            }
            let a = &mut acc[(yi as usize - top) * w + xi as usize];
            for c in 0..3 {
                a[c] += weight * p[c];
            }
            a[3] += weight;
        }
    }
}

joca_core::named_enum! {
    /// How 8-bit recorded values map to linear intensity (0–255 scale) before blur and formation.
    pub enum Linearize("linearisation") {
        /// The values are sRGB-encoded (IEC 61966-2-1 transfer curve): decode them. Right for
        /// JPEGs from a camera pipeline (Waymo's are).
        Srgb = "srgb",
        /// The values are already linear (raw or linear exports): use them as they are.
        None = "none",
    }
}

impl Linearize {
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
    fn the_fast_floor_is_the_floor() {
        for x in
            [-3.5f32, -3.0, -2.999, -0.5, -0.0, 0.0, 0.25, 1.0, 7.999_999, 1e6 + 0.5, -1e6 - 0.5]
        {
            assert_eq!(floor(x), x.floor(), "{x}");
        }
        for k in -2000..2000 {
            let x = k as f32 * 0.013 - 0.0005;
            assert_eq!(floor(x), x.floor(), "{x}");
        }
    }

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
