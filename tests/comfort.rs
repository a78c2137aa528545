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
    let out = common::heatrun(
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
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
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
