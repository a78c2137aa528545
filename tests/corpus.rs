//! A generated corpus of damaged and odd recordings, each with its documented outcome.
//!
//! | case | outcome |
//! |---|---|
//! | empty file; not MCAP; Git LFS pointer | exit 2, one line naming the file |
//! | cut short at any offset (mid-record, mid-chunk, no summary) | every complete chunk is used: exit 3 with "cut short" and the last complete sample, or exit 2 when too little is left |
//! | cut inside the summary section only | exit 0, a note: nothing lost |
//! | a corrupted chunk (CRC mismatch) | the chunk is dropped: exit 3, naming the chunk's start time |
//! | wrong schema; wrong message encoding | exit 2 naming the channel |
//! | a message that is not JSON, or has no `value`, or 1e999 (not a finite JSON number) | exit 2 naming channel and time |
//! | a value `null` or NaN (a dropout) | left out, counted per channel with the first time; exit 0 |
//! | a missing required quantity; an unknown unit | exit 2 naming the quantity or channel |
//! | absurd values (an RMS current of −3 kA, 10⁹ °C) | dropped with a warning naming channel, count, first value and time; exit 0 |
//! | an RMS current slightly negative at zero load (transducer noise) | kept, no warning; exit 0 |
//! | `bad`-quality samples | dropped and counted; exit 0 |
//! | duplicate timestamps; messages in any order (shuffled, chunks reversed, recorders merged with chunks overlapping in time, channel after channel) | the same report numbers as the time-ordered file; `info` the same periods and gaps; exit 0 |
//! | a gap of minutes in one channel | the regression is split (two segments, no row bridges the gap), a warning; exit 0 |
//! | a channel stored by exception (a historian's deadband) | interpolated between stored samples, silences are not gaps; exit 0 |
//! | a channel that stops early | a warning naming it; the estimate uses the data before; exit 0 |
//! | a clock jump backwards, in any storage order | exit 2 naming the channel and both times |
//! | too short to estimate; constant inputs; an unstable estimate | exit 2 saying which |
//! | no heat-run channels | replay: exit 2 "holds no heat-run data"; info: exit 0 |
//! | unchunked, lz4, uncompressed, no summary, no indexes | the same report numbers; exit 0 |
//! | the fuzz findings of `tests/data/` | each its documented exit status and message |
//!
//! Every failing case also checks: one line on stderr, no panic, no output file left
//! (complete or absent), and the input unchanged.

use crate::common;
use crate::layouts;

use std::path::Path;

use common::{heatrun, RecordingBuilder, T0};
use heatrun::synth::{self, SynthOptions};
use layouts::Order;
use serde_json::Value;

/// What a replay of a file did.
struct Replayed {
    code: i32,
    stderr: String,
    stdout: String,
    /// The report, when one was written.
    report: Option<Value>,
}

/// Replays `file` in `dir` and checks what every replay must do: no panic, the input
/// unchanged, no temporary file left, and on failure one line and no output.
fn replay(dir: &Path, file: &str) -> Replayed {
    let before = std::fs::read(dir.join(file)).ok();
    let out = heatrun(
        // The reading is under test, not the network: the nearest one, without rc's fit.
        &[
            "replay",
            file,
            "--rrd",
            "out.rrd",
            "--report",
            "out.json",
            "--network",
            "nearest",
        ],
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
    let report = std::fs::read_to_string(dir.join("out.json"))
        .ok()
        .map(|text| serde_json::from_str(&text).expect("the report is JSON"));
    let _ = std::fs::remove_file(dir.join("out.rrd"));
    let _ = std::fs::remove_file(dir.join("out.json"));
    Replayed {
        code,
        stderr,
        stdout,
        report,
    }
}

/// Replays a file that must succeed (exit 0); returns its report.
fn replay_ok(dir: &Path, file: &str) -> Value {
    let r = replay(dir, file);
    assert_eq!(r.code, 0, "{file}: {}", r.stderr);
    r.report.expect("a report")
}

/// The report's numbers a replay is judged by, by path (`phi[0][1]`): Φ, Γ, A_c, B_c, the
/// eigenvalues, time constants, steady-state rise and temperature, the fit, and the
/// equations used. Each must be present and non-empty: a report without them fails,
/// it does not compare equal to another without them.
fn numbers(report: &Value) -> Vec<(String, f64)> {
    fn flatten(v: &Value, path: String, out: &mut Vec<(String, f64)>) {
        match v {
            Value::Number(n) => out.push((path, n.as_f64().unwrap())),
            Value::Array(items) if !items.is_empty() => {
                for (i, item) in items.iter().enumerate() {
                    flatten(item, format!("{path}[{i}]"), out);
                }
            }
            other => panic!("report: `{path}` is missing or empty: {other}"),
        }
    }
    let mut out = Vec::new();
    for key in [
        "phi",
        "gamma",
        "a_c",
        "b_c",
        "eigenvalues_discrete",
        "time_constants_s",
    ] {
        flatten(&report[key], key.into(), &mut out);
    }
    for (block, key) in [
        ("steady_state", "rise_k"),
        ("steady_state", "temperature_c"),
        ("fit", "nrmse_fit_percent"),
        ("estimation", "equations_used"),
    ] {
        flatten(&report[block][key], format!("{block}.{key}"), &mut out);
    }
    out
}

/// Relative difference allowed between the numbers of two replays of the same samples
/// stored differently. A window's mean is a sum, and another order can change its last
/// bit; the estimate carries that through (measured: at most 7e-12 on the noisy 10 Hz run
/// reordered, exactly 0 on the 1 Hz fixture), while one electrical sample of 54,000 left
/// out moves the numbers by 4.5e-5 (measured): 1e-9 tells the two apart.
const SAME: f64 = 1e-9;

/// Asserts two reports hold the same numbers (to [`SAME`] relative, 1e-12 absolute).
fn assert_same_numbers(what: &str, got: &Value, want: &Value) {
    let (got, want) = (numbers(got), numbers(want));
    assert_eq!(got.len(), want.len(), "{what}: different report shapes");
    for ((path, a), (_, b)) in got.iter().zip(&want) {
        assert!(
            (a - b).abs() <= SAME * a.abs().max(b.abs()) + 1e-12,
            "{what}: {path} is {a}, the time-ordered file's {b}"
        );
    }
}

fn clean_run(dir: &Path, chunk_size: u64) -> std::path::PathBuf {
    let path = dir.join("clean.mcap");
    synth::write(
        &path,
        &SynthOptions {
            duration_s: 8000.0,
            chunk_size,
            // The layouts of the paper's channels (the offsets below sit in its chunks).
            coolant: synth::Coolant {
                channels: false,
                ..synth::Coolant::default()
            },
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
        let Replayed {
            code,
            stderr,
            stdout,
            ..
        } = replay(dir.path(), "cut.mcap");
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
    let r = replay(dir.path(), "cut.mcap");
    assert_eq!(r.code, 0, "{}", r.stderr);
    let info = heatrun(&["info", "cut.mcap"], dir.path());
    assert_eq!(info.status.code(), Some(0));
    let text = String::from_utf8_lossy(&info.stdout);
    assert!(
        text.contains("note: the summary section is cut short")
            && text.contains("no data were lost"),
        "{text}"
    );
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
    let r = replay(dir.path(), "bad.mcap");
    assert_eq!(r.code, 3, "{}", r.stderr);
    assert!(
        r.stdout.contains("chunk starting at") && r.stdout.contains("dropped"),
        "{}",
        r.stdout
    );
}

#[test]
fn messages_that_are_not_samples() {
    for (text, what) in [
        ("{\"value\": 1e999}", "1e999"),
        ("[1, 2]", "array"),
        ("{\"quality\": \"good\"}", "no value"),
        ("{\"value\": \"hot\"}", "a word"),
        ("value=3", "not JSON"),
    ] {
        let dir = common::tempdir();
        let mut r = RecordingBuilder::heat_run(3000.0, "");
        r.channels[4].2[50].1 = text.into();
        r.write(&dir.path().join("r.mcap"));
        let out = replay(dir.path(), "r.mcap");
        assert_eq!(out.code, 2, "{what}: {}", out.stderr);
        assert!(
            out.stderr.contains("/scada/stator_winding_temp")
                && out.stderr.contains("2020-09-13T12:27:30Z"),
            "{what}: {}",
            out.stderr
        );
    }
}

/// The channel table of `heatrun info --json`: (topic, nominal period, gaps, block-averaged)
/// per channel, each required present.
fn info_grids(dir: &Path, file: &str) -> Vec<(String, f64, u64, bool)> {
    let out = heatrun(&["info", "--json", file], dir);
    assert_eq!(out.status.code(), Some(0), "{file}: info failed");
    let v: Value = serde_json::from_slice(&out.stdout).expect("info --json is JSON");
    let grids = v["channel_grids"]
        .as_array()
        .unwrap_or_else(|| panic!("{file}: info shows no channel grids: {v}"));
    assert!(!grids.is_empty(), "{file}: no channels");
    // By topic: the channels are numbered in the order the file first defines them.
    let mut grids: Vec<(String, f64, u64, bool)> = grids
        .iter()
        .map(|g| {
            (
                g["topic"].as_str().unwrap().to_owned(),
                g["nominal_period_s"].as_f64().unwrap(),
                g["gaps"].as_u64().unwrap(),
                g["block_averaged"].as_bool().unwrap(),
            )
        })
        .collect();
    grids.sort_by(|a, b| a.0.cmp(&b.0));
    grids
}

#[test]
fn dropouts_are_left_out_and_counted() {
    let dir = common::tempdir();
    let mut r = RecordingBuilder::from_synth(5000.0);
    let core = r.channel_of("core_temp");
    for (i, text) in [
        (1000, "{\"value\": null}"),
        (1500, "{\"value\": NaN}"),
        (1501, "{\"value\":NaN,\"quality\":\"good\"}"),
    ] {
        r.channels[core].2[i].1 = text.into();
    }
    r.write(&dir.path().join("r.mcap"));
    let report = replay_ok(dir.path(), "r.mcap");
    // Three instants of one 1 Hz channel without a sample: three gaps in it, not an error.
    assert_eq!(report["time_constants_s"].as_array().map(Vec::len), Some(3));
    let info = heatrun(&["info", "r.mcap"], dir.path());
    let text = String::from_utf8_lossy(&info.stdout);
    let when = heatrun::recording::format_time(r.channels[core].2[1000].0);
    assert!(
        text.contains(&format!(
            "/scada/core_temp: 3 dropout(s) (value null or NaN), the first at {when}"
        )),
        "{text}"
    );
}

#[test]
fn a_wrong_message_encoding_names_the_channel() {
    let dir = common::tempdir();
    let mut r = RecordingBuilder::heat_run(3000.0, "");
    r.message_encoding = "protobuf".into();
    r.write(&dir.path().join("r.mcap"));
    let out = replay(dir.path(), "r.mcap");
    assert_eq!(out.code, 2);
    assert!(
        out.stderr.contains("protobuf") && out.stderr.contains("/scada/"),
        "{}",
        out.stderr
    );
}

#[test]
fn absurd_values_are_dropped_with_a_warning() {
    let dir = common::tempdir();
    let mut r = RecordingBuilder::from_synth(6000.0);
    let (current, core) = (r.channel_of("armature_current"), r.channel_of("core_temp"));
    r.channels[current].2[100].1 = "{\"value\": -3.0}".into(); // an RMS current of −3 kA
    r.channels[core].2[200].1 = "{\"value\": 1e9}".into(); // 10⁹ °C
    r.write(&dir.path().join("r.mcap"));
    let out = replay(dir.path(), "r.mcap");
    assert_eq!(out.code, 0, "{}", out.stderr);
    assert!(
        out.stdout
            .contains("/scada/armature_current: 1 sample(s) outside the physical range")
            && out.stdout.contains("-3000 A"),
        "{}",
        out.stdout
    );
    assert!(
        out.stdout.contains("/scada/core_temp: 1 sample(s)")
            && out.stdout.contains("1000000000 degC"),
        "{}",
        out.stdout
    );
}

#[test]
fn noise_around_zero_is_not_implausible() {
    // The armature current transducer reads ±0.15 % of the rated 3689 A around zero for
    // ten minutes (the machine off load): negative readings among them are noise.
    let dir = common::tempdir();
    let mut r = RecordingBuilder::from_synth(6000.0);
    let current = r.channel_of("armature_current");
    for (i, sample) in r.channels[current].2[3000..3600].iter_mut().enumerate() {
        let noise_ka = 0.0055 * ((i as f64) * 2.1).sin();
        sample.1 = format!("{{\"value\": {noise_ka}}}");
    }
    r.write(&dir.path().join("r.mcap"));
    let out = replay(dir.path(), "r.mcap");
    assert_eq!(out.code, 0, "{}", out.stderr);
    assert!(
        !out.stdout.contains("outside the physical range"),
        "{}",
        out.stdout
    );
    let info = heatrun(&["info", "r.mcap"], dir.path());
    assert!(!String::from_utf8_lossy(&info.stdout).contains("implausible"));
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
    let out = replay(dir.path(), "r.mcap");
    assert_eq!(out.code, 0, "{}", out.stderr);
    assert!(
        out.stdout.contains("30 samples marked `bad` were dropped"),
        "{}",
        out.stdout
    );
}

#[test]
fn duplicates_change_nothing() {
    let dir = common::tempdir();
    let base = RecordingBuilder::from_synth(5000.0);
    base.write(&dir.path().join("clean.mcap"));
    let clean = replay_ok(dir.path(), "clean.mcap");
    // Every temperature sample written twice with the same time and value.
    let mut dup = RecordingBuilder::from_synth(5000.0);
    for ch in dup.channels.iter_mut().filter(|c| c.0.ends_with("_temp")) {
        let copy = ch.2.clone();
        ch.2.extend(copy);
    }
    dup.write(&dir.path().join("dup.mcap"));
    assert_same_numbers("dup.mcap", &replay_ok(dir.path(), "dup.mcap"), &clean);
}

/// A noisy synthetic heat run of 1.5 h: electrical channels at 10 Hz, temperatures at
/// 1 Hz, PT100-like noise.
fn noisy_10_hz(path: &Path) {
    synth::write(
        path,
        &SynthOptions {
            duration_s: 5400.0,
            electrical_rate_hz: 10.0,
            temperature_rate_hz: 1.0,
            seed: 11,
            ..SynthOptions::default().with_noise_level(1.0)
        },
    )
    .unwrap();
}

/// Every order of storing the messages gives the time-ordered file's report numbers and
/// `info`'s periods and gaps; each generated layout is checked to be what it claims.
fn orders_give_the_same_report(dir: &Path, source: &str) {
    let reference = replay_ok(dir, source);
    let reference_grids = info_grids(dir, source);
    for order in [
        Order::Shuffled(7),
        Order::ReversedChunks(5000),
        Order::MergedRecorders(3000, 7000),
        Order::ChannelByChannel(4000),
    ] {
        let file = format!("{}-{}", order.name(), source);
        layouts::rewrite(&dir.join(source), &dir.join(&file), order);
        let chunks = layouts::chunk_ranges(&dir.join(&file));
        let starts: Vec<u64> = chunks.iter().map(|c| c.0).collect();
        match order {
            Order::ReversedChunks(_) => assert!(
                starts.windows(2).all(|w| w[0] > w[1]),
                "{file}: chunks not reversed: {chunks:?}"
            ),
            Order::MergedRecorders(..) | Order::ChannelByChannel(_) => assert!(
                chunks.windows(2).any(|w| w[1].0 < w[0].1),
                "{file}: no chunk overlaps the one before in time"
            ),
            _ => {
                let (first, last) = (chunks[0], chunks[chunks.len() - 1]);
                assert!(chunks.len() > 1 && first.1 > last.0, "{file}: not shuffled");
            }
        }
        assert_same_numbers(&file, &replay_ok(dir, &file), &reference);
        assert_eq!(info_grids(dir, &file), reference_grids, "{file}");
    }
}

#[test]
fn the_fixture_in_any_order_gives_the_same_report() {
    let dir = common::tempdir();
    let fixture = common::package_root().join("fixtures/paper_heat_run.mcap");
    std::fs::copy(fixture, dir.path().join("fixture.mcap")).unwrap();
    orders_give_the_same_report(dir.path(), "fixture.mcap");
}

#[test]
fn a_noisy_10_hz_run_in_any_order_gives_the_same_report() {
    let dir = common::tempdir();
    noisy_10_hz(&dir.path().join("noisy.mcap"));
    orders_give_the_same_report(dir.path(), "noisy.mcap");
}

#[test]
fn local_disorder_changes_nothing() {
    // The builder's own shuffle of a 1 Hz run, metadata first.
    let dir = common::tempdir();
    let base = RecordingBuilder::from_synth(5000.0);
    base.write(&dir.path().join("clean.mcap"));
    let clean = replay_ok(dir.path(), "clean.mcap");
    base.write_with(
        &dir.path().join("shuffled.mcap"),
        mcap::WriteOptions::new(),
        Some(7),
    );
    assert_same_numbers(
        "shuffled.mcap",
        &replay_ok(dir.path(), "shuffled.mcap"),
        &clean,
    );
}

/// The time constants of a report, ascending.
fn time_constants(report: &Value) -> Vec<f64> {
    let mut t: Vec<f64> = report["time_constants_s"]
        .as_array()
        .expect("time constants")
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    t.sort_by(f64::total_cmp);
    t
}

#[test]
fn an_output_gap_is_simulated_through_not_cut() {
    let dir = common::tempdir();
    let clean = RecordingBuilder::from_synth(6000.0);
    clean.write(&dir.path().join("clean.mcap"));
    let reference = replay_ok(dir.path(), "clean.mcap");
    // Five minutes of the core temperature missing.
    let mut r = RecordingBuilder::from_synth(6000.0);
    let core = r.channel_of("core_temp");
    r.channels[core]
        .2
        .retain(|(t, _)| !(T0 + 2_000_000_000_000..T0 + 2_300_000_000_000).contains(t));
    r.write(&dir.path().join("gap.mcap"));
    let out = replay(dir.path(), "gap.mcap");
    assert_eq!(out.code, 0, "{}", out.stderr);
    assert!(
        out.stdout.contains("/scada/core_temp has 1 gap(s)")
            && out.stdout.contains("1 segment(s)")
            && out
                .stdout
                .contains("core_temp 300 instant(s) unobserved (simulated through)")
            && !out.stdout.contains("no equation bridges"),
        "{}",
        out.stdout
    );
    let report = out.report.expect("a report");
    let gaps = &report["estimation"]["gaps"];
    assert_eq!(gaps["unobserved"][0]["state"], "core_temp");
    assert_eq!(gaps["unobserved"][0]["instants"], 300);
    // The other states keep every instant: the noise-free model comes back as without
    // the gap.
    for (got, want) in time_constants(&report)
        .iter()
        .zip(time_constants(&reference))
    {
        assert!((got / want - 1.0).abs() < 1e-3, "{got} against {want}");
    }
}

#[test]
fn a_short_input_gap_is_bridged_and_a_long_one_cuts() {
    let dir = common::tempdir();
    let clean = RecordingBuilder::from_synth(6000.0);
    clean.write(&dir.path().join("clean.mcap"));
    let reference = replay_ok(dir.path(), "clean.mcap");
    // Twenty single armature-current samples lost ("I/O Timeout" cells) and one 5-minute
    // outage of the link.
    let mut r = RecordingBuilder::from_synth(6000.0);
    let current = r.channel_of("armature_current");
    let second = 1_000_000_000u64;
    r.channels[current].2.retain(|(t, _)| {
        let s = (t - T0) / second;
        let timeout = s % 250 == 17 && s < 5000;
        let outage = (4000..4300).contains(&s);
        !(timeout || outage)
    });
    r.write(&dir.path().join("gaps.mcap"));
    let out = replay(dir.path(), "gaps.mcap");
    assert_eq!(out.code, 0, "{}", out.stderr);
    let report = out.report.expect("a report");
    let inputs = report["estimation"]["gaps"]["inputs"]
        .as_array()
        .expect("the inputs' gaps")
        .clone();
    // The loss computed from the current: its single losses bridged, the outage cut.
    let copper = inputs
        .iter()
        .find(|i| i["input"] == "armature_copper_loss")
        .unwrap_or_else(|| panic!("{inputs:?}"));
    assert_eq!(copper["bridge"], "hold");
    assert_eq!(copper["cut"], 1, "{copper}");
    assert!(copper["bridged"].as_u64().unwrap() >= 18, "{copper}");
    assert!(
        out.stdout.contains("2 segment(s)")
            && out.stdout.contains("cut the data")
            && out.stdout.contains("bridged (its last value held"),
        "{}",
        out.stdout
    );
    for (got, want) in time_constants(&report)
        .iter()
        .zip(time_constants(&reference))
    {
        assert!((got / want - 1.0).abs() < 5e-3, "{got} against {want}");
    }
}

#[test]
fn a_channel_stored_by_exception() {
    // The core temperature as a historian stores it: a sample when it moved by more than
    // 0.05 K since the last stored one, or after 600 s without one.
    let dir = common::tempdir();
    let sampled = RecordingBuilder::from_synth(8000.0);
    sampled.write(&dir.path().join("sampled.mcap"));
    let reference = replay_ok(dir.path(), "sampled.mcap");
    let mut r = RecordingBuilder::from_synth(8000.0);
    let core = r.channel_of("core_temp");
    let (deadband, max_interval_ns) = (0.05, 600_000_000_000u64);
    let value = |s: &(u64, String)| -> f64 {
        serde_json::from_str::<Value>(&s.1).unwrap()["value"]
            .as_f64()
            .unwrap()
    };
    let mut stored: Vec<(u64, String)> = Vec::new();
    for s in &r.channels[core].2 {
        let keep = stored.last().is_none_or(|last| {
            (value(s) - value(last)).abs() > deadband || s.0 - last.0 >= max_interval_ns
        });
        if keep {
            stored.push(s.clone());
        }
    }
    let kept = stored.len();
    r.channels[core].2 = stored;
    let meta = &mut r.channels[core].1;
    meta.insert("storage".into(), "exception".into());
    meta.insert("deadband".into(), deadband.to_string());
    meta.insert("max_interval_s".into(), "600".into());
    r.write(&dir.path().join("exception.mcap"));
    let out = replay(dir.path(), "exception.mcap");
    assert_eq!(out.code, 0, "{}", out.stderr);
    assert!(kept < 8000 / 4, "{kept} samples stored of 8000");
    assert!(!out.stdout.contains("gap"), "{}", out.stdout);
    let report = out.report.unwrap();
    // The interpolated core temperature is within the deadband of the sampled one, so
    // the steady state moves by a fraction of it.
    let temps = |r: &Value| -> Vec<f64> {
        r["steady_state"]["temperature_c"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect()
    };
    for (a, b) in temps(&report).iter().zip(temps(&reference)) {
        assert!((a - b).abs() < deadband, "{a} vs {b}");
    }
    let info = heatrun(&["info", "exception.mcap"], dir.path());
    let text = String::from_utf8_lossy(&info.stdout);
    assert!(
        text.contains("stored by exception (deadband 0.05 degC, at most every 600 s)"),
        "{text}"
    );
}

#[test]
fn a_channel_that_stops_early_is_named() {
    let dir = common::tempdir();
    let mut r = RecordingBuilder::from_synth(6000.0);
    let voltage = r.channel_of("line_voltage");
    r.channels[voltage].2.truncate(4500); // line voltage stops at 4500 s
    r.write(&dir.path().join("r.mcap"));
    let out = replay(dir.path(), "r.mcap");
    assert_eq!(out.code, 0, "{}", out.stderr);
    assert!(
        out.stdout.contains("line_voltage stops at")
            && out.stdout.contains("1500 s before the recording ends"),
        "{}",
        out.stdout
    );
}

#[test]
fn a_clock_jump_backwards_is_refused_in_any_order() {
    let dir = common::tempdir();
    let r = RecordingBuilder::from_synth(6000.0);
    // From 4000 s on, the stator RTD's clock is an hour behind: its samples carry times
    // from 400 s on again, so 400–2400 s come twice.
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
    // Written in arrival order (as the recorder got them), then stored in other orders.
    r.write_in_order(&dir.path().join("arrival.mcap"), &order);
    layouts::rewrite(
        &dir.path().join("arrival.mcap"),
        &dir.path().join("shuffled.mcap"),
        Order::Shuffled(5),
    );
    layouts::rewrite(
        &dir.path().join("arrival.mcap"),
        &dir.path().join("by-channel.mcap"),
        Order::ChannelByChannel(2000),
    );
    let at = |s: u64| heatrun::recording::format_time(T0 + s * 1_000_000_000);
    for file in ["arrival.mcap", "shuffled.mcap", "by-channel.mcap"] {
        let out = replay(dir.path(), file);
        assert_eq!(out.code, 2, "{file}: {}", out.stderr);
        // Both times, at the resolution of the stretches the density is judged over.
        let times: Vec<&str> = out
            .stderr
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|w| w.starts_with("2020-"))
            .collect();
        assert!(
            out.stderr.contains(file)
                && out.stderr.contains("/scada/stator_winding_temp")
                && out.stderr.contains("clock jumps back")
                && times.len() == 2
                && times[0] >= at(380).as_str()
                && times[0] <= at(420).as_str()
                && times[1] >= at(2380).as_str()
                && times[1] <= at(2400).as_str(),
            "{file}: {}",
            out.stderr
        );
    }
    // `info` shows the channel's period and the jump.
    let info = heatrun(&["info", "shuffled.mcap"], dir.path());
    let text = String::from_utf8_lossy(&info.stdout);
    assert!(
        text.contains("/scada/stator_winding_temp: its clock jumps back") && !text.contains(" ? s"),
        "{text}"
    );
}

#[test]
fn too_short_and_unstable_recordings_are_refused() {
    let dir = common::tempdir();
    RecordingBuilder::heat_run(40.0, "").write(&dir.path().join("short.mcap"));
    let r = replay(dir.path(), "short.mcap");
    assert_eq!(r.code, 2);
    assert!(r.stderr.contains("too few"), "{}", r.stderr);
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
    let r = replay(dir.path(), "runaway.mcap");
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(
        r.stderr.contains("not a stable thermal system") || r.stderr.contains("unstable"),
        "{}",
        r.stderr
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
    let r = replay(dir.path(), "camera.mcap");
    assert_eq!(r.code, 2);
    assert!(
        r.stderr.contains("holds no heat-run data") && r.stderr.contains("/camera/front"),
        "{}",
        r.stderr
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
    let reference = replay_ok(dir.path(), "default.mcap");
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
        assert_same_numbers(name, &replay_ok(dir.path(), &file), &reference);
        let info = heatrun(&["info", &file], dir.path());
        assert_eq!(info.status.code(), Some(0), "{name}");
    }
}

#[test]
fn fuzz_findings_stay_fixed() {
    // Inputs cargo-fuzz found crashing the recording path, kept as regressions, with the
    // outcome each must have.
    let expected: [(&str, i32, &str); 3] = [
        // A chunk header claiming 2.4·10¹⁷ bytes: the chunk is refused unread, and nothing
        // else in the file is a sample.
        (
            "fuzz-oversized-chunk.mcap",
            2,
            "f.mcap: the recording holds no heat-run samples",
        ),
        // A short attachment record (mcap 0.26's parser panicked on it): skipped unparsed;
        // the file ends before any channel.
        (
            "fuzz-short-attachment.mcap",
            2,
            "f.mcap: the file ends after 59 bytes, before any channel was defined",
        ),
        // A timestamp decades before the rest: the grid is not laid out to it.
        (
            "fuzz-stray-timestamp.mcap",
            2,
            "f.mcap: the samples span 2018-01-01T06:12:00Z to 2019-06-03T06:00:42Z, far more \
             sample times than there are samples",
        ),
    ];
    let found = common::package_root().join("tests/data");
    let mut files: Vec<String> = std::fs::read_dir(found.clone())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    let listed: Vec<&str> = expected.iter().map(|e| e.0).collect();
    assert_eq!(files, listed, "every regression has its documented outcome");
    for (name, code, message) in expected {
        let dir = common::tempdir();
        std::fs::copy(found.join(name), dir.path().join("f.mcap")).unwrap();
        let out = replay(dir.path(), "f.mcap");
        assert_eq!(out.code, code, "{name}: {}", out.stderr);
        assert!(out.stderr.contains(message), "{name}: {}", out.stderr);
    }
}
