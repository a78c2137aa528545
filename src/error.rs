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
    /// A model spec (`--spec FILE.toml`) is unusable.
    // Not `source`: the message already holds the spec's error, and a source would make
    // the CLI's `{:#}` print it twice.
    #[error("{path}: {problem}")]
    BadSpec {
        /// The spec file.
        path: PathBuf,
        /// What is wrong, naming the key, state or input.
        problem: crate::spec::SpecError,
    },
    /// A channel the model needs is not in the recording.
    #[error(
        "no channel carries `{channel}` (metadata `quantity` or a topic ending in /{channel})"
    )]
    MissingChannel {
        /// The quantity or free channel name.
        channel: String,
    },
    /// An input's dead time is not a whole number of samples of the grid.
    #[error(transparent)]
    InputDelay(#[from] crate::spec::delay::DelayError),
    /// The model's states are never all known at one instant.
    #[error("{what} are never all known at the same instant")]
    NoCommonInstant {
        /// What was looked for.
        what: String,
    },
    /// The model description needs a nameplate and none was resolved (a library misuse).
    #[error("the model's loss model and per-unit scaling need the machine's nameplate")]
    NameplateNeeded,
    /// No source of the generator's field winding temperature.
    #[error(
        "no field winding temperature: the recording has neither a `field_winding_temp` \
         nor a `field_voltage` channel, and nameplate key `field_winding_final_temp_c` is missing"
    )]
    NoFieldTemperature,
    /// A field-winding state, and the recording measures the field winding's temperature
    /// neither directly nor by its resistance.
    #[error(
        "the field winding state needs a `field_winding_temp` channel, or `field_voltage` \
         (with `field_current`) for the resistance method; the recording has neither"
    )]
    NoFieldState,
    /// The paper's field-temperature scaling needs a stator rise to scale.
    #[error(
        "the stator winding rises only {rise_k:.2} K, too little to scale the field \
         winding temperature to {final_temp_c} °C; record field_voltage or field_winding_temp"
    )]
    FieldScalingRise {
        /// The stator winding's rise over the recording, K.
        rise_k: f64,
        /// The nameplate's final field winding temperature, °C.
        final_temp_c: f64,
    },
    /// A stage after reading failed on this recording: the error, with the file it is about.
    // Not `source`: the message already holds the stage's error (see `BadSpec`).
    #[error("{path}: {error}")]
    InRecording {
        /// The recording.
        path: PathBuf,
        /// The stage's error.
        error: Box<Error>,
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
    /// The model has no thermal network, or a network figure cannot be computed.
    #[error(transparent)]
    Network(#[from] crate::network::NetworkError),
    /// The data are too few or too sparse for a stage (a grid with nothing on it).
    #[error("{0}")]
    InsufficientData(String),
    /// The held-out fraction of a recording is outside (0, 0.9).
    #[error("the held-out fraction {fraction} must be in (0, 0.9)")]
    HoldOutFraction {
        /// The fraction asked for.
        fraction: f64,
    },
    /// A split point outside the recording.
    #[error("the split at {split_s} s leaves nothing to estimate or validate on (the grid spans {span_s} s)")]
    SplitOutside {
        /// The split asked for, s from the first instant.
        split_s: f64,
        /// The grid's span, s.
        span_s: f64,
    },
    /// Per-state weights that do not fit the model.
    #[error("the weights want {states} positive numbers, one per state ({given} given)")]
    Weights {
        /// States of the model.
        states: usize,
        /// Weights given.
        given: usize,
    },
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
    /// A model report, load file or request of predict, rating or monitor is unusable.
    #[error(transparent)]
    ModelUse(Box<crate::predict::UseError>),
}

impl Error {
    /// Whether the error is the input's fault (exit status 2) rather than the machine's (1).
    pub fn is_bad_input(&self) -> bool {
        if let Error::InRecording { error, .. } = self {
            return error.is_bad_input();
        }
        if let Error::Import(e) = self {
            return e.is_bad_input();
        }
        matches!(
            self,
            Error::ReadInput { .. }
                | Error::BadRecording { .. }
                | Error::BadMachineFile { .. }
                | Error::BadSpec { .. }
                | Error::MissingChannel { .. }
                | Error::NoCommonInstant { .. }
                | Error::InputDelay(_)
                | Error::NoFieldTemperature
                | Error::NoFieldState
                | Error::FieldScalingRise { .. }
                | Error::Channel { .. }
                | Error::MissingNameplateKey { .. }
                | Error::BadNameplateValue { .. }
                | Error::Decimate(_)
                | Error::Estimation(_)
                | Error::ClockJump(_)
                | Error::Model(_)
                | Error::InsufficientData(_)
                | Error::Usage(_)
                | Error::HoldOutFraction { .. }
                | Error::Weights { .. }
                | Error::SplitOutside { .. }
                | Error::ModelUse(_)
        )
    }
}

/// Result alias for the library.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// The error as a stage's error on the recording at `path` (named in the message).
    pub fn in_recording(self, path: &std::path::Path) -> Error {
        match self {
            // Already about a file.
            e @ (Error::ReadInput { .. }
            | Error::BadRecording { .. }
            | Error::BadMachineFile { .. }
            | Error::BadSpec { .. }
            | Error::InRecording { .. }
            | Error::WriteOutput { .. }) => e,
            e => Error::InRecording {
                path: path.to_owned(),
                error: Box::new(e),
            },
        }
    }
}
