//! The replay pipeline: recording → decimation → losses → estimation → analysis.
//!
//! This is the one place that knows the order of the stages; publishing and the
//! report read its output, a [`Replay`].

use std::path::{Path, PathBuf};

use crate::decimate::{DecimatedRecording, Decimator};
use crate::error::{Error, Result};
use crate::estimate::rls::TrajectoryPoint;
use crate::estimate::{
    Estimate, Estimator, IdentificationData, InstrumentalVariables, OutputError,
    RecursiveLeastSquares, WeightedLeastSquares,
};
use crate::losses::{self, ThermalSignals};
use crate::model::{self, ModelAnalysis};
use crate::recording::{self, Nameplate, NameplateEntries, RecordingSummary, SampleSink};

/// An identification method selectable on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Ordinary least squares (eq. 7), W = I: biased by sensor noise on y.
    Ls,
    /// Weighted least squares (eqs. 3–7) with per-output weights.
    Wls,
    /// Recursive least squares with a forgetting factor.
    Rls,
    /// Iterated instrumental variables.
    Iv,
    /// Output error by Levenberg–Marquardt from the IV estimate (the default).
    Oe,
}

impl Method {
    /// The method's name.
    pub fn name(self) -> &'static str {
        match self {
            Method::Ls => "ls",
            Method::Wls => "wls",
            Method::Rls => "rls",
            Method::Iv => "iv",
            Method::Oe => "oe",
        }
    }

    /// Every method, for benchmarks and tests.
    pub const ALL: [Method; 5] = [Method::Ls, Method::Wls, Method::Rls, Method::Iv, Method::Oe];
}

/// How to replay a recording.
#[derive(Debug, Clone)]
pub struct ReplayOptions {
    /// Sample time Ts of the grid, s.
    pub ts_s: f64,
    /// A machine file whose keys override the recording's nameplate.
    pub machine: Option<PathBuf>,
    /// The identification method.
    pub method: Method,
    /// Per-output weights w_i for `wls` and `oe` (constant in time); `None`: equal for
    /// `wls`, the inverse noise variances for `oe`.
    pub weights: Option<Vec<f64>>,
    /// Forgetting factor λ of `rls`.
    pub forgetting: f64,
    /// Where to validate the model, if anywhere.
    pub validation: Option<ValidationSource>,
}

/// Data the model is validated on, not estimated from.
#[derive(Debug, Clone, PartialEq)]
pub enum ValidationSource {
    /// The last fraction (0, 1) of the recording is held out of the estimation.
    HoldOut(f64),
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
            weights: None,
            forgetting: 1.0,
            validation: None,
        }
    }
}

/// Everything a replay produced, stage by stage.
#[derive(Debug, Clone)]
pub struct Replay {
    /// The recording replayed.
    pub path: PathBuf,
    /// What the recording stage found.
    pub recording: RecordingSummary,
    /// The nameplate used (recording's record, overridden by the machine file).
    pub nameplate: Nameplate,
    /// The decimated quantities.
    pub decimated: DecimatedRecording,
    /// States and inputs in pu.
    pub signals: ThermalSignals,
    /// The identification data of the whole recording.
    pub data: IdentificationData,
    /// The instants the estimator saw (all, or those before a hold-out).
    pub estimation_range: std::ops::Range<usize>,
    /// The model's fit on held-out data or another recording.
    pub validation: Option<Validation>,
    /// The estimate.
    pub estimate: Estimate,
    /// The recursion's trajectory of Θ (`rls` only).
    pub trajectory: Vec<TrajectoryPoint>,
    /// The analysis of the estimate.
    pub analysis: ModelAnalysis,
    /// Warnings for the user (data loss, gaps).
    pub warnings: Vec<String>,
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
    /// What the recording stage found.
    pub recording: RecordingSummary,
    /// The nameplate used.
    pub nameplate: Nameplate,
    /// The decimated quantities.
    pub decimated: DecimatedRecording,
    /// States and inputs in pu.
    pub signals: ThermalSignals,
    /// The estimator's input.
    pub data: IdentificationData,
}

/// Reads, decimates and computes the losses of one recording.
pub fn prepare(path: &Path, options: &ReplayOptions) -> Result<Prepared> {
    prepare_with(path, options, None)
}

/// Gives every sample to the decimator and to a second sink (the full-rate publisher).
struct Tee<'a> {
    decimator: &'a mut Decimator,
    also: &'a mut dyn SampleSink,
}

impl SampleSink for Tee<'_> {
    fn channel(&mut self, channel: &recording::SensorChannel) {
        self.decimator.channel(channel);
        self.also.channel(channel);
    }

    fn sample(&mut self, sample: recording::Sample) {
        self.decimator.sample(sample);
        self.also.sample(sample);
    }

    fn retract(&mut self, sample: recording::Sample) {
        self.decimator.retract(sample);
        self.also.retract(sample);
    }
}

/// [`prepare`], with every raw sample also given to `also` as the file streams by.
pub fn prepare_with(
    path: &Path,
    options: &ReplayOptions,
    also: Option<&mut dyn SampleSink>,
) -> Result<Prepared> {
    let name = path.display().to_string();
    let mut decimator = Decimator::new(options.ts_s, crate::decimate::profile_alignments())?;
    let summary = match also {
        Some(also) => recording::read_recording(
            path,
            &mut Tee {
                decimator: &mut decimator,
                also,
            },
        )?,
        None => recording::read_recording(path, &mut decimator)?,
    };
    if summary.channels.is_empty() {
        let ignored = if summary.ignored_channels.is_empty() {
            "it has no channels at all".to_owned()
        } else {
            format!(
                "its {} channel(s) ({}) carry no quantity of the profile",
                summary.ignored_channels.len(),
                summary
                    .ignored_channels
                    .iter()
                    .map(|c| c.topic.as_str())
                    .take(5)
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        };
        return Err(Error::BadRecording {
            path: path.to_owned(),
            message: format!("holds no heat-run data: {ignored}"),
        });
    }
    let overrides = match &options.machine {
        Some(file) => Some(NameplateEntries::from_toml_file(file)?),
        None => None,
    };
    let entries = match &overrides {
        Some(o) => summary.nameplate.clone().overridden_by(o),
        None => summary.nameplate.clone(),
    };
    let nameplate = entries.resolve(&name)?;
    let decimated = decimator.finish(&summary.channels).map_err(|e| match e {
        Error::ClockJump(m) => Error::BadRecording {
            path: path.to_owned(),
            message: m,
        },
        Error::Estimation(m) => Error::BadRecording {
            path: path.to_owned(),
            message: m,
        },
        Error::Decimate(e) => Error::BadRecording {
            path: path.to_owned(),
            message: e.to_string(),
        },
        other => other,
    })?;
    let signals = losses::compute(&decimated, &nameplate, &name)?;
    let data = IdentificationData::from(&signals);
    Ok(Prepared {
        recording: summary,
        nameplate,
        decimated,
        signals,
        data,
    })
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
    let name = path.display().to_string();
    let Prepared {
        recording: summary,
        nameplate,
        decimated,
        signals,
        data,
    } = prepare_with(path, options, also)?;
    let estimation_range = match &options.validation {
        Some(ValidationSource::HoldOut(f)) => {
            if !(*f > 0.0 && *f < 0.9) {
                return Err(Error::Usage(format!(
                    "--holdout {f}: the held-out fraction must be in (0, 0.9)"
                )));
            }
            0..((data.len() as f64 * (1.0 - f)).round() as usize)
        }
        _ => 0..data.len(),
    };
    // Borrowed unless a part is held out: a week's data are not copied for nothing.
    let estimation_data = if estimation_range.len() == data.len() {
        std::borrow::Cow::Borrowed(&data)
    } else {
        std::borrow::Cow::Owned(data.slice(estimation_range.clone()))
    };
    let (mut estimate, trajectory) =
        estimate(&estimation_data, options).map_err(|e| with_file(e, &name))?;
    estimate.method = options.method.name().into();
    let (_, last_input) = signals
        .last_inputs()
        .ok_or_else(|| Error::Estimation(format!("{name}: the inputs are never all known")))?;
    let mut analysis = model::analyse(
        &estimate,
        &estimation_data,
        signals.temperature_base_k,
        &last_input,
    )
    .map_err(|e| with_file(e, &name))?;
    // Simulated traces over the whole recording (hold-out included) for publishing.
    if estimation_range.len() != data.len() {
        drop(estimation_data);
        analysis.simulated = estimate.model.simulate_segments(&data, &data.segments());
    }
    let validation = match &options.validation {
        None => None,
        Some(ValidationSource::HoldOut(f)) => {
            let held = data.slice(estimation_range.end..data.len());
            let sim = estimate.model.simulate_segments(&held, &held.segments());
            Some(Validation {
                source: format!("hold-out of the last {:.0} % of the recording", f * 100.0),
                fit: model::fit::fit(&held, &sim, signals.temperature_base_k),
            })
        }
        Some(ValidationSource::Recording(other)) => {
            let prepared = prepare(other, options)?;
            let sim = estimate
                .model
                .simulate_segments(&prepared.data, &prepared.data.segments());
            Some(Validation {
                source: other.display().to_string(),
                fit: model::fit::fit(&prepared.data, &sim, prepared.signals.temperature_base_k),
            })
        }
    };

    let mut warnings: Vec<String> = summary
        .data_loss
        .iter()
        .map(|l| format!("data lost: {l}"))
        .collect();
    for ch in &decimated.channels {
        if ch.gaps > 0 {
            warnings.push(format!(
                "channel {} has {} gap(s) ({} instants without data); no equation bridges them",
                ch.topic, ch.gaps, ch.gap_instants
            ));
        }
    }
    for (i, ch) in summary.channels.iter().enumerate() {
        if let Some((t, v)) = summary.first_implausible[i] {
            warnings.push(format!(
                "channel {}: {} sample(s) outside the physical range of {} were dropped, the first {} {} at {}",
                ch.topic,
                summary.implausible_per_channel[i],
                ch.signal,
                v,
                ch.canonical_unit(),
                crate::recording::format_time(t)
            ));
        }
    }
    // A required channel that stops well before the others.
    if let Some((_, end)) = summary.time_span_ns {
        for series in decimated.series.values() {
            if let Some(last) = series.values.iter().rposition(|v| v.is_some()) {
                let stop_ns = decimated.time_ns(last);
                let early_s = (end as i64 - stop_ns) as f64 * 1e-9;
                if early_s > 600.0 {
                    warnings.push(format!(
                        "{} stops at {}, {:.0} s before the recording ends; the rest is not used",
                        series.signal,
                        crate::recording::format_time(stop_ns.max(0) as u64),
                        early_s
                    ));
                }
            }
        }
    }
    if summary.bad_quality_dropped > 0 {
        warnings.push(format!(
            "{} samples marked `bad` were dropped",
            summary.bad_quality_dropped
        ));
    }
    for a in &analysis.assignment {
        if a.resolved_conflict {
            warnings.push(format!(
                "the time constant {:.1} s was claimed by two states; it was assigned one-to-one",
                a.time_constant_s
            ));
        }
    }
    Ok(Replay {
        path: path.to_owned(),
        recording: summary,
        nameplate,
        decimated,
        signals,
        data,
        estimation_range,
        validation,
        estimate,
        trajectory,
        analysis,
        warnings,
    })
}

/// Runs the chosen estimator on the data.
pub fn estimate(
    data: &IdentificationData,
    options: &ReplayOptions,
) -> Result<(Estimate, Vec<TrajectoryPoint>)> {
    if let Some(w) = &options.weights {
        if w.len() != data.states() || w.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
            return Err(Error::Usage(format!(
                "--weights wants {} positive numbers, one per state",
                data.states()
            )));
        }
    }
    let per_instant =
        |w: &Vec<f64>| nalgebra::DMatrix::from_fn(data.len(), data.states(), |_, j| w[j]);
    Ok(match options.method {
        Method::Ls => (WeightedLeastSquares::default().estimate(data)?, Vec::new()),
        Method::Wls => (
            WeightedLeastSquares {
                weights: options.weights.as_ref().map(per_instant),
            }
            .estimate(data)?,
            Vec::new(),
        ),
        Method::Rls => RecursiveLeastSquares {
            forgetting: options.forgetting,
            keep_every: 10,
        }
        .run(data)?,
        Method::Iv => (InstrumentalVariables::default().estimate(data)?, Vec::new()),
        Method::Oe => (
            OutputError {
                weights: options.weights.clone(),
            }
            .estimate(data)?,
            Vec::new(),
        ),
    })
}

/// Prefixes an estimation or model error with the recording's name.
fn with_file(e: Error, name: &str) -> Error {
    match e {
        Error::Estimation(m) => Error::Estimation(format!("{name}: {m}")),
        Error::Model(m) => Error::Model(format!("{name}: {m}")),
        other => other,
    }
}
