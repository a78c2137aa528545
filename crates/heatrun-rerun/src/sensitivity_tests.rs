//! The sensitivity responses drawn are the analysis's (each drawn point to the bit, the
//! polyline through them within the curve's tolerance of every instant), each state's
//! under its own entity, now that one run of the recursion sends every state's (it was
//! run once per state), across more instants than one slice of a series.

use heatrun::pipeline::ReplayOptions;
use heatrun::synth::{self, SynthOptions};

use crate::curve::departure_in_tolerances;
use crate::rrd_testing::replayed_and_drawn;
use crate::traces::SERIES_SLICE;

#[test]
fn each_states_sensitivity_response_is_drawn_as_the_analysis_made_it() {
    let dir = tempfile::tempdir().unwrap();
    let mcap = dir.path().join("run.mcap");
    synth::write(&mcap, &SynthOptions::default().with_noise_level(1.0)).unwrap();
    let options = ReplayOptions {
        network: heatrun::NetworkChoice::Nearest,
        ..ReplayOptions::default()
    };
    let (replayed, drawn) = replayed_and_drawn(&mcap, &options);
    let r = &replayed.replay;
    let t = &r.signals.time_ns;
    let constants = r.analysis.spectrum.time_constants_s.len();
    assert!(constants >= 3);
    for i in 0..constants {
        for (k, state) in r.signals.states.iter().enumerate() {
            let mut want = Vec::new();
            r.analysis
                .sensitivities
                .responses
                .for_each(i, &r.data, |instant, rel| {
                    if rel[k].is_finite() {
                        want.push((t[instant], rel[k]));
                    }
                });
            assert!(want.len() > SERIES_SLICE, "{}", want.len());
            let got = &drawn[&format!("/sensitivity/T{}/{}", i + 1, state.name)];
            // Drawn as the polyline within the tolerance: points of the response, to the
            // bit, fewer than its instants (a response to measured, noisy losses: here a
            // seventh of them).
            let departure = departure_in_tolerances(&want, got, 0.0);
            assert!(
                departure <= 1.0 + 1e-9,
                "T{} {}: {departure}",
                i + 1,
                state.name
            );
            assert!(got.len() < want.len(), "{} of {}", got.len(), want.len());
        }
    }
}
