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
    #[error("{0}")]
    Estimation(String),
    /// The estimated model cannot be analysed (no real logarithm, singular matrix).
    #[error("{0}")]
    Model(String),
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
    /// A table could not be imported (a bad cell, row, time, or map).
    #[error(transparent)]
    Import(Box<crate::import::ImportError>),
}

impl Error {
    /// Whether the error is the input's fault (exit status 2) rather than the machine's (1).
    pub fn is_bad_input(&self) -> bool {
        if let Error::Import(e) = self {
            return e.is_bad_input();
        }
        matches!(
            self,
            Error::ReadInput { .. }
                | Error::BadRecording { .. }
                | Error::BadMachineFile { .. }
                | Error::Estimation(_)
                | Error::ClockJump(_)
                | Error::Model(_)
                | Error::Usage(_)
        )
    }
}

/// Result alias for the library.
pub type Result<T, E = Error> = std::result::Result<T, E>;
