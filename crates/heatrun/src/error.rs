//! The library's front error: each stage's own error, combined only here, for the
//! pipeline (a replay runs every stage) and the uses of the model that drive several
//! stages (`monitor`). Every stage returns its own error type and knows nothing of
//! this one; nothing below `pipeline` imports this file.
//!
//! Every error is either the input's fault ([`Error::is_bad_input`]: a file that is
//! not a heat run, a missing quantity, an unusable estimate) or the machine's (I/O
//! on the output side, the viewer connection). A command line maps the first to exit
//! status 2 and the second to 1; each message is one line that names the file,
//! channel, key or time it is about.

use std::path::PathBuf;

use crate::atomic::WriteError;
use crate::decimate::DecimateError;
use crate::estimate::EstimationError;
use crate::fleet::compare::CompareError;
use crate::hidden::HiddenError;
use crate::import::ImportError;
use crate::model::ModelError;
use crate::model_file::UseError;
use crate::network::NetworkError;
use crate::plausibility::PlausibilityError;
use crate::recording::RecordingError;
use crate::screen::ScreenError;
use crate::signals::SignalError;
use crate::spec::SpecFileError;
use crate::synth::SynthError;

/// Errors of a replay, a monitor run, or any stage they drive.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The recording cannot be read, breaks the profile, or lacks a nameplate key.
    #[error(transparent)]
    Recording(#[from] RecordingError),
    /// A model spec (`--spec FILE.toml`) cannot be read or used.
    #[error(transparent)]
    Spec(#[from] SpecFileError),
    /// The samples cannot be laid on the grid (sample time, clock jump, span).
    #[error(transparent)]
    Decimate(#[from] DecimateError),
    /// The model's signals cannot be built (a missing channel, no common instant, losses).
    #[error(transparent)]
    Signals(#[from] SignalError),
    /// The data do not support an estimate (too short, not exciting, unstable).
    #[error(transparent)]
    Estimation(#[from] EstimationError),
    /// The estimated model cannot be analysed (no real logarithm, singular matrix).
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The hidden-state model the spec declares could not be identified.
    #[error("hidden states: {0}")]
    Hidden(#[from] HiddenError),
    /// The data contradict physics in a way the replay refuses (a channel in another
    /// unit than declared): the message names the channel and what to fix.
    #[error(transparent)]
    Plausibility(#[from] PlausibilityError),
    /// The model has no thermal network, or a network figure cannot be computed.
    #[error(transparent)]
    Network(#[from] NetworkError),
    /// The screen for glitches and frozen values was given inputs that disagree (the
    /// pipeline's fault, not the recording's).
    #[error(transparent)]
    Screen(#[from] ScreenError),
    /// A stage after reading failed on this recording: the error, with the file it is about.
    // Not `source`: the message already holds the stage's error (see `SpecFileError::Bad`).
    #[error("{path}: {error}")]
    InRecording {
        /// The recording.
        path: PathBuf,
        /// The stage's error.
        error: Box<Error>,
    },
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
    /// A table could not be imported (a bad cell, row, time, or map).
    #[error(transparent)]
    Import(Box<ImportError>),
    /// A model report, load file or request of predict, rating or monitor is unusable.
    #[error(transparent)]
    ModelUse(Box<UseError>),
    /// A synthetic heat run cannot be made.
    #[error(transparent)]
    Synth(#[from] SynthError),
    /// A fleet's reports cannot be compared (unreadable, too few, of another design).
    #[error(transparent)]
    Compare(Box<CompareError>),
    /// The monitor's observer (the rerun publisher) stopped the monitor.
    #[error("{0}")]
    Observer(Box<dyn std::error::Error + Send + Sync>),
    /// Writing an output failed.
    #[error(transparent)]
    Output(#[from] WriteError),
}

impl From<ImportError> for Error {
    fn from(e: ImportError) -> Error {
        Error::Import(Box::new(e))
    }
}

impl From<CompareError> for Error {
    fn from(e: CompareError) -> Error {
        Error::Compare(Box::new(e))
    }
}

impl From<UseError> for Error {
    fn from(e: UseError) -> Error {
        Error::ModelUse(Box::new(e))
    }
}

impl Error {
    /// Whether the error is the input's fault (exit status 2) rather than the machine's (1).
    pub fn is_bad_input(&self) -> bool {
        match self {
            Error::InRecording { error, .. } => error.is_bad_input(),
            Error::Import(e) => e.is_bad_input(),
            Error::Signals(e) => e.is_bad_input(),
            Error::Synth(e) => e.is_bad_input(),
            Error::Network(_) | Error::Screen(_) | Error::Observer(_) | Error::Output(_) => false,
            Error::Recording(_)
            | Error::Spec(_)
            | Error::Decimate(_)
            | Error::Plausibility(_)
            | Error::Estimation(_)
            | Error::Hidden(_)
            | Error::Model(_)
            | Error::HoldOutFraction { .. }
            | Error::SplitOutside { .. }
            | Error::Weights { .. }
            | Error::ModelUse(_)
            | Error::Compare(_) => true,
        }
    }

    /// The error as a stage's error on the recording at `path` (named in the message).
    pub fn in_recording(self, path: &std::path::Path) -> Error {
        match self {
            // Already about a file.
            e @ (Error::Recording(
                RecordingError::ReadInput { .. }
                | RecordingError::BadRecording { .. }
                | RecordingError::BadMachineFile { .. }
                | RecordingError::Store(_),
            )
            | Error::Spec(_)
            | Error::InRecording { .. }
            | Error::Output(_)) => e,
            e => Error::InRecording {
                path: path.to_owned(),
                error: Box::new(e),
            },
        }
    }
}

/// Result alias for the library's front.
pub type Result<T, E = Error> = std::result::Result<T, E>;
