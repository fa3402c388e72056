//! Image formation: from calibrated radiometry `I0` to the 8-bit frame a camera delivers.
//!
//! For a frame taken with exposure `E`, gain `G` (linear) and pixel pitch `p`, each channel value
//! is (paper Eq. 2, with the pixel-area factor of Sec. 4):
//!
//! ```text
//! I  = I0 · (E/E0) · (G/G0) · (p/p0)²
//! σ² = (G/G0)·σp²·I + (G/G0)²·σr²          (Eq. 3, affine noise of Foi et al.)
//! out = round(clamp(I + σ·z, 0, 255)),  z ~ N(0, 1) independent per pixel and channel
//! ```
//!
//! `E0, G0, p0` and the per-channel `σp², σr²` come from a [`Calibration`]. Noise is the Gaussian
//! approximation of the Poisson–Gaussian model that Eq. 3 describes. The scenario "noise ×N"
//! multiplies σp² and σr² by N ([`ImageFormation::with_noise_scale`]); DESIGN.md explains why the
//! variances and not σ.
//!
//! The normal samples come from per-tile generators seeded from one draw of the caller's stream,
//! so a frame is bit-identical whether it is formed on one thread or many, and
//! [`ImageFormation::standard_normals`] reproduces the exact `z` field a frame used (the
//! differentiable formation of `joca-nn` consumes it to mirror this one).

mod kernels;

use crate::CameraError;
use crate::settings::DynamicSettings;
use joca_core::units::linear_from_db;
use joca_core::{HdrImage, Rgb8Image};
use rand::Rng;
use serde::{Deserialize, Serialize};

pub use kernels::TILE_ROWS;

/// The physical camera that calibrated brightness and noise (DESIGN.md reference values).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Calibration {
    /// Pixel pitch p0 of the calibration camera, micrometres.
    pub pixel_pitch_um: f64,
    /// Exposure E0 at which `I0` is expressed, seconds.
    pub exposure_s: f64,
    /// Gain G0 at which `I0` is expressed, dB.
    pub gain_db: f64,
    /// Photon (signal-dependent) noise parameter σp² per RGB channel, DN at gain G0.
    pub sigma_p2: [f64; 3],
    /// Read (signal-independent) noise variance σr² per RGB channel, DN² at gain G0.
    pub sigma_r2: [f64; 3],
}

impl Calibration {
    /// Basler Dart daA1280-54uc (AR0134, 3.75 µm) at 5 ms, 10 dB; noise parameters of a FLIR
    /// IMX172 camera's published calibration (an assumption: the paper's own are unpublished).
    pub const DEFAULT: Calibration = Calibration {
        pixel_pitch_um: 3.75,
        exposure_s: 5e-3,
        gain_db: 10.0,
        sigma_p2: [0.24, 0.12, 0.29],
        sigma_r2: [1.82, 0.91, 3.2],
    };

    /// Checks that every parameter lies in a physically meaningful range: pixel pitch
    /// 0.5–50 µm, exposure 1 µs–10 s, gain −20–60 dB, noise variances 0–10⁴ DN².
    pub fn validate(&self) -> Result<(), CameraError> {
        let within = |field: &str, v: f64, min: f64, max: f64, unit: &'static str| {
            if (min..=max).contains(&v) {
                Ok(())
            } else {
                Err(CameraError::OutOfRange { field: field.to_owned(), value: v, min, max, unit })
            }
        };
        within("calibration.pixel_pitch_um", self.pixel_pitch_um, 0.5, 50.0, " µm")?;
        within("calibration.exposure_s", self.exposure_s, 1e-6, 10.0, " s")?;
        within("calibration.gain_db", self.gain_db, -20.0, 60.0, " dB")?;
        for (name, values) in [("sigma_p2", self.sigma_p2), ("sigma_r2", self.sigma_r2)] {
            for v in values {
                within(&format!("calibration.{name}"), v, 0.0, 1e4, " DN²")?;
            }
        }
        Ok(())
    }
}

impl Default for Calibration {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The white level of 8-bit output, DN.
pub const WHITE_LEVEL: f32 = 255.0;

/// Per-frame constants of Eq. 2–3, resolved once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FormationParams {
    /// `(E/E0)(G/G0)(p/p0)²`.
    pub intensity_scale: f32,
    /// Per channel `(G/G0)·σp²·N`: variance per DN of signal.
    pub photon_var_per_dn: [f32; 3],
    /// Per channel `(G/G0)²·σr²·N`: signal-independent variance.
    pub read_var: [f32; 3],
}

/// Turns calibrated radiometry into camera frames.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImageFormation {
    calibration: Calibration,
    noise_scale: f64,
    render_scale: f64,
}

impl ImageFormation {
    /// Formation with `calibration` and calibrated noise (×1).
    pub fn new(calibration: Calibration) -> Result<Self, CameraError> {
        calibration.validate()?;
        Ok(Self { calibration, noise_scale: 1.0, render_scale: 1.0 })
    }

    /// The same formation with σp² and σr² multiplied by `noise_scale` (scenario "noise ×N").
    pub fn with_noise_scale(self, noise_scale: f64) -> Result<Self, CameraError> {
        if !(noise_scale.is_finite() && noise_scale >= 0.0) {
            return Err(CameraError::OutOfRange {
                field: "noise_scale".into(),
                value: noise_scale,
                min: 0.0,
                max: f64::INFINITY,
                unit: "",
            });
        }
        Ok(Self { noise_scale, ..self })
    }

    /// The same formation for frames rendered at `render_scale` times the sensor's pixel grid
    /// (DESIGN.md: a shortcut must not bend the physics). A rendered pixel then stands for
    /// `1/s²` sensor pixels, and its noise is that of their area average: the variances of Eq. 3
    /// are divided by `1/s²`, the mean is unchanged. What differs from forming every sensor pixel
    /// and averaging: clipping applies to the average instead of to each sensor pixel, so within
    /// a few σ of 0 or 255 the formed pixel is less biased than the sensor's average (by about
    /// +0.1 DN at 3 DN and −1.3 DN at 250 DN at E0, G0 in the tests); quantisation rounds the
    /// average once, as an 8-bit downscaled frame does.
    pub fn with_render_scale(self, render_scale: f64) -> Result<Self, CameraError> {
        if !(render_scale > 0.0 && render_scale <= 1.0) {
            return Err(CameraError::OutOfRange {
                field: "render_scale".into(),
                value: render_scale,
                min: 0.0,
                max: 1.0,
                unit: "",
            });
        }
        Ok(Self { render_scale, ..self })
    }

    /// The render scale s: a formed pixel is the average of `1/s²` sensor pixels.
    pub fn render_scale(&self) -> f64 {
        self.render_scale
    }

    /// The factor on σp² and σr²: the scenario's noise ×N over the `1/s²` sensor pixels a formed
    /// pixel averages.
    pub fn variance_scale(&self) -> f64 {
        self.noise_scale * self.render_scale * self.render_scale
    }

    /// The calibration.
    pub fn calibration(&self) -> &Calibration {
        &self.calibration
    }

    /// The noise multiplier N.
    pub fn noise_scale(&self) -> f64 {
        self.noise_scale
    }

    /// Eq. 2–3 constants for a frame taken with `settings` by a sensor of pitch `pixel_pitch_um`.
    pub fn params(&self, settings: DynamicSettings, pixel_pitch_um: f64) -> FormationParams {
        let c = &self.calibration;
        let gain_ratio = settings.gain_linear() / linear_from_db(c.gain_db);
        let area_ratio = (pixel_pitch_um / c.pixel_pitch_um).powi(2);
        let scale = settings.exposure_s / c.exposure_s * gain_ratio * area_ratio;
        let n = self.variance_scale();
        FormationParams {
            intensity_scale: scale as f32,
            photon_var_per_dn: c.sigma_p2.map(|v| (gain_ratio * v * n) as f32),
            read_var: c.sigma_r2.map(|v| (gain_ratio * gain_ratio * v * n) as f32),
        }
    }

    /// The 8-bit frame: scale, add noise, clip at 0 and 255, round to the nearest integer.
    pub fn form(
        &self,
        i0: &HdrImage,
        settings: DynamicSettings,
        pixel_pitch_um: f64,
        rng: &mut impl Rng,
    ) -> Rgb8Image {
        let params = self.params(settings, pixel_pitch_um);
        let mut out = Rgb8Image::zeros(i0.width(), i0.height());
        kernels::form_u8(i0, &params, rng.random(), out.data_mut(), false);
        out
    }

    /// [`ImageFormation::form`] on a noise field drawn beforehand: `normals` is
    /// [`ImageFormation::standard_normals`] for the seed `form`'s stream would yield, and the
    /// frame is then bit-identical to `form`'s. Frames of one noise sample under several
    /// settings (DF-Grad's perturbed frames) draw the sample once instead of once per frame.
    ///
    /// Panics if `normals` does not hold one value per pixel channel of `i0`.
    pub fn form_with_normals(
        &self,
        i0: &HdrImage,
        settings: DynamicSettings,
        pixel_pitch_um: f64,
        normals: &[f32],
    ) -> Rgb8Image {
        assert_eq!(normals.len(), i0.data().len(), "one normal per pixel channel");
        let params = self.params(settings, pixel_pitch_um);
        let mut out = Rgb8Image::zeros(i0.width(), i0.height());
        kernels::form_u8_with_normals(i0, &params, normals, out.data_mut());
        out
    }

    /// [`ImageFormation::form`] with image tiles spread over rayon's thread pool; the result is
    /// bit-identical to the sequential one.
    pub fn form_parallel(
        &self,
        i0: &HdrImage,
        settings: DynamicSettings,
        pixel_pitch_um: f64,
        rng: &mut impl Rng,
    ) -> Rgb8Image {
        let params = self.params(settings, pixel_pitch_um);
        let mut out = Rgb8Image::zeros(i0.width(), i0.height());
        kernels::form_u8(i0, &params, rng.random(), out.data_mut(), true);
        out
    }

    /// Scale and noise without clipping or quantisation (`I + σ·z`), drawing the same random
    /// numbers as [`ImageFormation::form`] would from the same stream state.
    pub fn form_linear(
        &self,
        i0: &HdrImage,
        settings: DynamicSettings,
        pixel_pitch_um: f64,
        rng: &mut impl Rng,
    ) -> HdrImage {
        let params = self.params(settings, pixel_pitch_um);
        let mut out = HdrImage::zeros(i0.width(), i0.height());
        kernels::form_linear(i0, &params, rng.random(), out.data_mut());
        out
    }

    /// The standard-normal field `z` (interleaved RGB, one value per pixel channel) that
    /// [`ImageFormation::form`] uses when its stream yields `noise_seed` as its next `u64`.
    pub fn standard_normals(width: usize, height: usize, noise_seed: u64) -> Vec<f32> {
        kernels::standard_normals(width, height, noise_seed)
    }
}

#[cfg(test)]
mod tests;
