//! What the replay produces, stage by stage: the [`Prepared`] estimator input, the whole
//! [`Replay`], and the figures set beside its model (validation, another estimator, the
//! hidden-state model). `pipeline` fills them in the stages' order; the report, the summary
//! and the publishers read them.

use std::ops::Range;
use std::path::PathBuf;

use crate::decide::{Decision, EstimatorChoice, NoiseFloor};
use crate::decimate::DecimatedRecording;
use crate::estimate::{Estimate, IdentificationData, Method};
use crate::model::{self, ModelAnalysis};
use crate::network::NetworkAnalysis;
use crate::recording::{Nameplate, RecordingSummary};
use crate::screen::LeftOut;
use crate::signals::ModelSignals;
use crate::spec::ModelDescription;
use crate::warnings;

/// Fit of the model on data it was not estimated from.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Validation {
    /// What the data were: `hold-out of the last 30 %` or a file.
    pub source: String,
    /// The fit (NRMSE %, MSE K², largest error K), from the measured state at the start.
    pub fit: crate::model::Fit,
}

/// Another estimate's figures, set beside the replay's own (rc beside oe).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Beside {
    /// Its method.
    pub method: Method,
    /// Its time constants, ascending, s.
    pub time_constants_s: Vec<f64>,
    /// Its fit on the estimation range.
    pub fit: crate::model::Fit,
}

impl Beside {
    /// The figures of `model` on `data`'s `range`, where it has real time constants.
    pub(super) fn of(
        method: Method,
        model: &crate::estimate::DiscreteModel,
        data: &IdentificationData,
        range: Range<usize>,
        temperature_base_k: f64,
    ) -> Option<Beside> {
        let spectrum = model::Spectrum::of(model).ok()?;
        let data = data.slice(range);
        let sim = model::fit::simulate(model, &data, &data.segments());
        Some(Beside {
            method,
            time_constants_s: spectrum.time_constants_s,
            fit: model::fit::fit(&data, &sim, temperature_base_k),
        })
    }
}

/// The model with hidden states a spec declares (`[hidden]`), identified on the same
/// instants as the replay's own estimate and validated on the same data.
#[derive(Debug, Clone, serde::Serialize)]
pub struct HiddenReplay {
    /// The model, its order and the orders tried.
    pub estimate: crate::hidden::HiddenEstimate,
    /// Its fit on the estimation instants, each segment from its fitted initial state.
    pub fit: crate::model::Fit,
    /// Its fit on held-out data or another recording, each segment from the initial
    /// state fitted to that segment's outputs (no measured state gives the hidden ones).
    pub validation: Option<Validation>,
    /// Its time constants, the measured outputs' sensitivities to them and its steady
    /// state at the replay's steady-state input; `None` where Φ has no real logarithm
    /// (the report then gives the time constants of Φ's eigenvalues alone).
    pub analysis: Option<crate::hidden::analysis::HiddenAnalysis>,
    /// The covariance of its parameters at the optimum (`hidden::covariance`), which
    /// predict, rating and monitor carry into their bands; `None` where no output entry
    /// was observed.
    pub covariance: Option<crate::hidden::covariance::HiddenCovariance>,
}

impl HiddenReplay {
    /// The slowest time constant of the hidden-state model, s: its analysis's (A_c =
    /// ln(Φ)/Ts, eq. 26), else the slowest −Ts/ln|λ| of Φ's eigenvalues; `None` for an
    /// unstable Φ.
    pub fn slowest_time_constant_s(&self) -> Option<f64> {
        match &self.analysis {
            Some(a) => a.spectrum.time_constants_s.last().copied(),
            None => self.estimate.model.time_constants_s()?.last().copied(),
        }
    }
}

/// Everything a replay produced, stage by stage.
#[derive(Debug, Clone)]
pub struct Replay {
    /// The recording replayed.
    pub path: PathBuf,
    /// The model description the replay identified (the options' one, resolved against
    /// the recording's coolant inlet).
    pub model: ModelDescription,
    /// What the recording stage found.
    pub recording: RecordingSummary,
    /// The nameplate used (recording's record, overridden by the machine file), where the
    /// model needs one.
    pub nameplate: Option<Nameplate>,
    /// The decimated quantities.
    pub decimated: DecimatedRecording,
    /// The model's states and inputs on the grid.
    pub signals: ModelSignals,
    /// The identification data of the whole recording.
    pub data: IdentificationData,
    /// The instants the estimator saw (all, or those before a hold-out).
    pub estimation_range: Range<usize>,
    /// The model's fit on held-out data or another recording.
    pub validation: Option<Validation>,
    /// The estimate (with its method's own details, e.g. the RLS trajectory).
    pub estimate: Estimate,
    /// The analysis of the estimate.
    pub analysis: ModelAnalysis,
    /// The physical network, calorimetric balance and equilibrium checks.
    pub network: NetworkAnalysis,
    /// For `rc`: the output-error model it started from, fitted on the same instants, to
    /// set beside it.
    pub output_error_beside: Option<Beside>,
    /// The stretches the screen left out of the estimation (glitches, frozen values),
    /// by state then time; empty when it found none.
    pub left_out: Vec<LeftOut>,
    /// The model with hidden states the spec declares, where it declares one.
    pub hidden: Option<HiddenReplay>,
    /// Warnings for the user (data loss, gaps).
    pub warnings: Vec<String>,
    /// Which estimator the replay chose and why, where the method was not given.
    pub estimator_choice: Option<EstimatorChoice>,
    /// The noise model the decisions compared residuals with: each state's resolution.
    pub noise_floor: NoiseFloor,
    /// The default's decisions ([`crate::decide`]), in the order they were made: each
    /// with its candidates, the figures compared and the verdict.
    pub decisions: Vec<Decision>,
    /// Where the data contradicted physics, and what was done.
    pub plausibility: crate::plausibility::Plausibility,
}

impl Replay {
    /// Whether data were lost to damage in the file (exit status 3).
    pub fn had_data_loss(&self) -> bool {
        !self.recording.data_loss.is_empty()
    }
}

/// The stages up to the estimator's input, for one recording.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// The model description the signals follow (the options', resolved against the
    /// recording's coolant inlet).
    pub model: ModelDescription,
    /// What the recording stage found.
    pub recording: RecordingSummary,
    /// The nameplate used, where the model needs one.
    pub nameplate: Option<Nameplate>,
    /// The decimated quantities.
    pub decimated: DecimatedRecording,
    /// The model's states and inputs.
    pub signals: ModelSignals,
    /// The estimator's input.
    pub data: IdentificationData,
    /// Where the data contradicted physics, and what was done.
    pub plausibility: crate::plausibility::Plausibility,
}

impl Prepared {
    /// The pieces the warnings are built from.
    pub fn for_warnings(&self) -> warnings::Prepared<'_> {
        warnings::Prepared {
            model: &self.model,
            recording: &self.recording,
            decimated: &self.decimated,
            signals: &self.signals,
        }
    }
}
