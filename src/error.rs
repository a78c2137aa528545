//! The library's error type.
//!
//! Every error is either the input's fault ([`Error::is_bad_input`]: a file that is
//! not a heat run, a missing quantity, an unusable estimate) or the machine's (I/O
//! on the output side, the viewer connection). The CLI maps the first to exit
//! status 2 and the second to 1; each message is one line that names the file,
//! channel, key or time it is about.

use std::path::PathBuf;

/// Errors raised by the heatrun pipeline stages.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The input file could not be opened or read.
    #[error("{path}: cannot read: {source}")]
    ReadInput {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// The recording violates the MCAP format or the heatrun profile.
    #[error("{path}: {message}")]
    BadRecording {
        /// The file.
        path: PathBuf,
        /// What is wrong, naming the channel, key or time.
        message: String,
    },
    /// A machine (nameplate) file given on the command line is unusable.
    #[error("{path}: {message}")]
    BadMachineFile {
        /// The machine file.
        path: PathBuf,
        /// What is wrong, naming the key.
        message: String,
    },
    /// A channel's clock jumps back over its own earlier data.
    #[error("{0}")]
    ClockJump(String),
    /// The data do not support an estimate (too short, not exciting, unstable).
    #[error(transparent)]
    Estimation(#[from] crate::estimate::EstimationError),
    /// The estimated model cannot be analysed (no real logarithm, singular matrix).
    #[error(transparent)]
    Model(#[from] crate::model::ModelError),
    /// A stage's error, with the recording it arose in (the stages below the pipeline
    /// do not know file names).
    #[error("{}: {error}", path.display())]
    InRecording {
        /// The recording.
        path: PathBuf,
        /// The stage's error.
        error: Box<Error>,
    },
    /// The data do not support a stage before the estimate (no common instant of the
    /// states, too little rise, a grid out of proportion to the samples).
    #[error("{0}")]
    InsufficientData(String),
    /// A command-line value is out of its range.
    #[error("{0}")]
    Usage(String),
    /// Writing an output failed.
    #[error("{path}: cannot write: {message}")]
    WriteOutput {
        /// The output file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// Publishing to rerun failed.
    #[error("rerun: {0}")]
    Publish(String),
}

impl Error {
    /// Whether the error is the input's fault (exit status 2) rather than the machine's (1).
    pub fn is_bad_input(&self) -> bool {
        matches!(
            self,
            Error::ReadInput { .. }
                | Error::BadRecording { .. }
                | Error::BadMachineFile { .. }
                | Error::Estimation(_)
                | Error::ClockJump(_)
                | Error::Model(_)
                | Error::InsufficientData(_)
                | Error::Usage(_)
        ) || matches!(self, Error::InRecording { error, .. } if error.is_bad_input())
    }
}

/// Result alias for the library.
pub type Result<T, E = Error> = std::result::Result<T, E>;
