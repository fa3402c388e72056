//! Noise calibration by photon transfer: estimate σp² and σr² of Eq. 3 from frames of a static
//! scene.
//!
//! With `N ≥ 2` frames of an unchanging scene at one exposure and gain, every pixel's temporal
//! mean `μ` and unbiased temporal variance `s²` sample the noise curve of Eq. 3,
//! `σ²(μ) = g·σp²·μ + g²·σr²` with `g = G/G0`. Pixels are pooled in bins of equal mean; a line
//! `s² = a·μ + b` is fitted by weighted least squares (weights `n_bin / σ⁴`, the inverse variance
//! of a pooled Gaussian sample variance), then `σp² = a/g` and `σr² = (b − 1/12)/g²`. The
//! `1/12` is Sheppard's correction: rounding to integer DN adds the variance of a uniform
//! distribution of width one. Pixels whose mean lies within 4σ of 0 or 255 are excluded because
//! clipping shrinks their variance; the fit is repeated once with that σ.

use crate::CameraError;
use joca_core::Rgb8Image;
use joca_core::units::linear_from_db;

/// Width of a mean-intensity bin, DN.
const BIN_DN: f64 = 2.0;

/// Result of a photon-transfer fit for one channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChannelFit {
    /// Slope of variance against mean at the frames' gain, DN.
    pub slope: f64,
    /// Intercept of variance at zero mean at the frames' gain (after Sheppard's correction), DN².
    pub intercept: f64,
    /// σp² referred to the calibration gain G0.
    pub sigma_p2: f64,
    /// σr² referred to the calibration gain G0.
    pub sigma_r2: f64,
    /// Pixels that entered the fit.
    pub samples: usize,
}

/// Estimates σp² and σr² per RGB channel from `frames` of a static scene taken at `gain_db`;
/// `calibration_gain_db` is G0, the gain the parameters are referred to.
pub fn calibrate_noise(
    frames: &[Rgb8Image],
    gain_db: f64,
    calibration_gain_db: f64,
) -> Result<[ChannelFit; 3], CameraError> {
    let first = frames.first().ok_or_else(|| bad("no frames given"))?;
    if frames.len() < 2 {
        return Err(bad("photon transfer needs at least 2 frames of the same static scene"));
    }
    let (w, h) = (first.width(), first.height());
    if let Some(f) = frames.iter().find(|f| (f.width(), f.height()) != (w, h)) {
        return Err(bad(&format!(
            "frames differ in size: {}x{} and {}x{}",
            w,
            h,
            f.width(),
            f.height()
        )));
    }
    for (field, value) in [("gain_db", gain_db), ("calibration_gain_db", calibration_gain_db)] {
        if !(-20.0..=60.0).contains(&value) {
            return Err(CameraError::OutOfRange {
                field: field.into(),
                value,
                min: -20.0,
                max: 60.0,
                unit: " dB",
            });
        }
    }
    let g = linear_from_db(gain_db) / linear_from_db(calibration_gain_db);
    let n = frames.len() as f64;
    let values = w * h * 3;
    let mut means = vec![0.0f64; values];
    let mut vars = vec![0.0f64; values];
    for f in frames {
        for (m, &v) in means.iter_mut().zip(f.data()) {
            *m += f64::from(v);
        }
    }
    means.iter_mut().for_each(|m| *m /= n);
    for f in frames {
        for ((s, &v), m) in vars.iter_mut().zip(f.data()).zip(&means) {
            *s += (f64::from(v) - m).powi(2);
        }
    }
    vars.iter_mut().for_each(|s| *s /= n - 1.0);
    if vars.iter().all(|&v| v == 0.0) {
        return Err(bad(
            "the frames are identical: there is no temporal noise to measure (photon transfer \
             needs several raw frames of a static scene, not copies of one frame)",
        ));
    }

    let mut fits =
        [ChannelFit { slope: 0.0, intercept: 0.0, sigma_p2: 0.0, sigma_r2: 0.0, samples: 0 }; 3];
    for (c, fit) in fits.iter_mut().enumerate() {
        let pairs: Vec<(f64, f64)> = (c..values).step_by(3).map(|k| (means[k], vars[k])).collect();
        // First pass on a conservative range, second with the clipping margin from that fit.
        let (a0, b0, _) =
            fit_line(&pairs, None, |mu| (10.0..=245.0).contains(&mu)).ok_or_else(|| {
                bad("the frames hold too little intensity variation between 10 and 245 DN to \
                     fit a noise curve; use a scene with a range of grey levels")
            })?;
        let (a, b, used) = fit_line(&pairs, Some((a0, b0)), |mu| {
            let sigma = (a0 * mu + b0).max(0.25).sqrt();
            mu - 4.0 * sigma > 0.0 && mu + 4.0 * sigma < 255.0
        })
        .ok_or_else(|| bad("too few unclipped pixels to fit a noise curve"))?;
        let intercept = b - 1.0 / 12.0;
        *fit = ChannelFit {
            slope: a,
            intercept,
            sigma_p2: a / g,
            sigma_r2: intercept / (g * g),
            samples: used,
        };
    }
    Ok(fits)
}

/// Weighted least-squares line through binned (mean, pooled variance) points of the pixels that
/// `keep` accepts; `None` with fewer than two usable bins. Each bin is weighted by the inverse
/// variance of its pooled sample variance, `n / σ⁴`, with σ² from `prior` (a previous fit) or,
/// on the first pass, from the bin itself (which slightly favours low bins, hence the refit).
fn fit_line(
    pairs: &[(f64, f64)],
    prior: Option<(f64, f64)>,
    keep: impl Fn(f64) -> bool,
) -> Option<(f64, f64, usize)> {
    let bins = (256.0 / BIN_DN).ceil() as usize;
    let mut sum_mu = vec![0.0f64; bins];
    let mut sum_var = vec![0.0f64; bins];
    let mut count = vec![0usize; bins];
    for &(mu, var) in pairs {
        if keep(mu) {
            let b = ((mu / BIN_DN) as usize).min(bins - 1);
            sum_mu[b] += mu;
            sum_var[b] += var;
            count[b] += 1;
        }
    }
    let (mut sw, mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    let mut used = 0;
    let mut bins_used = 0;
    for b in 0..bins {
        if count[b] < 8 {
            continue;
        }
        let n = count[b] as f64;
        let (x, y) = (sum_mu[b] / n, sum_var[b] / n);
        let model = prior.map_or(y, |(a, b)| a * x + b);
        let w = n / model.max(1e-3).powi(2);
        sw += w;
        sx += w * x;
        sy += w * y;
        sxx += w * x * x;
        sxy += w * x * y;
        used += count[b];
        bins_used += 1;
    }
    let det = sw * sxx - sx * sx;
    if bins_used < 2 || det <= 0.0 {
        return None;
    }
    let a = (sw * sxy - sx * sy) / det;
    let b = (sy - a * sx) / sw;
    Some((a, b, used))
}

fn bad(reason: &str) -> CameraError {
    CameraError::BadInput { reason: reason.to_owned() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formation::{Calibration, ImageFormation};
    use crate::settings::DynamicSettings;
    use joca_core::{HdrImage, SeedStreams};

    /// A static scene: a horizontal ramp from 0 to 250 DN.
    fn ramp(width: usize, height: usize) -> HdrImage {
        let mut img = HdrImage::zeros(width, height);
        for y in 0..height {
            for x in 0..width {
                let v = 250.0 * x as f32 / (width - 1) as f32;
                img.set_pixel(x, y, [v, v, v]);
            }
        }
        img
    }

    fn recovers(cal: Calibration, settings: DynamicSettings, frames: usize) {
        let formation = ImageFormation::new(cal).unwrap();
        let scene = ramp(320, 240);
        let streams = SeedStreams::new(21);
        let stack: Vec<Rgb8Image> = (0..frames)
            .map(|k| {
                formation.form(
                    &scene,
                    settings,
                    cal.pixel_pitch_um,
                    &mut streams.indexed("f", k as u64),
                )
            })
            .collect();
        let fits = calibrate_noise(&stack, settings.gain_db, cal.gain_db).unwrap();
        for (c, f) in fits.iter().enumerate() {
            let (ep, er) = (f.sigma_p2 / cal.sigma_p2[c] - 1.0, f.sigma_r2 / cal.sigma_r2[c] - 1.0);
            assert!(
                ep.abs() < 0.10,
                "ch {c}: σp² {} vs {} ({ep:+.3})",
                f.sigma_p2,
                cal.sigma_p2[c]
            );
            assert!(
                er.abs() < 0.10,
                "ch {c}: σr² {} vs {} ({er:+.3})",
                f.sigma_r2,
                cal.sigma_r2[c]
            );
        }
    }

    #[test]
    fn recovers_the_default_calibration_at_g0() {
        recovers(Calibration::DEFAULT, DynamicSettings::new(5e-3, 10.0), 8);
    }

    #[test]
    fn recovers_larger_parameters_at_another_gain_from_two_frames() {
        let cal = Calibration {
            sigma_p2: [0.9, 0.5, 1.3],
            sigma_r2: [4.0, 2.5, 6.0],
            ..Calibration::DEFAULT
        };
        // At 16 dB the frames' variance is g·σp²·μ + g²·σr² with g ≈ 2; the fit refers back.
        recovers(cal, DynamicSettings::new(2.5e-3, 16.0), 4);
    }

    #[test]
    fn refuses_unusable_stacks() {
        let one = vec![Rgb8Image::zeros(8, 8)];
        assert!(calibrate_noise(&one, 10.0, 10.0).unwrap_err().to_string().contains("at least 2"));
        let flat = vec![Rgb8Image::zeros(8, 8), Rgb8Image::zeros(8, 8)];
        assert!(calibrate_noise(&flat, 10.0, 10.0).is_err());
        let mixed = vec![Rgb8Image::zeros(8, 8), Rgb8Image::zeros(4, 8)];
        assert!(calibrate_noise(&mixed, 10.0, 10.0).unwrap_err().to_string().contains("differ"));
    }
}
