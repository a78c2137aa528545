//! The default's decisions on synthetic heat runs of known machines (issue 33): rounding
//! alone never moves the estimator off `oe`, temperatures recorded every 10 s move the
//! grid to 10 s and nothing is left out, and the paper's model (no passive network) is
//! given its nearest network with that verdict rather than rc's fit.

use crate::options::{NetworkChoice, ReplayOptions};
use crate::pipeline::{replay, Replay};
use crate::synth::{self, Machine, NetworkMachine, SynthOptions, Truth};

use super::noise::ResolutionSource;

/// The default as the command line runs it: Ts, the estimator and the network chosen.
fn by_default() -> ReplayOptions {
    ReplayOptions {
        choose_ts: true,
        choose_estimator: true,
        ..ReplayOptions::default()
    }
}

fn run(options: SynthOptions, replay_options: &ReplayOptions) -> (Replay, Truth) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.mcap");
    let truth = synth::write(&path, &options).unwrap();
    (replay(&path, replay_options).unwrap(), truth)
}

/// Largest relative error of the time constants, and of the steady-state rises in K.
fn errors(r: &Replay, truth: &Truth) -> (f64, f64) {
    let t = &r.analysis.spectrum.time_constants_s;
    let relative = t
        .iter()
        .zip(&truth.time_constants_s)
        .map(|(a, b)| ((a - b) / b).abs())
        .fold(0.0, f64::max);
    let base = r.signals.temperature_base_k;
    let steady = r
        .analysis
        .steady_state
        .iter()
        .zip(&truth.steady_state_rise_k)
        .map(|(a, b)| (a * base - b).abs())
        .fold(0.0, f64::max);
    (relative, steady)
}

fn decision<'a>(r: &'a Replay, what: &str) -> &'a super::Decision {
    r.decisions
        .iter()
        .find(|d| d.what == what)
        .unwrap_or_else(|| panic!("no {what} decision in {:?}", r.decisions))
}

/// The paper's noise-free heat run stored to 0.01 K: oe reproduces it to the rounding,
/// whose staircase is not white; the default keeps oe (issue 33: pem took it, 6.1 % off
/// in T1 and 0.86 K in the steady state), and the network is the nearest one with the
/// verdict that the paper's model is no passive network (rc not run).
#[test]
fn rounding_to_a_hundredth_keeps_oe_and_the_paper_model_gets_no_network_fit() {
    let (r, truth) = run(
        SynthOptions {
            temperature_resolution_k: 0.01,
            ..SynthOptions::default()
        },
        &by_default(),
    );
    assert_eq!(r.estimate.method, crate::estimate::Method::Oe);
    let (tc, ss) = errors(&r, &truth);
    assert!(tc < 0.001, "time constants {:.4} % off", 100.0 * tc);
    assert!(ss < 0.05, "steady state {ss:.3} K off");
    assert!(r.left_out.is_empty(), "{:?}", r.left_out);
    // The resolution was seen in the values (the synthetic run declares none).
    assert!(r
        .noise_floor
        .resolution_k
        .iter()
        .all(|q| (q - 0.01).abs() < 1e-9));
    assert!(r
        .noise_floor
        .source
        .iter()
        .all(|s| *s == ResolutionSource::Estimated));
    assert!(decision(&r, "estimator").reason.contains("resolution"));
    let network = decision(&r, "network");
    assert!(
        network.reason.contains("no passive network"),
        "{}",
        network.reason
    );
    let fitted_from = r
        .network
        .network
        .as_ref()
        .ok()
        .and_then(|n| n.fitted_from.as_deref());
    assert!(
        fitted_from.is_some_and(|f| f.contains("no passive network")),
        "{fitted_from:?}"
    );
}

/// The RC unit's temperatures every 10 s at 0.1 K with light noise (a historian export):
/// the grid follows them to 10 s, no sample is left out as frozen or as a glitch, and
/// the estimate stays oe (issue 33: on the 1 s grid 151 frozen stretches were left out,
/// pem was chosen, 88.9 % off). The readings fall 5 s before the 10 s instants: taken
/// where they were read (the grid moved to them), T1 is unbiased (issue 33: laid 5 s
/// late, it came out 3.8 % long on seed 1 and 7.7-13.8 % on seeds 2-3). With this noise
/// one run's T1 scatters by about ±5 % (its 95 % interval; seed 1 lands −5.9 %), so the
/// issue's 3 % bar is held to the mean over five seeds, the steady state to 0.3 K each.
#[test]
fn temperatures_every_ten_seconds_move_the_grid_and_nothing_is_left_out() {
    let mut t1 = Vec::new();
    for seed in 1..=5 {
        let (r, truth) = run(
            SynthOptions {
                machine: Machine::Network(NetworkMachine::rc_unit()),
                temperature_rate_hz: 0.1,
                temperature_resolution_k: 0.1,
                temperature_noise_k: 0.02,
                seed,
                ..SynthOptions::default()
            },
            &ReplayOptions {
                network: NetworkChoice::Nearest,
                ..by_default()
            },
        );
        assert_eq!(r.signals.ts_s, 10.0);
        assert_eq!(
            decision(&r, "sample time").chosen,
            "10 s (the temperatures' own interval)"
        );
        assert!(r.left_out.is_empty(), "{:?}", r.left_out);
        assert_eq!(
            r.estimate.method,
            crate::estimate::Method::Oe,
            "seed {seed}"
        );
        let (_, ss) = errors(&r, &truth);
        assert!(ss < 0.3, "seed {seed}: steady state {ss:.3} K off");
        let fastest = r.analysis.spectrum.time_constants_s[0];
        t1.push(fastest / truth.time_constants_s[0] - 1.0);
    }
    let mean = t1.iter().sum::<f64>() / t1.len() as f64;
    assert!(
        mean.abs() < 0.03,
        "T1 {:.2} % off on average: {t1:?}",
        100.0 * mean
    );
}

/// A noise-free 10 s export of the RC unit, read 5 s off the grid's instants: the time
/// constants within 1 % and the steady state within 0.05 K by oe (laid 5 s late, T1 was
/// 9.0 % long; what remains is the zero-order hold of 10 s interval means).
#[test]
fn a_noise_free_ten_second_export_gives_its_time_constants() {
    let (r, truth) = run(
        SynthOptions {
            machine: Machine::Network(NetworkMachine::rc_unit()),
            temperature_rate_hz: 0.1,
            ..SynthOptions::default()
        },
        &ReplayOptions {
            network: NetworkChoice::Nearest,
            choose_ts: true,
            ..ReplayOptions::default()
        },
    );
    assert_eq!(r.signals.ts_s, 10.0);
    let (tc, ss) = errors(&r, &truth);
    assert!(tc < 0.01, "time constants {:.2} % off", 100.0 * tc);
    assert!(ss < 0.05, "steady state {ss:.3} K off");
}

/// A grid asked for keeps its Ts, and the replay says nothing of a choice it did not make.
#[test]
fn an_asked_sample_time_is_kept_and_no_decision_is_recorded_for_it() {
    let (r, _) = run(
        SynthOptions {
            temperature_rate_hz: 0.1,
            duration_s: 3600.0,
            ..SynthOptions::default()
        },
        &ReplayOptions {
            network: NetworkChoice::Nearest,
            ..ReplayOptions::default()
        },
    );
    assert_eq!(r.signals.ts_s, 1.0);
    assert!(r.decisions.iter().all(|d| d.what != "sample time"));
}
