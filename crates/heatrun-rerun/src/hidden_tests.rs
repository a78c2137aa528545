//! An .rrd of a hidden-state replay carries the hidden model's outputs: a known unit
//! with a node no sensor reads (the "rc field" machine, `FieldChannel::Unmeasured`),
//! replayed with `[hidden]`, published, and read back with rerun's own decoder. The
//! reference is the hidden model's own simulation, ŷ = C x + D u from the initial state
//! fitted to the segment (`HiddenStateModel::simulate_segments`, what the report's fit
//! compares), computed here apart from the publisher; the measured-state model's
//! simulation is the trace it must not be.

use std::collections::BTreeMap;

use heatrun::pipeline::ReplayOptions;
use heatrun::spec::hidden::HiddenSpec;
use heatrun::spec::ModelDescription;
use heatrun::synth;

use crate::curve::departure_in_tolerances;
use crate::rrd_testing::replayed_and_drawn;

#[test]
fn an_rrd_of_a_hidden_replay_draws_the_hidden_models_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let mcap = dir.path().join("field-unmeasured.mcap");
    synth::write(&mcap, &synth::example::field_unmeasured(7)).unwrap();
    let mut model = ModelDescription::generator();
    // Four states, given (no order search: seconds, not a minute), three measured.
    model.hidden = Some(HiddenSpec::given(4));
    let options = ReplayOptions {
        ts_s: 10.0,
        model,
        ..ReplayOptions::default()
    };
    let (replayed, drawn) = replayed_and_drawn(&mcap, &options);

    let r = &replayed.replay;
    let h = r.hidden.as_ref().expect("the spec declares [hidden]");
    assert_eq!(r.estimation_range, 0..r.data.len(), "no hold-out here");
    let hidden = h.estimate.model.simulate_segments(&r.data);
    let measured_state = &r.analysis.simulated;
    let s = &r.signals;
    let base = s.temperature_base_k;
    for (j, state) in s.states.iter().enumerate() {
        let on_grid = |sim: &dyn Fn(usize) -> f64| -> BTreeMap<i64, f64> {
            (0..s.len())
                .filter_map(|k| {
                    let v = state.reference_at(k)? + base * sim(k);
                    v.is_finite().then_some((s.time_ns[k], v))
                })
                .collect()
        };
        let want = on_grid(&|k| hidden[(k, j)]);
        let other = on_grid(&|k| measured_state[(k, j)]);
        let model = &drawn[&format!("/temperature/{}/model", state.name)];
        // A smooth curve, drawn as the polyline within its tolerance (and the 10⁻⁹ K of
        // the reference's summation order below): fewer points than instants.
        let curve: Vec<(i64, f64)> = want.iter().map(|(&t, &v)| (t, v)).collect();
        let departure = departure_in_tolerances(&curve, model, 1e-9);
        assert!(departure <= 1.01, "{}: {departure}", state.name);
        assert!(model.len() < want.len(), "{}", state.name);
        let (mut off_hidden, mut off_measured_state) = (0.0f64, 0.0f64);
        for (t, v) in model {
            off_hidden = off_hidden.max((v - want[t]).abs());
            off_measured_state = off_measured_state.max((v - other[t]).abs());
        }
        println!(
            "{}: drawn model against the hidden model's simulation {off_hidden:.2e} K, \
             against the measured-state model's {off_measured_state:.3} K",
            state.name
        );
        // Values are sent as f64: equal but for the summation order of the reference.
        assert!(off_hidden < 1e-9, "{}: {off_hidden}", state.name);
        assert!(off_measured_state > 1e-3, "{}", state.name);
        // The measured-state model is drawn beside it, under its own name.
        let beside = &drawn[&format!("/temperature/{}/measured_state_model", state.name)];
        assert!(beside.iter().all(|(t, v)| (v - other[t]).abs() < 1e-9));
        // The residuals are the hidden model's: measured less its output.
        let residual = &drawn[&format!("/residual/{}", state.name)];
        let measured: BTreeMap<i64, f64> = drawn[&format!("/temperature/{}/measured", state.name)]
            .iter()
            .copied()
            .collect();
        assert!(!residual.is_empty());
        for (t, e) in residual {
            assert!(
                (e - (measured[t] - want[t])).abs() < 1e-9,
                "{} at {t}",
                state.name
            );
        }
    }
    // The sensitivities are the hidden model's: one plot per time constant of its four.
    for i in 1..=4 {
        assert!(
            drawn.contains_key(&format!("/sensitivity/T{i}/{}", s.states[0].name)),
            "T{i}"
        );
    }
    assert!(!drawn.keys().any(|k| k.starts_with("/sensitivity/T5")));
}
