//! Publishing stage: a [`Replay`] → a rerun recording (an .rrd file, a running
//! viewer, or one spawned for it), on the recording's own time line.
//!
//! Long series go out as columns with `send_columns`, one chunk per entity,
//! and a blueprint opens the viewer on the story: measured against model per
//! state, then residuals and heat sources, then the raw quantities and the
//! sensitivity responses behind the time-constant assignment.

use std::path::PathBuf;

use rerun::blueprint::{
    Blueprint, ContainerLike, Horizontal, Tabs, TextDocumentView, TimeSeriesView, Vertical,
};
use rerun::{RecordingStream, RecordingStreamBuilder, Scalars, SeriesLines, TimeColumn};

#[allow(unused_imports)]
use crate::recording::SampleSink as _;

use crate::atomic::PendingOutput;
use crate::error::{Error, Result};
use crate::model::sensitivity::SensitivityModel;
use crate::pipeline::Replay;

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

fn publish_err(e: impl std::fmt::Display) -> Error {
    Error::Publish(e.to_string())
}

/// Entity path of a state's temperature plot.
pub fn temperature_entity(state: &str) -> String {
    format!("temperature/{state}")
}

/// The viewer layout.
pub fn blueprint(replay: &Replay, full_rate: bool) -> Blueprint {
    let states = &replay.signals.states;
    let per_state: Vec<ContainerLike> = states
        .iter()
        .map(|s| {
            TimeSeriesView::new(format!("{} temperature, °C", s.part))
                .with_origin(temperature_entity(&s.name))
                .into()
        })
        .collect();
    let sensitivity_views: Vec<ContainerLike> = replay
        .analysis
        .spectrum
        .time_constants_s
        .iter()
        .enumerate()
        .map(|(i, t)| {
            TimeSeriesView::new(format!("T{} = {:.1} s: T ∂y/∂T, pu", i + 1, t))
                .with_origin(format!("sensitivity/T{}", i + 1))
                .into()
        })
        .collect();
    let correlation_views: Vec<ContainerLike> = states
        .iter()
        .map(|st| {
            TimeSeriesView::new(format!("{}: residual correlation (x: lag)", st.part))
                .with_origin(format!("residual_correlation/{}", st.name))
                .into()
        })
        .collect();
    let mut tabs: Vec<ContainerLike> = vec![
        Horizontal::new([
            TimeSeriesView::new("residual y − ŷ, K")
                .with_origin("residual")
                .into(),
            TimeSeriesView::new(input_title(replay))
                .with_origin("loss")
                .into(),
        ])
        .with_name("residuals and losses")
        .into(),
        TimeSeriesView::new("decimated quantities")
            .with_origin("decimated")
            .into(),
        Horizontal::new(sensitivity_views)
            .with_name("sensitivities")
            .into(),
        Horizontal::new(correlation_views)
            .with_name("residual correlation")
            .into(),
        TextDocumentView::new("summary")
            .with_origin("summary")
            .into(),
    ];
    if full_rate {
        tabs.insert(
            1,
            TimeSeriesView::new("full-rate channels")
                .with_origin("full_rate")
                .into(),
        );
    }
    if replay.estimate.trajectory.is_some() {
        tabs.insert(
            1,
            Horizontal::new([
                TimeSeriesView::new("RLS time constants, s")
                    .with_origin("rls/time_constant")
                    .into(),
                TimeSeriesView::new("RLS Φ").with_origin("rls/phi").into(),
                TimeSeriesView::new("RLS Γ").with_origin("rls/gamma").into(),
            ])
            .with_name("recursive estimate")
            .into(),
        );
    }
    let bottom = Tabs::new(tabs);
    Blueprint::new(Vertical::new([
        Horizontal::new(per_state).into(),
        bottom.into(),
    ]))
    .with_auto_views(false)
}

/// An open rerun recording: created before the replay (so full-rate samples can stream
/// into it), finished with the replay's traces and the blueprint.
pub struct Publisher {
    rec: RecordingStream,
    pending: Option<PendingOutput>,
    full_rate: std::cell::Cell<bool>,
}

impl Publisher {
    /// Opens the recording on `sink`; `name` is the recording's name in the viewer.
    pub fn open(sink: &RerunSink, name: &str) -> Result<Publisher> {
        let builder = RecordingStreamBuilder::new("heatrun").recording_name(name.to_owned());
        Ok(match sink {
            RerunSink::Rrd(path) => {
                let pending = PendingOutput::new(path);
                let rec = builder.save(pending.path()).map_err(publish_err)?;
                Publisher {
                    rec,
                    pending: Some(pending),
                    full_rate: Default::default(),
                }
            }
            RerunSink::Connect(url) => {
                let rec = match url {
                    Some(url) => builder.connect_grpc_opts(url.clone()),
                    None => builder.connect_grpc(),
                }
                .map_err(publish_err)?;
                Publisher {
                    rec,
                    pending: None,
                    full_rate: Default::default(),
                }
            }
            RerunSink::Spawn => Publisher {
                rec: builder.spawn().map_err(publish_err)?,
                pending: None,
                full_rate: Default::default(),
            },
        })
    }

    /// A sink that publishes every raw sample at full rate under `full_rate/<topic>`.
    pub fn full_rate(&self) -> FullRatePublisher {
        self.full_rate.set(true);
        FullRatePublisher {
            rec: self.rec.clone(),
            channels: Vec::new(),
            failed: None,
        }
    }

    /// Logs the replay's traces, sends the blueprint, and completes the output (an .rrd
    /// is renamed into place only now).
    pub fn finish(self, replay: &Replay, summary_text: &str) -> Result<()> {
        log_all(&self.rec, replay, summary_text)?;
        blueprint(replay, self.full_rate.get())
            .send(
                &self.rec,
                rerun::blueprint::BlueprintActivation {
                    make_active: true,
                    make_default: true,
                },
            )
            .map_err(publish_err)?;
        self.rec.flush_blocking().map_err(publish_err)?;
        drop(self.rec);
        match self.pending {
            Some(pending) => pending.commit(),
            None => Ok(()),
        }
    }
}

/// Sends a replay's traces to `sink`. For an .rrd the file is written under a
/// temporary name and renamed when complete.
pub fn publish(replay: &Replay, summary_text: &str, sink: &RerunSink) -> Result<()> {
    let name = replay
        .path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    Publisher::open(sink, &name)?.finish(replay, summary_text)
}

/// Samples buffered per channel before they go out as one column chunk.
const FULL_RATE_BATCH: usize = 1 << 16;

/// Publishes raw samples at full rate as they stream by, in column batches, so that
/// memory stays bounded whatever the recording's length.
pub struct FullRatePublisher {
    rec: RecordingStream,
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
            // Waited for, so that rerun's queue holds one batch, not a week of them.
            .and_then(|()| self.rec.flush_blocking().map_err(publish_err));
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
            Some(e) => Err(Error::Publish(e)),
            None => Ok(()),
        }
    }
}

impl crate::recording::SampleSink for FullRatePublisher {
    fn channel(&mut self, channel: &crate::recording::SensorChannel) {
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

    fn sample(&mut self, sample: crate::recording::Sample) {
        let ch = &mut self.channels[sample.channel];
        ch.1.push(sample.log_time_ns as i64);
        ch.2.push(sample.value);
        if ch.1.len() >= FULL_RATE_BATCH {
            self.flush_channel(sample.channel);
        }
    }

    /// The full-rate view shows the channels as recorded, faults included: nothing to undo.
    fn retract(&mut self, _sample: crate::recording::Sample) {}
}

/// Rows per column chunk of a decimated series.
const SERIES_SLICE: usize = 1 << 16;

/// Sends one series as columns, `(time ns, value)` pairs in time order, skipping
/// non-finite values. It goes out in slices of [`SERIES_SLICE`] rows, each waited for
/// before the next is built, so a week-long series never sits in memory twice.
fn send_series(
    rec: &RecordingStream,
    entity: &str,
    points: impl Iterator<Item = (i64, f64)>,
) -> Result<usize> {
    let mut points = points.filter(|(_, v)| v.is_finite()).peekable();
    let mut sent = 0;
    while points.peek().is_some() {
        let (times, values): (Vec<i64>, Vec<f64>) = points.by_ref().take(SERIES_SLICE).unzip();
        sent += times.len();
        rec.send_columns(
            entity,
            [TimeColumn::new_timestamp_nanos_since_epoch(TIMELINE, times)],
            Scalars::new(values)
                .columns_of_unit_batches()
                .map_err(publish_err)?,
        )
        .map_err(publish_err)?;
        rec.flush_blocking().map_err(publish_err)?;
    }
    Ok(sent)
}

/// Pairs a grid series with the grid's times, keeping the instants where it is known.
fn on_grid<'a>(
    time_ns: &'a [i64],
    values: impl Iterator<Item = Option<f64>> + 'a,
) -> impl Iterator<Item = (i64, f64)> + 'a {
    time_ns
        .iter()
        .zip(values)
        .filter_map(|(t, v)| v.map(|v| (*t, v)))
}

fn style(rec: &RecordingStream, entity: &str, name: &str, rgb: [u8; 3]) -> Result<()> {
    rec.log_static(
        entity,
        &SeriesLines::new().with_names([name]).with_colors([rgb]),
    )
    .map_err(publish_err)
}

const MEASURED: [u8; 3] = [31, 119, 180];
const MODEL: [u8; 3] = [255, 127, 14];
const PALETTE: [[u8; 3]; 4] = [[214, 39, 40], [44, 160, 44], [148, 103, 189], [140, 86, 75]];

/// Title of the inputs' plot: the generator's heat sources in kW, or a spec's inputs.
fn input_title(replay: &Replay) -> String {
    match replay.model.scaling {
        crate::spec::Scaling::NameplatePerUnit => "heat sources, kW".into(),
        crate::spec::Scaling::AsRecorded => {
            let units: Vec<&str> = replay
                .signals
                .inputs
                .iter()
                .map(|i| i.unit.as_str())
                .collect();
            format!("inputs, {}", units.join(", "))
        }
    }
}

/// Factor from an input in the model's scaling to the plotted unit (kW for pu of S_n).
fn input_plot_scale(replay: &Replay) -> f64 {
    match replay.model.scaling {
        crate::spec::Scaling::NameplatePerUnit => replay.signals.power_base / 1e3,
        crate::spec::Scaling::AsRecorded => replay.signals.power_base,
    }
}

fn log_all(rec: &RecordingStream, replay: &Replay, summary_text: &str) -> Result<()> {
    let s = &replay.signals;
    let t = &s.time_ns;
    let base = s.temperature_base_k;
    let sim = &replay.analysis.simulated;
    for (j, state) in s.states.iter().enumerate() {
        let root = temperature_entity(&state.name);
        style(rec, &format!("{root}/measured"), "measured", MEASURED)?;
        style(rec, &format!("{root}/model"), "model", MODEL)?;
        send_series(
            rec,
            &format!("{root}/measured"),
            on_grid(t, state.measured.iter()),
        )?;
        send_series(
            rec,
            &format!("{root}/model"),
            on_grid(
                t,
                (0..s.len()).map(|k| Some(state.reference_at(k)? + base * sim[(k, j)])),
            ),
        )?;
        let residual = format!("residual/{}", state.name);
        style(rec, &residual, &state.name, PALETTE[j % PALETTE.len()])?;
        send_series(
            rec,
            &residual,
            on_grid(
                t,
                (0..s.len()).map(|k| s.rise_pu(j, k).map(|y| base * (y - sim[(k, j)]))),
            ),
        )?;
    }
    let scale = input_plot_scale(replay);
    for (j, input) in s.inputs.iter().enumerate() {
        let entity = format!("loss/{}", input.name);
        style(rec, &entity, &input.name, PALETTE[j % PALETTE.len()])?;
        send_series(
            rec,
            &entity,
            on_grid(t, input.values.iter().map(|v| v.map(|v| v * scale))),
        )?;
    }
    for (i, series) in replay.decimated.series.values().enumerate() {
        let entity = format!("decimated/{}", series.signal.name());
        let name = format!("{} [{}]", series.signal.name(), series.unit);
        style(rec, &entity, &name, PALETTE[i % PALETTE.len()])?;
        send_series(rec, &entity, on_grid(t, series.values.iter()))?;
    }
    log_sensitivities(rec, replay)?;
    log_residual_correlation(rec, replay)?;
    log_trajectory(rec, replay)?;
    rec.log_static(
        "summary",
        &rerun::TextDocument::new(summary_text.to_owned()),
    )
    .map_err(publish_err)?;
    Ok(())
}

/// The sensitivity responses T_i ∂ŷ/∂T_i behind the assignment, regenerated from the
/// model over the instants it was estimated on, one state at a time.
fn log_sensitivities(rec: &RecordingStream, replay: &Replay) -> Result<()> {
    let analysis = &replay.analysis;
    let tcs = &analysis.spectrum.time_constants_s;
    let recursion = SensitivityModel::new(&analysis.continuous, tcs, replay.signals.ts_s)?;
    let end = replay.estimation_range.end;
    let segments: Vec<_> = replay
        .data
        .segments()
        .into_iter()
        .map(|s| s.start..s.end.min(end))
        .filter(|s| s.len() >= 2)
        .collect();
    let t = &replay.signals.time_ns;
    for i in 0..tcs.len() {
        for (k, state) in replay.signals.states.iter().enumerate() {
            let entity = format!("sensitivity/T{}/{}", i + 1, state.name);
            style(rec, &entity, &state.name, PALETTE[k % PALETTE.len()])?;
            let mut points = Vec::with_capacity(SERIES_SLICE);
            let mut failed = None;
            recursion.for_each_response(i, &replay.data, &segments, |instant, rel| {
                points.push((t[instant], rel[k]));
                if points.len() == SERIES_SLICE && failed.is_none() {
                    failed = send_series(rec, &entity, points.drain(..)).err();
                }
            });
            if let Some(e) = failed {
                return Err(e);
            }
            send_series(rec, &entity, points.into_iter())?;
        }
    }
    Ok(())
}

/// Name of the timeline of the correlation plots (lag in samples).
pub const LAG_TIMELINE: &str = "lag";

fn send_by_lag(
    rec: &RecordingStream,
    entity: &str,
    lags: Vec<i64>,
    values: Vec<f64>,
) -> Result<()> {
    rec.send_columns(
        entity,
        [TimeColumn::new_sequence(LAG_TIMELINE, lags)],
        Scalars::new(values)
            .columns_of_unit_batches()
            .map_err(publish_err)?,
    )
    .map_err(publish_err)
}

fn log_residual_correlation(rec: &RecordingStream, replay: &Replay) -> Result<()> {
    let res = &replay.analysis.residuals;
    let lag = res.max_lag as i64;
    for (i, state) in replay.signals.states.iter().enumerate() {
        let root = format!("residual_correlation/{}", state.name);
        style(
            rec,
            &format!("{root}/autocorrelation"),
            "autocorrelation",
            MEASURED,
        )?;
        send_by_lag(
            rec,
            &format!("{root}/autocorrelation"),
            (0..=lag).collect(),
            res.autocorrelation[i].clone(),
        )?;
        for (bound, sign) in [("band99_upper", 1.0), ("band99_lower", -1.0)] {
            style(
                rec,
                &format!("{root}/{bound}"),
                "99 % band",
                [128, 128, 128],
            )?;
            send_by_lag(
                rec,
                &format!("{root}/{bound}"),
                vec![-lag, lag],
                vec![sign * res.band99; 2],
            )?;
        }
        for (j, input) in replay.signals.inputs.iter().enumerate() {
            let entity = format!("{root}/cross_{}", input.name);
            style(
                rec,
                &entity,
                &format!("× {}", input.name),
                PALETTE[j % PALETTE.len()],
            )?;
            send_by_lag(
                rec,
                &entity,
                (-lag..=lag).collect(),
                res.cross_correlation[i][j].clone(),
            )?;
        }
    }
    Ok(())
}

fn log_trajectory(rec: &RecordingStream, replay: &Replay) -> Result<()> {
    let Some(traj) = &replay.estimate.trajectory else {
        return Ok(());
    };
    let model = &replay.estimate.model;
    let (n, m) = (model.phi.nrows(), model.gamma.ncols());
    let p = n + m;
    let t: Vec<i64> = traj
        .iter()
        .map(|pt| replay.signals.time_ns[pt.instant])
        .collect();
    for i in 0..n {
        for j in 0..p {
            let (entity, name) = if j < n {
                (
                    format!("rls/phi/{}{}", i + 1, j + 1),
                    format!("Φ({},{})", i + 1, j + 1),
                )
            } else {
                (
                    format!("rls/gamma/{}{}", i + 1, j - n + 1),
                    format!("Γ({},{})", i + 1, j - n + 1),
                )
            };
            style(rec, &entity, &name, PALETTE[(i * p + j) % PALETTE.len()])?;
            send_series(
                rec,
                &entity,
                on_grid(&t, traj.iter().map(|pt| Some(pt.theta[i * p + j]))),
            )?;
        }
    }
    // Time constants where the running estimate is a stable thermal system.
    let constants: Vec<Option<Vec<f64>>> = traj
        .iter()
        .map(|pt| {
            crate::model::Spectrum::of(&model.with_theta(&pt.theta))
                .ok()
                .map(|s| s.time_constants_s)
        })
        .collect();
    for i in 0..n {
        let entity = format!("rls/time_constant/T{}", i + 1);
        style(
            rec,
            &entity,
            &format!("T{}", i + 1),
            PALETTE[i % PALETTE.len()],
        )?;
        send_series(
            rec,
            &entity,
            on_grid(&t, constants.iter().map(|c| c.as_ref().map(|c| c[i]))),
        )?;
    }
    Ok(())
}
