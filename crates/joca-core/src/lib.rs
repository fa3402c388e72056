//! Shared vocabulary of joca: the types every other crate speaks.
//!
//! - [`HdrImage`] — linear RGB in calibrated digital numbers (DN), the `I0` of the paper's Eq. 2:
//!   what the calibration camera (pixel pitch p0, exposure E0, gain G0) would record before
//!   clipping. [`Rgb8Image`] — the 8-bit frame a camera delivers after image formation.
//! - [`BBox`], [`Class`], [`Annotation`], [`Detection`] — 2D boxes in pixel coordinates with
//!   continuous corners (no `+1` convention).
//! - [`units`] — conversions with units in their names (`linear_from_db`, `ms_from_s`).
//! - [`SeedStreams`] — one run seed, many named independent random streams: the only way joca
//!   code obtains randomness.
//! - [`FrameSource`] — what a renderer or a recorded dataset provides to the training loop.
//!
//! ```
//! use joca_core::{units, SeedStreams};
//! use rand::Rng;
//!
//! let streams = SeedStreams::new(7);
//! let a: u64 = streams.stream("noise").random();
//! let b: u64 = SeedStreams::new(7).stream("noise").random();
//! assert_eq!(a, b); // same seed and name, same numbers
//! assert!((units::linear_from_db(20.0) - 10.0).abs() < 1e-12);
//! ```
#![deny(missing_docs)]

mod boxes;
pub mod compute;
mod frame;
pub mod fs;
pub mod glare;
mod image;
mod named;
pub mod optics;
pub mod output;
pub mod rng;
pub mod sun;
pub mod tunnels;
pub mod units;
pub mod weather;

pub use boxes::{Annotation, BBox, Class, Detection, TRAINING_MIN_BOX_PX, training_targets};
pub use frame::{Frame, FrameRequest, FrameSource, PinholeCamera, Shot, SourceError};
pub use image::{HdrImage, ImageError, Rgb8Image, RgbImage};
pub use rng::SeedStreams;
