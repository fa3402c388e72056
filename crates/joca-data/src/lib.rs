//! Recorded sequences for joca's real-image mode: the folder format ([`folder`]) and Waymo v2
//! parquet ([`waymo`]) sources, importers from KITTI tracking and labelme labels into the folder
//! format ([`import`]), Dense Inverse Search optical flow ([`flow`]) and flow-based motion blur
//! ([`blur`]).
//!
//! ```
//! use joca_data::flow::{DisParams, DisPreset, Gray, dis};
//! // A smooth pattern moved 1.5 pixels to the right: I0(x) = I1(x + 1.5).
//! let pattern = |x: f32, y: f32| 128.0 + 60.0 * (0.3 * x).sin() * (0.23 * y).cos();
//! let (w, h) = (64, 48);
//! let image = |dx: f32| -> Vec<f32> {
//!     (0..w * h).map(|k| pattern((k % w) as f32 - dx, (k / w) as f32)).collect()
//! };
//! let i0 = Gray::new(w, h, image(0.0));
//! let i1 = Gray::new(w, h, image(1.5));
//! let flow = dis(&i0, &i1, &DisParams::preset(DisPreset::Medium));
//! let centre = flow.at(32, 24);
//! assert!((centre[0] - 1.5).abs() < 0.2 && centre[1].abs() < 0.2, "{centre:?}");
//! ```
#![deny(missing_docs)]

pub mod blur;
mod error;
pub mod flow;
pub mod folder;
pub mod import;
pub mod waymo;

pub use error::DataError;
