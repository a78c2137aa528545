//! How to replay a recording: the options every stage and decision of a replay reads,
//! apart from the pipeline that orders them (so that [`crate::decide`], below the
//! pipeline, can read them too). [`crate::pipeline`] re-exports them.

use std::path::PathBuf;

use crate::estimate::Method;
use crate::progress::Observer;
use crate::spec::coolant::ReferencePolicy;
use crate::spec::ModelDescription;

/// How to replay a recording.
#[derive(Debug, Clone)]
pub struct ReplayOptions {
    /// Sample time Ts of the grid, s.
    pub ts_s: f64,
    /// Whether the grid's Ts follows the temperatures where they are recorded slower than
    /// `ts_s` ([`crate::decide::sample_time`]): what the command line does when `--ts` is
    /// not given. Off by default, so that a library caller's Ts is the grid's.
    pub choose_ts: bool,
    /// A machine file whose keys override the recording's nameplate.
    pub machine: Option<PathBuf>,
    /// The identification method.
    pub method: Method,
    /// Whether the replay chooses between `oe` and `pem` by the whiteness of `oe`'s
    /// residuals ([`crate::decide::estimator::estimate_chosen`]), where `method` is `oe`: what the command line does
    /// when neither it nor the spec names a method. Off by default, so that a library
    /// caller's `oe` is `oe`.
    pub choose_estimator: bool,
    /// Per-output weights w_i for `wls` and `oe` (constant in time); `None`: equal for
    /// `wls`, the inverse noise variances for `oe`.
    pub weights: Option<Vec<f64>>,
    /// Forgetting factor λ of `rls`.
    pub forgetting: f64,
    /// Where to validate the model, if anywhere.
    pub validation: Option<ValidationSource>,
    /// The thermal system: its states, inputs and scaling.
    pub model: ModelDescription,
    /// What the states are measured from: the description's references, or the coolant
    /// inlet where the recording calls for it ([`crate::spec::coolant::resolve`]).
    pub reference: ReferencePolicy,
    /// Told how reading and estimation go ([`crate::progress`]); silent by default.
    pub progress: Observer,
    /// Which network the replay prints beside an `oe` model ([`NetworkChoice`]).
    pub network: NetworkChoice,
}

/// Which thermal network a replay prints beside an `oe` model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NetworkChoice {
    /// The best network for the data: the passive network nearest the identified model
    /// where the data cannot tell it from that model (χ² p ≥ 0.05, or no noise), else rc's
    /// fit of C, G, K to the data started from it.
    #[default]
    Best,
    /// The passive network nearest the identified model (minimum distance to Φ, Γ),
    /// without rc's fit: the fast replay, for a user who needs the model and not the
    /// network (rc takes seconds to tens of seconds on a noisy four-node run).
    Nearest,
}

/// Data the model is validated on, not estimated from.
#[derive(Debug, Clone, PartialEq)]
pub enum ValidationSource {
    /// The last fraction (0, 1) of the recording is held out of the estimation.
    HoldOut(f64),
    /// The recording is estimated on before this many seconds from its first grid instant
    /// and validated on from there (a data set's published split, e.g. "the first 400
    /// samples").
    SplitAt(f64),
    /// Another recording of the same machine.
    Recording(PathBuf),
}

impl Default for ReplayOptions {
    fn default() -> Self {
        ReplayOptions {
            ts_s: 1.0,
            choose_ts: false,
            machine: None,
            method: Method::Oe,
            choose_estimator: false,
            weights: None,
            forgetting: 1.0,
            validation: None,
            model: ModelDescription::generator(),
            reference: ReferencePolicy::Auto,
            progress: Observer::silent(),
            network: NetworkChoice::Best,
        }
    }
}
