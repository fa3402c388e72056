//! Errors of the deep-learning side.

use thiserror::Error;

/// What can go wrong in `joca-nn`.
#[derive(Debug, Error)]
pub enum NnError {
    /// A weights file does not fit the model.
    #[error("weights file {path}: {reason}")]
    Weights {
        /// The file.
        path: String,
        /// Which tensor is missing or mismatched.
        reason: String,
    },
    /// A loss became NaN or infinite.
    #[error("the {what} loss is {value}: training diverged (try a lower learning rate)")]
    NonFinite {
        /// Which loss.
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// A setting (an environment variable) has a value joca does not accept.
    #[error("{0}")]
    Config(String),
    /// A training batch cannot be formed.
    #[error("training batch: {0}")]
    Batch(String),
    /// libtorch reported an error.
    #[error(transparent)]
    Torch(#[from] tch::TchError),
}
