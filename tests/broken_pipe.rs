//! A reader that stops early (`heatrun info f.mcap | head -1`) ends heatrun quietly:
//! no panic message, and every output written before the first print is complete.

use std::path::Path;
use std::process::{Command, ExitStatus, Stdio};

use crate::common;

/// Runs heatrun with its stdout a pipe whose read end is closed before heatrun writes;
/// returns the status and stderr.
fn run_with_closed_stdout(args: &[&str], cwd: &Path) -> (ExitStatus, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_heatrun"))
        .args(args)
        .current_dir(cwd)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("heatrun starts");
    drop(child.stdout.take()); // the reader is gone
    let out = child.wait_with_output().expect("heatrun ends");
    (
        out.status,
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Killed by SIGPIPE, as `cat` or `grep` would be.
#[cfg(unix)]
fn ended_by_the_closed_pipe(status: ExitStatus) -> bool {
    use std::os::unix::process::ExitStatusExt;
    status.signal() == Some(libc::SIGPIPE)
}

#[cfg(not(unix))]
fn ended_by_the_closed_pipe(status: ExitStatus) -> bool {
    status.success()
}

#[test]
fn replay_into_a_closed_pipe_ends_quietly_with_its_outputs_complete() {
    let dir = common::tempdir();
    let fixture = common::package_root().join("fixtures/paper_heat_run.mcap");
    // The replay takes a good part of a second before its first print, so the pipe is
    // certainly closed by then.
    let (status, stderr) = run_with_closed_stdout(
        &[
            "replay",
            fixture.to_str().unwrap(),
            "--rrd",
            "run.rrd",
            "--report",
            "report.json",
        ],
        dir.path(),
    );
    assert!(stderr.is_empty(), "{stderr}");
    assert!(ended_by_the_closed_pipe(status), "{status:?}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("report.json")).unwrap())
            .unwrap();
    assert_eq!(report["profile"], "heatrun-scada/1");
    let names: Vec<_> = common::files_in(dir.path())
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, ["report.json", "run.rrd"]);
}

#[test]
fn info_into_a_closed_pipe_ends_quietly() {
    let fixture = common::package_root().join("fixtures/paper_heat_run.mcap");
    for args in [&["info"][..], &["info", "--json"]] {
        let mut args = args.to_vec();
        args.push(fixture.to_str().unwrap());
        let (status, stderr) = run_with_closed_stdout(&args, &common::package_root());
        assert!(stderr.is_empty(), "{args:?}: {stderr}");
        // A reader that closes only after info has written all (it is quick) sees a
        // normal end: either way, no message and no failure status.
        assert!(
            ended_by_the_closed_pipe(status) || status.success(),
            "{args:?}: {status:?}"
        );
    }
}
