//! What a person reads of a hidden-state replay — the summary, its warnings and the HTML
//! page — describes the replay's model, the hidden one: a known unit with a node no
//! sensor reads (the "rc field" machine, `FieldChannel::Unmeasured`) replayed with
//! `[hidden]` (order 4 given). The references are the replay's own two models, read from
//! the `Replay` apart from the report and the page.

use crate::pipeline::{replay, ReplayOptions};
use crate::report::Replayed;
use crate::spec::hidden::HiddenSpec;
use crate::spec::ModelDescription;
use crate::synth;

fn hidden_replay(dir: &std::path::Path) -> (Replayed, ReplayOptions) {
    let mcap = dir.join("field-unmeasured.mcap");
    synth::write(&mcap, &synth::example::field_unmeasured(7)).unwrap();
    let mut model = ModelDescription::generator();
    model.hidden = Some(HiddenSpec::given(4));
    let options = ReplayOptions {
        ts_s: 10.0,
        model,
        ..ReplayOptions::default()
    };
    (Replayed::new(replay(&mcap, &options).unwrap()), options)
}

#[test]
fn the_summary_and_the_page_of_a_hidden_replay_describe_the_hidden_model() {
    let dir = tempfile::tempdir().unwrap();
    let (replayed, options) = hidden_replay(dir.path());
    let (r, report) = (&replayed.replay, &replayed.report);
    let h = r.hidden.as_ref().unwrap();
    let slowest = *h
        .analysis
        .as_ref()
        .unwrap()
        .spectrum
        .time_constants_s
        .last()
        .unwrap();
    let measured_slowest = *r.analysis.spectrum.time_constants_s.last().unwrap();
    println!(
        "slowest: hidden-state model {slowest:.1} s, measured-state model {measured_slowest:.1} s"
    );
    assert!(
        (slowest - measured_slowest).abs() > 1.0,
        "the two models differ here"
    );

    // The equilibrium (report, warning, summary) is judged against the hidden model's.
    let e = report.equilibrium.as_ref().unwrap();
    assert_eq!(e.slowest_time_constant_s, slowest);
    assert!((e.held_over_slowest - e.held_s / slowest).abs() < 1e-12);
    for w in report
        .warnings
        .iter()
        .filter(|w| w.contains("slowest time constant"))
    {
        assert!(w.contains(&format!("({slowest:.0} s)")), "{w}");
    }
    let summary = &replayed.summary;
    assert!(
        summary.contains("Φ (eq. 19) of the measured-state model:"),
        "{summary}"
    );
    assert!(summary.contains("residuals (simulation error) of the measured-state model"));
    assert!(summary.contains("rows: the measured outputs"));
    assert!(summary.contains("fit of the hidden-state model"));

    // The page: the hidden model's matrices, its temperatures and sensitivities drawn.
    let page = crate::html::replay_page(&replayed, &options)
        .render()
        .unwrap();
    assert!(page.contains("(hidden-state model: subspace start, output error, Ts = 10 s)"));
    assert!(!page.contains(&format!("({} estimate, Ts", report.method)));
    assert!(page.contains("Φ of the hidden-state model."));
    assert!(page.contains("C of the hidden-state model"));
    assert!(page.contains("measured and hidden-state model (grey: the measured-state model)"));
    assert!(page.contains("Φ (eq. 19) of the measured-state model."));
    // One sensitivity chart per time constant of the hidden model's four, each captioned
    // with the report's (the hidden model's) assignment.
    for (i, a) in report.assignment.iter().enumerate() {
        let caption = format!(
            "Sensitivity responses to T{} = {} s, which belongs to the {}.",
            i + 1,
            super::markup::fixed(a.time_constant_s, 2),
            a.part
        );
        assert!(page.contains(&crate::html::escape(&caption)), "{caption}");
    }
    assert_eq!(report.assignment.len(), 4);
    assert!(!page.contains("Sensitivity responses to T5"));
}
