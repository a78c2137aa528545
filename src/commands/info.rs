//! `heatrun info`.

use heatrun::decimate::Decimator;
use heatrun::recording::{self, format_time};

use super::Outcome;
use crate::cli::InfoArgs;

pub fn run(args: InfoArgs) -> anyhow::Result<Outcome> {
    let mut decimator = Decimator::new(1.0)?;
    let summary = recording::read_recording(&args.file, &mut decimator)?;
    let grid = if summary.channels.is_empty() {
        None
    } else {
        decimator.finish(&summary.channels).ok()
    };
    if args.json {
        let value = serde_json::json!({
            "recording": summary,
            "nameplate": summary.nameplate.iter().collect::<std::collections::BTreeMap<_, _>>(),
            "channel_grids": grid.as_ref().map(|g| &g.channels),
        });
        println!("{}", serde_json::to_string_pretty(&value)?);
    } else {
        println!("{} ({} bytes)", args.file.display(), summary.file_bytes);
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
            let g = grid.as_ref().and_then(|g| g.channels.get(i));
            println!(
                "    {:<40} {:<26} {:<5} {:>9} samples  period {:>8} s  gaps {}{}",
                c.topic,
                c.quantity.name(),
                c.unit,
                summary.samples_per_channel[i],
                g.map_or("?".into(), |g| format!("{:.3}", g.nominal_period_s)),
                g.map_or(0, |g| g.gaps),
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
        if summary.nameplate.is_empty() {
            println!("  nameplate: none (give one with --machine FILE.toml when replaying)");
        } else {
            println!("  nameplate:");
            for (k, v) in summary.nameplate.iter() {
                println!("    {k:<32} {v}");
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
        if summary.bad_quality_dropped > 0 {
            println!("  samples marked bad: {}", summary.bad_quality_dropped);
        }
        for (i, c) in summary.channels.iter().enumerate() {
            if let Some((t, v)) = summary.first_implausible[i] {
                println!(
                    "  {}: {} implausible sample(s), the first {v} {} at {}",
                    c.topic,
                    summary.implausible_per_channel[i],
                    c.quantity.canonical_unit(),
                    format_time(t)
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
    Ok(if summary.data_loss.is_empty() {
        Outcome::Complete
    } else {
        Outcome::DataLoss
    })
}
