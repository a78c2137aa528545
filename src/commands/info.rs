//! `heatrun info`: what is in a recording, before replaying it.

use std::path::Path;

use heatrun::decimate::{ChannelGrid, DecimatedRecording};
use heatrun::grid::GridBuilder;
use heatrun::recording::RecordingIndex;
use heatrun::recording::{
    self, format_time, Interpolation, RecordingSummary, SensorChannel, Storage,
};
use heatrun::spec::ModelDescription;
use heatrun::store::Location;

use super::Outcome;
use crate::cli::InfoArgs;

/// Reads the recording, lays it on a 1 s grid for the channels' periods and gaps, and
/// prints both (text or JSON).
pub fn run(args: &InfoArgs) -> anyhow::Result<Outcome> {
    // A recording in object storage: its summary section only, by ranged requests.
    let location = Location::from_path(&args.file)?;
    if location.is_remote() {
        let index = recording::read_index(&location).map_err(heatrun::Error::from)?;
        if args.json {
            println!("{}", serde_json::to_string_pretty(&index)?);
        } else {
            print_index(&index);
        }
        return Ok(Outcome::Complete);
    }
    // The generator's placement of each profile quantity on the grid; channels it does not
    // name are averaged over intervals.
    let mut grid = GridBuilder::whole(1.0, ModelDescription::generator().alignments())
        .map_err(heatrun::Error::from)?;
    let summary = recording::read_recording(&args.file, &mut grid).map_err(heatrun::Error::from)?;
    // `inspect`, not `finish`: a channel whose clock jumped is shown, not refused.
    let grid = if summary.channels.is_empty() {
        None
    } else {
        grid.inspect(&summary.channels).ok()
    };
    if args.json {
        let value = serde_json::json!({
            "recording": summary,
            "nameplate": summary.nameplate.iter().collect::<std::collections::BTreeMap<_, _>>(),
            "nameplate_missing": summary.nameplate.missing_required().iter().map(|k| k.key).collect::<Vec<_>>(),
            "channel_grids": grid.as_ref().map(|g| &g.channels),
        });
        println!("{}", serde_json::to_string_pretty(&value)?);
    } else {
        print_channels(&args.file, &summary, grid.as_ref());
        print_records(&summary);
        print_findings(&summary, grid.as_ref());
    }
    Ok(if summary.data_loss.is_empty() {
        Outcome::Complete
    } else {
        Outcome::DataLoss
    })
}

/// The file, its span and the channel table.
fn print_channels(file: &Path, summary: &RecordingSummary, grid: Option<&DecimatedRecording>) {
    println!("{} ({} bytes)", file.display(), summary.file_bytes);
    if let Some((a, b)) = summary.time_span_ns {
        println!(
            "  span {} to {} ({:.1} s)",
            format_time(a),
            format_time(b),
            (b - a) as f64 * 1e-9
        );
    }
    println!("  heat-run channels: {}", summary.channels.len());
    for (i, c) in summary.channels.iter().enumerate() {
        let g = grid.and_then(|g| g.channels.get(i));
        println!(
            "    {:<40} {:<26} {:<5} {:>9} samples  {}{}",
            c.topic,
            c.signal.name(),
            c.unit,
            summary.samples_per_channel[i],
            timing(c, g),
            c.sensor
                .as_ref()
                .map(|s| format!("  sensor {s}"))
                .unwrap_or_default()
        );
    }
    if !summary.ignored_channels.is_empty() {
        println!(
            "  other channels (not heat-run data): {}",
            summary.ignored_channels.len()
        );
        for c in &summary.ignored_channels {
            println!("    {:<40} {}", c.topic, c.reason);
        }
    }
}

/// A channel's storage, nominal period and gaps, as one column of the channel table
/// (`?` where the grid could not be laid out).
fn timing(c: &SensorChannel, g: Option<&ChannelGrid>) -> String {
    let period = g.map_or("?".into(), |g| format!("{:.3}", g.nominal_period_s));
    let gaps = g.map_or("?".into(), |g| g.gaps.to_string());
    let held = match c.interpolation {
        Interpolation::Step => "  held between samples (step)",
        Interpolation::Linear => "",
    };
    match c.storage {
        Storage::Sampled => format!("period {period:>8} s  gaps {gaps}{held}"),
        Storage::Exception {
            deadband,
            max_interval_s,
        } => format!(
            "stored by exception (deadband {deadband} {}, at most every {}), median spacing {period} s  gaps {gaps}{held}",
            c.unit,
            max_interval_s.map_or("-".into(), |m| format!("{m} s"))
        ),
    }
}

/// The nameplate and the other metadata records.
fn print_records(summary: &RecordingSummary) {
    if summary.nameplate.is_empty() {
        println!("  nameplate: none");
    } else {
        println!("  nameplate:");
        for (k, v) in summary.nameplate.iter() {
            println!("    {k:<32} {v}");
        }
    }
    // A generator's replay needs them all: name every one at once, with what it is for.
    let missing = summary.nameplate.missing_required();
    let generator = summary
        .channels
        .iter()
        .any(|c| c.signal.quantity().is_some());
    if generator && !missing.is_empty() {
        println!(
            "  nameplate keys a generator replay needs and the recording lacks ({}; give them \
             with --machine FILE.toml):",
            missing.len()
        );
        for k in missing {
            println!("    {:<32} {:<5} {}", k.key, k.unit, k.feeds);
        }
    }
    for (name, m) in &summary.metadata {
        println!(
            "  metadata {name}: {}",
            m.iter()
                .map(|(k, v)| format!("{k}={v}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
}

/// Samples left out (bad, implausible, dropouts), clock jumps, notes and data loss.
fn print_findings(summary: &RecordingSummary, grid: Option<&DecimatedRecording>) {
    if summary.bad_quality_dropped > 0 {
        println!("  samples marked bad: {}", summary.bad_quality_dropped);
    }
    for (i, c) in summary.channels.iter().enumerate() {
        if let Some((t, v)) = summary.first_implausible[i] {
            println!(
                "  {}: {} implausible sample(s), the first {v} {} at {}",
                c.topic,
                summary.implausible_per_channel[i],
                c.canonical_unit(),
                format_time(t)
            );
        }
        if let Some(t) = summary.first_dropout[i] {
            println!(
                "  {}: {} dropout(s) (value null or NaN), the first at {}",
                c.topic,
                summary.dropouts_per_channel[i],
                format_time(t)
            );
        }
        if let Some(jump) = grid.and_then(|g| g.channels.get(i)?.clock_jump) {
            println!(
                "  {}: its clock jumps back: from {} to {} it holds {:.1} times the samples its rate allows",
                c.topic,
                format_time(jump.overlap_start_ns),
                format_time(jump.overlap_end_ns),
                jump.density_ratio
            );
        }
    }
    for n in &summary.notes {
        println!("  note: {n}");
    }
    for l in &summary.data_loss {
        println!("  data lost: {l}");
    }
    if summary.channels.is_empty() {
        println!("  this recording holds no heat-run data");
    }
}

/// A remote recording's summary section: channels with their message counts, span,
/// chunks, metadata, and the bytes fetched to read it.
fn print_index(index: &RecordingIndex) {
    println!("{} ({} bytes)", index.path.display(), index.object_bytes);
    if let Some((a, b)) = index.time_span_ns {
        println!(
            "  span {} to {} ({:.1} s)",
            format_time(a),
            format_time(b),
            (b - a) as f64 * 1e-9
        );
    }
    println!(
        "  channels: {} (from the summary section)",
        index.channels.len()
    );
    for c in &index.channels {
        let get = |k: &str| c.metadata.get(k).map_or("", String::as_str);
        println!(
            "    {:<40} {:<26} {:<5} {:>9} messages",
            c.topic,
            get("quantity"),
            get("unit"),
            c.messages.map_or("?".into(), |m| m.to_string())
        );
    }
    println!("  chunks: {}", index.chunks);
    for (name, m) in &index.metadata {
        println!(
            "  metadata {name}: {}",
            m.iter()
                .map(|(k, v)| format!("{k}={v}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    println!(
        "  read by ranged requests: {} of {} bytes ({:.2} %) in {} requests; the samples' \
         periods and gaps need the whole recording (a local copy)",
        index.fetched_bytes,
        index.object_bytes,
        100.0 * index.fetched_bytes as f64 / index.object_bytes.max(1) as f64,
        index.requests
    );
}
