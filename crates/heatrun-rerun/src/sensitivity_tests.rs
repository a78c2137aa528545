//! The sensitivity responses drawn are the analysis's, to the bit, each state's under its
//! own entity, now that one run of the recursion sends every state's (it was run once per
//! state), across more instants than one slice of a series.

use heatrun::pipeline::ReplayOptions;
use heatrun::synth::{self, SynthOptions};

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
                        want.push((t[instant], rel[k].to_bits()));
                    }
                });
            assert!(want.len() > SERIES_SLICE, "{}", want.len());
            let got: Vec<(i64, u64)> = drawn[&format!("/sensitivity/T{}/{}", i + 1, state.name)]
                .iter()
                .map(|&(t, v)| (t, v.to_bits()))
                .collect();
            assert_eq!(got, want, "T{} {}", i + 1, state.name);
        }
    }
}
