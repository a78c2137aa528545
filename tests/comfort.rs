//! The CLI's comforts for scripts and shells: `replay --summary json` (the report on
//! stdout, nothing else), `completions` and `man` generated from the CLI's definitions.

use heatrun::synth::{self, SynthOptions};
use serde_json::Value;

use crate::common;
use crate::outputs::ReportSchema;

#[test]
fn the_json_summary_is_the_report_alone_on_stdout() {
    let dir = common::tempdir();
    let mcap = dir.path().join("run.mcap");
    synth::write(
        &mcap,
        &SynthOptions {
            duration_s: 6000.0,
            ..SynthOptions::default()
        },
    )
    .unwrap();
    let out = common::heatrun_ok(
        &[
            "replay",
            "run.mcap",
            "--rrd",
            "run.rrd",
            "--summary",
            "json",
        ],
        dir.path(),
    );
    // The whole of stdout is one JSON document: no summary table, no "replayed in".
    let report: Value = serde_json::from_slice(&out.stdout).expect("stdout is JSON");
    ReportSchema::load().check(&report).unwrap();
    assert_eq!(report["time_constants_s"].as_array().unwrap().len(), 3);
}

#[test]
fn completions_and_the_man_page_name_every_command() {
    let dir = common::tempdir();
    let bash = common::heatrun(&["completions", "bash"], dir.path());
    assert!(bash.status.success());
    let script = String::from_utf8(bash.stdout).unwrap();
    for command in ["replay", "synth", "info", "import"] {
        assert!(script.contains(command), "completion lacks {command}");
    }
    assert!(script.contains("--summary"));
    let man = common::heatrun(&["man", "--out", "heatrun.1"], dir.path());
    assert!(man.status.success());
    let page = std::fs::read_to_string(dir.path().join("heatrun.1")).unwrap();
    assert!(
        page.starts_with(".ie") && page.contains(".SH NAME"),
        "{page:.200}"
    );
    assert!(page.contains("replay"));
    let bad = common::heatrun(&["completions", "tcsh"], dir.path());
    assert_eq!(bad.status.code(), Some(2));
}

/// `heatrun man`: one stream holding every command's page with every option; one
/// command's page; a page per command in a folder it makes; an unknown command refused.
#[test]
fn man_pages_hold_every_command_and_option() {
    let dir = common::tempdir();
    let d = dir.path();
    let text = |out: std::process::Output| {
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8(out.stdout).unwrap()
    };
    let all = text(common::heatrun(&["man"], d));
    for needle in [
        "heatrun\\-replay",
        "heatrun\\-fleet\\-summary",
        "\\-\\-holdout",
        "\\-\\-guess",
        "\\-\\-machine",
        "\\-\\-index",
        "\\-\\-out\\-dir",
    ] {
        assert!(all.contains(needle), "`heatrun man` lacks {needle}");
    }
    // `heatrun man | grep -- --holdout` finds the option in the page's source too.
    assert!(
        all.lines().any(|l| l.contains(" --holdout")),
        "no plain --holdout"
    );
    let replay = text(common::heatrun(&["man", "replay"], d));
    assert!(replay.contains("\\-\\-holdout") && replay.contains(".TH heatrun-replay"));
    assert!(!replay.contains("heatrun\\-synth"), "only replay's page");
    let summary = text(common::heatrun(&["man", "fleet", "summary"], d));
    assert!(summary.contains(".TH heatrun-fleet-summary"));
    let wrote = common::heatrun(&["man", "--out-dir", "man/1"], d);
    assert!(wrote.status.success());
    for page in [
        "heatrun.1",
        "heatrun-replay.1",
        "heatrun-import.1",
        "heatrun-fleet-compare.1",
    ] {
        assert!(d.join("man/1").join(page).is_file(), "{page}");
    }
    // A file where the folder should be: refused as usage (exit 1 before, "File exists"),
    // here and for a fleet's outputs.
    for args in [
        &["man", "--out-dir", "man/1/heatrun.1"][..],
        &["replay", "man", "--out-dir", "man/1/heatrun.1"],
    ] {
        let file = common::heatrun(args, d);
        assert_eq!(file.status.code(), Some(2), "{args:?}");
        let message = String::from_utf8_lossy(&file.stderr);
        assert!(message.contains("is a file: name a folder"), "{message}");
    }
    let bad = common::heatrun(&["man", "replayy"], d);
    assert_eq!(bad.status.code(), Some(2));
    let message = String::from_utf8_lossy(&bad.stderr);
    assert!(
        message.contains("replayy") && message.contains("replay,"),
        "{message}"
    );
}

/// A short synthetic heat run of the RC unit in `dir`, written once per test: a machine
/// that is a thermal network, so `--method rc` fits it (the paper's model is none, and rc
/// says so in one line).
fn short_run(dir: &std::path::Path, name: &str) -> std::path::PathBuf {
    let mcap = dir.join(name);
    synth::write(
        &mcap,
        &SynthOptions {
            duration_s: 6000.0,
            machine: synth::Machine::Network(synth::NetworkMachine::rc_unit()),
            ..SynthOptions::default()
        },
    )
    .unwrap();
    mcap
}

/// Whether text shows a progress bar: the bars' words, a lone carriage return or an
/// escape sequence.
fn shows_progress(stderr: &[u8]) -> bool {
    // A terminal turns each newline into CR LF: only a lone CR redraws a line.
    let text = String::from_utf8_lossy(stderr).replace("\r\n", "\n");
    text.contains('\x1b')
        || text.contains('\r')
        || text.contains("reading")
        || text.contains("estimating")
        || text.contains("replaying")
        || text.contains("analysing")
}

#[test]
fn progress_never_goes_into_a_pipe() {
    let dir = common::tempdir();
    short_run(dir.path(), "a.mcap");
    // One recording (the reader's and the estimator's bars, rc for both fits), then a
    // fleet (recordings done): stderr is a pipe here, as in CI logs.
    let one = common::heatrun(
        &["replay", "a.mcap", "--method", "rc", "--rrd", "a.rrd"],
        dir.path(),
    );
    assert!(
        one.status.success(),
        "{}",
        String::from_utf8_lossy(&one.stderr)
    );
    assert!(
        !shows_progress(&one.stderr),
        "{:?}",
        String::from_utf8_lossy(&one.stderr)
    );
    let fleet_dir = dir.path().join("fleet");
    std::fs::create_dir(&fleet_dir).unwrap();
    short_run(&fleet_dir, "b.mcap");
    short_run(&fleet_dir, "c.mcap");
    let fleet = common::heatrun(&["replay", "fleet", "--out-dir", "out"], dir.path());
    assert!(
        fleet.status.success(),
        "{}",
        String::from_utf8_lossy(&fleet.stderr)
    );
    assert!(
        !shows_progress(&fleet.stderr),
        "{:?}",
        String::from_utf8_lossy(&fleet.stderr)
    );
}

/// Runs heatrun with stderr on a pseudo-terminal; returns its exit status and what it
/// wrote there.
#[cfg(unix)]
fn heatrun_on_a_terminal(args: &[&str], cwd: &std::path::Path) -> (bool, Vec<u8>) {
    use std::io::Read;
    use std::os::fd::FromRawFd;
    let (mut master, mut slave) = (0, 0);
    // SAFETY: openpty writes two file descriptors, which are owned by the Files below.
    let rc = unsafe {
        libc::openpty(
            &mut master,
            &mut slave,
            std::ptr::null_mut(),
            std::ptr::null(),
            std::ptr::null(),
        )
    };
    assert_eq!(rc, 0, "openpty");
    // SAFETY: both descriptors were just opened and are owned by nothing else.
    let (mut master, slave) = unsafe {
        (
            std::fs::File::from_raw_fd(master),
            std::fs::File::from_raw_fd(slave),
        )
    };
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_heatrun"))
        .args(args)
        .current_dir(cwd)
        .stdout(std::process::Stdio::null())
        .stderr(slave)
        .spawn()
        .expect("heatrun runs");
    // The terminal's buffer is small: read while the child writes. The read ends (EIO)
    // when the child, the last holder of the terminal's other end, exits.
    let reader = std::thread::spawn(move || {
        let mut out = Vec::new();
        let mut buf = [0u8; 4096];
        while let Ok(n) = master.read(&mut buf) {
            if n == 0 {
                break;
            }
            out.extend_from_slice(&buf[..n]);
        }
        out
    });
    let status = child.wait().unwrap();
    (status.success(), reader.join().unwrap())
}

#[cfg(unix)]
#[test]
fn progress_is_drawn_on_a_terminal_and_not_with_quiet() {
    let dir = common::tempdir();
    short_run(dir.path(), "a.mcap");
    let (ok, shown) = heatrun_on_a_terminal(
        &["replay", "a.mcap", "--method", "rc", "--rrd", "a.rrd"],
        dir.path(),
    );
    assert!(ok, "{}", String::from_utf8_lossy(&shown));
    let text = String::from_utf8_lossy(&shown);
    assert!(
        text.contains("reading") && text.contains("estimating"),
        "{text:?}"
    );
    let (ok, quiet) = heatrun_on_a_terminal(
        &["replay", "a.mcap", "--rrd", "a.rrd", "--quiet"],
        dir.path(),
    );
    assert!(ok);
    assert!(
        !shows_progress(&quiet),
        "{:?}",
        String::from_utf8_lossy(&quiet)
    );
}
