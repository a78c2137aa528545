//! A channel recorded in another unit than its metadata says: a historian tag in °F or K
//! declared °C, a current in A declared kA (or a voltage in V declared kV, and the other
//! way round). The profile accepts the declared unit and the values stay inside their
//! physical ranges, or are dropped as outside them one by one; only physics tells.
//!
//! - **K for °C**: a temperature whose first reading is above [`NO_START_ABOVE_C`] °C, no
//!   heat run's start, while in kelvin it is one (−40 to 150 °C).
//! - **°F for °C**: at a cold start (every other temperature within [`COLD_START_SPREAD_K`]
//!   of the others), a channel that starts more than [`FAR_K`] from them while its value
//!   read as °F, (x − 32)/1.8, lies among them.
//! - **A for kA, V for kV** (and the reverse): the channel's level (the 95th percentile of
//!   its magnitude, or, where it lost at least as many samples as it kept as outside the
//!   physical range, the first of those; a lone fault code is no unit) is more than
//!   [`ORDERS_APART`] times, or for a voltage or field current less than 1/[`ORDERS_APART`]
//!   of, the nameplate's rated value, and a factor of 1000 brings it within 3 × of it.
//!
//! Each refuses the replay (exit status 2): a unit error bends every figure after it, and
//! its correction (which factor, which offset) is the recording's to make, not a guess.

use super::{Action, Check, Finding, PlausibilityError};
use crate::decimate::DecimatedRecording;
use crate::recording::{format_time, Nameplate, Quantity, RecordingSummary, Signal};

/// No heat run starts with a part above this temperature, °C.
pub const NO_START_ABOVE_C: f64 = 200.0;
/// The other temperatures of a cold start lie within this many kelvin of each other.
pub const COLD_START_SPREAD_K: f64 = 3.0;
/// A channel this far from the others at a cold start is out of place, K.
pub const FAR_K: f64 = 15.0;
/// Read as °F, it lies within this many kelvin of the others (or their spread, if wider).
pub const FITS_K: f64 = 1.5;
/// An electrical level this many times the rated value (or less than its inverse) is
/// orders of magnitude off.
pub const ORDERS_APART: f64 = 30.0;

/// The median of a channel's first five known values on the grid, and its instant.
fn start(decimated: &DecimatedRecording, signal: &Signal) -> Option<(usize, f64)> {
    let s = decimated.series.get(signal)?;
    let first = (0..decimated.len).find(|&k| s.values.get(k).is_some())?;
    let mut v: Vec<f64> = (first..decimated.len)
        .filter_map(|k| s.values.get(k))
        .take(5)
        .collect();
    v.sort_by(f64::total_cmp);
    Some((first, v[v.len() / 2]))
}

/// The channels of the summary that carry `signal`, by topic.
fn topics(summary: &RecordingSummary, signal: &Signal) -> String {
    let t: Vec<&str> = summary
        .channels
        .iter()
        .filter(|c| &c.signal == signal)
        .map(|c| c.topic.as_str())
        .collect();
    if t.is_empty() {
        signal.name().to_owned()
    } else {
        format!("{} ({})", t.join(", "), signal.name())
    }
}

fn refuse(
    check: Check,
    channel: &str,
    time: Option<String>,
    cause: &str,
    message: String,
) -> PlausibilityError {
    PlausibilityError(Box::new(Finding {
        check,
        channels: vec![channel.to_owned()],
        time,
        cause: cause.to_owned(),
        action: Action::Refused,
        message,
    }))
}

/// The temperature channels' units: refuses a channel whose values are kelvin or
/// degrees Fahrenheit by the evidence above. Nothing is found on data in °C.
pub fn temperatures(
    summary: &RecordingSummary,
    decimated: &DecimatedRecording,
) -> Result<Vec<Finding>, PlausibilityError> {
    let temperatures: Vec<Signal> = Quantity::ALL
        .into_iter()
        .filter(|q| q.is_temperature())
        .map(Signal::Profile)
        .filter(|s| summary.channels.iter().any(|c| &c.signal == s))
        .collect();
    // Kelvin: a start no heat run has, or every sample dropped above the physical range.
    for signal in &temperatures {
        let first = start(decimated, signal)
            .map(|(k, v)| (format_time(decimated.time_ns(k).max(0) as u64), v))
            .or_else(|| {
                summary
                    .channels
                    .iter()
                    .filter(|c| &c.signal == signal)
                    .filter_map(|c| summary.first_implausible.get(c.index).copied().flatten())
                    .min_by_key(|(t, _)| *t)
                    .map(|(t, v)| (format_time(t), v))
            });
        let Some((time, x)) = first else { continue };
        let as_c = x - 273.15;
        if x > NO_START_ABOVE_C && (-40.0..=150.0).contains(&as_c) {
            let name = topics(summary, signal);
            return Err(refuse(
                Check::TemperatureUnit,
                signal.name(),
                Some(time.clone()),
                "recorded in K, declared °C",
                format!(
                    "{name}: its first reading {x:.1} at {time} is no heat run's start in °C \
                     but {as_c:.1} °C in kelvin: the channel is likely recorded in K while its \
                     unit says degC; convert it to °C (°C = K − 273.15) in the historian, the \
                     table or the recording (the profile takes temperatures in degC only); \
                     the replay is refused"
                ),
            ));
        }
    }
    // Fahrenheit, at a cold start.
    let starts: Vec<(&Signal, usize, f64)> = temperatures
        .iter()
        .filter_map(|s| start(decimated, s).map(|(k, v)| (s, k, v)))
        .collect();
    for (i, &(signal, k, x)) in starts.iter().enumerate() {
        let mut others: Vec<f64> = starts
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != i)
            .map(|(_, s)| s.2)
            .collect();
        if others.len() < 2 {
            continue;
        }
        others.sort_by(f64::total_cmp);
        let spread = others[others.len() - 1] - others[0];
        if spread > COLD_START_SPREAD_K {
            continue;
        }
        let reference = others[others.len() / 2];
        let as_c = (x - 32.0) / 1.8;
        if (x - reference).abs() > FAR_K && (as_c - reference).abs() < FITS_K.max(spread) {
            let time = format_time(decimated.time_ns(k).max(0) as u64);
            let name = topics(summary, signal);
            return Err(refuse(
                Check::TemperatureUnit,
                signal.name(),
                Some(time.clone()),
                "recorded in °F, declared °C",
                format!(
                    "{name}: it starts at {x:.1} at {time} where every other temperature \
                     starts at {reference:.1} °C, and read as °F it is {as_c:.1} °C: the \
                     channel is likely recorded in °F while its unit says degC; convert it to \
                     °C (°C = (°F − 32)/1.8) in the historian, the table or the recording (the \
                     profile takes temperatures in degC only); the replay is refused"
                ),
            ));
        }
    }
    Ok(Vec::new())
}

/// The electrical channels' levels against the nameplate: refuses a current or voltage
/// orders of magnitude from its rated value that a factor of 1000 explains.
pub fn electrical(
    summary: &RecordingSummary,
    decimated: &DecimatedRecording,
    nameplate: &Nameplate,
) -> Result<Vec<Finding>, PlausibilityError> {
    let rated = [
        (
            Quantity::ArmatureCurrent,
            Some(nameplate.rated_current_a),
            "rated_current_a",
            false,
        ),
        (
            Quantity::LineVoltage,
            Some(nameplate.rated_voltage_v),
            "rated_voltage_kv",
            true,
        ),
        (
            Quantity::FieldCurrent,
            nameplate.rated_field_current_a,
            "rated_field_current_a",
            true,
        ),
    ];
    for (quantity, rated, key, low_is_wrong) in rated {
        let Some(rated) = rated.filter(|r| *r > 0.0) else {
            continue;
        };
        for channel in summary
            .channels
            .iter()
            .filter(|c| c.quantity() == Some(quantity))
        {
            // The level of the samples kept (the 95th percentile of their magnitude); and
            // where the channel lost at least as many samples as it kept to the physical
            // range, the first of those: a current of 10⁶ A is a unit's factor, not a
            // fault, when most samples are. A single fault code among good samples is
            // neither.
            let kept = decimated.get(quantity).and_then(|s| {
                let mut v: Vec<f64> = s.values.iter().flatten().map(f64::abs).collect();
                if v.is_empty() {
                    return None;
                }
                let i = ((v.len() - 1) as f64 * 0.95) as usize;
                let (_, p95, _) = v.select_nth_unstable_by(i, f64::total_cmp);
                Some((None, *p95))
            });
            let lost = summary.implausible_per_channel.get(channel.index).copied();
            let kept_samples = summary.samples_per_channel.get(channel.index).copied();
            let dropped = summary
                .first_implausible
                .get(channel.index)
                .copied()
                .flatten()
                .filter(|_| lost.unwrap_or(0) >= kept_samples.unwrap_or(0).max(1))
                .map(|(t, v)| (Some(t), v.abs()));
            let judged = [kept, dropped]
                .into_iter()
                .flatten()
                .find_map(|(time, level)| {
                    let ratio = level / rated;
                    let within = |r: f64| r > 1.0 / 3.0 && r < 3.0;
                    if ratio > ORDERS_APART && within(ratio / 1e3) {
                        Some((time, level, ratio, smaller_unit(&channel.unit)))
                    } else if low_is_wrong && ratio < 1.0 / ORDERS_APART && within(ratio * 1e3) {
                        Some((time, level, ratio, larger_unit(&channel.unit)))
                    } else {
                        None
                    }
                });
            let Some((time, level, ratio, likely)) = judged else {
                continue;
            };
            let canonical = quantity.canonical_unit();
            let when = time
                .map(|t| {
                    format!(
                        " (a sample at {} dropped as outside the physical range)",
                        format_time(t)
                    )
                })
                .unwrap_or_default();
            let likely = likely.unwrap_or("another unit");
            let name = format!("{} ({quantity})", channel.topic);
            return Err(refuse(
                Check::ElectricalUnit,
                quantity.name(),
                time.map(format_time),
                &format!("recorded in {likely}, declared {}", channel.unit),
                format!(
                    "{name}: its level {level:.4e} {canonical}{when} is {ratio:.3e} × the \
                     nameplate's {key} ({rated:.4e} {canonical}), which no machine runs at: the \
                     channel is likely recorded in {likely} while its unit says {}; fix `unit` \
                     of this channel in the import map or the recording's channel metadata; \
                     the replay is refused",
                    channel.unit
                ),
            ));
        }
    }
    Ok(Vec::new())
}

/// The unit a thousand times smaller than `unit` (kA → A).
fn smaller_unit(unit: &str) -> Option<&'static str> {
    match unit {
        "kA" => Some("A"),
        "kV" => Some("V"),
        "A" => Some("mA"),
        "V" => Some("mV"),
        _ => None,
    }
}

/// The unit a thousand times larger than `unit` (A → kA).
fn larger_unit(unit: &str) -> Option<&'static str> {
    match unit {
        "A" => Some("kA"),
        "V" => Some("kV"),
        _ => None,
    }
}
