//! The inputs' plot draws every input that is not a boundary temperature: the losses, and
//! a spec's inputs that are not heat (a lamp's voltage to a power, a fan's speed), which
//! its title already named by their units and which were left out before.

use heatrun::pipeline::ReplayOptions;
use heatrun::spec::{InputKind, ModelDescription};
use heatrun::synth::{self, SynthOptions};

use crate::rrd_testing::replayed_and_drawn;

#[test]
fn an_input_that_is_not_heat_is_drawn_among_the_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let mcap = dir.path().join("run.mcap");
    synth::write(&mcap, &SynthOptions::default().with_noise_level(1.0)).unwrap();
    let mut model = ModelDescription::generator();
    model.inputs[1].kind = InputKind::Exogenous;
    let options = ReplayOptions {
        ts_s: 10.0,
        model,
        ..ReplayOptions::default()
    };
    let (replayed, drawn) = replayed_and_drawn(&mcap, &options);
    let s = &replayed.replay.signals;
    let kw = s.power_base / 1e3;
    for input in &s.inputs {
        let rows = &drawn[&format!("/loss/{}", input.name)];
        let want: Vec<(i64, f64)> = s
            .time_ns
            .iter()
            .zip(input.values.iter())
            .filter_map(|(t, v)| v.map(|v| (*t, v * kw)))
            .collect();
        assert_eq!(rows.len(), want.len(), "{} ({:?})", input.name, input.kind);
        let off = rows
            .iter()
            .zip(&want)
            .map(|(a, b)| (a.1 - b.1).abs())
            .fold(0.0, f64::max);
        assert!(off < 1e-9, "{}: {off}", input.name);
    }
    assert_eq!(s.inputs[1].kind, InputKind::Exogenous);
}
