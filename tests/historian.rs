//! A plant historian's export of a heat run, with the flaws real exports have: `;` and
//! decimal commas, the current in kA with "I/O Timeout" cells, temperatures stored by
//! exception (0.05 K deadband, 10-minute heartbeat), a coolant inlet drifting 1 K, and
//! stator values flagged Bad; and the same run stored on every change but imported as
//! ordinary sampled channels (seconds without a value where it did not change). Each is
//! replayed beside the same run straight from `heatrun synth`, and against its truth.

use crate::common;

use std::collections::BTreeMap;
use std::path::Path;

use common::heatrun_ok;
use serde_json::Value;

const S: u64 = 1_000_000_000;

/// Every channel of a recording: topic → (log time, value or `None` for a dropout).
pub(crate) fn samples(path: &Path) -> BTreeMap<String, Vec<(u64, Option<f64>)>> {
    let bytes = std::fs::read(path).unwrap();
    let mut out: BTreeMap<String, Vec<(u64, Option<f64>)>> = BTreeMap::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let text = String::from_utf8(m.data.to_vec()).unwrap();
        let value = serde_json::from_str::<Value>(&text)
            .ok()
            .and_then(|v| v["value"].as_f64());
        out.entry(m.channel.topic.clone())
            .or_default()
            .push((m.log_time, value));
    }
    out
}

/// A number as a German historian writes it: decimal comma.
fn german(v: f64) -> String {
    format!("{v}").replace('.', ",")
}

/// The recording as a historian's `;` table: one row per distinct time (seconds after
/// the first sample), a column per channel, empty where it has no sample, "I/O Timeout"
/// where the current's sample is missing, and a status column for the stator winding
/// with `Bad` on `bad_stator` of its rows. Returns the table and its map (temperatures
/// declared stored by exception with `deadband`, or as sampled channels).
pub(crate) fn historian_export(
    path: &Path,
    deadband: Option<f64>,
    bad_stator: usize,
) -> (String, String, u64) {
    let channels = samples(path);
    let topics: Vec<&String> = channels.keys().collect();
    let t0 = channels.values().map(|c| c[0].0).min().unwrap();
    let mut rows: BTreeMap<u64, Vec<String>> = BTreeMap::new();
    let columns = topics.len() + 1;
    for (j, topic) in topics.iter().enumerate() {
        for &(t, v) in &channels[*topic] {
            let cell = match v {
                Some(v) => german(v),
                None if topic.ends_with("armature_current") => "I/O Timeout".into(),
                None => String::new(),
            };
            rows.entry(t - t0)
                .or_insert_with(|| vec![String::new(); columns])[j] = cell;
        }
    }
    // Bad flags on stator rows spread over the run.
    let stator = topics
        .iter()
        .position(|t| t.ends_with("stator_winding_temp"))
        .unwrap();
    let stator_rows: Vec<u64> = rows
        .iter()
        .filter(|(_, cells)| !cells[stator].is_empty())
        .map(|(t, _)| *t)
        .collect();
    for i in 0..bad_stator {
        let t = stator_rows[(i + 1) * stator_rows.len() / (bad_stator + 1)];
        rows.get_mut(&t).unwrap()[columns - 1] = "Bad".into();
    }
    for (t, cells) in rows.iter_mut() {
        if !cells[stator].is_empty() && cells[columns - 1].is_empty() {
            cells[columns - 1] = if t % 2 == 0 { "Good" } else { "good" }.into();
        }
    }
    let name = |t: &str| t.trim_start_matches("/scada/").to_owned();
    let mut table = format!(
        "Zeit;{};Status Stator\n",
        topics.iter().map(|t| name(t)).collect::<Vec<_>>().join(";")
    );
    for (t, cells) in &rows {
        table.push_str(&format!("{},{:09};{}\n", t / S, t % S, cells.join(";")));
    }
    let mut map = format!(
        "[input]\ndelimiter = \";\"\ndecimal_comma = true\nmissing = [\"I/O Timeout\"]\n\
         [time]\ncolumn = \"Zeit\"\nformat = \"seconds\"\nstart = \"{}\"\n",
        heatrun::recording::format_time(t0)
    );
    for topic in &topics {
        let q = name(topic);
        let unit = if q == "armature_current" || q == "line_voltage" {
            "kA"
        } else if q.ends_with("_temp") {
            "degC"
        } else if q == "cooling_water_flow" {
            "l/s"
        } else if q == "field_current" {
            "A"
        } else {
            "V"
        };
        let unit = if q == "line_voltage" { "kV" } else { unit };
        map.push_str(&format!(
            "[[column]]\ncolumn = \"{q}\"\nquantity = \"{q}\"\nunit = \"{unit}\"\n"
        ));
        if q == "stator_winding_temp" {
            map.push_str("quality_column = \"Status Stator\"\n");
        }
        if let (Some(d), true) = (deadband, q.ends_with("_temp")) {
            map.push_str(&format!(
                "storage = \"exception\"\ndeadband = {d}\nmax_interval_s = 600\n"
            ));
        }
    }
    for record in mcap::read::LinearReader::new(&std::fs::read(path).unwrap()).unwrap() {
        if let mcap::records::Record::Metadata(m) = record.unwrap() {
            map.push_str(&if m.name == "heatrun.nameplate" {
                "[nameplate]\n".to_owned()
            } else {
                format!("[metadata.\"{}\"]\n", m.name)
            });
            for (k, v) in &m.metadata {
                map.push_str(&format!("{k} = \"{v}\"\n"));
            }
        }
    }
    (table, map, t0)
}

/// The time constants of a replay's report, ascending.
pub(crate) fn time_constants(dir: &Path, mcap: &str) -> Vec<f64> {
    let report = format!("{mcap}.json");
    heatrun_ok(&["replay", mcap, "--report", &report, "-q"], dir);
    let r: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join(report)).unwrap()).unwrap();
    let mut t: Vec<f64> = r["time_constants_s"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    t.sort_by(f64::total_cmp);
    t
}

pub(crate) fn truth(dir: &Path, mcap: &str) -> Vec<f64> {
    let t: Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join(format!("{mcap}.truth.json"))).unwrap(),
    )
    .unwrap();
    t["time_constants_s"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect()
}

pub(crate) fn synth(dir: &Path, out: &str, extra: &[&str]) {
    let mut args = vec![
        "synth",
        out,
        "--machine",
        "rc-unit",
        "--temperature-noise",
        "0.05",
        "--resolution",
        "0.01",
        "--seed",
        "5",
    ];
    args.extend_from_slice(extra);
    heatrun_ok(&args, dir);
}

pub(crate) fn import(dir: &Path, table: &str, map: &str, out: &str) {
    heatrun_ok(&["import", table, "--map", map, "--out", out], dir);
}

/// Relative differences, %.
pub(crate) fn percent(got: &[f64], want: &[f64]) -> Vec<f64> {
    got.iter()
        .zip(want)
        .map(|(g, w)| 100.0 * (g / w - 1.0))
        .collect()
}

#[test]
fn a_historian_export_replays_as_the_run_it_came_from() {
    let dir = common::tempdir();
    let d = dir.path();
    // The run as the historian stored it, and the same run sampled (the noise is drawn
    // for every sample either way: the same realisation).
    let flaws = [
        "--deadband",
        "0.05",
        "--heartbeat",
        "600",
        "--inlet-drift",
        "1",
        "--input-timeouts",
        "20",
    ];
    synth(d, "stored.mcap", &flaws);
    synth(d, "sampled.mcap", &["--inlet-drift", "1"]);
    let (table, map, _) = historian_export(&d.join("stored.mcap"), Some(0.05), 12);
    std::fs::write(d.join("export.csv"), table).unwrap();
    std::fs::write(d.join("export.toml"), map).unwrap();
    import(d, "export.csv", "export.toml", "imported.mcap");

    let truth = truth(d, "sampled.mcap");
    let sampled = time_constants(d, "sampled.mcap");
    let stored = time_constants(d, "stored.mcap");
    let imported = time_constants(d, "imported.mcap");
    eprintln!(
        "truth {truth:?}\nsampled {:?} %\nstored {:?} %\nimported {:?} %",
        percent(&sampled, &truth),
        percent(&stored, &truth),
        percent(&imported, &truth)
    );
    // The export is the stored run: the same time constants but for the Bad values.
    for (p, q) in percent(&imported, &stored).iter().zip([0.2, 0.2, 0.2]) {
        assert!(
            p.abs() < q,
            "imported against stored {imported:?} {stored:?}"
        );
    }
    // Storage by exception and the flaws cost little beside the noise itself.
    for p in percent(&stored, &sampled) {
        assert!(
            p.abs() < 1.0,
            "stored against sampled {stored:?} {sampled:?}"
        );
    }
}

#[test]
fn an_export_on_change_imported_as_sampled_is_not_cut() {
    let dir = common::tempdir();
    let d = dir.path();
    // Stored on every change (no deadband), as many historians do by default, with a
    // 10-minute heartbeat; imported as ordinary sampled channels: the seconds where a
    // value did not change have none.
    synth(
        d,
        "on_change.mcap",
        &["--deadband", "0", "--heartbeat", "600"],
    );
    synth(d, "sampled.mcap", &[]);
    let (table, map, _) = historian_export(&d.join("on_change.mcap"), None, 0);
    std::fs::write(d.join("export.csv"), table).unwrap();
    std::fs::write(d.join("export.toml"), map).unwrap();
    import(d, "export.csv", "export.toml", "imported.mcap");
    let report = "imported.json";
    heatrun_ok(&["replay", "imported.mcap", "--report", report, "-q"], d);
    let r: Value = serde_json::from_str(&std::fs::read_to_string(d.join(report)).unwrap()).unwrap();
    // Missing seconds are unobserved, not cuts.
    let unobserved = r["estimation"]["gaps"]["unobserved"].as_array().unwrap();
    let core = unobserved
        .iter()
        .find(|u| u["state"] == "core_temp")
        .unwrap();
    let instants = r["estimation"]["instants"].as_f64().unwrap();
    let share = core["instants"].as_f64().unwrap() / instants;
    assert!((0.02..0.15).contains(&share), "{share}");
    assert!(
        r["estimation"]["segments"].as_u64().unwrap() <= 2,
        "{}",
        r["estimation"]
    );
    let truth = truth(d, "sampled.mcap");
    let sampled = time_constants(d, "sampled.mcap");
    let imported = time_constants(d, "imported.mcap");
    eprintln!(
        "truth {truth:?}\nsampled {:?} %\nimported {:?} %",
        percent(&sampled, &truth),
        percent(&imported, &truth)
    );
    for p in percent(&imported, &sampled) {
        assert!(
            p.abs() < 0.5,
            "imported against sampled {imported:?} {sampled:?}"
        );
    }
}
