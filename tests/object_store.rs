//! Object storage, against a real S3-compatible server on loopback (moto's, started by
//! each test): a recording read from `s3://` gives the same report as the local file; a
//! prefix is a fleet (three recordings, three rows); `--index` picks one recording of a
//! prefix into an output prefix; `fleet summary` reduces an output prefix into the same
//! table as the fleet replay; a missing bucket or object is one line naming the URL, exit 2.

use std::path::Path;

use crate::common::s3::S3Server;
use crate::common::{heatrun_ok, package_root};

fn fixture() -> std::path::PathBuf {
    package_root().join("fixtures/paper_heat_run.mcap")
}

/// A report's JSON without the recording's own name (a path here, a URL there).
fn report_without_path(file: &Path) -> serde_json::Value {
    let mut report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(file).unwrap()).unwrap();
    report["recording"]["path"] = serde_json::Value::Null;
    report
}

fn assert_ok(out: &std::process::Output, what: &str) {
    assert!(
        out.status.success(),
        "{what} failed ({:?}): {}",
        out.status.code(),
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn a_recording_in_s3_gives_the_same_report_as_the_local_file() {
    let Some(s3) = S3Server::start() else { return };
    s3.boto3("s3.create_bucket(Bucket='heatruns')");
    s3.upload(&fixture(), "heatruns", "2024/unit 1.mcap");
    let dir = tempfile::tempdir().unwrap();
    let fixture = fixture();
    heatrun_ok(
        &[
            "replay",
            fixture.to_str().unwrap(),
            "--report",
            "local.json",
            "--rrd",
            "local.rrd",
            "-q",
        ],
        dir.path(),
    );
    let out = s3.heatrun(
        &[
            "replay",
            "s3://heatruns/2024/unit%201.mcap",
            "--report",
            "s3://heatruns/reports/unit 1.json",
            "--rrd",
            "remote.rrd",
            "-q",
        ],
        dir.path(),
    );
    assert_ok(&out, "replay s3://");
    s3.download(
        "heatruns",
        "reports/unit 1.json",
        &dir.path().join("remote.json"),
    );
    // `info` reads the footer, summary and metadata by ranged requests, not the data.
    let info = s3.heatrun(
        &["info", "s3://heatruns/2024/unit%201.mcap", "--json"],
        dir.path(),
    );
    assert_ok(&info, "info s3://");
    let index: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    let (fetched, size) = (
        index["fetched_bytes"].as_u64().unwrap(),
        index["object_bytes"].as_u64().unwrap(),
    );
    println!(
        "info s3://: {fetched} of {size} bytes fetched ({:.2} %) in {} ranged requests",
        100.0 * fetched as f64 / size as f64,
        index["requests"]
    );
    assert_eq!(size, std::fs::metadata(&fixture).unwrap().len());
    assert!(
        fetched * 10 < size,
        "info fetched {fetched} of {size} bytes"
    );
    assert!(
        index["metadata"]["heatrun.nameplate"].is_object(),
        "{index}"
    );

    let local = report_without_path(&dir.path().join("local.json"));
    let remote = report_without_path(&dir.path().join("remote.json"));
    assert_eq!(
        local, remote,
        "the report of s3:// differs from the local file's"
    );
}

#[test]
fn a_prefix_is_a_fleet_and_fleet_summary_reduces_its_reports_alike() {
    let Some(s3) = S3Server::start() else { return };
    s3.boto3("s3.create_bucket(Bucket='fleet')");
    for name in ["a", "b", "c"] {
        s3.upload(&fixture(), "fleet", &format!("in/{name}.mcap"));
    }
    // Not a recording, and one in a deeper "folder": neither is part of the fleet.
    s3.boto3("s3.put_object(Bucket='fleet', Key='in/notes.txt', Body=b'x')");
    s3.upload(&fixture(), "fleet", "in/old/d.mcap");
    let dir = tempfile::tempdir().unwrap();
    let replay = s3.heatrun(
        &[
            "replay",
            "s3://fleet/in/",
            "--out-dir",
            "s3://fleet/out/",
            "--jobs",
            "2",
            "-q",
        ],
        dir.path(),
    );
    assert_ok(&replay, "replay of a prefix");
    s3.download(
        "fleet",
        "out/fleet-summary.csv",
        &dir.path().join("replayed.csv"),
    );
    let replayed = std::fs::read_to_string(dir.path().join("replayed.csv")).unwrap();
    let rows: Vec<&str> = replayed.lines().skip(1).collect();
    assert_eq!(rows.len(), 3, "{replayed}");
    for (row, name) in rows.iter().zip(["a", "b", "c"]) {
        assert!(
            row.starts_with(&format!("s3://fleet/in/{name}.mcap,ok,")),
            "{row}"
        );
    }
    let listed = s3.boto3(
        "print(sorted(o['Key'] for o in s3.list_objects_v2(Bucket='fleet', Prefix='out/')['Contents']))",
    );
    for name in ["a", "b", "c"] {
        assert!(
            listed.contains(&format!("out/{name}.report.json")),
            "{listed}"
        );
        assert!(listed.contains(&format!("out/{name}.rrd")), "{listed}");
    }

    // The cluster's way: the summary gathered from the reports is the replay's table.
    let summary = s3.heatrun(
        &[
            "fleet",
            "summary",
            "s3://fleet/out/",
            "--csv",
            "gathered.csv",
        ],
        dir.path(),
    );
    assert_ok(&summary, "fleet summary");
    let gathered = std::fs::read_to_string(dir.path().join("gathered.csv")).unwrap();
    assert_eq!(gathered, replayed);
}

#[test]
fn index_replays_the_nth_recording_of_a_prefix_or_a_listing() {
    let Some(s3) = S3Server::start() else { return };
    s3.boto3("s3.create_bucket(Bucket='array')");
    for name in ["c", "a", "b"] {
        s3.upload(&fixture(), "array", &format!("in/{name}.mcap"));
    }
    let dir = tempfile::tempdir().unwrap();
    let out = s3.heatrun(
        &[
            "replay",
            "--index",
            "1",
            "s3://array/in/",
            "--out-dir",
            "s3://array/out",
            "-q",
        ],
        dir.path(),
    );
    assert_ok(&out, "replay --index 1 PREFIX");
    let listed = s3.boto3(
        "print(sorted(o['Key'] for o in s3.list_objects_v2(Bucket='array', Prefix='out/')['Contents']))",
    );
    assert_eq!(listed.trim(), "['out/b.report.json', 'out/b.rrd']");

    // A listing (a text file, here in the store too); the task number from Slurm's variable.
    s3.boto3("s3.put_object(Bucket='array', Key='list.txt', Body=b's3://array/in/c.mcap\\n# a comment\\ns3://array/in/a.mcap\\n')");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_heatrun"))
        .args([
            "replay",
            "--index-from-env",
            "s3://array/list.txt",
            "--out-dir",
            "s3://array/listed/",
            "-q",
        ])
        .envs(s3.env())
        .env("SLURM_ARRAY_TASK_ID", "1")
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert_ok(&out, "replay --index-from-env LISTING");
    let listed = s3.boto3(
        "print(sorted(o['Key'] for o in s3.list_objects_v2(Bucket='array', Prefix='listed/')['Contents']))",
    );
    assert_eq!(listed.trim(), "['listed/c.report.json', 'listed/c.rrd']");

    let past = s3.heatrun(
        &["replay", "--index", "3", "s3://array/in/", "-q"],
        dir.path(),
    );
    assert_eq!(past.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&past.stderr);
    assert!(stderr.contains("lists 3 recordings"), "{stderr}");
}

#[test]
fn a_missing_bucket_or_object_is_one_line_naming_the_url() {
    let Some(s3) = S3Server::start() else { return };
    s3.boto3("s3.create_bucket(Bucket='there')");
    let dir = tempfile::tempdir().unwrap();
    for (url, said) in [
        ("s3://no-such-bucket/run.mcap", "no such bucket"),
        ("s3://there/missing.mcap", "no such object"),
    ] {
        for args in [
            vec!["replay", url, "-q"],
            vec!["info", url],
            vec!["rating", "--model", url],
        ] {
            let out = s3.heatrun(&args, dir.path());
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
            assert_eq!(stderr.lines().count(), 1, "{args:?}: {stderr}");
            assert!(
                stderr.contains(url) && stderr.contains(said),
                "{args:?}: {stderr}"
            );
            assert!(!stderr.contains("panicked"), "{stderr}");
        }
    }
    assert!(
        std::fs::read_dir(dir.path()).unwrap().next().is_none(),
        "a failed read left an output behind"
    );
}
