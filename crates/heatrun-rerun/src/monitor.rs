//! `heatrun monitor` in rerun: per part the measured temperature (wide, light) under the
//! model's prediction (thin, full colour), and beside it the residual θ − θ̂ between its
//! band ±b (grey), with the stretches that raised an alarm drawn over it in red; the
//! alarm lines and the summary as text. Sent a stretch at a time as the monitor seals it
//! ([`LivePublisher`]), so a connected viewer follows the recording as it is read.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use crate::paced::PacedStream;

use super::layout::{Layout, Node, View, ViewKind};
use super::traces::on_grid;
use super::{publish_err, style, Publisher, RerunSink};
use crate::Result;
use heatrun::monitor::{Band, MonitorResult, ObserverError, Stretch, StretchObserver};

/// Near-black, for alarms (no part has it).
const ALARM: [u8; 3] = [25, 25, 25];

/// Entity of state `state`'s temperature plot.
pub fn temperature_entity(state: &str) -> String {
    format!("monitor/temperature/{state}")
}

/// Entity of state `state`'s residual plot.
pub fn residual_entity(state: &str) -> String {
    format!("monitor/residual/{state}")
}

/// The monitor's recording, published a stretch at a time as the recording is read (a
/// [`StretchObserver`]): per part the measured and predicted temperatures and the
/// residual of each sealed stretch, the band along them, the alarm's residuals once the
/// alarm is known; the blueprint first, so a connected viewer lays the plots out before
/// the first stretch; the summary when the recording has ended ([`LivePublisher::finish`]).
pub struct LivePublisher {
    publisher: Publisher,
    states: Vec<String>,
    /// Points not yet sent, per entity, and how many in all.
    pending: BTreeMap<String, (Vec<i64>, Vec<f64>)>,
    pending_points: usize,
    last_sent: Instant,
}

/// Points gathered before they go out as column chunks: stretches that come faster
/// than [`SEND_EVERY`] (a file read at speed) go out together, in fewer, larger chunks.
const SEND_BATCH_POINTS: usize = 1 << 16;

/// The longest a sealed stretch waits before it is sent (a recording read live).
const SEND_EVERY: Duration = Duration::from_millis(500);

impl LivePublisher {
    /// Opens the recording `name` on `sink` for a model's `states` (with their `parts`)
    /// and band, and sends the styles and the blueprint.
    pub fn open(
        sink: &RerunSink,
        name: &str,
        (states, parts): (&[String], &[String]),
        band: &Band,
    ) -> Result<LivePublisher> {
        let publisher = Publisher::open(sink, name)?;
        for (j, state) in states.iter().enumerate() {
            let label = match band.kind {
                heatrun::monitor::BandKind::Fixed => format!("band ±{:.2} K", band.half_width_k[j]),
                heatrun::monitor::BandKind::Model => {
                    "band (from the model, at each instant)".into()
                }
            };
            styles(&publisher.rec, j, state, &label)?;
        }
        layout(states, parts)
            .send(&publisher.rec)
            .map_err(publish_err)?;
        Ok(LivePublisher {
            publisher,
            states: states.to_vec(),
            pending: BTreeMap::new(),
            pending_points: 0,
            last_sent: Instant::now(),
        })
    }

    /// Logs the summary and completes the output (an .rrd is renamed into place only now).
    pub fn finish(mut self, result: &MonitorResult) -> Result<()> {
        self.send_pending()?;
        let rec = &self.publisher.rec;
        rec.log_static(
            "monitor/summary",
            &super::text::preformatted(&result.summary()),
        )
        .map_err(publish_err)?;
        rec.flush_blocking().map_err(publish_err)?;
        let Publisher { rec, pending, .. } = self.publisher;
        drop(rec);
        match pending {
            Some(pending) => Ok(pending.commit()?),
            None => Ok(()),
        }
    }
}

impl LivePublisher {
    /// Adds points to an entity's pending ones.
    fn queue(&mut self, entity: String, points: impl Iterator<Item = (i64, f64)>) {
        let (times, values) = self.pending.entry(entity).or_default();
        for (t, v) in points.filter(|(_, v)| v.is_finite()) {
            times.push(t);
            values.push(v);
            self.pending_points += 1;
        }
    }

    /// Sends every entity's pending points as columns, as the replay sends its series.
    fn send_pending(&mut self) -> Result<()> {
        let rec = &self.publisher.rec;
        for (entity, (times, values)) in std::mem::take(&mut self.pending) {
            super::traces::send_series(rec, &entity, times.into_iter().zip(values))?;
        }
        self.pending_points = 0;
        self.last_sent = Instant::now();
        Ok(())
    }
}

impl StretchObserver for LivePublisher {
    fn stretch(&mut self, s: &Stretch<'_>) -> std::result::Result<(), ObserverError> {
        let t = s.time_ns;
        let states = self.states.clone();
        for (j, state) in states.iter().enumerate() {
            let temp = temperature_entity(state);
            let res = residual_entity(state);
            let (measured, predicted) = (&s.measured[j], &s.predicted[j]);
            self.queue(format!("{temp}/measured"), on_grid(t, measured.iter()));
            self.queue(format!("{temp}/predicted"), on_grid(t, predicted.iter()));
            let residual = (0..t.len()).map(|k| Some(measured.get(k)? - predicted.get(k)?));
            self.queue(format!("{res}/residual"), on_grid(t, residual));
            // The band as the detector used it, instant by instant (the model band
            // varies; the fixed one is the same at every instant).
            let band = &s.band_k[j];
            for (side, sign) in [("band_upper", 1.0), ("band_lower", -1.0)] {
                let edge = (0..t.len()).map(|k| Some(sign * band.get(k)?));
                self.queue(format!("{res}/{side}"), on_grid(t, edge));
            }
            let alarm = s.alarm_points[j].iter().copied();
            self.queue(format!("{res}/alarm"), alarm);
        }
        // Not waited for: the SDK sends on its own within milliseconds, and the monitor
        // goes on reading meanwhile.
        if self.pending_points >= SEND_BATCH_POINTS || self.last_sent.elapsed() >= SEND_EVERY {
            self.send_pending()?;
        }
        Ok(())
    }
}

/// State j's series names, colours and widths.
fn styles(rec: &PacedStream, j: usize, state: &str, band_label: &str) -> Result<()> {
    let colour = style::part(j);
    let temp = temperature_entity(state);
    let res = residual_entity(state);
    let measured = (style::measured(j), style::MEASURED_WIDTH);
    style::series(
        rec,
        &format!("{temp}/measured"),
        "measured, °C",
        measured.0,
        measured.1,
    )?;
    let line = style::LINE_WIDTH;
    style::series(rec, &format!("{temp}/predicted"), "model, °C", colour, line)?;
    // In words: the viewer's font draws θ̂'s combining hat as nothing ("θ − θ").
    style::series(
        rec,
        &format!("{res}/residual"),
        "measured − model, K",
        colour,
        line,
    )?;
    for side in ["band_upper", "band_lower"] {
        style::series(
            rec,
            &format!("{res}/{side}"),
            band_label,
            style::REFERENCE,
            line,
        )?;
    }
    style::series(
        rec,
        &format!("{res}/alarm"),
        "alarm",
        ALARM,
        style::MEASURED_WIDTH,
    )
}

/// One row per part: its temperatures beside its residual; the summary below.
fn layout(states: &[String], parts: &[String]) -> Layout {
    let mut rows: Vec<Node> = states
        .iter()
        .zip(parts)
        .map(|(state, part)| {
            Node::horizontal(
                part.clone(),
                vec![
                    View::time_series(
                        format!("{part}: measured and model, °C"),
                        temperature_entity(state),
                    )
                    .into(),
                    View::time_series(
                        format!("{part}: residual and band, K"),
                        residual_entity(state),
                    )
                    .into(),
                ],
            )
        })
        .collect();
    rows.push(
        View::new(
            ViewKind::TextDocument,
            "alarms and summary",
            "monitor/summary",
        )
        .into(),
    );
    Layout {
        root: Node::vertical("heatrun monitor", rows),
    }
}
