//! Why the data do not support an estimate, with the figures that decided it.
//!
//! Messages describe the data and the method, never the command line: the CLI
//! edge adds what to do next.

use levenberg_marquardt::TerminationReason;

/// An estimator's refusal or failure.
#[derive(Debug, PartialEq, thiserror::Error)]
pub enum EstimationError {
    /// Fewer usable equations than [`super::MIN_ROWS_PER_PARAMETER`] per unknown.
    #[error(
        "only {rows} usable samples (instants where the states and inputs are known), too few \
         to estimate {parameters} parameters per state; at least {needed} are needed"
    )]
    TooFewRows {
        /// Usable equations (regression rows) found.
        rows: usize,
        /// Equations needed.
        needed: usize,
        /// Parameters per state, n + m.
        parameters: usize,
    },
    /// A regressor is zero at every usable row, so its parameters are not seen.
    #[error(
        "regressor {} is zero throughout: that signal never changes from zero, so its \
         parameters cannot be estimated",
        column + 1
    )]
    ZeroRegressor {
        /// Column of [y(k−1)ᵀ u(k−1)ᵀ], from 0.
        column: usize,
    },
    /// The regression (or the instruments' moment matrix) is rank deficient.
    #[error(
        "{method}: the regression is rank deficient (σ_min/σ_max = {singular_value_ratio:.1e}): \
         the inputs are not persistently exciting (constant, or proportional to each other), \
         so Φ and Γ cannot be told apart"
    )]
    NoExcitation {
        /// The method's name.
        method: &'static str,
        /// σ_min/σ_max of the column-scaled matrix.
        singular_value_ratio: f64,
    },
    /// The regression is rank deficient because two inputs are proportional, named
    /// ([`super::excitation::input_dependence`]).
    #[error("{method}: the regression is rank deficient: {which}, so Γ's columns for them cannot be told apart")]
    DependentInputs {
        /// The method's name.
        method: &'static str,
        /// The dependence, the inputs named.
        which: String,
        /// Both inputs are constant (the run wants load steps, not a spec with one fewer).
        constant: bool,
    },
    /// An iterative method's starting model is unstable.
    #[error("{method}: the starting model is unstable (spectral radius {spectral_radius:.6})")]
    UnstableStart {
        /// The method's name.
        method: &'static str,
        /// Largest modulus of the start's Φ eigenvalues.
        spectral_radius: f64,
    },
    /// Instrumental variables found no stable model along its first step.
    #[error(
        "instrumental variables made no stable step: the re-estimate from the start's \
         instruments has spectral radius {spectral_radius:.6}"
    )]
    NoStableStep {
        /// Spectral radius of the first re-estimate.
        spectral_radius: f64,
    },
    /// Levenberg–Marquardt ended on a non-finite objective.
    #[error(
        "output error: the minimisation failed ({termination:?}); the start model may be unstable"
    )]
    MinimisationFailed {
        /// Why the minimiser stopped.
        termination: TerminationReason,
    },
    /// The forgetting factor of recursive least squares is outside (0, 1].
    #[error("the forgetting factor {value} is outside (0, 1]")]
    ForgettingFactor {
        /// The factor given.
        value: f64,
    },
    /// Weights whose shape does not match the data.
    #[error(
        "weights for {given_rows} × {given_columns} entries, but the data have {rows} × {columns}"
    )]
    WeightShape {
        /// Rows given (instants, or 1 for per-state weights).
        given_rows: usize,
        /// Columns given.
        given_columns: usize,
        /// Rows wanted.
        rows: usize,
        /// Columns wanted (states).
        columns: usize,
    },
    /// The grey-box network fit cannot start.
    #[error("rc: no thermal network to start from: {reason}")]
    NoNetworkStart {
        /// Why.
        reason: String,
    },
    /// The grey-box network fit ended on no network that simulates the data: the data hold
    /// no passive network (the identified model is none), or the fit stopped on a model
    /// that cannot be one.
    #[error(
        "rc found no passive network that fits these data ({reason}); the data may hold no \
         network: replay without --method rc to see the nearest network and its verdict"
    )]
    NoNetworkFits {
        /// What the fit ended on.
        reason: String,
    },
    /// The grey-box network fit from one of several starts was given up: its deviance
    /// stood further above another start's than it could still gain
    /// ([`crate::estimate::StartRace`]).
    #[error(
        "rc: the fit from this start was dropped, its deviance {gap:.1} above another start's"
    )]
    StartDropped {
        /// How far its deviance stood above the lowest.
        gap: f64,
    },
    /// The grey-box network fit was called off: its result was no longer needed
    /// ([`crate::estimate::StartRace::call_off`]).
    #[error("rc: the fit was called off, its result no longer needed")]
    CalledOff,
    /// The grey-box network fit was asked for a model with an input that is not heat.
    #[error("rc fits a thermal network, whose inputs are heat; the input '{input}' is not (kind = \"exogenous\")")]
    InputNotHeat {
        /// The input's name.
        input: String,
    },
    /// A weight that is negative, zero where it must be positive, or not finite.
    #[error("the weight {value} of state {} is not allowed (weights are finite, and positive per state)", state + 1)]
    InvalidWeight {
        /// The state, from 0.
        state: usize,
        /// The weight.
        value: f64,
    },
}
