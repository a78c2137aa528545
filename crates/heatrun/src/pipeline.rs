//! The replay pipeline: recording → decimation → signals → estimation → screen
//! (→ estimation again without what the screen left out) → analysis.
//!
//! This is the one place that knows the order of the stages; each stage returns what it
//! owns, and publishing and the report read their outputs, gathered in a [`Replay`]
//! (publishing may start on a stage's output while the next stage runs:
//! [`StageObserver`]). Work that needs nothing of the stage beside it runs on a thread of
//! its own: `oe`'s re-estimation for the network beside the model's analysis.
//! What the model is — states, inputs, alignment, scaling — comes from the
//! [`ModelDescription`] in the options (the generator by default).

use std::ops::Range;
use std::path::{Path, PathBuf};

use std::borrow::Cow;

use crate::decimate::DecimatedRecording;
use crate::error::{Error, Result};
use crate::estimate::{
    Estimate, EstimationError, Estimator, IdentificationData, InstrumentalVariables, OutputError,
    PredictionError, RecursiveLeastSquares, ResistanceCapacitance, WeightedLeastSquares,
};
use crate::grid::GridBuilder;
use crate::model::{self, ModelAnalysis};
use crate::network::{self, NetworkAnalysis};
use crate::progress::Observer;
use crate::recording::RecordingError;
use crate::recording::{
    self, Nameplate, NameplateEntries, ReadOptions, RecordingSummary, SampleSink,
};
use crate::screen::{self, LeftOut};
use crate::signals::SignalError;
use crate::signals::{self, ModelSignals};
use crate::spec::coolant::{self, ReferencePolicy};
use crate::spec::ModelDescription;
use crate::warnings;

pub use crate::estimate::Method;

/// How to replay a recording.
#[derive(Debug, Clone)]
pub struct ReplayOptions {
    /// Sample time Ts of the grid, s.
    pub ts_s: f64,
    /// A machine file whose keys override the recording's nameplate.
    pub machine: Option<PathBuf>,
    /// The identification method.
    pub method: Method,
    /// Whether the replay chooses between `oe` and `pem` by the whiteness of `oe`'s
    /// residuals ([`estimate_chosen`]), where `method` is `oe`: what the command line does
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
    /// inlet where the recording calls for it ([`coolant::resolve`]).
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

/// Fit of the model on data it was not estimated from.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Validation {
    /// What the data were: `hold-out of the last 30 %` or a file.
    pub source: String,
    /// The fit (NRMSE %, MSE K², largest error K), from the measured state at the start.
    pub fit: crate::model::Fit,
}

impl Default for ReplayOptions {
    fn default() -> Self {
        ReplayOptions {
            ts_s: 1.0,
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
    fn of(
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
    // plausibility (issue 34)
    /// Where the data contradicted physics, and what was done (issue 34).
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
    // plausibility (issue 34)
    /// Where the data contradicted physics, and what was done (issue 34).
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

/// Reads, decimates and computes the signals of one recording.
pub fn prepare(path: &Path, options: &ReplayOptions) -> Result<Prepared> {
    prepare_with(path, options, None)
}

/// [`prepare`], with every raw sample also given to `also` as the file streams by.
pub fn prepare_with(
    path: &Path,
    options: &ReplayOptions,
    also: Option<&mut dyn SampleSink>,
) -> Result<Prepared> {
    let model = &options.model;
    let mut grid = GridBuilder::whole(options.ts_s, model.alignments())?;
    let read = ReadOptions {
        free_channels: model.free_channels(),
        progress: options.progress.clone(),
    };
    let summary = match also {
        Some(also) => recording::read_recording_with(
            path,
            &mut crate::recording::Tee {
                first: &mut grid,
                also,
            },
            &read,
        )?,
        None => recording::read_recording_with(path, &mut grid, &read)?,
    };
    if summary.channels.is_empty() {
        return Err(no_heat_run_data(path, &summary));
    }
    let nameplate = if model.needs_nameplate() {
        Some(resolve_nameplate(path, &summary, options)?)
    } else {
        None
    };
    let mut decimated = grid
        .finish(&summary.channels)
        .map_err(|e| Error::from(e).in_recording(path))?;
    // plausibility (issue 34): channels exchanged mid-run swapped back, wrong units refused.
    let mut plausibility =
        crate::plausibility::before_signals(&summary, &mut decimated, nameplate.as_ref())
            .map_err(|e| Error::from(e).in_recording(path))?;
    let model = coolant::resolve(
        model,
        options.reference,
        coolant::inlet_behaviour(&decimated).as_ref(),
    )
    .map_err(|channel| SignalError::MissingChannel {
        channel: channel.to_owned(),
    })
    .map_err(|e| Error::from(e).in_recording(path))?;
    let signals = signals::compute(&model, &decimated, nameplate.as_ref())
        .map_err(|e| Error::from(e).in_recording(path))?;
    // plausibility (issue 34): the calorimetric balance over the run.
    plausibility.findings.extend(
        crate::plausibility::of_signals(&model, &decimated, &signals)
            .map_err(|e| Error::from(e).in_recording(path))?,
    );
    let data = signals.identification_data();
    Ok(Prepared {
        model,
        recording: summary,
        nameplate,
        decimated,
        signals,
        data,
        plausibility, // plausibility (issue 34)
    })
}

/// The error of a recording none of whose channels the model can read.
fn no_heat_run_data(path: &Path, summary: &RecordingSummary) -> Error {
    let ignored = if summary.ignored_channels.is_empty() {
        "it has no channels at all".to_owned()
    } else {
        let topics: Vec<&str> = summary
            .ignored_channels
            .iter()
            .map(|c| c.topic.as_str())
            .take(5)
            .collect();
        format!(
            "its {} channel(s) ({}) carry no quantity of the profile",
            summary.ignored_channels.len(),
            topics.join(", ")
        )
    };
    Error::Recording(RecordingError::BadRecording {
        path: path.to_owned(),
        message: format!("holds no heat-run data: {ignored}"),
    })
}

/// The recording's nameplate record, overridden by the machine file's keys.
fn resolve_nameplate(
    path: &Path,
    summary: &RecordingSummary,
    options: &ReplayOptions,
) -> Result<Nameplate> {
    let entries = match &options.machine {
        Some(file) => summary
            .nameplate
            .clone()
            .overridden_by(&NameplateEntries::from_toml_file(file)?),
        None => summary.nameplate.clone(),
    };
    Ok(entries.resolve(&path.display().to_string())?)
}

/// Replays one recording through every stage.
pub fn replay(path: &Path, options: &ReplayOptions) -> Result<Replay> {
    replay_with(path, options, None)
}

/// [`replay`], with every raw sample also given to `also` as the file streams by.
pub fn replay_with(
    path: &Path,
    options: &ReplayOptions,
    also: Option<&mut dyn SampleSink>,
) -> Result<Replay> {
    replay_observed(path, options, also, &Unobserved)
}

/// Told each stage's output as a replay goes, to work on it beside the stages after it:
/// the rerun publisher sends the measured series while the model is estimated, and the
/// model's while the network is fitted, rather than all of them after the replay.
///
/// Each call runs on a thread of its own while the pipeline goes on; the pipeline waits
/// for it before it changes what the call was given, and before it returns.
pub trait StageObserver: Sync {
    /// The recording is read, decimated and its signals computed; the estimator runs.
    fn prepared(&self, prepared: &Prepared) {
        let _ = prepared;
    }

    /// The model is analysed (`prepared`'s references moved to the initial temperatures
    /// the estimator found, where it estimated an output offset); the network stage runs.
    fn analysed(&self, prepared: &Prepared, analysis: &ModelAnalysis) {
        let _ = (prepared, analysis);
    }
}

/// The observer that does nothing with the stages.
#[derive(Debug, Clone, Copy, Default)]
pub struct Unobserved;

impl StageObserver for Unobserved {}

/// [`replay_with`], with `observer` told each stage's output as it is done, to work on
/// it beside the next stage.
pub fn replay_observed(
    path: &Path,
    options: &ReplayOptions,
    also: Option<&mut dyn SampleSink>,
    observer: &dyn StageObserver,
) -> Result<Replay> {
    let mut prepared = prepare_with(path, options, also)?;
    let estimation_range = estimation_range(prepared.data.len(), options)?;
    let in_file = |e: Error| e.in_recording(path);
    // The estimator's data: the recording's own unless a part is held out (a week's data
    // are not copied for nothing); kept for the network's refit below.
    let held_back = (estimation_range.len() != prepared.data.len())
        .then(|| prepared.data.slice(estimation_range.clone()));
    let scaling = network::Scaling {
        theta_base_k: prepared.signals.temperature_base_k,
        p_base_w: prepared.signals.power_base,
    };
    let (estimate, estimator_choice) = std::thread::scope(|scope| {
        scope.spawn(|| observer.prepared(&prepared));
        estimate_chosen(
            held_back.as_ref().unwrap_or(&prepared.data),
            options,
            scaling,
        )
    })
    .map_err(in_file)?;
    let mut held_back = held_back;
    let (estimate, left_out) = screen_and_estimate_again(
        &mut prepared,
        &mut held_back,
        &estimation_range,
        (options, scaling),
        estimate,
    )
    .map_err(in_file)?;
    // Where the estimator found the rises offset by the error of the first sample they are
    // measured from, the references become the initial temperatures it estimated: from
    // here on ŷ = x (the analysis, validation, steady state, network and report).
    let analysed = match &estimate.output_offset {
        Some(offset) => {
            prepared.signals.shift_references(offset);
            prepared.data.shift_outputs(offset);
            Cow::Owned(Estimate {
                output_offset: None,
                ..estimate.clone()
            })
        }
        None => Cow::Borrowed(&estimate),
    };
    // The continuous model, made once: the steady state's input and the analysis use it.
    let continuous = crate::model::ContinuousModel::from_discrete(&estimate.model).ok();
    // The steady state's input: the last one, with an input fed by the outlet's rise
    // (a changed flow's heat) made consistent with the steady state it leads to.
    let steady_input = match &continuous {
        Some(c) => prepared.signals.steady_state_input(&c.a_c, &c.b_c),
        None => prepared.signals.last_inputs().map(|(_, u)| u),
    };
    let steady_input = steady_input.ok_or_else(|| {
        in_file(Error::Signals(SignalError::NoCommonInstant {
            what: "the inputs".into(),
        }))
    })?;
    options.progress.stage("analysing the model");
    let estimation_data = held_back.as_ref().unwrap_or(&prepared.data);
    let (analysis, validation, output_error_beside, network, hidden) =
        std::thread::scope(|scope| -> Result<_> {
            // `oe`'s re-estimation for the network is as long as a fit and needs nothing
            // of the analysis: it runs on a thread of its own beside it.
            let refit = scope.spawn(|| {
                network_source(
                    estimation_data,
                    options,
                    &estimate,
                    &prepared.model,
                    scaling,
                )
            });
            // The hidden-state model needs nothing of the analysis either.
            let hidden = scope.spawn(|| {
                identify_hidden(&prepared, estimation_data, options, steady_input.as_slice())
            });
            let analysis = model::analyse(
                &analysed,
                continuous,
                &prepared.data,
                estimation_range.clone(),
                prepared.signals.temperature_base_k,
                &steady_input,
            )
            .map_err(|e| in_file(e.into()))?;
            let (validation, output_error_beside, network) = std::thread::scope(|inner| {
                inner.spawn(|| observer.analysed(&prepared, &analysis));
                let validation = validate(&prepared, &analysed, &estimation_range, options)?;
                let output_error_beside = estimate.network.as_deref().and_then(|n| {
                    Beside::of(
                        n.output_error.method,
                        &n.output_error.model,
                        &prepared.data,
                        estimation_range.clone(),
                        prepared.signals.temperature_base_k,
                    )
                });
                let balance = network::stage::Balance::of(
                    &prepared.model,
                    &prepared.signals,
                    &prepared.decimated,
                    &analysis.spectrum.time_constants_s,
                );
                let network_source = refit
                    .join()
                    .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
                let network = balance.with_network(
                    &prepared.model,
                    network_source
                        .grey_box
                        .as_ref()
                        .and_then(|e| e.network.as_deref())
                        .or(estimate.network.as_deref()),
                    network_source.refit.as_ref().unwrap_or(&estimate),
                    &analysis.continuous,
                    &prepared.signals,
                    network_source.said.as_deref(),
                );
                Ok::<_, Error>((validation, output_error_beside, network))
            })?;
            let hidden = hidden
                .join()
                .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
                .map_err(in_file)?;
            Ok((analysis, validation, output_error_beside, network, hidden))
        })?;
    drop(analysed);
    drop(held_back);
    // Where the spec declares hidden states, the hidden model is the replay's: whether the
    // final load was held long enough is judged against its slowest time constant (the
    // network stage judged the measured-state model's), for the warning, the report and
    // the page alike.
    let mut network = network;
    if let Some(slowest) = hidden
        .as_ref()
        .and_then(HiddenReplay::slowest_time_constant_s)
    {
        let e = &network.equilibrium;
        network.equilibrium = crate::network::equilibrium::Equilibrium::assess(
            &e.states,
            e.rate_of_rise.clone(),
            e.held_s,
            slowest,
        );
    }
    let mut warnings = warnings::collect(&prepared.for_warnings(), &analysis, &network);
    // plausibility (issue 34): the parts' labels against the losses that heat them.
    if let Ok(n) = &network.network {
        let labels = crate::plausibility::labels::check(&prepared.model, n);
        prepared.plausibility.findings.extend(labels);
    }
    warnings.extend(prepared.plausibility.warnings()); // plausibility (issue 34)
    warnings.extend(warnings::left_out(&left_out));
    Ok(Replay {
        path: path.to_owned(),
        model: prepared.model,
        recording: prepared.recording,
        nameplate: prepared.nameplate,
        decimated: prepared.decimated,
        signals: prepared.signals,
        data: prepared.data,
        estimation_range,
        validation,
        estimate,
        analysis,
        network,
        output_error_beside,
        left_out,
        hidden,
        warnings,
        estimator_choice,
        plausibility: prepared.plausibility, // plausibility (issue 34)
    })
}

/// Rounds of screen → estimate again at most; each leaves out only what the last
/// estimate's residuals show, so a glitch that bent the first estimate is found in the
/// first round and one it hid in the next.
const SCREEN_ROUNDS: usize = 4;

/// Screens the data against the estimate's simulation for glitches and frozen values
/// ([`screen`]); where it finds some, marks them unobserved in the data (the held-back
/// part included), gives the signals computed from those channels (a copper loss from
/// the winding's temperature) the model's predicted readings there, and estimates again;
/// once a round finds nothing new, the predictions are refreshed from that round's model
/// and the model estimated a last time. On clean data this is one simulation and one
/// screen, nothing estimated again.
fn screen_and_estimate_again(
    prepared: &mut Prepared,
    held_back: &mut Option<IdentificationData>,
    estimation_range: &Range<usize>,
    (options, scaling): (&ReplayOptions, network::Scaling),
    mut estimate: Estimate,
) -> Result<(Estimate, Vec<LeftOut>)> {
    let mut left_out: Vec<LeftOut> = Vec::new();
    let measured = prepared.signals.clone();
    for _ in 0..SCREEN_ROUNDS {
        let new = screen_once(prepared, &estimate, &mut left_out)?;
        let found = !new.is_empty();
        if !found && left_out.is_empty() {
            break;
        }
        left_out.extend(new);
        leave_out(prepared, &measured, &left_out)?;
        if held_back.is_some() {
            *held_back = Some(prepared.data.slice(estimation_range.clone()));
        }
        options
            .progress
            .stage("estimating again without glitches and frozen values");
        // The method the replay chose (pem where the default took it), not the one asked.
        let chosen = ReplayOptions {
            method: estimate.method,
            ..options.clone()
        };
        estimate = estimate_in(
            held_back.as_ref().unwrap_or(&prepared.data),
            &chosen,
            scaling,
        )?;
        if !found {
            break;
        }
    }
    left_out.sort_by_key(|l| (l.state, l.from_index));
    Ok((estimate, left_out))
}

/// One screen of the whole data against the estimate's simulation ŷ = x + d (d its
/// output offset, where it has one): returns the new stretches, and sets the readings
/// of those already left out to this model's predictions.
fn screen_once(
    prepared: &Prepared,
    estimate: &Estimate,
    left_out: &mut [LeftOut],
) -> Result<Vec<LeftOut>> {
    let data = &prepared.data;
    let mut simulated = estimate.model.simulate_segments(data, &data.segments());
    if let Some(offset) = &estimate.output_offset {
        for (j, d) in offset.iter().enumerate().take(data.states()) {
            simulated.column_mut(j).add_scalar_mut(*d);
        }
    }
    let signals = &prepared.signals;
    let channels: Vec<screen::Channel> = signals
        .states
        .iter()
        .map(|s| screen::Channel {
            name: &s.name,
            measured: &s.measured,
            stored_by_exception: s.exception.is_some() || s.observed.is_some(),
        })
        .collect();
    let input = screen::ScreenInput {
        data,
        simulated: &simulated,
        channels: &channels,
        time_ns: &signals.time_ns,
        temperature_base_k: signals.temperature_base_k,
    };
    screen::predict(&input, left_out)?;
    Ok(screen::screen(&input)?.left_out)
}

/// The signals and data without the stretches left out: the grid's channels take the
/// model's predicted readings there, the signal stage runs again on them (the inputs
/// computed from those channels follow), the states keep what was `measured`, and the
/// entries left out are unobserved.
fn leave_out(prepared: &mut Prepared, measured: &ModelSignals, left_out: &[LeftOut]) -> Result<()> {
    let mut grid = prepared.decimated.clone();
    for l in left_out {
        let channel = &prepared.model.states[l.state].channel;
        let Some(series) = grid.series.get_mut(channel) else {
            continue;
        };
        for (k, v) in (l.from_index..=l.to_index).zip(&l.predicted) {
            if v.is_finite() {
                series.values.set(k, Some(*v));
            }
        }
    }
    let mut signals = signals::compute(&prepared.model, &grid, prepared.nameplate.as_ref())?;
    for (state, was) in signals.states.iter_mut().zip(&measured.states) {
        state.measured = was.measured.clone();
    }
    prepared.data = screen::mark_unobserved(&signals.identification_data(), left_out);
    prepared.signals = signals;
    Ok(())
}

/// The hidden-state model the spec declares, identified on `estimation` (subspace start,
/// output error, the order chosen on it alone where the spec gives none) and validated
/// where the replay validates; `None` where the spec declares none. The data are the
/// estimator's own, before any output offset (the model fits its own initial states).
fn identify_hidden(
    prepared: &Prepared,
    estimation: &IdentificationData,
    options: &ReplayOptions,
    steady_input: &[f64],
) -> Result<Option<HiddenReplay>> {
    let Some(spec) = &prepared.model.hidden else {
        return Ok(None);
    };
    let estimate =
        crate::hidden::identify(estimation, &crate::hidden::HiddenOptions::from_spec(spec))?;
    let base = prepared.signals.temperature_base_k;
    let fit_on = |data: &IdentificationData, base: f64| {
        model::fit::fit(data, &estimate.model.simulate_segments(data), base)
    };
    let estimation_range = 0..estimation.len();
    let validation = validate_with(prepared, &estimation_range, options, &fit_on)?;
    let analysis = crate::hidden::analysis::analyse(&estimate.model, estimation, steady_input).ok();
    let covariance = crate::hidden::covariance::covariance(estimation, &estimate);
    Ok(Some(HiddenReplay {
        fit: fit_on(estimation, base),
        validation,
        analysis,
        covariance,
        estimate,
    }))
}

/// Where a replay's network comes from, found beside the model's analysis.
struct NetworkSource {
    /// `rc`'s fit to the data from the passive network nearest `oe`'s model.
    grey_box: Option<Estimate>,
    /// `oe`'s Θ re-estimated with the first sample's offset, where the nearest passive
    /// network is the replay's network and the refit applies.
    refit: Option<Estimate>,
    /// Which network it is, and why, for the report ([`crate::network::Network::fitted_from`]).
    said: Option<String>,
}

/// The replay's network: for `oe` (the default), the passive network nearest `oe`'s
/// model where the χ² test of that distance cannot reject it ([`CONSISTENT_LEVEL`]: the
/// model is a passive network within its uncertainty, and rc's seconds would buy
/// nothing the data can tell), else `rc`'s fit to the data
/// ([`ResistanceCapacitance::estimate_from`]) started from that nearest network, which is
/// near the minimum (few evaluations); the nearest passive network itself where `rc`
/// cannot apply (an input that is not heat), saying why. The reported
/// model stays the estimator's own: only the network changes source. `rc` itself
/// brings its own network; the other methods keep the network nearest their model.
fn network_source(
    data: &IdentificationData,
    options: &ReplayOptions,
    estimate: &Estimate,
    model: &ModelDescription,
    scaling: network::Scaling,
) -> NetworkSource {
    match options.method {
        Method::Rc => NetworkSource {
            grey_box: None,
            refit: None,
            said: Some("fitted to the data by rc (--method rc), started from oe's network".into()),
        },
        Method::Oe if reproduced_exactly(estimate, scaling) => NetworkSource {
            grey_box: None,
            refit: with_output_offset(data, options, estimate),
            said: Some(format!(
                "not rc's fit to the data: the identified model reproduces them within \
                 {NOISE_FREE_K:e} K (they carry no noise), so its own nearest passive network is \
                 the network"
            )),
        },
        Method::Oe if options.network == NetworkChoice::Nearest => NetworkSource {
            grey_box: None,
            refit: with_output_offset(data, options, estimate),
            said: Some(
                "the passive network nearest the identified model, as asked (--network \
                 nearest): rc's fit to the data was not run"
                    .into(),
            ),
        },
        Method::Oe => {
            // The nearest network is judged as the network stage would print it: from
            // `oe`'s Θ re-estimated with the first sample's offset where that applies.
            let refit = with_output_offset(data, options, estimate);
            match consistent_with_nearest(refit.as_ref().unwrap_or(estimate), model, scaling) {
                Some(p_value) => NetworkSource {
                    grey_box: None,
                    refit,
                    said: Some(format!(
                        "not rc's fit to the data: the identified model is consistent with its \
                     nearest passive network (χ² p = {p_value:.2} ≥ {CONSISTENT_LEVEL}), so that \
                     network is the network"
                    )),
                },
                None => from_grey_box(data, options, estimate, model, scaling),
            }
        }
        _ => NetworkSource {
            grey_box: None,
            refit: None,
            said: None,
        },
    }
}

/// The level at or above which the minimum distance's χ² test says the identified model
/// is a passive network within its own uncertainty: that nearest network is then as good
/// as the data can tell, and `rc` (two fits and a held refit, seconds on a 6 h run) is
/// not run. The four-node machine's model, far from passive, fails it (issue 22).
const CONSISTENT_LEVEL: f64 = 0.05;

/// The χ² p-value of the passive network nearest `estimate`'s model, where the test
/// cannot reject it ([`CONSISTENT_LEVEL`]); `None` where it rejects it or has no p-value
/// (no covariance, an input that is not heat).
fn consistent_with_nearest(
    estimate: &Estimate,
    model: &ModelDescription,
    scaling: network::Scaling,
) -> Option<f64> {
    let continuous = crate::model::ContinuousModel::from_discrete(&estimate.model).ok()?;
    let (_, distance) =
        network::stage::nearest_parts(model, estimate, &continuous, scaling).ok()?;
    distance.p_value.filter(|p| *p >= CONSISTENT_LEVEL)
}

/// The network from `rc`'s fit ([`grey_box_from_nearest`]), or the nearest passive
/// network with the reason `rc` could not apply.
fn from_grey_box(
    data: &IdentificationData,
    options: &ReplayOptions,
    estimate: &Estimate,
    model: &ModelDescription,
    scaling: network::Scaling,
) -> NetworkSource {
    match grey_box_from_nearest(data, options, estimate, model, scaling) {
        Ok((grey_box, said)) => NetworkSource {
            grey_box: Some(grey_box),
            refit: None,
            said: Some(said),
        },
        Err(why) => NetworkSource {
            grey_box: None,
            refit: with_output_offset(data, options, estimate),
            said: Some(format!("not rc's fit to the data: {why}")),
        },
    }
}

/// The residual, in kelvin, below which an identified model reproduces its data exactly:
/// far below the quantisation of any temperature sensor (0.001 K/√12 ≈ 3·10⁻⁴ K), so
/// only data without noise (the paper's fixture: 3·10⁻¹² K) come within it.
const NOISE_FREE_K: f64 = 1e-4;

/// Whether `estimate`'s model reproduces its data within [`NOISE_FREE_K`] on every
/// output: the data carry no noise, the model is the system's own, and its departure from
/// a passive network is the system's, which no fit to the same data would undo; the
/// network nearest the model is then the network, at no cost.
fn reproduced_exactly(estimate: &Estimate, scaling: network::Scaling) -> bool {
    let limit = (NOISE_FREE_K / scaling.theta_base_k).powi(2);
    !estimate.noise_variance.is_empty() && estimate.noise_variance.iter().all(|v| *v < limit)
}

/// The least noise, in kelvin, a temperature's residuals are taken to carry when fits are
/// compared ([`crate::estimate::deviance`]): the resolution of a PT100 transducer. Below
/// it, a difference between two networks is none a sensor can tell.
const SENSOR_FLOOR_K: f64 = 0.01;

/// [`SENSOR_FLOOR_K`]² in the outputs' units (θ_base per unit).
fn sensor_floor(scaling: network::Scaling) -> f64 {
    (SENSOR_FLOOR_K / scaling.theta_base_k).powi(2)
}

/// The level of the likelihood-ratio test that every part but the cooling water has no
/// conductance to the coolant: above it, the data cannot tell those conductances from
/// zero and the network holds them there.
const THROUGH_COOLANT_LEVEL: f64 = 0.05;

/// `rc`'s fit to `data` from the passive network nearest `estimate`'s model (`oe`'s),
/// with heat leaving only through the cooling water where the data allow it
/// ([`through_coolant`]), and what it is: how much more than the identified model it
/// leaves unexplained, as an RMS in kelvin, max_i θ_base·√(σ̂²_rc,i − σ̂²_model,i) (the
/// model's own misfit is the noise, or less); or why it cannot be made.
fn grey_box_from_nearest(
    data: &IdentificationData,
    options: &ReplayOptions,
    estimate: &Estimate,
    model: &ModelDescription,
    scaling: network::Scaling,
) -> std::result::Result<(Estimate, String), String> {
    let continuous =
        crate::model::ContinuousModel::from_discrete(&estimate.model).map_err(|e| e.to_string())?;
    let (nearest, _) = network::stage::nearest_parts(model, estimate, &continuous, scaling)?;
    let projected = crate::estimate::start_parts(&estimate.model, scaling);
    let rc = ResistanceCapacitance {
        weights: options.weights.clone(),
        scaling,
        progress: options.progress.clone(),
    };
    let floor = sensor_floor(scaling);
    // Two starts, each fitted on a core of its own: the nearest passive network, and the
    // identified model's algebraic network projected onto the passive set (`--method
    // rc`'s). On the four-node machine with a field winding read without noise, the
    // nearest one (C 10⁴ % off) led rc to a minimum 100 % off (seed 5) that the other
    // start avoids; the fit with the lower deviance is kept. Each core then fits the
    // network held to heat through the cooling water from its own start as well
    // ([`through_coolant`]).
    let water = crate::spec::coolant::outlet_state(model);
    let fits: Vec<_> = std::thread::scope(|scope| {
        let handles: Vec<_> = [&nearest, &projected]
            .map(|start| {
                let rc = &rc;
                scope.spawn(move || {
                    let free = rc.estimate_from(data, start, estimate.clone());
                    let held = water.and_then(|w| {
                        let start = crate::thermal::rc::projected(start.clone());
                        rc.fit_through_coolant(data, &start, w).ok()
                    });
                    (free, held)
                })
            })
            .into_iter()
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join()
                    .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
            })
            .collect()
    });
    let (fits, held): (Vec<_>, Vec<_>) = fits.into_iter().unzip();
    let mut failure = None;
    let (start, full) = [
        "the passive network nearest the identified model",
        "the identified model's own network projected onto the passive set (nearer the data \
         than rc's fit from the passive network nearest the model)",
    ]
    .into_iter()
    .zip(fits)
    .filter_map(|(start, fit)| fit.map_err(|e| failure = Some(e)).ok().map(|f| (start, f)))
    .min_by(|(_, a), (_, b)| {
        let d = |e: &Estimate| crate::estimate::deviance(data, e, floor);
        d(a).total_cmp(&d(b))
    })
    .ok_or_else(|| match failure {
        Some(e) => format!("rc's fit failed ({e})"),
        None => "rc's fit failed".into(),
    })?;
    let held: Vec<Estimate> = held.into_iter().flatten().collect();
    let (chosen, coolant, held_at) = through_coolant(&rc, data, model, full, held, floor);
    // The network chosen at the capped weights, refitted at each output's own weight where
    // one is above the cap (an output read without noise); itself otherwise.
    // A failed refit keeps the capped network, and the text says so.
    let (chosen, refit) = match rc.heavier(data, &chosen, held_at) {
        Ok(heavier) => (heavier, String::new()),
        Err(e) => (
            chosen,
            format!(
                "; its refit at an exact output's own weight failed ({e}), so it is the fit at \
                 capped weights"
            ),
        ),
    };
    let beyond_k = chosen
        .noise_variance
        .iter()
        .zip(&estimate.noise_variance)
        .map(|(r, m)| (r - m).max(0.0).sqrt() * scaling.theta_base_k)
        .fold(0.0, f64::max);
    Ok((
        chosen,
        format!(
            "fitted to the data by rc, started from {start}{coolant}; it leaves at most {beyond_k:.3} K RMS unexplained \
             beyond the identified model's residuals{refit}"
        ),
    ))
}

/// `full` (rc's network) or the same network refitted with every part's conductance to
/// the coolant but the cooling water's held at zero
/// ([`ResistanceCapacitance::fit_through_coolant`]), where the likelihood-ratio test
/// cannot tell them apart ([`THROUGH_COOLANT_LEVEL`]): a conductance the data cannot
/// see otherwise takes a few kW/K that bend C and G by 10 % (the four-node machine,
/// docs/src/methods/thermal-network.md). With what the text says of it, and the cooling
/// water's state where the network returned is the held one.
fn through_coolant(
    rc: &ResistanceCapacitance,
    data: &IdentificationData,
    model: &ModelDescription,
    full: Estimate,
    held_from_starts: Vec<Estimate>,
    floor: f64,
) -> (Estimate, String, Option<usize>) {
    let (Some(water), Some(parts)) = (
        crate::spec::coolant::outlet_state(model),
        full.network.as_ref().map(|n| n.parts.clone()),
    ) else {
        return (full, String::new(), None);
    };
    let held_parts = parts.capacitance_j_per_k.len() - 1;
    // The held network refitted from the free one's parts, beside those fitted from rc's
    // own starts: from the free network alone, with its conductances to the coolant cut,
    // the held fit stopped short of its minimum on the four-node machine (seed 1: a
    // likelihood ratio of 43.8 against 2.1 from the truth) and the test rejected a
    // network that is the truth's. The lowest deviance is the held fit.
    let Some(mut held) = rc
        .fit_through_coolant(data, &parts, water)
        .into_iter()
        .chain(held_from_starts)
        .min_by(|a, b| {
            let d = |e: &Estimate| crate::estimate::deviance(data, e, floor);
            d(a).total_cmp(&d(b))
        })
    else {
        return (full, String::new(), None);
    };
    let ratio = crate::estimate::likelihood_ratio(data, &full, &held, floor);
    let p = network::fit::chi_square_survival(ratio.max(0.0), held_parts);
    if p < THROUGH_COOLANT_LEVEL {
        let said = format!(
            "; every part's conductance to the coolant fitted (held at zero but the cooling \
             water's, they fit the data worse: likelihood ratio {ratio:.1} on {held_parts} \
             degrees of freedom, p = {p:.1e})"
        );
        return (full, said, None);
    }
    if let (Some(h), Some(f)) = (held.network.as_mut(), full.network) {
        h.output_error = f.output_error;
    }
    let said = format!(
        "; heat leaves only through the cooling water: the other parts' conductances to the \
         coolant are held at zero, which fits the data as well (likelihood ratio {ratio:.2} on \
         {held_parts} degrees of freedom, p = {p:.2})"
    );
    (held, said, Some(water))
}

/// What the network is fitted to after `oe`: its Θ re-estimated with the constant output
/// offset of the first sample the rises are measured from
/// ([`OutputError::refit_with_output_offset`]), where the data start at that sample and are
/// not stored by exception. The free Φ, Γ take that offset up, which biases the passive
/// network nearest them (its conductances to the coolant most); the reported model stays
/// `oe`'s own. `None` where the refit does not apply or fails (the network is then
/// fitted to `oe`'s Θ). `oe`'s estimate carries no offset of its own, so `data` are the
/// estimator's, not shifted to an offset.
fn with_output_offset(
    data: &IdentificationData,
    options: &ReplayOptions,
    estimate: &Estimate,
) -> Option<Estimate> {
    let applies = options.method == Method::Oe
        && estimate.output_offset.is_none()
        && crate::estimate::oe::starts_at_reference(data)
        && !crate::estimate::oe::censored::applies(data);
    if !applies {
        return None;
    }
    let oe = OutputError {
        weights: options.weights.clone(),
        progress: options.progress.clone(),
    };
    oe.refit_with_output_offset(data, &estimate.model).ok()
}

/// The instants the estimator sees: all, or those before the held-out fraction.
fn estimation_range(len: usize, options: &ReplayOptions) -> Result<Range<usize>> {
    match &options.validation {
        Some(ValidationSource::HoldOut(f)) => {
            if !(*f > 0.0 && *f < 0.9) {
                return Err(Error::HoldOutFraction { fraction: *f });
            }
            Ok(0..((len as f64 * (1.0 - f)).round() as usize))
        }
        Some(ValidationSource::SplitAt(t)) => {
            let k = (t / options.ts_s).round();
            if !(k >= 1.0 && (k as usize) < len.saturating_sub(1)) {
                return Err(Error::SplitOutside {
                    split_s: *t,
                    span_s: len as f64 * options.ts_s,
                });
            }
            Ok(0..k as usize)
        }
        _ => Ok(0..len),
    }
}

/// The model's fit on the held-out instants or on another recording, simulated from
/// that data's own measured state at the start of each segment.
fn validate(
    prepared: &Prepared,
    estimate: &Estimate,
    estimation_range: &Range<usize>,
    options: &ReplayOptions,
) -> Result<Option<Validation>> {
    let fit_on = |data: &IdentificationData, base: f64| {
        let sim = estimate.model.simulate_segments(data, &data.segments());
        model::fit::fit(data, &sim, base)
    };
    validate_with(prepared, estimation_range, options, &fit_on)
}

/// [`validate`] for any model: `fit_on` gives its fit on data of the given temperature base.
fn validate_with(
    prepared: &Prepared,
    estimation_range: &Range<usize>,
    options: &ReplayOptions,
    fit_on: &dyn Fn(&IdentificationData, f64) -> crate::model::Fit,
) -> Result<Option<Validation>> {
    Ok(match &options.validation {
        None => None,
        Some(held @ (ValidationSource::HoldOut(_) | ValidationSource::SplitAt(_))) => {
            let rest = estimation_range.end..prepared.data.len();
            let source = match held {
                ValidationSource::HoldOut(f) => {
                    format!("hold-out of the last {:.0} % of the recording", f * 100.0)
                }
                _ => format!(
                    "the recording from {} s on (instants {}..{})",
                    rest.start as f64 * options.ts_s,
                    rest.start,
                    rest.end
                ),
            };
            Some(Validation {
                source,
                fit: fit_on(
                    &prepared.data.slice(rest),
                    prepared.signals.temperature_base_k,
                ),
            })
        }
        Some(ValidationSource::Recording(other)) => {
            // The same description as this recording's, whatever the other's inlet does.
            let same = ReplayOptions {
                model: prepared.model.clone(),
                reference: ReferencePolicy::Initial,
                ..options.clone()
            };
            let other_data = prepare(other, &same)?;
            Some(Validation {
                source: other.display().to_string(),
                fit: fit_on(&other_data.data, other_data.signals.temperature_base_k),
            })
        }
    })
}

/// Which estimator a replay chose, and why: `oe`, or `pem` (with the disturbance state
/// where the model has a cooling-water node) where `oe`'s residuals are not white and the
/// likelihood ratio of `pem`'s innovations against them says the gain is real.
#[derive(Debug, Clone, serde::Serialize)]
pub struct EstimatorChoice {
    /// The method chosen.
    pub method: Method,
    /// Why, in a sentence.
    pub reason: String,
    /// Per output, the fraction of lags 1..max_lag of `oe`'s simulation residuals'
    /// autocorrelation outside the 99 % band of a white sequence (about 0.01 when white).
    pub oe_autocorrelation_outside_band: Vec<f64>,
    /// The fraction above which an output's residuals are taken as not white.
    pub threshold: f64,
    /// The likelihood ratio of `pem` against `oe`, where `pem` was fitted to test it.
    pub likelihood_ratio: Option<crate::estimate::LikelihoodRatio>,
}

/// Above this fraction of lags outside the 99 % band, a residual is not white: 6 of 60
/// lags, where a white sequence puts one lag in a hundred outside (P(≥ 6 of 60) ≈ 4·10⁻⁵
/// for independent lags).
pub const NOT_WHITE_FRACTION: f64 = 0.1;

/// Below this RMS (K) on every output `oe`'s simulation reproduces the data (a noise-free
/// run): there is no noise for a predictor to model, and a likelihood ratio of rounding
/// errors would be no test.
pub const EXACT_FIT_RMS_K: f64 = 1e-6;

/// The state a disturbance enters where the model has one: the cooling water's, where an
/// unmeasured heat (a valve, the air circuit, a neighbour) arrives.
pub fn disturbance_state(model: &ModelDescription) -> Option<usize> {
    let outlet =
        crate::recording::Signal::Profile(crate::recording::Quantity::CoolingWaterOutletTemp);
    model.states.iter().position(|s| s.channel == outlet)
}

/// The estimate of `options.method`, or, where the method is `oe`, the replay is to
/// choose ([`ReplayOptions::choose_estimator`]) and the model has a cooling-water state
/// ([`disturbance_state`]), the choice between `oe` and `pem` with the disturbance state:
/// `oe`'s fit; `oe` kept where it reproduces the data ([`EXACT_FIT_RMS_K`]) or its
/// simulation residuals are white (the sensors' noise is all there is; `pem` would cost
/// a second fit for nothing); else `pem` from that fit, taken where the likelihood ratio
/// of its innovations against `oe`'s residuals rejects K_a = 0 at size 1 %
/// ([`crate::estimate::LikelihoodRatio`]). The whiteness test alone is too eager (a
/// small systematic misfit of the RC unit's white-noise runs fails it); the ratio weighs
/// what the gain buys against the parameters it costs. Data stored by exception keep
/// `oe`, whose likelihood of the censored values `pem` does not have.
pub fn estimate_chosen(
    data: &IdentificationData,
    options: &ReplayOptions,
    scaling: network::Scaling,
) -> Result<(Estimate, Option<EstimatorChoice>)> {
    // Without a cooling-water state there is no disturbance state to offer: a free gain
    // (white process noise) was measured worse than `oe` on a wandering heat, so such a
    // model keeps `oe`.
    let Some(state) = disturbance_state(&options.model) else {
        return Ok((estimate_in(data, options, scaling)?, None));
    };
    if !options.choose_estimator
        || options.method != Method::Oe
        || crate::estimate::oe::censored::applies(data)
        || state >= data.states()
    {
        return Ok((estimate_in(data, options, scaling)?, None));
    }
    let oe = OutputError {
        weights: options.weights.clone(),
        progress: options.progress.clone(),
    };
    let start = oe.start(data).map_err(Error::from)?;
    let fitted = oe.fit(data, &start).map_err(Error::from)?;
    let segments = data.segments();
    let simulated = fitted.estimate.model.simulate_segments(data, &segments);
    let residuals = model::residuals::analyse(data, &simulated, model::RESIDUAL_MAX_LAG);
    let outside = residuals.autocorrelation_outside_band;
    let worst = outside.iter().copied().fold(0.0, f64::max);
    let choice = |method, reason, likelihood_ratio| EstimatorChoice {
        method,
        reason,
        oe_autocorrelation_outside_band: outside.clone(),
        threshold: NOT_WHITE_FRACTION,
        likelihood_ratio,
    };
    let rms_k = fitted
        .estimate
        .noise_variance
        .iter()
        .fold(0.0_f64, |m, v| m.max(v.sqrt() * scaling.theta_base_k));
    if rms_k < EXACT_FIT_RMS_K {
        let reason = format!(
            "oe reproduces the data (residuals' RMS {rms_k:.1e} K): there is no noise for a predictor to model"
        );
        return Ok((fitted.estimate, Some(choice(Method::Oe, reason, None))));
    }
    if worst <= NOT_WHITE_FRACTION {
        let reason = format!(
            "oe's residuals are white (at most {:.0} % of lags outside the 99 % band): the sensors' noise is all there is",
            100.0 * worst
        );
        return Ok((fitted.estimate, Some(choice(Method::Oe, reason, None))));
    }
    let pem = PredictionError {
        weights: options.weights.clone(),
        progress: options.progress.clone(),
        disturbance_state: Some(state),
    };
    // Where no predictor with the disturbance state can be fitted (no intensity gives a
    // stable Kalman filter: a frozen stretch makes the residuals far from white, and the
    // data offer the filter nothing to follow), the default keeps `oe` and says why:
    // the choice is the default's, not the user's, so its failure is not theirs either.
    let estimate = match pem.refine(data, &fitted.estimate, &fitted.initial_states) {
        Ok(estimate) => estimate,
        Err(e) => {
            let reason = format!(
                "oe's residuals are not white, but no predictor with a disturbance state could be fitted ({e}): oe kept"
            );
            return Ok((fitted.estimate, Some(choice(Method::Oe, reason, None))));
        }
    };
    let counts = data.observed_counts(&segments);
    let lr = match estimate.predictor.as_ref() {
        Some(p) if p.disturbance.is_some() => crate::estimate::LikelihoodRatio::intensity(
            &counts,
            &fitted.estimate.noise_variance,
            &estimate.noise_variance,
        ),
        _ => crate::estimate::LikelihoodRatio::gain(
            &counts,
            &fitted.estimate.noise_variance,
            &estimate.noise_variance,
            data.states() * data.states(),
        ),
    };
    let what = if estimate
        .predictor
        .as_ref()
        .is_some_and(|p| p.disturbance.is_some())
    {
        "a random-walk heat into the cooling water"
    } else {
        "a process noise"
    };
    if lr.rejects_zero_gain() {
        let reason = format!(
            "oe's residuals are not white ({:.0} % of lags outside the 99 % band) and pem's innovations explain them: likelihood ratio {:.1} > {:.1} ({} parameter(s), size 1 %): {what} the inputs do not explain",
            100.0 * worst,
            lr.statistic,
            lr.critical,
            lr.degrees_of_freedom
        );
        return Ok((estimate, Some(choice(Method::Pem, reason, Some(lr)))));
    }
    let reason = format!(
        "oe's residuals are not white ({:.0} % of lags outside the 99 % band), but pem's gain does not pay for its {} parameter(s): likelihood ratio {:.1} ≤ {:.1} (size 1 %)",
        100.0 * worst,
        lr.degrees_of_freedom,
        lr.statistic,
        lr.critical
    );
    Ok((fitted.estimate, Some(choice(Method::Oe, reason, Some(lr)))))
}

/// Runs the chosen estimator on the data; `rc`'s network is then in the data's own units
/// (states in K, inputs in W): [`estimate_in`] gives it the model's scaling.
pub fn estimate(data: &IdentificationData, options: &ReplayOptions) -> Result<Estimate> {
    estimate_in(data, options, network::Scaling::PHYSICAL)
}

/// Runs the chosen estimator on data in `scaling` (x = θ/θ_base, u = P/P_base), which
/// `rc` needs to put its network in J/K and W/K. `rc` refuses a model with an input that
/// is not heat: a thermal network has no place for it.
pub fn estimate_in(
    data: &IdentificationData,
    options: &ReplayOptions,
    scaling: network::Scaling,
) -> Result<Estimate> {
    if let Some(w) = &options.weights {
        if w.len() != data.states() || w.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
            return Err(Error::Weights {
                states: data.states(),
                given: w.len(),
            });
        }
    }
    let per_instant =
        |w: &Vec<f64>| nalgebra::DMatrix::from_fn(data.len(), data.states(), |_, j| w[j]);
    let estimator: Box<dyn Estimator> = match options.method {
        Method::Ls => Box::new(WeightedLeastSquares::default()),
        Method::Wls => Box::new(WeightedLeastSquares {
            weights: options.weights.as_ref().map(per_instant),
        }),
        Method::Rls => Box::new(RecursiveLeastSquares {
            forgetting: options.forgetting,
            keep_every: 10,
        }),
        Method::Iv => Box::new(InstrumentalVariables::default()),
        Method::Oe => Box::new(OutputError {
            weights: options.weights.clone(),
            progress: options.progress.clone(),
        }),
        Method::Pem => Box::new(PredictionError {
            weights: options.weights.clone(),
            progress: options.progress.clone(),
            disturbance_state: disturbance_state(&options.model),
        }),
        Method::Rc => {
            if let Some(input) = options
                .model
                .inputs
                .iter()
                .find(|i| i.kind != crate::spec::InputKind::Heat)
            {
                return Err(EstimationError::InputNotHeat {
                    input: input.name.clone(),
                }
                .into());
            }
            Box::new(ResistanceCapacitance {
                weights: options.weights.clone(),
                scaling,
                progress: options.progress.clone(),
            })
        }
    };
    Ok(estimator.estimate(data)?)
}

#[cfg(test)]
mod tests {
    use nalgebra::DMatrix;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    use super::*;
    use crate::estimate::testing::{simulate, step_inputs, two_state_model, with_noise};

    /// The two-state model's outputs with white sensor noise, and with a random-walk heat
    /// into state 0 as well (the disturbance the inputs do not explain).
    fn runs() -> (IdentificationData, IdentificationData) {
        let truth = two_state_model();
        let u = step_inputs(20_000, 2, 5);
        let y = simulate(&truth, &u, &[0.5, 0.2]);
        let white = IdentificationData::complete(1.0, with_noise(&y, 0.02, 6), u.clone());
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let step = Normal::new(0.0, 0.002).unwrap();
        let (mut heat, mut walked) = (0.0, DMatrix::zeros(20_000, 2));
        let mut x = nalgebra::DVector::from_column_slice(&[0.5, 0.2]);
        for k in 0..20_000 {
            walked.set_row(k, &x.transpose());
            heat += step.sample(&mut rng);
            x = &truth.phi * &x + &truth.gamma * u.row(k).transpose();
            x[0] += heat;
        }
        let disturbed = IdentificationData::complete(1.0, with_noise(&walked, 0.02, 6), u);
        (white, disturbed)
    }

    #[test]
    fn the_default_keeps_oe_on_white_residuals_and_takes_pem_where_they_are_not() {
        let (white, disturbed) = runs();
        // Two states, the first the cooling water's (where the walk enters).
        let mut model = ModelDescription::generator();
        model.states = vec![model.states[2].clone(), model.states[1].clone()];
        let options = ReplayOptions {
            choose_estimator: true,
            model: model.clone(),
            ..ReplayOptions::default()
        };
        let (e, choice) = estimate_chosen(&white, &options, network::Scaling::PHYSICAL).unwrap();
        let choice = choice.expect("the replay chooses");
        assert_eq!(
            (e.method, choice.method),
            (Method::Oe, Method::Oe),
            "{}",
            choice.reason
        );
        assert!(choice
            .oe_autocorrelation_outside_band
            .iter()
            .all(|v| *v <= NOT_WHITE_FRACTION));
        let (e, choice) =
            estimate_chosen(&disturbed, &options, network::Scaling::PHYSICAL).unwrap();
        let choice = choice.unwrap();
        assert_eq!(
            (e.method, choice.method),
            (Method::Pem, Method::Pem),
            "{}",
            choice.reason
        );
        let d = e.predictor.as_ref().and_then(|p| p.disturbance.as_ref());
        assert_eq!(d.map(|d| d.state), Some(0), "the walk's state");
        let lr = choice.likelihood_ratio.expect("pem was tested against oe");
        assert!(lr.rejects_zero_gain() && lr.statistic > lr.critical);
        // Without a cooling-water state the default keeps oe and does not choose.
        let mut dry = ModelDescription::generator();
        dry.states.truncate(2);
        let no_water = ReplayOptions {
            choose_estimator: true,
            model: dry,
            ..ReplayOptions::default()
        };
        let (e, choice) =
            estimate_chosen(&disturbed, &no_water, network::Scaling::PHYSICAL).unwrap();
        assert_eq!(e.method, Method::Oe);
        assert!(choice.is_none());
        // A method given is run as given, whatever the residuals.
        let given = ReplayOptions {
            model,
            ..ReplayOptions::default()
        };
        let (e, choice) = estimate_chosen(&disturbed, &given, network::Scaling::PHYSICAL).unwrap();
        assert_eq!(e.method, Method::Oe);
        assert!(choice.is_none());
    }

    /// A noisy heat run of the RC unit with 30 kW/√h of unmeasured heat into the cooling
    /// water (its outlet wanders 0.4 K, seed 1): the default takes pem with the
    /// disturbance state, whose time constants lie within three of their reported
    /// standard errors of the truth and whose steady state is within 1 K (the issue's
    /// bar); `oe` on the same run misses the slowest constant by more than its three σ.
    #[test]
    fn the_default_recovers_a_heat_run_with_a_wandering_heat_into_the_cooling_water() {
        use crate::synth::{self, Disturbances, Machine, NetworkMachine, SynthOptions};
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("walk.mcap");
        let truth = synth::write(
            &path,
            &SynthOptions {
                machine: Machine::Network(NetworkMachine::rc_unit()),
                disturbances: Disturbances {
                    coolant_heat_walk_kw_per_sqrt_h: 30.0,
                    ..Disturbances::default()
                },
                temperature_noise_k: 0.05,
                temperature_resolution_k: 0.01,
                seed: 1,
                ..SynthOptions::default()
            },
        )
        .unwrap();
        let run = |choose| {
            replay(
                &path,
                &ReplayOptions {
                    choose_estimator: choose,
                    // The estimator's bars only: rc's network fit has no part in them.
                    network: NetworkChoice::Nearest,
                    ..ReplayOptions::default()
                },
            )
            .unwrap()
        };
        let off_by_sigmas = |r: &Replay| -> Vec<f64> {
            let u = r.analysis.uncertainty.as_ref().unwrap();
            (0..3)
                .map(|i| {
                    let t = truth.time_constants_s[i];
                    let sigma = u.time_constants_ci95_s[i] / 1.96;
                    (r.analysis.spectrum.time_constants_s[i] - t).abs() / sigma
                })
                .collect()
        };
        let chosen = run(true);
        assert_eq!(chosen.estimate.method, Method::Pem);
        let d = chosen
            .estimate
            .predictor
            .as_ref()
            .unwrap()
            .disturbance
            .as_ref();
        assert_eq!(d.map(|d| d.state), Some(2), "the cooling water's node");
        let z = off_by_sigmas(&chosen);
        assert!(z.iter().all(|z| *z < 3.0), "pem: {z:?} σ");
        let base = chosen.signals.temperature_base_k;
        let refs = chosen.signals.initial_references();
        for (j, rise) in truth.steady_state_rise_k.iter().enumerate() {
            let predicted = refs[j] + base * chosen.analysis.steady_state[j];
            let error = predicted - truth.coolant.inlet_initial_c - rise;
            assert!(
                error.abs() < 1.0,
                "state {j}: steady state off by {error} K"
            );
        }
        let oe = run(false);
        assert_eq!(oe.estimate.method, Method::Oe);
        assert!(
            off_by_sigmas(&oe)[2] > 3.0,
            "oe: {:?} σ",
            off_by_sigmas(&oe)
        );
    }
}
