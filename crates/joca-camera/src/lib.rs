//! The camera model of joca: what a camera is, and how it turns light into an 8-bit frame.
//!
//! - [`catalogue`] — the 43 commercial CMOS sensors of the paper's design space.
//! - [`CameraDesign`], [`DesignSpace`] — static hardware Φcam (mount x/z, focal length, sensor).
//! - [`GenomeCodec`] — designs as GA genomes, with the paper's quantised-continuous sensor genes.
//! - [`DynamicSettings`], [`AccRanges`] — exposure and gain, per frame.
//! - [`ImageFormation`] — paper Eq. 2–3: exposure/gain/pixel-area scaling, affine noise, clipping
//!   and 8-bit quantisation.
//! - [`DetectorInput`], [`Resampler`] — one detector input size for every design, and the noise
//!   a native-grid frame keeps through the resize.
//! - [`compensate_for_pixel_size`] — paper Eq. 4.
//! - [`ImageFormation::capture`] — render and form one frame (the exposure sets blur and
//!   brightness alike).
//! - [`AverageAe`] — the mean-intensity auto-exposure baseline.
//! - [`calibrate_noise`] — photon-transfer estimation of the noise parameters from frames.
//!
//! ```
//! use joca_camera::{Calibration, DynamicSettings, ImageFormation};
//! use joca_core::{HdrImage, SeedStreams};
//!
//! // A mid-grey patch as the calibration camera records it, taken with twice its exposure.
//! let i0 = HdrImage::from_vec(1, 1, vec![60.0, 60.0, 60.0]).unwrap();
//! let formation = ImageFormation::new(Calibration::DEFAULT).unwrap();
//! let mut rng = SeedStreams::new(1).stream("noise");
//! let frame = formation.form(&i0, DynamicSettings::new(10e-3, 10.0), 3.75, &mut rng);
//! assert!((frame.mean() - 120.0).abs() < 10.0);
//! ```
#![deny(missing_docs)]

mod average_ae;
mod capture;
pub mod catalogue;
mod compensation;
mod design;
mod error;
mod formation;
mod genome;
pub mod input;
mod noise_calibration;
mod settings;

pub use average_ae::{AverageAe, MID_GREY_DN, MIN_MEAN_DN};
pub use capture::Capture;
pub use catalogue::{Sensor, Shutter, sensor_by_name};
pub use compensation::{compensate_for_pixel_size, limit_exposure};
pub use design::{ApertureControl, CameraDesign, DesignSpace, LensModel};
pub use error::CameraError;
pub use formation::{
    Calibration, FormationParams, ImageFormation, NoiseGain, TILE_ROWS, WHITE_LEVEL,
};
pub use genome::{GeneSpec, GenomeCodec, SensorEncoding};
pub use input::{DetectorInput, Resampler};
pub use noise_calibration::{ChannelFit, calibrate_noise};
pub use settings::{AccRanges, Bounds, DynamicSettings, Iris};
