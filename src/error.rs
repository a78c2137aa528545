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
    /// A heat-run channel record breaks the profile (schema, encoding, unit, storage).
    #[error("{path}: {source}")]
    Channel {
        /// The file.
        path: PathBuf,
        /// What is wrong with which channel.
        source: crate::recording::ChannelError,
    },
    /// A nameplate key the loss model needs is in neither the recording nor a machine file.
    #[error(
        "{path}: nameplate key `{key}` is missing: the recording's `heatrun.nameplate` record \
         does not have it and no machine file gives it"
    )]
    MissingNameplateKey {
        /// The recording.
        path: PathBuf,
        /// The key.
        key: String,
    },
    /// A nameplate value is not what its key needs.
    #[error("{path}: nameplate key `{key}` is `{value}`; it must be {requirement}")]
    BadNameplateValue {
        /// The recording or machine file the value came from.
        path: PathBuf,
        /// The key.
        key: String,
        /// The value as written.
        value: String,
        /// What the key needs ("a decimal number", "positive", ...).
        requirement: &'static str,
    },
    /// The samples cannot be laid on the grid (sample time, clock jump, span).
    #[error(transparent)]
    Decimate(#[from] crate::decimate::DecimateError),
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
}

impl Error {
    /// Whether the error is the input's fault (exit status 2) rather than the machine's (1).
    pub fn is_bad_input(&self) -> bool {
        matches!(
            self,
            Error::ReadInput { .. }
                | Error::BadRecording { .. }
                | Error::BadMachineFile { .. }
                | Error::Channel { .. }
                | Error::MissingNameplateKey { .. }
                | Error::BadNameplateValue { .. }
                | Error::Decimate(_)
                | Error::Estimation(_)
                | Error::ClockJump(_)
                | Error::Model(_)
                | Error::Usage(_)
        )
    }
}

/// Result alias for the library.
pub type Result<T, E = Error> = std::result::Result<T, E>;
