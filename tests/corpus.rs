//! A generated corpus of damaged and odd recordings, each with its documented outcome.
//!
//! | case | outcome |
//! |---|---|
//! | empty file; not MCAP; Git LFS pointer | exit 2, one line naming the file |
//! | cut short at any offset (mid-record, mid-chunk, no summary) | every complete chunk is used: exit 3 with "cut short" and the last complete sample, or exit 2 when too little is left |
//! | cut inside the summary section only | exit 0, a note: nothing lost |
//! | a corrupted chunk (CRC mismatch) | the chunk is dropped: exit 3, naming the chunk's start time |
//! | wrong schema; wrong message encoding | exit 2 naming the channel |
//! | a message that is not JSON, or has no `value`; NaN or 1e999 (not JSON numbers) | exit 2 naming channel and time |
//! | a missing required quantity; an unknown unit | exit 2 naming the quantity or channel |
//! | absurd values (negative current, 10⁹ °C) | dropped with a warning naming channel, count, first value and time; exit 0 |
//! | `bad`-quality samples | dropped and counted; exit 0 |
//! | duplicate timestamps; messages out of order | the same estimate as the clean file; exit 0 |
//! | a gap of minutes in one channel | the regression is split (two segments, no row bridges the gap), a warning; exit 0 |
//! | a channel that stops early | a warning naming it; the estimate uses the data before; exit 0 |
//! | a clock jump backwards | exit 2 naming the channel and both times |
//! | too short to estimate; constant inputs; an unstable estimate | exit 2 saying which |
//! | no heat-run channels | replay: exit 2 "holds no heat-run data"; info: exit 0 |
//! | unchunked, lz4, uncompressed, no summary, no indexes | the same estimate; exit 0 |
//!
//! Every failing case also checks: one line on stderr, no panic, no output file left
//! (complete or absent), and the input unchanged.

use crate::common;

use std::path::Path;

use common::{heatrun, RecordingBuilder, T0};
use heatrun::synth::{self, SynthOptions};

/// The outcome of a replay of `file` in `dir`: exit status, stderr, stdout.
fn replay(dir: &Path, file: &str) -> (i32, String, String) {
    let before = std::fs::read(dir.join(file)).ok();
    let out = heatrun(
        &["replay", file, "--rrd", "out.rrd", "--report", "out.json"],
        dir,
    );
    let code = out.status.code().unwrap_or(-1);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(!stderr.contains("panicked"), "{file}: {stderr}");
    assert_eq!(
        std::fs::read(dir.join(file)).ok(),
        before,
        "{file}: the input was modified"
    );
    for f in common::files_in(dir) {
        assert!(
            !f.to_string_lossy().contains("partial"),
            "{f:?} left behind"
        );
    }
    if code == 2 || code == 1 {
        assert_eq!(
            stderr.trim_end().lines().count(),
            1,
            "{file}: one line: {stderr}"
        );
        assert!(
            !dir.join("out.rrd").exists() && !dir.join("out.json").exists(),
            "{file}: output on failure"
        );
    } else {
        assert!(
            dir.join("out.rrd").exists() && dir.join("out.json").exists(),
            "{file}: outputs missing"
        );
    }
    let _ = std::fs::remove_file(dir.join("out.rrd"));
    let _ = std::fs::remove_file(dir.join("out.json"));
    (code, stderr, stdout)
}

fn report_time_constants(stdout: &str) -> Vec<f64> {
    stdout
        .lines()
        .filter(|l| l.trim_start().starts_with('T') && l.contains(" s ") && l.contains("->"))
        .map(|l| {
            l.split('=')
                .nth(1)
                .unwrap()
                .split_whitespace()
                .next()
                .unwrap()
                .parse()
                .unwrap()
        })
        .collect()
}

fn clean_run(dir: &Path, chunk_size: u64) -> std::path::PathBuf {
    let path = dir.join("clean.mcap");
    synth::write(
        &path,
        &SynthOptions {
            duration_s: 8000.0,
            chunk_size,
            ..SynthOptions::default()
        },
    )
    .unwrap();
    path
}

#[test]
fn cut_short_at_many_offsets() {
    let dir = common::tempdir();
    let clean = clean_run(dir.path(), 64 * 1024);
    let bytes = std::fs::read(&clean).unwrap();
    let (mut lost, mut refused) = (0, 0);
    for i in 1..=24 {
        let cut = bytes.len() * i / 25 + (i * 7919) % 97; // mid-record and mid-chunk offsets
        std::fs::write(dir.path().join("cut.mcap"), &bytes[..cut]).unwrap();
        let (code, stderr, stdout) = replay(dir.path(), "cut.mcap");
        match code {
            3 => {
                assert!(
                    stdout.contains("cut short") && stdout.contains("last complete sample"),
                    "{stdout}"
                );
                lost += 1;
            }
            2 => {
                assert!(stderr.contains("cut.mcap"), "{stderr}");
                refused += 1;
            }
            other => panic!("cut at {cut}: exit {other}: {stderr}"),
        }
    }
    assert!(
        lost >= 15,
        "most cuts leave enough to estimate: {lost} used, {refused} refused"
    );
}

#[test]
fn a_cut_in_the_summary_loses_nothing() {
    let dir = common::tempdir();
    let clean = clean_run(dir.path(), 1 << 20);
    let bytes = std::fs::read(&clean).unwrap();
    // The footer and summary are the file's tail; cut 40 bytes before the end.
    std::fs::write(dir.path().join("cut.mcap"), &bytes[..bytes.len() - 40]).unwrap();
    let (code, stderr, _) = replay(dir.path(), "cut.mcap");
    assert_eq!(code, 0, "{stderr}");
}

#[test]
fn a_corrupted_chunk_is_dropped_and_named() {
    let dir = common::tempdir();
    let clean = clean_run(dir.path(), 64 * 1024);
    let mut bytes = std::fs::read(&clean).unwrap();
    // Flip bytes in the middle of the file: inside some chunk's compressed data.
    let mid = bytes.len() / 2;
    for b in &mut bytes[mid..mid + 8] {
        *b ^= 0x5a;
    }
    std::fs::write(dir.path().join("bad.mcap"), &bytes).unwrap();
    let (code, stderr, stdout) = replay(dir.path(), "bad.mcap");
    assert_eq!(code, 3, "{stderr}");
    assert!(
        stdout.contains("chunk starting at") && stdout.contains("dropped"),
        "{stdout}"
    );
}

#[test]
fn messages_that_are_not_samples() {
    for (text, what) in [
        ("{\"value\": 1e999}", "1e999"),
        ("[1, 2]", "array"),
        ("{\"quality\": \"good\"}", "no value"),
    ] {
        let dir = common::tempdir();
        let mut r = RecordingBuilder::heat_run(3000.0, "");
        r.channels[4].2[50].1 = text.into();
        r.write(&dir.path().join("r.mcap"));
        let (code, stderr, _) = replay(dir.path(), "r.mcap");
        assert_eq!(code, 2, "{what}: {stderr}");
        assert!(
            stderr.contains("/scada/stator_winding_temp")
                && stderr.contains("2020-09-13T12:27:30Z"),
            "{what}: {stderr}"
        );
    }
}

#[test]
fn a_wrong_message_encoding_names_the_channel() {
    let dir = common::tempdir();
    let mut r = RecordingBuilder::heat_run(3000.0, "");
    r.message_encoding = "protobuf".into();
    r.write(&dir.path().join("r.mcap"));
    let (code, stderr, _) = replay(dir.path(), "r.mcap");
    assert_eq!(code, 2);
    assert!(
        stderr.contains("protobuf") && stderr.contains("/scada/"),
        "{stderr}"
    );
}

#[test]
fn absurd_values_are_dropped_with_a_warning() {
    let dir = common::tempdir();
    let mut r = RecordingBuilder::from_synth(6000.0);
    let (current, core) = (r.channel_of("armature_current"), r.channel_of("core_temp"));
    r.channels[current].2[100].1 = "{\"value\": -3.0}".into(); // negative RMS current, kA
    r.channels[core].2[200].1 = "{\"value\": 1e9}".into(); // 10⁹ °C
    r.write(&dir.path().join("r.mcap"));
    let (code, stderr, stdout) = replay(dir.path(), "r.mcap");
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stdout.contains("/scada/armature_current: 1 sample(s) outside the physical range"),
        "{stdout}"
    );
    assert!(
        stdout.contains("/scada/core_temp: 1 sample(s)") && stdout.contains("1000000000 degC"),
        "{stdout}"
    );
}

#[test]
fn bad_quality_samples_are_dropped_and_counted() {
    let dir = common::tempdir();
    let mut r = RecordingBuilder::heat_run(4000.0, "");
    for i in 0..30 {
        r.channels[6].2[300 + i].1 = "{\"value\": 99.0, \"quality\": \"bad\"}".into();
    }
    r.channels[6].2[400].1 = "{\"value\": 12.0, \"quality\": \"uncertain\"}".into();
    r.write(&dir.path().join("r.mcap"));
    let (code, stderr, stdout) = replay(dir.path(), "r.mcap");
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stdout.contains("30 samples marked `bad` were dropped"),
        "{stdout}"
    );
}

#[test]
fn duplicates_and_disorder_change_nothing() {
    let dir = common::tempdir();
    let base = RecordingBuilder::from_synth(5000.0);
    base.write(&dir.path().join("clean.mcap"));
    let (_, _, clean_out) = replay(dir.path(), "clean.mcap");
    let clean = report_time_constants(&clean_out);
    assert_eq!(clean.len(), 3, "{clean_out}");
    // Every temperature sample written twice with the same time and value.
    let mut dup = RecordingBuilder::from_synth(5000.0);
    for ch in dup.channels.iter_mut().filter(|c| c.0.ends_with("_temp")) {
        let copy = ch.2.clone();
        ch.2.extend(copy);
    }
    dup.write(&dir.path().join("dup.mcap"));
    base.write_with(
        &dir.path().join("shuffled.mcap"),
        mcap::WriteOptions::new(),
        Some(7),
    );
    for file in ["dup.mcap", "shuffled.mcap"] {
        let (code, stderr, out) = replay(dir.path(), file);
        assert_eq!(code, 0, "{file}: {stderr}");
        let t = report_time_constants(&out);
        for (a, b) in t.iter().zip(&clean) {
            assert!(
                (a - b).abs() <= 1e-6 * b.abs() + 0.011,
                "{file}: {t:?} vs {clean:?}"
            );
        }
    }
}

#[test]
fn a_gap_splits_the_regression() {
    let dir = common::tempdir();
    // Five minutes of the core temperature missing.
    let mut r = RecordingBuilder::from_synth(6000.0);
    let core = r.channel_of("core_temp");
    r.channels[core]
        .2
        .retain(|(t, _)| !(T0 + 2_000_000_000_000..T0 + 2_300_000_000_000).contains(t));
    r.write(&dir.path().join("gap.mcap"));
    let (code, stderr, stdout) = replay(dir.path(), "gap.mcap");
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stdout.contains("/scada/core_temp has 1 gap(s)") && stdout.contains("2 segment(s)"),
        "{stdout}"
    );
    let report: serde_json::Value = {
        heatrun(
            &[
                "replay", "gap.mcap", "--rrd", "g.rrd", "--report", "g.json", "-q",
            ],
            dir.path(),
        );
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("g.json")).unwrap()).unwrap()
    };
    // 6000 instants, 300 without the core temperature; 301 equations touch them.
    assert_eq!(report["estimation"]["equations_used"], 6000 - 1 - 301);
}

#[test]
fn a_channel_that_stops_early_is_named() {
    let dir = common::tempdir();
    let mut r = RecordingBuilder::from_synth(6000.0);
    let voltage = r.channel_of("line_voltage");
    r.channels[voltage].2.truncate(4500); // line voltage stops at 4500 s
    r.write(&dir.path().join("r.mcap"));
    let (code, stderr, stdout) = replay(dir.path(), "r.mcap");
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stdout.contains("line_voltage stops at")
            && stdout.contains("1500 s before the recording ends"),
        "{stdout}"
    );
}

#[test]
fn a_clock_jump_backwards_is_refused() {
    let dir = common::tempdir();
    let r = RecordingBuilder::from_synth(6000.0);
    // From 4000 s on, the stator RTD's clock is an hour behind: written in arrival order,
    // its samples carry times from 400 s on again.
    let stator = r.channel_of("stator_winding_temp");
    let mut order: Vec<(usize, usize, u64)> = Vec::new();
    for (c, ch) in r.channels.iter().enumerate() {
        for (i, (t, _)) in ch.2.iter().enumerate() {
            order.push((c, i, *t));
        }
    }
    order.sort_by_key(|o| o.2);
    for o in order.iter_mut() {
        if o.0 == stator && o.2 >= T0 + 4_000_000_000_000 {
            o.2 -= 3_600_000_000_000;
        }
    }
    r.write_in_order(&dir.path().join("r.mcap"), &order);
    let (code, stderr, _) = replay(dir.path(), "r.mcap");
    assert_eq!(code, 2, "{stderr}");
    assert!(
        stderr.contains("/scada/stator_winding_temp") && stderr.contains("clock jumps back"),
        "{stderr}"
    );
}

#[test]
fn too_short_and_unstable_recordings_are_refused() {
    let dir = common::tempdir();
    RecordingBuilder::heat_run(40.0, "").write(&dir.path().join("short.mcap"));
    let (code, stderr, _) = replay(dir.path(), "short.mcap");
    assert_eq!(code, 2);
    assert!(stderr.contains("too few"), "{stderr}");
    // Temperatures that run away exponentially: no stable thermal system fits them.
    let mut r = RecordingBuilder::new();
    let step = |t: f64| {
        if (t / 500.0) as i64 % 2 == 0 {
            1.0
        } else {
            1.3
        }
    };
    r = r
        .channel("armature_current", "A", 1.0, 5000.0, move |t| {
            3000.0 * step(t)
        })
        .channel("field_current", "A", 1.0, 5000.0, move |t| {
            1000.0 * step(t + 170.0)
        })
        .channel("line_voltage", "V", 1.0, 5000.0, move |t| {
            15650.0 * (0.95 + 0.1 * step(t + 330.0))
        })
        .channel("field_voltage", "V", 1.0, 5000.0, |_| 150.0)
        .channel("stator_winding_temp", "degC", 1.0, 5000.0, |t| {
            30.0 + (t / 1500.0).exp()
        })
        .channel("core_temp", "degC", 1.0, 5000.0, |t| {
            30.0 + (t / 1800.0).exp()
        })
        .channel("cooling_water_outlet_temp", "degC", 1.0, 5000.0, |t| {
            10.0 + (t / 2000.0).exp()
        });
    r.write(&dir.path().join("runaway.mcap"));
    let (code, stderr, _) = replay(dir.path(), "runaway.mcap");
    assert_eq!(code, 2, "{stderr}");
    assert!(
        stderr.contains("not a stable thermal system") || stderr.contains("unstable"),
        "{stderr}"
    );
}

#[test]
fn a_recording_without_heat_run_channels() {
    let dir = common::tempdir();
    let file = std::fs::File::create(dir.path().join("camera.mcap")).unwrap();
    let mut w = mcap::Writer::new(std::io::BufWriter::new(file)).unwrap();
    let schema = w
        .add_schema("foxglove.CompressedImage", "jsonschema", b"{}")
        .unwrap();
    let ch = w
        .add_channel(schema, "/camera/front", "json", &Default::default())
        .unwrap();
    w.write_to_known_channel(
        &mcap::records::MessageHeader {
            channel_id: ch,
            sequence: 0,
            log_time: T0,
            publish_time: T0,
        },
        b"{}",
    )
    .unwrap();
    w.finish().unwrap();
    drop(w);
    let (code, stderr, _) = replay(dir.path(), "camera.mcap");
    assert_eq!(code, 2);
    assert!(
        stderr.contains("holds no heat-run data") && stderr.contains("/camera/front"),
        "{stderr}"
    );
    let info = heatrun(&["info", "camera.mcap"], dir.path());
    assert_eq!(info.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&info.stdout).contains("holds no heat-run data"));
}

#[test]
fn every_mcap_layout_gives_the_same_estimate() {
    let dir = common::tempdir();
    let base = RecordingBuilder::heat_run(4000.0, "");
    base.write(&dir.path().join("default.mcap"));
    let (_, _, out) = replay(dir.path(), "default.mcap");
    let reference = report_time_constants(&out);
    let layouts: Vec<(&str, mcap::WriteOptions)> = vec![
        ("unchunked", mcap::WriteOptions::new().use_chunks(false)),
        (
            "lz4",
            mcap::WriteOptions::new().compression(Some(mcap::Compression::Lz4)),
        ),
        ("uncompressed", mcap::WriteOptions::new().compression(None)),
        (
            "no-summary",
            mcap::WriteOptions::new()
                .emit_summary_records(false)
                .emit_summary_offsets(false)
                .emit_statistics(false),
        ),
        (
            "no-indexes",
            mcap::WriteOptions::new()
                .emit_message_indexes(false)
                .emit_chunk_indexes(false)
                .emit_metadata_indexes(false),
        ),
        (
            "small-chunks",
            mcap::WriteOptions::new().chunk_size(Some(4096)),
        ),
    ];
    for (name, options) in layouts {
        let file = format!("{name}.mcap");
        base.write_with(&dir.path().join(&file), options, None);
        let (code, stderr, out) = replay(dir.path(), &file);
        assert_eq!(code, 0, "{name}: {stderr}");
        assert_eq!(report_time_constants(&out), reference, "{name}");
        let info = heatrun(&["info", &file], dir.path());
        assert_eq!(info.status.code(), Some(0), "{name}");
    }
}

#[test]
fn fuzz_findings_stay_fixed() {
    // Inputs cargo-fuzz found crashing the recording path, kept as regressions.
    let found = common::package_root().join("tests/data");
    for entry in std::fs::read_dir(found).unwrap() {
        let path = entry.unwrap().path();
        let dir = common::tempdir();
        std::fs::copy(&path, dir.path().join("f.mcap")).unwrap();
        let (code, stderr, _) = replay(dir.path(), "f.mcap");
        assert!(
            code == 2 || code == 3 || code == 0,
            "{}: exit {code}: {stderr}",
            path.display()
        );
    }
}
