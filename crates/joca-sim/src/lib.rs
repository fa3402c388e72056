//! The built-in procedural driving simulator: seeded urban maps, moving ego vehicle and actors,
//! day/night/tunnel illumination in calibrated radiometric units, a z-buffered rasteriser and
//! motion blur integrated over the shutter interval.
//!
//! Not implemented yet: this crate marks its boundary in the workspace (see ARCHITECTURE.md).
#![deny(missing_docs)]
