//! Recorded sequences as frame sources: a documented folder format and Waymo Open v2 parquet,
//! resize/crop to a sensor's grid, Dense Inverse Search optical flow and flow-based motion blur.
//!
//! Not implemented yet: this crate marks its boundary in the workspace (see ARCHITECTURE.md).
#![deny(missing_docs)]
