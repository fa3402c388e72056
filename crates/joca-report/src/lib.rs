//! Reports that read run directories only: tables laid out like the paper's, figures and
//! qualitative images.
//!
//! Not implemented yet: this crate marks its boundary in the workspace (see ARCHITECTURE.md).
#![deny(missing_docs)]
