//! The replay pipeline: recording → decimation → signals → estimation → screen
//! (→ estimation again without what the screen left out) → analysis.
//!
//! This is the one place that knows the order of the stages; each stage returns what it
//! owns, and publishing and the report read their outputs, gathered in a [`Replay`]
//! (publishing may start on a stage's output while the next stage runs:
//! [`StageObserver`]). Work that needs nothing of the stage beside it runs on a thread of
//! its own: `oe`'s re-estimation for the network beside the model's analysis.
//! What the model is — states, inputs, alignment, scaling — comes from the
//! [`ModelDescription`](crate::spec::ModelDescription) in the options (the generator by
//! default). What the stages produce is typed in `pipeline/outcome.rs`.

use std::ops::Range;
use std::path::Path;

use std::borrow::Cow;

use crate::decide::{self, Decision, EstimatorChoice, NoiseFloor};
use crate::error::{Error, Result};
use crate::estimate::{Estimate, IdentificationData};
use crate::grid::GridBuilder;
use crate::model::{self, ModelAnalysis};
use crate::network;
use crate::recording::RecordingError;
use crate::recording::{
    self, Nameplate, NameplateEntries, ReadOptions, RecordingSummary, SampleSink,
};
use crate::signals;
use crate::signals::SignalError;
use crate::spec::coolant::{self, ReferencePolicy};
use crate::warnings;

pub use crate::decide::{estimate, estimate_chosen, estimate_in};
pub use crate::estimate::Method;
pub use crate::options::{NetworkChoice, ReplayOptions, ValidationSource};

mod outcome;

pub use outcome::{Beside, HiddenReplay, Prepared, Replay, Validation};

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
    // Plausibility: channels exchanged mid-run swapped back, wrong units refused.
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
    // Plausibility: the calorimetric balance over the run.
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
        plausibility,
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
    // The grid's Ts: the one asked, or the temperatures' own where the replay chooses it.
    let (ts_s, sample_time) = decide::sample_time::decide(path, options);
    let options = &ReplayOptions {
        ts_s,
        ..options.clone()
    };
    let mut decisions: Vec<Decision> = sample_time.into_iter().collect();
    let mut prepared = prepare_with(path, options, also)?;
    let estimation_range = estimation_range(prepared.data.len(), options)?;
    let in_file = |e: Error| e.in_recording(path);
    let noise_floor = NoiseFloor::of(
        &prepared.model,
        &prepared.signals,
        &prepared.recording.channels,
    );
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
            &noise_floor,
        )
    })
    .map_err(in_file)?;
    decisions.extend(estimator_choice.as_ref().map(EstimatorChoice::decision));
    let mut held_back = held_back;
    let (estimate, screened) = decide::screening::screen_and_estimate_again(
        &mut decide::screening::ScreenTarget {
            model: &prepared.model,
            decimated: &prepared.decimated,
            nameplate: prepared.nameplate.as_ref(),
            signals: &mut prepared.signals,
            data: &mut prepared.data,
        },
        &mut held_back,
        &estimation_range,
        (options, scaling, &noise_floor),
        estimate,
    )
    .map_err(in_file)?;
    decisions.push(screened.decision());
    // The decisions after the screen compare residuals with the sensors' white noise it
    // measured as well.
    let noise_floor = noise_floor.with_white_noise(screened.noise_k.clone());
    let left_out = screened.left_out;
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
                decide::network::network_source(
                    estimation_data,
                    options,
                    &estimate,
                    &prepared.model,
                    (scaling, &noise_floor),
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
                    (
                        network_source.said.as_deref(),
                        network_source.nearest.as_ref(),
                    ),
                );
                let decided = network_source.decision;
                Ok::<_, Error>((validation, output_error_beside, (network, decided)))
            })?;
            let hidden = hidden
                .join()
                .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
                .map_err(in_file)?;
            Ok((analysis, validation, output_error_beside, network, hidden))
        })?;
    drop(analysed);
    drop(held_back);
    let (network, network_decision) = network;
    decisions.extend(network_decision);
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
    // Plausibility: the parts' labels against the losses that heat them.
    if let Ok(n) = &network.network {
        let labels = crate::plausibility::labels::check(&prepared.model, n);
        prepared.plausibility.findings.extend(labels);
    }
    warnings.extend(prepared.plausibility.warnings());
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
        noise_floor,
        decisions,
        plausibility: prepared.plausibility,
    })
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
