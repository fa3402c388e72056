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
//! multiplies σp² and σr² by N ([`ImageFormation::with_noise_scale`]); docs/design.md explains why the
//! variances and not σ.
//!
//! The normal samples come from per-tile generators seeded from one draw of the caller's stream,
//! so a frame is bit-identical whether it is formed on one thread or many, and
//! [`ImageFormation::input_normals`] reproduces the exact `z` field a frame used (the
//! differentiable formation of `joca-nn` consumes it to mirror this one).

mod kernels;

use crate::CameraError;
use crate::catalogue::Sensor;
use crate::input::Resampler;
use crate::settings::DynamicSettings;
use joca_core::units::linear_from_db;
use joca_core::{HdrImage, Rgb8Image};
use rand::Rng;
use serde::{Deserialize, Serialize};

pub use kernels::TILE_ROWS;

/// The physical camera that calibrated brightness and noise (docs/design.md reference values).
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
///
/// Frames are formed at the size of the image they are given (the detector's input). A
/// formation [`on_native_grid`](ImageFormation::on_native_grid) knows the sensor's own pixel
/// grid and gives every input pixel the noise of forming the frame on that grid, Eq. 3 per
/// native pixel, and resizing it with its [`Resampler`] (see [`crate::input`]): the variance of
/// Eq. 3 times `Σw²` of the resize's weights at that pixel. Without a native grid the image is
/// taken to be the sensor's own grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImageFormation {
    calibration: Calibration,
    noise_scale: f64,
    resampler: Resampler,
    native_px: Option<(usize, usize)>,
    light_factor: f64,
}

/// Per-pixel factors on the noise's standard deviation, `√(Σw²)` of a resize: the value at
/// input pixel `(x, y)` is `cols[x] · rows[y]`.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseGain {
    /// Per column.
    pub cols: Vec<f32>,
    /// Per row.
    pub rows: Vec<f32>,
}

impl NoiseGain {
    /// Multiplies the interleaved RGB normals `z` of rows `first_row..` (`width` pixels each)
    /// by the factors.
    pub fn apply(&self, z: &mut [f32], first_row: usize) {
        let width = self.cols.len();
        for (dy, row) in z.chunks_mut(width * 3).enumerate() {
            let ry = self.rows[first_row + dy];
            for (px, col) in row.chunks_exact_mut(3).zip(&self.cols) {
                let k = ry * col;
                px.iter_mut().for_each(|v| *v *= k);
            }
        }
    }
}

/// The largest noise-variance multiplier accepted: 50× the paper's strongest scenario (×20).
pub const MAX_NOISE_SCALE: f64 = 1000.0;

impl ImageFormation {
    /// Formation with `calibration` and calibrated noise (×1).
    pub fn new(calibration: Calibration) -> Result<Self, CameraError> {
        calibration.validate()?;
        Ok(Self {
            calibration,
            noise_scale: 1.0,
            resampler: Resampler::Bilinear,
            native_px: None,
            light_factor: 1.0,
        })
    }

    /// The same formation with σp² and σr² multiplied by `noise_scale` (scenario "noise ×N").
    pub fn with_noise_scale(self, noise_scale: f64) -> Result<Self, CameraError> {
        if !(0.0..=MAX_NOISE_SCALE).contains(&noise_scale) {
            return Err(CameraError::OutOfRange {
                field: "noise_scale".into(),
                value: noise_scale,
                min: 0.0,
                max: MAX_NOISE_SCALE,
                unit: "",
            });
        }
        Ok(Self { noise_scale, ..self })
    }

    /// The same formation behind a lens at `f_number`: the signal of Eq. 2 gains (N0/N)² over
    /// the calibration aperture N0 = 16 (the noise follows Eq. 3 from that signal). Runs keep
    /// the calibration aperture.
    pub fn with_f_number(self, f_number: f64) -> Result<Self, CameraError> {
        let (min, max) = joca_core::optics::F_NUMBER_RANGE;
        if !(f_number >= min && f_number <= max) {
            return Err(CameraError::OutOfRange {
                field: "f_number".into(),
                value: f_number,
                min,
                max,
                unit: "",
            });
        }
        let light_factor = (joca_core::optics::CALIBRATION_F_NUMBER / f_number).powi(2);
        Ok(Self { light_factor, ..self })
    }

    /// The same formation with frames resized from the native grid by `resampler`.
    pub fn with_resampler(self, resampler: Resampler) -> Self {
        Self { resampler, ..self }
    }

    /// The same formation for a sensor whose pixel grid is `width × height`: images given to
    /// it are that grid resized to the detector's input, and their noise is the native
    /// formation's carried through the resize. What differs from forming each native pixel and
    /// resizing: clipping and rounding apply once to the input pixel instead of to each native
    /// pixel (within a few σ of 0 or 255 the native path's mean carries the clipping's bias),
    /// the signal under a pixel's taps is taken as uniform, and neighbouring input pixels
    /// that share native taps (an upscale, or area footprints at r < 2) get independent noise
    /// where the resize would correlate it.
    pub fn on_native_grid(self, width: usize, height: usize) -> Self {
        Self { native_px: Some((width.max(1), height.max(1))), ..self }
    }

    /// The formation of `design`'s frames: its sensor's native grid, and its lens's light,
    /// (N0/N)² of the calibration's (Eq. 2 at the design's aperture).
    pub fn for_design(self, design: &crate::CameraDesign) -> Self {
        let light_factor = (joca_core::optics::CALIBRATION_F_NUMBER / design.f_number).powi(2);
        Self { light_factor, ..self.for_sensor(design.sensor()) }
    }

    /// The signal's factor for the lens's aperture, (N0/N)² (1 at the calibration's f/16).
    pub fn light_factor(&self) -> f64 {
        self.light_factor
    }

    /// [`on_native_grid`](ImageFormation::on_native_grid) of `sensor`'s pixel grid.
    pub fn for_sensor(self, sensor: &Sensor) -> Self {
        self.on_native_grid(sensor.res_x, sensor.res_y)
    }

    /// The resampler.
    pub fn resampler(&self) -> Resampler {
        self.resampler
    }

    /// The factors on the noise's standard deviation for an input of `width × height`, or
    /// `None` where the image is the native grid itself.
    pub fn noise_gain(&self, width: usize, height: usize) -> Option<NoiseGain> {
        let (nw, nh) = self.native_px?;
        if (nw, nh) == (width, height) || width == 0 || height == 0 {
            return None;
        }
        let sd = |n_in, n_out| -> Vec<f32> {
            self.resampler.variance_factors(n_in, n_out).iter().map(|v| v.sqrt() as f32).collect()
        };
        Some(NoiseGain { cols: sd(nw, width), rows: sd(nh, height) })
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
        let scale =
            settings.exposure_s / c.exposure_s * gain_ratio * area_ratio * self.light_factor;
        let n = self.noise_scale;
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
        self.form_u8(i0, settings, pixel_pitch_um, rng.random(), false)
    }

    /// [`ImageFormation::form`] on a noise field drawn beforehand: `normals` is
    /// [`ImageFormation::input_normals`] for the seed `form`'s stream would yield, and the
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
        self.form_u8(i0, settings, pixel_pitch_um, rng.random(), true)
    }

    /// The 8-bit frame of [`ImageFormation::form`] for the frame seed `seed`, on rayon's
    /// threads or not (same bits either way).
    fn form_u8(
        &self,
        i0: &HdrImage,
        settings: DynamicSettings,
        pixel_pitch_um: f64,
        seed: u64,
        parallel: bool,
    ) -> Rgb8Image {
        let params = self.params(settings, pixel_pitch_um);
        let gain = self.noise_gain(i0.width(), i0.height());
        let mut out = Rgb8Image::zeros(i0.width(), i0.height());
        kernels::form_u8(i0, &params, seed, gain.as_ref(), out.data_mut(), parallel);
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
        kernels::form_linear(
            i0,
            &params,
            rng.random(),
            self.noise_gain(i0.width(), i0.height()).as_ref(),
            out.data_mut(),
        );
        out
    }

    /// The standard-normal field `z` (interleaved RGB, one value per pixel channel) that
    /// [`ImageFormation::form`] uses when its stream yields `noise_seed` as its next `u64`.
    pub fn standard_normals(width: usize, height: usize, noise_seed: u64) -> Vec<f32> {
        kernels::standard_normals(width, height, noise_seed)
    }

    /// The noise field of a `width × height` frame in units of Eq. 3's σ at each pixel: the
    /// [`standard_normals`](ImageFormation::standard_normals) times the resize's
    /// [`noise_gain`](ImageFormation::noise_gain) (the same values where there is none). This
    /// is what [`ImageFormation::form`] adds, scaled by σ, when its stream yields `noise_seed`.
    pub fn input_normals(&self, width: usize, height: usize, noise_seed: u64) -> Vec<f32> {
        let mut z = kernels::standard_normals(width, height, noise_seed);
        if let Some(gain) = self.noise_gain(width, height) {
            gain.apply(&mut z, 0);
        }
        z
    }
}

#[cfg(test)]
mod native_grid_tests;
#[cfg(test)]
mod tests;
