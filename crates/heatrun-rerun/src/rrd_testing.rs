//! Tests' access to what an .rrd draws: a recording replayed, published to an .rrd and read
//! back with rerun's own decoder, apart from the publisher.

use std::collections::BTreeMap;
use std::io::BufReader;
use std::path::Path;

use crate::sdk::external::re_log_encoding::DecoderApp;
use crate::sdk::log::{Chunk, LogMsg};
use crate::sdk::StoreKind;
use heatrun::pipeline::{replay, ReplayOptions};
use heatrun::report::Replayed;

/// `mcap` replayed with `options` and published to an .rrd beside it; with each
/// time-series entity the .rrd holds ([`series`]).
pub(crate) fn replayed_and_drawn(
    mcap: &Path,
    options: &ReplayOptions,
) -> (Replayed, BTreeMap<String, Vec<(i64, f64)>>) {
    let replayed = Replayed::new(replay(mcap, options).unwrap());
    let rrd = mcap.with_extension("rrd");
    crate::publish(&replayed, &crate::RerunSink::Rrd(rrd.clone())).unwrap();
    let drawn = series(&rrd);
    (replayed, drawn)
}

/// The recording store's chunks (the blueprint's left out), in the order the file holds.
fn recording_chunks(path: &std::path::Path) -> Vec<Chunk> {
    let file = std::fs::File::open(path).unwrap();
    DecoderApp::decode_eager(BufReader::new(file))
        .unwrap()
        .filter_map(|msg| match msg.unwrap() {
            LogMsg::ArrowMsg(store, arrow) if store.kind() != StoreKind::Blueprint => {
                Some(Chunk::from_arrow_msg(&arrow).unwrap())
            }
            _ => None,
        })
        .collect()
}

/// Each time-series entity of the recording store: its (time ns, value) rows, in order.
fn series(path: &std::path::Path) -> BTreeMap<String, Vec<(i64, f64)>> {
    let component = crate::sdk::Scalars::descriptor_scalars().component;
    let timeline = crate::sdk::TimelineName::try_new(crate::TIMELINE).unwrap();
    let mut out: BTreeMap<String, Vec<(i64, f64)>> = BTreeMap::new();
    for chunk in recording_chunks(path) {
        let Some(times) = chunk.timelines().get(&timeline) else {
            continue;
        };
        let values = chunk.iter_slices::<f64>(component).map(|v| v[0]);
        let rows: Vec<(i64, f64)> = times.times_raw().iter().copied().zip(values).collect();
        out.entry(chunk.entity_path().to_string())
            .or_default()
            .extend(rows);
    }
    for rows in out.values_mut() {
        rows.sort_by_key(|r| r.0);
    }
    out
}

/// The entities of the recording store whose static chunks carry a bar chart's values.
pub(crate) fn static_bar_charts(path: &std::path::Path) -> std::collections::BTreeSet<String> {
    let component = crate::sdk::BarChart::descriptor_values().component;
    recording_chunks(path)
        .iter()
        .filter(|c| c.is_static() && c.components().contains_component(component))
        .map(|c| c.entity_path().to_string())
        .collect()
}
