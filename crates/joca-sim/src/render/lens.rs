//! The lens's defocus and diffraction blur by depth, between the scene (after the air,
//! [`super::fog`]) and the sensor.
//!
//! Each pixel spreads as a Gaussian of the standard deviation
//! [`Lens::blur_sigma_mm`] gives for its depth, in pixels of the view (the blur is optical, so it
//! is the same on the sensor's native grid and carried to the detector input by the view's
//! pixel pitch). The spread is gathered, not scattered: a pixel receives from a neighbour only if
//! the neighbour is not behind it, so a defocused background never spreads over a sharp
//! foreground, while a defocused foreground spreads over what lies behind it. Each
//! neighbour's Gaussian is normalised over the window, so a flat field stays flat and a sharp
//! pixel (σ below [`SHARP_SIGMA_PX`]) keeps its value.

use super::Target;
use joca_core::PinholeCamera;
use joca_core::optics::Lens;
use rayon::prelude::*;

/// Below this standard deviation, pixels, a pixel's blur sends less than 0.05 % of its light to
/// a neighbour (exp(−1/(2σ²)) at σ = 0.25 px is 3·10⁻⁴): it is treated as sharp.
pub const SHARP_SIGMA_PX: f32 = 0.25;

/// The widest blur radius gathered, pixels (3σ up to this): a σ of 8 px and beyond is cut here.
pub const MAX_RADIUS_PX: usize = 24;

/// A neighbour this much farther than a pixel (relative depth) counts as behind it.
const BEHIND: f32 = 1.02;

/// A lens's blur in view pixels as a function of inverse depth: the circle of confusion is
/// linear in |1/d − 1/s| (c = (f/N)·f/(s − f)·s·|1/d − 1/s|), so each pixel's σ is two
/// multiplications and a square root in f32, and the widest σ of a view is at its nearest or
/// farthest depth.
#[derive(Debug, Clone, Copy)]
struct BlurModel {
    /// c in view pixels per unit of |1/d − 1/s| (1/m).
    coc_px_per_inv_m: f32,
    /// 1/s, 1/m (0 when focused at infinity).
    inv_focus: f32,
    /// The diffraction's σ², view pixels².
    diffraction_var: f32,
}

impl BlurModel {
    fn new(lens: &Lens, pitch_mm: f64) -> Self {
        let f = lens.focal_length_mm;
        // |d − s|/d = s·|1/d − 1/s|, so c = (f/N)·f/(s − f)·s·|1/d − 1/s| (s in m for the last
        // factor); focused at infinity, c = (f/N)·f/d = (f/N)·f·10⁻³·(1/d in 1/m).
        let coc_mm_per_inv_m = if lens.focus_m.is_infinite() {
            f / lens.f_number * f * 1e-3
        } else {
            f / lens.f_number * f / (lens.focus_m * 1e3 - f) * lens.focus_m
        };
        let diffraction = 0.42 * joca_core::optics::WAVELENGTH_UM * 1e-3 * lens.f_number;
        Self {
            coc_px_per_inv_m: (coc_mm_per_inv_m / pitch_mm) as f32,
            inv_focus: if lens.focus_m.is_infinite() { 0.0 } else { (1.0 / lens.focus_m) as f32 },
            diffraction_var: ((diffraction / pitch_mm) as f32).powi(2),
        }
    }

    /// σ in view pixels at inverse depth `inv_z` (0: infinitely far).
    fn sigma_px(&self, inv_z: f32) -> f32 {
        let c = self.coc_px_per_inv_m * (inv_z - self.inv_focus).abs();
        (c * c / 16.0 + self.diffraction_var).sqrt()
    }
}

/// Blurs `target` by its lens's defocus and diffraction (nothing without a lens, or where every
/// pixel is sharp).
pub fn defocus(target: &mut Target, camera: &PinholeCamera) {
    let (w, h) = (target.width, target.height);
    defocus_colour(&mut target.colour, &target.inv_depth, w, h, camera);
}

/// [`defocus`] of an interleaved RGB `colour` (`width × height`) whose depths are `inv_depth`:
/// a shutter-integrated frame with the depths of its middle instant.
pub fn defocus_colour(
    colour: &mut Vec<f32>,
    inv_depth: &[f32],
    width: usize,
    height: usize,
    camera: &PinholeCamera,
) {
    let Some(lens) = camera.lens else { return };
    if colour.is_empty() {
        return;
    }
    // The view's pixel on the sensor: f / f_px (the pinhole's pixels are square to 0.1 %).
    let pitch_mm = lens.focal_length_mm / camera.fx_px;
    let model = BlurModel::new(&lens, pitch_mm);
    let (near, far) =
        inv_depth.iter().fold((0.0f32, f32::INFINITY), |(hi, lo), &v| (hi.max(v), lo.min(v)));
    let widest = model.sigma_px(near).max(model.sigma_px(far));
    if widest < SHARP_SIGMA_PX {
        return;
    }
    let sigmas: Vec<f32> = inv_depth.iter().map(|&v| model.sigma_px(v)).collect();
    let radius = ((3.0 * widest).ceil() as usize).clamp(1, MAX_RADIUS_PX);
    *colour = gather(colour, inv_depth, width, height, &sigmas, radius);
}

/// The blurred colour: every pixel the normalised-Gaussian-weighted mean of the neighbours
/// within `radius` that are not behind it, each by its own σ.
fn gather(
    colour: &[f32],
    inv_depth: &[f32],
    w: usize,
    h: usize,
    sigmas: &[f32],
    radius: usize,
) -> Vec<f32> {
    // Each pixel's Gaussian, sampled at integer offsets and normalised over the window, as a
    // table per pixel: its weight at offset (dx, dy) is taps[|dx|]·taps[|dy|] (no exp per tap).
    let span = radius + 1;
    let mut taps = vec![0.0f32; sigmas.len() * span];
    taps.par_chunks_mut(span).zip(sigmas).for_each(|(t, &s)| {
        if s < SHARP_SIGMA_PX {
            t[0] = 1.0;
            return;
        }
        for (k, v) in t.iter_mut().enumerate() {
            *v = (-((k * k) as f32) / (2.0 * s * s)).exp();
        }
        let norm = t[0] + 2.0 * t[1..].iter().sum::<f32>();
        t.iter_mut().for_each(|v| *v /= norm);
    });
    let mut out = vec![0.0f32; w * h * 3];
    out.par_chunks_mut(w * 3).enumerate().for_each(|(y, row)| {
        for x in 0..w {
            let p = y * w + x;
            let here = inv_depth[p];
            let mut acc = [0.0f32; 3];
            let mut total = 0.0f32;
            for qy in y.saturating_sub(radius)..(y + radius + 1).min(h) {
                for qx in x.saturating_sub(radius)..(x + radius + 1).min(w) {
                    let q = qy * w + qx;
                    // Behind this pixel (farther, by depth; sky is farthest): occluded. A
                    // sharp neighbour keeps its light.
                    if q != p && (sigmas[q] < SHARP_SIGMA_PX || inv_depth[q] * BEHIND < here) {
                        continue;
                    }
                    let t = &taps[q * span..q * span + span];
                    let weight = t[qx.abs_diff(x)] * t[qy.abs_diff(y)];
                    for (a, v) in acc.iter_mut().zip(&colour[q * 3..q * 3 + 3]) {
                        *a += weight * v;
                    }
                    total += weight;
                }
            }
            for (o, a) in row[x * 3..x * 3 + 3].iter_mut().zip(acc) {
                *o = a / total;
            }
        }
    });
    out
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// A view through an 8 mm lens whose pixels are `pitch_um` wide on the sensor.
    pub(in crate::render) fn camera(
        w: usize,
        h: usize,
        pitch_um: f64,
        lens: Option<Lens>,
    ) -> PinholeCamera {
        let f = 8.0 / (pitch_um * 1e-3);
        PinholeCamera { lens, ..PinholeCamera::centred((w, h), (f, f), [0.0, 0.0, 1.5]) }
    }

    /// A `w`×`h` view of one grey `value` at depth `depth_m` everywhere.
    pub(in crate::render) fn flat(w: usize, h: usize, depth_m: f32, value: f32) -> Target {
        let mut t = Target::new(w, h, 0);
        t.colour.iter_mut().for_each(|v| *v = value);
        t.inv_depth.iter_mut().for_each(|d| *d = 1.0 / depth_m);
        t
    }

    /// Per-axis standard deviation of the light around pixel (cx, cy), pixels.
    fn spread(t: &Target, cx: usize, cy: usize) -> f64 {
        let (mut m, mut v) = (0.0, 0.0);
        for y in 0..t.height {
            for x in 0..t.width {
                let e = f64::from(t.colour[(y * t.width + x) * 3]);
                let d2 = (x as f64 - cx as f64).powi(2) + (y as f64 - cy as f64).powi(2);
                m += e;
                v += e * d2;
            }
        }
        (v / m / 2.0).sqrt()
    }

    #[test]
    fn a_point_spreads_as_the_thin_lens_says_at_three_depths() {
        // 8 mm at f/1.4 focused at 5 m; a point at each depth on a black plane at that depth.
        let lens = Lens { focal_length_mm: 8.0, f_number: 1.4, focus_m: 5.0 };
        // 1.5 µm view pixels: σ from 1.3 px (40 m) to 4.8 px (1.2 m).
        let cam = camera(97, 97, 1.5, Some(lens));
        for depth in [1.2f32, 2.0, 40.0] {
            let mut t = flat(97, 97, depth, 0.0);
            t.colour[(48 * 97 + 48) * 3] = 1000.0;
            defocus(&mut t, &cam);
            let want = lens.blur_sigma_mm(f64::from(depth)) / 1.5e-3;
            let got = spread(&t, 48, 48);
            // The sampled Gaussian's variance is the continuous one's to well under 1 % for
            // σ ≥ 1 px (and the window, 3σ, holds 99.7 % of it per axis).
            assert!(want > 1.0, "{depth} m: σ {want} px too small to measure");
            assert!((got - want).abs() < 0.03 * want, "{depth} m: σ {got} px, thin lens {want}");
            let total: f32 = t.colour.iter().step_by(3).sum();
            assert!((total - 1000.0).abs() < 1.0, "energy {total}");
        }
    }

    #[test]
    fn the_f32_blur_model_is_the_thin_lens_formula() {
        for lens in [
            Lens { focal_length_mm: 8.0, f_number: 1.4, focus_m: 5.0 },
            Lens { focal_length_mm: 3.6, f_number: 16.0, focus_m: 0.7 },
            Lens { focal_length_mm: 10.0, f_number: 2.0, focus_m: f64::INFINITY },
        ] {
            let model = BlurModel::new(&lens, 4e-3);
            for depth in [0.5f64, 1.0, 5.0, 37.0, f64::INFINITY] {
                let want = lens.blur_sigma_mm(depth) / 4e-3;
                let inv = if depth.is_infinite() { 0.0 } else { (1.0 / depth) as f32 };
                let got = f64::from(model.sigma_px(inv));
                assert!(
                    (got - want).abs() < 1e-5 * want.max(1.0),
                    "{lens:?} {depth} m: {got} vs {want}"
                );
            }
        }
    }

    #[test]
    fn flat_fields_stay_flat_and_sharp_views_are_untouched() {
        let lens = Lens { focal_length_mm: 8.0, f_number: 1.4, focus_m: 5.0 };
        let mut t = flat(40, 30, 1.0, 77.0);
        defocus(&mut t, &camera(40, 30, 1.5, Some(lens)));
        assert!(t.colour.iter().all(|&v| (v - 77.0).abs() < 1e-3));
        // f/4 at the hyperfocal distance of 10 µm native pixels, seen at 20 µm view pixels (a
        // 2× downscale to the detector input): σ = 0.13 view px at most, sharp.
        let sharp = Lens::at_hyperfocal(8.0, 4.0, 10.0);
        let mut t = flat(40, 30, 20.0, 0.0);
        t.colour[(15 * 40 + 20) * 3] = 500.0;
        let before = t.colour.clone();
        defocus(&mut t, &camera(40, 30, 20.0, Some(sharp)));
        assert_eq!(t.colour, before);
        let mut t2 = flat(40, 30, 20.0, 0.0);
        t2.colour[(15 * 40 + 20) * 3] = 500.0;
        defocus(&mut t2, &camera(40, 30, 20.0, None));
        assert_eq!(t2.colour, before);
    }

    #[test]
    fn a_blurred_background_does_not_spread_over_a_sharp_foreground() {
        // Focused at 5 m, 2 µm view pixels: a bright square at 5 m (sharp) in front of a dark,
        // textured wall at 100 m (σ ≈ 2.2 µm = 1.1 px), and the reverse: a blurred near square
        // over a sharp far wall.
        let lens = Lens { focal_length_mm: 8.0, f_number: 1.4, focus_m: 5.0 };
        let cam = camera(60, 60, 2.0, Some(lens));
        let mut t = flat(60, 60, 100.0, 0.0);
        for y in 0..60 {
            for x in 0..60 {
                let p = y * 60 + x;
                t.colour[p * 3] = if (x + y) % 2 == 0 { 10.0 } else { 30.0 };
                if (20..40).contains(&x) && (20..40).contains(&y) {
                    t.colour[p * 3] = 200.0;
                    t.inv_depth[p] = 1.0 / 5.0;
                }
            }
        }
        let before = t.colour.clone();
        defocus(&mut t, &cam);
        for y in 20..40 {
            for x in 20..40 {
                let p = (y * 60 + x) * 3;
                assert_eq!(t.colour[p], before[p], "foreground ({x}, {y}) changed");
            }
        }
        // The background's checkerboard is blurred away, and the sharp square does not leak.
        let bg = t.colour[(5 * 60 + 5) * 3];
        assert!((bg - 20.0).abs() < 0.5, "{bg}");
        let edge = t.colour[(30 * 60 + 18) * 3];
        assert!((edge - 20.0).abs() < 1.0, "the square leaked onto the wall: {edge}");

        // A defocused near object (0.6 m: σ > 8 px) spreads over a sharp wall at 5 m.
        let mut t = flat(60, 60, 5.0, 0.0);
        for y in 25..35 {
            for x in 25..35 {
                t.colour[(y * 60 + x) * 3] = 200.0;
                t.inv_depth[y * 60 + x] = 1.0 / 0.6;
            }
        }
        defocus(&mut t, &cam);
        assert!(t.colour[(30 * 60 + 20) * 3] > 5.0, "blurred foreground did not spread");
    }
}
