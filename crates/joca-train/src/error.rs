//! Errors of training and evaluation.

use thiserror::Error;

/// What can stop a training run.
#[derive(Debug, Error)]
pub enum TrainError {
    /// A configuration value is invalid.
    #[error("{field} = {value} is invalid: {allowed}")]
    Config {
        /// The field, as written in the TOML file.
        field: String,
        /// The value given.
        value: String,
        /// What is allowed.
        allowed: String,
    },
    /// `--resume` with a configuration that differs from the checkpoint's.
    #[error(
        "cannot resume {dir}: the configuration differs from the checkpoint's in {fields}; use \
            the original configuration or start a new run"
    )]
    ResumeMismatch {
        /// The run directory.
        dir: String,
        /// The differing fields.
        fields: String,
    },
    /// Reading or writing run files failed.
    #[error("{path}: {source}")]
    Io {
        /// The file or directory.
        path: String,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// The output folder is not joca's, or another process writes it.
    #[error(transparent)]
    Output(#[from] joca_core::output::OutputError),
    /// The caller stopped the run (work since the last checkpoint is discarded, as after a kill).
    #[error("stopped at step {step}; resume from the last checkpoint with --resume")]
    Interrupted {
        /// Steps done when stopped.
        step: usize,
    },
    /// A worker thread could not start or stopped unexpectedly.
    #[error("the {what} failed: {reason}")]
    Thread {
        /// Which thread.
        what: String,
        /// What happened.
        reason: String,
    },
    /// A run file is corrupt.
    #[error("{path} is corrupt: {reason}")]
    Corrupt {
        /// The file.
        path: String,
        /// What is wrong.
        reason: String,
    },
    /// A loss became NaN or infinite during joint training; nothing of that candidate was saved.
    #[error(
        "training diverged in generation {generation}, candidate {candidate}: {source}. The last \
            checkpoint ({checkpoint}) is intact; after fixing the cause, --resume continues from it"
    )]
    Diverged {
        /// Generation (0-based).
        generation: usize,
        /// Candidate in the generation (0-based).
        candidate: usize,
        /// The last checkpoint, described.
        checkpoint: String,
        /// The non-finite loss.
        #[source]
        source: joca_nn::NnError,
    },
    /// A loss became NaN or infinite during pre-training; the checkpoint before it is intact.
    #[error(
        "pre-training diverged in the batch after frame {frame}: {source}. The last checkpoint \
            ({checkpoint}) is intact; after fixing the cause, --resume continues from it"
    )]
    PretrainDiverged {
        /// Frames trained before the diverging batch.
        frame: usize,
        /// The last checkpoint, described.
        checkpoint: String,
        /// The non-finite loss.
        #[source]
        source: joca_nn::NnError,
    },
    /// The deep-learning side failed.
    #[error(transparent)]
    Nn(#[from] joca_nn::NnError),
    /// A frame could not be produced.
    #[error(transparent)]
    Source(#[from] joca_core::SourceError),
    /// The camera model refused a value.
    #[error(transparent)]
    Camera(#[from] joca_camera::CameraError),
}

impl TrainError {
    /// An I/O error with its path.
    pub fn io(path: &std::path::Path, source: std::io::Error) -> Self {
        TrainError::Io { path: path.display().to_string(), source }
    }
}
