//! The grid's sample time: the one asked (`--ts`), or, by default, the temperatures' own
//! where they are recorded slower than the default grid. A historian export of 10 s rows
//! laid on a 1 s grid repeats each stored value (rounded to 0.1 K) for ten instants and
//! draws straight lines between them: the frozen screen reads the repeats as a sensor
//! that stopped, and the estimator fits nine interpolated instants in ten. On the
//! temperatures' own interval every instant is a reading.

use std::path::Path;

use crate::options::ReplayOptions;
use crate::recording::{self, IndexedChannel};
use crate::store::Location;

use super::{Candidate, Decision, Figure};

/// A temperature recorded at least this many times slower than the asked grid moves the
/// grid to its interval (a 1 s grid keeps temperatures read every 1.2 s).
pub const SLOWER_BY: f64 = 1.5;

/// The sample time to replay at, and the decision where the replay chose it
/// ([`ReplayOptions::choose_ts`]): the median interval of the states' sampled channels
/// (span / (messages − 1), from the recording's summary section, read without its data),
/// as a whole multiple of the asked Ts where it is [`SLOWER_BY`] times the asked Ts or
/// more; the asked Ts otherwise, or where the summary does not tell.
pub fn decide(path: &Path, options: &ReplayOptions) -> (f64, Option<Decision>) {
    let asked = options.ts_s;
    if !options.choose_ts {
        return (asked, None);
    }
    let index = Location::from_path(path)
        .ok()
        .and_then(|l| recording::read_index(&l).ok());
    let interval = index.as_ref().and_then(|index| {
        let span = index.time_span_ns?;
        states_interval_s(&index.channels, options, span)
    });
    let asked_name = format!("{asked} s (the default grid)");
    let Some(interval) = interval else {
        return (
            asked,
            Some(Decision {
                what: "sample time".into(),
                candidates: vec![Candidate::new(&asked_name, vec![])],
                chosen: asked_name,
                reason: "the recording's summary does not say how often the temperatures \
                         were recorded"
                    .into(),
            }),
        );
    };
    let own = (interval / asked).round().max(1.0) * asked;
    let figures = vec![Figure::new("temperatures recorded every", interval, "s")];
    let slower = interval >= SLOWER_BY * asked;
    let own_name = format!("{own} s (the temperatures' own interval)");
    let candidates = vec![
        Candidate::new(&asked_name, vec![]),
        Candidate::new(&own_name, figures),
    ];
    let (ts, chosen, reason) = if slower {
        (
            own,
            own_name,
            format!(
                "the temperatures are recorded every {interval:.3} s, {:.1} times the default \
                 grid: on the finer grid most instants would be interpolated and repeated \
                 values read as frozen (--ts overrides)",
                interval / asked
            ),
        )
    } else {
        (
            asked,
            asked_name,
            format!("the temperatures are recorded every {interval:.3} s, no slower than the grid"),
        )
    };
    (
        ts,
        Some(Decision {
            what: "sample time".into(),
            candidates,
            chosen,
            reason,
        }),
    )
}

/// The median interval, s, of the channels of the model's states that are sampled (not
/// stored by exception), from their message counts over the recording's span.
fn states_interval_s(
    channels: &[IndexedChannel],
    options: &ReplayOptions,
    (first_ns, last_ns): (u64, u64),
) -> Option<f64> {
    let span_s = last_ns.saturating_sub(first_ns) as f64 * 1e-9;
    let mut intervals: Vec<f64> = channels
        .iter()
        .filter(|c| {
            c.metadata
                .get("storage")
                .is_none_or(|s| s.trim() != "exception")
        })
        .filter(|c| {
            let quantity = c.metadata.get("quantity").map(String::as_str);
            let topic_last = c.topic.rsplit('/').next();
            options.model.states.iter().any(|s| {
                let name = s.channel.name();
                quantity == Some(name) || (quantity.is_none() && topic_last == Some(name))
            })
        })
        .filter_map(|c| {
            let n = c.messages?;
            (n >= 2 && span_s > 0.0).then(|| span_s / (n - 1) as f64)
        })
        .collect();
    if intervals.is_empty() {
        return None;
    }
    intervals.sort_by(f64::total_cmp);
    Some(intervals[intervals.len() / 2])
}
