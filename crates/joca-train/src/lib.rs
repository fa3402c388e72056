//! The joint optimisation loop of the paper (hardware GA, NeuralAE trained with DF-Grad,
//! detector), with every method and ablation as a configuration, checkpoints and resume.
//!
//! Not implemented yet: this crate marks its boundary in the workspace (see ARCHITECTURE.md).
#![deny(missing_docs)]
