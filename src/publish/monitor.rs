//! `heatrun monitor` in rerun: per part the measured temperature (wide, light) under the
//! model's prediction (thin, full colour), and beside it the residual θ − θ̂ between its
//! band ±b (grey), with the stretches that raised an alarm drawn over it in red; the
//! alarm lines and the summary as text.

use rerun::RecordingStream;

use super::layout::{Layout, Node, View, ViewKind};
use super::traces::{on_grid, send_series};
use super::{publish_err, style, Publisher, RerunSink};
use crate::error::Result;
use crate::monitor::MonitorResult;

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

/// Sends a monitoring result to `sink` (an .rrd is complete when this returns, or absent).
pub fn publish(result: &MonitorResult, sink: &RerunSink) -> Result<()> {
    let name = result
        .recording
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let publisher = Publisher::open(sink, &name)?;
    log_result(&publisher.rec, result)?;
    layout(result).send(&publisher.rec).map_err(publish_err)?;
    publisher.rec.flush_blocking().map_err(publish_err)?;
    let Publisher { rec, pending, .. } = publisher;
    drop(rec);
    match pending {
        Some(pending) => pending.commit(),
        None => Ok(()),
    }
}

fn log_result(rec: &RecordingStream, result: &MonitorResult) -> Result<()> {
    let t = &result.traces;
    for (j, state) in result.states.iter().enumerate() {
        let colour = style::part(j);
        let temp = temperature_entity(state);
        let measured = format!("{temp}/measured");
        style::series(
            rec,
            &measured,
            "measured, °C",
            style::lightened(colour, 0.55),
            style::MEASURED_WIDTH,
        )?;
        send_series(rec, &measured, on_grid(&t.time_ns, t.measured[j].iter()))?;
        let predicted = format!("{temp}/predicted");
        style::series(rec, &predicted, "model, °C", colour, style::LINE_WIDTH)?;
        send_series(rec, &predicted, on_grid(&t.time_ns, t.predicted[j].iter()))?;
        let res = residual_entity(state);
        let residual = format!("{res}/residual");
        style::series(rec, &residual, "θ − θ̂, K", colour, style::LINE_WIDTH)?;
        let r = |k: usize| t.residual(j, k);
        send_series(
            rec,
            &residual,
            on_grid(&t.time_ns, (0..t.time_ns.len()).map(r)),
        )?;
        let b = result.band.half_width_k[j];
        for (side, sign) in [("band_upper", 1.0), ("band_lower", -1.0)] {
            let entity = format!("{res}/{side}");
            let label = format!("band ±{b:.2} K");
            style::series(rec, &entity, &label, style::REFERENCE, style::LINE_WIDTH)?;
            let ends = [t.time_ns.first(), t.time_ns.last()];
            send_series(
                rec,
                &entity,
                ends.into_iter().flatten().map(|&t| (t, sign * b)),
            )?;
        }
        let alarm = format!("{res}/alarm");
        style::series(rec, &alarm, "alarm", ALARM, style::MEASURED_WIDTH)?;
        let in_alarm = |k: usize| {
            let now = t.time_ns[k];
            result
                .alarms
                .iter()
                .filter(|a| a.state == j)
                .any(|a| now >= a.start_ns && a.end_ns.is_none_or(|e| now < e))
        };
        let points = (0..t.time_ns.len()).map(|k| r(k).filter(|_| in_alarm(k)));
        send_series(rec, &alarm, on_grid(&t.time_ns, points))?;
    }
    rec.log_static(
        "monitor/summary",
        &super::text::preformatted(&result.summary()),
    )
    .map_err(publish_err)?;
    Ok(())
}

/// One row per part: its temperatures beside its residual; the summary below.
fn layout(result: &MonitorResult) -> Layout {
    let mut rows: Vec<Node> = result
        .states
        .iter()
        .zip(&result.parts)
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
