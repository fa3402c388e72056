//! A generic ask/tell genetic algorithm (population, best-50 % parents, uniform crossover,
//! multiplicative mutation, clipping, serialisable state). It knows nothing about cameras: the
//! hardware GA and the exposure-perturbation GA of the paper are two configurations of it.
//!
//! Not implemented yet: this crate marks its boundary in the workspace (see ARCHITECTURE.md).
#![deny(missing_docs)]
