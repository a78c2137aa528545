//! The warnings a replay gives its user, built by one pure function from what the stages
//! returned: data lost to damage, gaps, implausible or dropped samples, channels that stop
//! early, time constants that two states claimed, and a steady state that lies beyond
//! what the recording shows (judged against the replay's model's slowest time constant:
//! the hidden-state model's where the spec declares one, as the pipeline assesses it).

use crate::decimate::DecimatedRecording;
use crate::model::ModelAnalysis;
use crate::network::NetworkAnalysis;
use crate::recording::{format_time, RecordingSummary};
use crate::screen::{LeftOut, Why};
use crate::signals::{Bridge, ModelSignals, INPUT_GAP_BRIDGED_S};
use crate::spec::{coolant, InputSource, ModelDescription};

/// What the stages before the estimator found, as the warnings read it (the pipeline's
/// prepared recording, borrowed piece by piece: this module knows no pipeline).
#[derive(Debug, Clone, Copy)]
pub struct Prepared<'a> {
    /// The model description the signals follow.
    pub model: &'a ModelDescription,
    /// What the recording stage found.
    pub recording: &'a RecordingSummary,
    /// The decimated quantities.
    pub decimated: &'a DecimatedRecording,
    /// The model's states and inputs (their gaps: bridged, cut or unobserved).
    pub signals: &'a ModelSignals,
}

/// A channel that stops this long before the recording ends gets a warning, s.
const EARLY_STOP_S: f64 = 600.0;

/// Every warning for a prepared recording and its model's analysis, in a stable order.
pub fn collect(
    prepared: &Prepared<'_>,
    analysis: &ModelAnalysis,
    network: &NetworkAnalysis,
) -> Vec<String> {
    let mut out = Vec::new();
    data_loss(prepared, &mut out);
    gaps(prepared, &mut out);
    implausible(prepared, &mut out);
    dropouts(prepared, &mut out);
    early_stops(prepared, &mut out);
    out.extend(flow_change(prepared));
    if prepared.recording.bad_quality_dropped > 0 {
        out.push(format!(
            "{} samples marked `bad` were dropped",
            prepared.recording.bad_quality_dropped
        ));
    }
    out.extend(network.equilibrium.warning());
    // With `[hidden]` the report's time constants are the hidden-state model's (ranked on
    // the measured outputs, no one-to-one rule): a conflict is the measured-state model's.
    let whose = match prepared.model.hidden {
        Some(_) => "the measured-state model's time constant",
        None => "the time constant",
    };
    for a in &analysis.assignment {
        if a.resolved_conflict {
            out.push(format!(
                "{whose} {:.1} s was claimed by two states; it was assigned one-to-one",
                a.time_constant_s
            ));
        }
    }
    out
}

fn data_loss(p: &Prepared<'_>, out: &mut Vec<String>) {
    out.extend(
        p.recording
            .data_loss
            .iter()
            .map(|l| format!("data lost: {l}")),
    );
}

/// Each channel's gaps, then what the model made of them: a state's missing instants are
/// unobserved (the model is simulated through them), an input's short gaps bridged, its
/// long ones cuts of the data.
fn gaps(p: &Prepared<'_>, out: &mut Vec<String>) {
    for ch in p.decimated.channels.iter().filter(|c| c.gaps > 0) {
        out.push(format!(
            "channel {} has {} gap(s) ({} instants without data)",
            ch.topic, ch.gaps, ch.gap_instants
        ));
    }
    let s = p.signals;
    for (j, state) in s.states.iter().enumerate() {
        let missing = (s.initial_index..s.len())
            .filter(|&k| state.observed.is_none() && s.rise_pu(j, k).is_none())
            .count();
        if missing > 0 {
            out.push(format!(
                "state {}: {missing} instant(s) without a value are unobserved; the model is simulated through them",
                state.name
            ));
        }
    }
    for input in &s.inputs {
        let g = &input.gaps;
        if g.bridged > 0 {
            let how = match g.bridge {
                Bridge::Hold => "its last value held",
                Bridge::Interpolate => "interpolated",
            };
            out.push(format!(
                "input {}: {} gap(s) of at most {INPUT_GAP_BRIDGED_S} s bridged ({how}; the longest {} s)",
                input.name, g.bridged, g.longest_bridged_s
            ));
        }
        if g.cut > 0 {
            out.push(format!(
                "input {}: {} gap(s) longer than {INPUT_GAP_BRIDGED_S} s ({} instants) cut the data; each following segment's initial state is estimated",
                input.name, g.cut, g.cut_instants
            ));
        }
    }
}

fn implausible(p: &Prepared<'_>, out: &mut Vec<String>) {
    let summary = &p.recording;
    for (i, ch) in summary.channels.iter().enumerate() {
        if let Some((t, v)) = summary.first_implausible[i] {
            out.push(format!(
                "channel {}: {} sample(s) outside the physical range of {} were dropped, the first {} {} at {}",
                ch.topic,
                summary.implausible_per_channel[i],
                ch.signal,
                v,
                ch.signal.quantity().map_or("", |q| q.canonical_unit()),
                format_time(t)
            ));
        }
    }
}

/// Samples written as `null` or NaN: a sensor's dropouts, left out like `bad` ones.
fn dropouts(p: &Prepared<'_>, out: &mut Vec<String>) {
    let summary = &p.recording;
    for (i, ch) in summary.channels.iter().enumerate() {
        let count = summary.dropouts_per_channel.get(i).copied().unwrap_or(0);
        if let (true, Some(Some(t))) = (count > 0, summary.first_dropout.get(i)) {
            out.push(format!(
                "channel {}: {count} dropout(s) (value null or NaN) were left out, the first at {}",
                ch.topic,
                format_time(*t)
            ));
        }
    }
}

/// A channel that stops well before the others.
fn early_stops(p: &Prepared<'_>, out: &mut Vec<String>) {
    let Some((_, end)) = p.recording.time_span_ns else {
        return;
    };
    for series in p.decimated.series.values() {
        if let Some(last) = series.values.iter().rposition(|v| v.is_some()) {
            let stop_ns = p.decimated.time_ns(last);
            let early_s = (end as i64 - stop_ns) as f64 * 1e-9;
            if early_s > EARLY_STOP_S {
                out.push(format!(
                    "{} stops at {}, {:.0} s before the recording ends; the rest is not used",
                    series.signal,
                    format_time(stop_ns.max(0) as u64),
                    early_s
                ));
            }
        }
    }
}

/// A cooling-water flow that changed during the run (a pump switched): the coolant
/// conductance c·ρ·Q changed with it. Its 10-minute means are compared with the first
/// ([`coolant::flow_behaviour`]); a change beyond [`coolant::FLOW_VARIES`] of their
/// median is named with its time, and the note says whether the model carries the flow
/// (an [`InputSource::CoolantFlow`] input) or assumes it constant.
pub fn flow_change(p: &Prepared<'_>) -> Option<String> {
    let flow = coolant::flow_behaviour(p.decimated)?;
    let (k, changed) = flow.first_change?;
    let carried = p
        .model
        .inputs
        .iter()
        .find(|i| matches!(i.source, InputSource::CoolantFlow { .. }));
    let consequence = match carried {
        Some(input) => format!(
            "the model carries it as the input `{}` (the heat the change of flow carries \
             away), so its A_c, time constants and network are the machine's at the initial \
             flow",
            input.name
        ),
        None => "the model assumes a constant flow (the coolant conductance c·ρ·Q), so its \
                 estimate mixes the machine before and after the change (the flow enters the \
                 model only with the coolant inlet as reference and the outlet as a state)"
            .to_owned(),
    };
    Some(format!(
        "cooling_water_flow changes during the run (from {:.1} to {changed:.1} l/s by {}; \
         10-minute means from {:.1} to {:.1}): {consequence}",
        flow.initial_l_per_s,
        format_time(p.decimated.time_ns(k).max(0) as u64),
        flow.range_l_per_s.0,
        flow.range_l_per_s.1,
    ))
}

/// Stretches left out that are named one by one; more are counted in one line.
const LEFT_OUT_NAMED: usize = 20;

/// One warning per stretch the screen left out of the estimation (channel, from, to,
/// value, why), the first `LEFT_OUT_NAMED` of them by time, the rest counted.
pub fn left_out(stretches: &[LeftOut]) -> Vec<String> {
    let mut by_time: Vec<&LeftOut> = stretches.iter().collect();
    by_time.sort_by_key(|l| (l.from_ns, l.state));
    let mut out: Vec<String> = by_time
        .iter()
        .take(LEFT_OUT_NAMED)
        .map(|l| left_out_line(l))
        .collect();
    if by_time.len() > LEFT_OUT_NAMED {
        out.push(format!(
            "{} more stretch(es) were left out as glitches or frozen values (the report's `left_out` lists them all)",
            by_time.len() - LEFT_OUT_NAMED
        ));
    }
    out
}

fn left_out_line(l: &LeftOut) -> String {
    let at = |ns: i64| format_time(ns.max(0) as u64);
    // Six decimals: finer than any temperature sensor, without a binary fraction's tail.
    let value = (l.value * 1e6).round() / 1e6;
    let span = if l.from_ns == l.to_ns {
        format!("at {}", at(l.from_ns))
    } else {
        format!("from {} to {}", at(l.from_ns), at(l.to_ns))
    };
    match l.why {
        Why::Glitch => format!(
            "{}: {} sample(s) {span} left out of the estimation as a glitch: {} against the model's prediction, {:.2} K apart, far outside the measurement noise",
            l.channel,
            l.instants(),
            value,
            l.deviation_k
        ),
        Why::Frozen => format!(
            "{}: {} sample(s) {span} left out of the estimation as frozen: every one reads {} while the model predicts a change of {:.2} K (a sensor or link that stopped moving)",
            l.channel,
            l.instants(),
            value,
            l.deviation_k
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stretch(from_s: i64, samples: usize, why: Why) -> LeftOut {
        let ns = 1_559_541_600_000_000_000 + from_s * 1_000_000_000;
        LeftOut {
            state: 1,
            channel: "core_temp".into(),
            from_index: from_s as usize,
            to_index: from_s as usize + samples - 1,
            from_ns: ns,
            to_ns: ns + (samples as i64 - 1) * 1_000_000_000,
            value: 41.010000000000005,
            why,
            deviation_k: 15.0,
            predicted: vec![26.0; samples],
        }
    }

    #[test]
    fn each_stretch_left_out_is_named_by_time_and_the_rest_counted() {
        let lines = left_out(&[stretch(60, 1, Why::Glitch), stretch(0, 3600, Why::Frozen)]);
        assert_eq!(
            lines,
            [
                "core_temp: 3600 sample(s) from 2019-06-03T06:00:00Z to 2019-06-03T06:59:59Z left out of the estimation as frozen: every one reads 41.01 while the model predicts a change of 15.00 K (a sensor or link that stopped moving)",
                "core_temp: 1 sample(s) at 2019-06-03T06:01:00Z left out of the estimation as a glitch: 41.01 against the model's prediction, 15.00 K apart, far outside the measurement noise",
            ]
        );
        let many: Vec<LeftOut> = (0..25).map(|i| stretch(10 * i, 1, Why::Glitch)).collect();
        let lines = left_out(&many);
        assert_eq!(lines.len(), LEFT_OUT_NAMED + 1);
        assert!(lines[LEFT_OUT_NAMED].starts_with("5 more stretch(es)"));
    }
}
