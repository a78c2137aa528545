//! The recording stage's error: the file cannot be read, breaks the format or the
//! profile, or its nameplate (or a machine file) lacks what the loss model needs.

use std::path::PathBuf;

/// Errors of the recording stage. Every one is the input's fault.
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
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
        source: super::ChannelError,
    },
    /// Nameplate keys the loss model needs are in neither the recording nor a machine
    /// file: all of them named at once, each with its unit and what it feeds.
    #[error(
        "{path}: the nameplate lacks {count} required key(s), in neither the recording's \
         `heatrun.nameplate` record nor a machine file: {keys}"
    )]
    MissingNameplateKeys {
        /// The recording.
        path: PathBuf,
        /// The keys, each as `key (unit: what it feeds)`, `; `-separated.
        keys: String,
        /// How many.
        count: usize,
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
    /// A recording in object storage could not be read (no such bucket or object, no
    /// credentials, access denied): the store's error names the URL.
    #[error(transparent)]
    Store(#[from] crate::store::StoreError),
    /// A machine (nameplate) file given on the command line is unusable.
    #[error("{path}: {message}")]
    BadMachineFile {
        /// The machine file.
        path: PathBuf,
        /// What is wrong, naming the key.
        message: String,
    },
}

/// The recording stage's result.
pub type Result<T, E = RecordingError> = std::result::Result<T, E>;
