//! Publishing stage: a [`Replay`] → a rerun recording (an .rrd file, a running
//! viewer, or one spawned for it), on the recording's own time line.
//!
//! Long series go out as columns with `send_columns`, one chunk per entity, each
//! named and coloured (a part keeps its colour in every plot), and a blueprint opens
//! the viewer on the story with every plot showing the whole recording: measured
//! against model per part, the residuals, the inputs and the model's figures; tabs
//! for the sensitivities, residual analysis, recursive estimate and raw channels.
//!
//! Modules: `sdk` (rerun's SDK under the `rerun` crate's names, without that crate's
//! viewer-side dependencies), `traces` (the time series), `analysis` (sensitivities, correlations, RLS),
//! `text` (the figures panel), `style` (names and colours), `layout` (a blueprint
//! writer with view properties), `blueprint` (the layout of a replay).

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

use crate::paced::PacedStream;
use crate::sdk::{RecordingStreamBuilder, Scalars, SeriesLines, TimeColumn};

mod analysis;
pub mod blueprint;
pub mod curve;
#[cfg(test)]
mod hidden_tests;
#[cfg(test)]
mod inputs_tests;
pub mod layout;
pub mod monitor;
pub mod network;
pub mod paced;
pub mod prediction;
#[cfg(test)]
mod rrd_testing;
pub mod sdk;
#[cfg(test)]
mod sensitivity_tests;
mod style;
mod text;
mod traces;

pub use blueprint::blueprint;
pub use traces::temperature_entity;

#[allow(unused_imports)]
use heatrun::recording::SampleSink as _;

use heatrun::atomic::{PendingOutput, WriteError};
use heatrun::model::ModelAnalysis;
use heatrun::model_file::Report;
use heatrun::pipeline::{Prepared, Replay, StageObserver};
use heatrun::report::Replayed;

/// Name of the timeline: the recording's own clock (log_time).
pub const TIMELINE: &str = "time";

/// Where the rerun data go.
#[derive(Debug, Clone, PartialEq)]
pub enum RerunSink {
    /// A saved .rrd file, complete when [`publish`] returns.
    Rrd(PathBuf),
    /// A running viewer at a gRPC URL (`None`: the default local viewer).
    Connect(Option<String>),
    /// A viewer started for this replay.
    Spawn,
}

/// Publishing failed: rerun refused a recording or a batch, or the .rrd could not be
/// completed.
#[derive(Debug, thiserror::Error)]
pub enum PublishError {
    /// rerun's SDK reported an error (a viewer that cannot be reached or spawned, a
    /// batch that cannot be serialised).
    #[error("rerun: {0}")]
    Rerun(String),
    /// The .rrd file could not be renamed into place.
    #[error(transparent)]
    Output(#[from] WriteError),
}

/// The publisher's result.
pub type Result<T, E = PublishError> = std::result::Result<T, E>;

fn publish_err(e: impl std::fmt::Display) -> PublishError {
    PublishError::Rerun(e.to_string())
}

/// An open rerun recording: created before the replay (so full-rate samples can stream
/// into it), finished with the replay's traces and the blueprint.
///
/// As the replay's [`StageObserver`] it sends the series each stage determines while
/// the next one runs ([`heatrun::pipeline::replay_observed`]): the measured ones while
/// the model is estimated, the model's while the network is fitted; [`Publisher::finish`]
/// then sends the rest, and whatever no stage sent.
pub struct Publisher {
    rec: PacedStream,
    pending: Option<PendingOutput>,
    full_rate: AtomicBool,
    early: Mutex<Early>,
}

/// What the publisher sent as the stages ended, and the first failure if any.
#[derive(Default)]
struct Early {
    measured: bool,
    model: bool,
    failed: Option<PublishError>,
}

impl StageObserver for Publisher {
    fn prepared(&self, prepared: &Prepared) {
        let result = traces::log_measured(&self.rec, prepared.into());
        self.sent(result, |e| &mut e.measured);
    }

    fn analysed(&self, prepared: &Prepared, analysis: &ModelAnalysis) {
        let result = log_model(&self.rec, prepared.into(), analysis);
        self.sent(result, |e| &mut e.model);
    }
}

impl Publisher {
    /// Opens the recording on `sink`; `name` is the recording's name in the viewer.
    pub fn open(sink: &RerunSink, name: &str) -> Result<Publisher> {
        let builder = RecordingStreamBuilder::new("heatrun").recording_name(name.to_owned());
        Ok(match sink {
            RerunSink::Rrd(path) => {
                let pending = PendingOutput::new(path);
                // A missing folder is named by the .rrd's own path, not the temporary one
                // rerun's sink would name.
                pending.made()?;
                let rec = builder.save(pending.path()).map_err(publish_err)?;
                Publisher {
                    rec: PacedStream::new(rec),
                    pending: Some(pending),
                    full_rate: Default::default(),
                    early: Default::default(),
                }
            }
            RerunSink::Connect(url) => {
                let rec = match url {
                    Some(url) => builder.connect_grpc_opts(url.clone()),
                    None => builder.connect_grpc(),
                }
                .map_err(publish_err)?;
                Publisher {
                    rec: PacedStream::new(rec),
                    pending: None,
                    full_rate: Default::default(),
                    early: Default::default(),
                }
            }
            RerunSink::Spawn => Publisher {
                rec: PacedStream::new(builder.spawn().map_err(publish_err)?),
                pending: None,
                full_rate: Default::default(),
                early: Default::default(),
            },
        })
    }

    /// A sink that publishes every raw sample at full rate under `full_rate/<topic>`.
    pub fn full_rate(&self) -> FullRatePublisher {
        self.full_rate.store(true, Ordering::Relaxed);
        FullRatePublisher {
            rec: self.rec.clone(),
            channels: Vec::new(),
            failed: None,
        }
    }

    /// Logs the replay's traces (those no stage sent already), its figures from `report`
    /// and `summary_text`, sends the blueprint, and completes the output (an .rrd is
    /// renamed into place only now).
    pub fn finish(self, replayed: &Replayed) -> Result<()> {
        let (replay, report, summary_text) = (
            &replayed.replay,
            &replayed.report,
            replayed.summary.as_str(),
        );
        let early = self.early.into_inner().unwrap_or_else(|e| e.into_inner());
        if let Some(e) = early.failed {
            return Err(e);
        }
        if !early.measured {
            traces::log_measured(&self.rec, replay.into())?;
        }
        if !early.model {
            log_model(&self.rec, replay.into(), &replay.analysis)?;
        }
        log_rest(&self.rec, replay, report, summary_text)?;
        blueprint(replay, self.full_rate.load(Ordering::Relaxed))
            .send(&self.rec)
            .map_err(publish_err)?;
        if let Some(pending) = &self.pending {
            pending.remove_destination();
        }
        self.rec.flush_blocking().map_err(publish_err)?;
        // The file is written but for its footer, which the drop below adds.
        if let Some(pending) = &self.pending {
            pending.start_writeback();
        }
        drop(self.rec);
        match self.pending {
            Some(pending) => Ok(pending.commit()?),
            None => Ok(()),
        }
    }

    /// Notes a part sent early, or its failure (the first is reported by `finish`).
    fn sent(&self, result: Result<()>, part: impl FnOnce(&mut Early) -> &mut bool) {
        let mut early = self.early.lock().unwrap_or_else(|e| e.into_inner());
        match result {
            Ok(()) => *part(&mut early) = true,
            Err(e) => {
                early.failed.get_or_insert(e);
            }
        }
    }
}

/// Sends a replay's traces to `sink`, with the figures of its report and summary. For an
/// .rrd the file is written under a temporary name and renamed when complete.
pub fn publish(replayed: &Replayed, sink: &RerunSink) -> Result<()> {
    let name = replayed
        .replay
        .path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    Publisher::open(sink, &name)?.finish(replayed)
}

/// Samples buffered per channel before they go out as one column chunk.
const FULL_RATE_BATCH: usize = 1 << 16;

/// Publishes raw samples at full rate as they stream by, in column batches, so that
/// memory stays bounded whatever the recording's length.
pub struct FullRatePublisher {
    rec: PacedStream,
    /// Per channel: entity path, times, values.
    channels: Vec<(String, Vec<i64>, Vec<f64>)>,
    failed: Option<String>,
}

impl FullRatePublisher {
    fn flush_channel(&mut self, i: usize) {
        let (entity, times, values) = &mut self.channels[i];
        if times.is_empty() {
            return;
        }
        let t = std::mem::take(times);
        let v = std::mem::take(values);
        let rows = t.len();
        let result = Scalars::new(v)
            .columns_of_unit_batches()
            .map_err(publish_err)
            .and_then(|cols| {
                self.rec
                    .send_columns(
                        entity.as_str(),
                        [TimeColumn::new_timestamp_nanos_since_epoch(TIMELINE, t)],
                        cols,
                    )
                    .map_err(publish_err)
            })
            // Paced, so that rerun's queue holds a bounded backlog, not a week of batches.
            .and_then(|()| self.rec.sent(rows));
        if let Err(e) = result {
            self.failed.get_or_insert(e.to_string());
        }
    }

    /// Sends what is buffered; reports the first failure, if any.
    pub fn flush(&mut self) -> Result<()> {
        for i in 0..self.channels.len() {
            self.flush_channel(i);
        }
        match self.failed.take() {
            Some(e) => Err(PublishError::Rerun(e)),
            None => Ok(()),
        }
    }
}

impl heatrun::recording::SampleSink for FullRatePublisher {
    fn channel(&mut self, channel: &heatrun::recording::SensorChannel) {
        while self.channels.len() <= channel.index {
            self.channels.push((String::new(), Vec::new(), Vec::new()));
        }
        let entity = format!("full_rate/{}", channel.topic.trim_start_matches('/'));
        let _ = self.rec.log_static(
            entity.as_str(),
            &SeriesLines::new().with_names([format!(
                "{} [{}]",
                channel.signal,
                channel.canonical_unit()
            )]),
        );
        self.channels[channel.index].0 = entity;
    }

    fn sample(&mut self, sample: heatrun::recording::Sample) {
        let ch = &mut self.channels[sample.channel];
        ch.1.push(sample.log_time_ns as i64);
        ch.2.push(sample.value);
        if ch.1.len() >= FULL_RATE_BATCH {
            self.flush_channel(sample.channel);
        }
    }

    /// The full-rate view shows the channels as recorded, faults included: nothing to undo.
    fn retract(&mut self, _sample: heatrun::recording::Sample) {}
}

/// Name of the timeline of the correlation plots (lag in samples).
pub const LAG_TIMELINE: &str = "lag";

/// What the model and its analysis determine: the model temperatures and residuals, the
/// sensitivity responses and the residuals' correlations.
///
/// Where the spec declares hidden states the replay's model is the hidden one, known only
/// when the replay ends ([`log_rest`] draws it): the measured-state model's temperatures
/// are then drawn beside it, labelled, and its sensitivities not at all (the report's
/// time constants are the hidden model's); its residual correlations, which the report's
/// `residuals` hold, stay under a tab that names them.
fn log_model(
    rec: &PacedStream,
    stages: traces::Stages<'_>,
    analysis: &ModelAnalysis,
) -> Result<()> {
    traces::log_model_temperatures(rec, stages, analysis)?;
    if stages.model.hidden.is_none() {
        analysis::log_sensitivities(rec, stages, analysis)?;
    }
    analysis::log_residual_correlation(rec, stages.signals, analysis)
}

/// What only the whole replay determines: the hidden-state model's outputs, residuals
/// and sensitivities where it is the replay's model, the calorimetric balance, the
/// recursive estimate, the network, the figures and the summary.
fn log_rest(rec: &PacedStream, replay: &Replay, report: &Report, summary_text: &str) -> Result<()> {
    traces::log_hidden_temperatures(rec, replay)?;
    analysis::log_hidden_sensitivities(rec, replay)?;
    traces::log_calorimetry(rec, replay)?;
    analysis::log_trajectory(rec, replay)?;
    network::log_network(rec, replay)?;
    let figures = text::model_figures(report);
    rec.log_static(
        "model",
        &crate::sdk::TextDocument::new(figures).with_media_type(crate::sdk::MediaType::markdown()),
    )
    .map_err(publish_err)?;
    rec.log_static("summary", &text::preformatted(summary_text))
        .map_err(publish_err)?;
    if !report.decisions.is_empty() {
        rec.log_static("decisions", &text::preformatted(&text::decisions(report)))
            .map_err(publish_err)?;
    }
    Ok(())
}
