//! Recovery of a known model from synthetic heat runs, end to end through the file.

use crate::common;

use heatrun::pipeline::{replay, ReplayOptions};
use heatrun::synth::{self, FieldChannel, SynthOptions};

fn assert_matches_truth(est: &nalgebra::DMatrix<f64>, truth: &[Vec<f64>], rel: f64, what: &str) {
    for i in 0..3 {
        for j in 0..3 {
            let (e, t) = (est[(i, j)], truth[i][j]);
            assert!(
                (e - t).abs() <= rel * t.abs(),
                "{what}({},{}) = {e} vs true {t} (relative {:.2e})",
                i + 1,
                j + 1,
                ((e - t) / t).abs()
            );
        }
    }
}

fn parts(r: &heatrun::pipeline::Replay) -> Vec<&str> {
    r.analysis
        .assignment
        .iter()
        .map(|a| r.signals.states[a.state].name.as_str())
        .collect()
}

#[test]
fn noise_free_paper_run_recovers_phi_gamma_and_the_papers_assignment() {
    let dir = common::tempdir();
    let path = dir.path().join("run.mcap");
    let truth = synth::write(&path, &SynthOptions::default()).unwrap();
    let r = replay(&path, &ReplayOptions::default()).unwrap();
    assert_matches_truth(&r.estimate.model.phi, &truth.phi, 1e-3, "Φ");
    assert_matches_truth(&r.estimate.model.gamma, &truth.gamma, 1e-3, "Γ");
    // Shortest to the cooling water, middle to the stator winding, longest to the core.
    assert_eq!(
        parts(&r),
        vec![
            "cooling_water_outlet_temp",
            "stator_winding_temp",
            "core_temp"
        ]
    );
    for (t, want) in r
        .analysis
        .spectrum
        .time_constants_s
        .iter()
        .zip(&truth.time_constants_s)
    {
        assert!((t - want).abs() < 1e-3 * want);
    }
    for (ss, want) in r
        .analysis
        .steady_state
        .iter()
        .zip(&truth.steady_state_rise_k)
    {
        assert!((ss * 80.0 - want).abs() < 1e-3, "{ss} vs {want}");
    }
    assert!(
        r.analysis.fit.snr_db.iter().all(|s| *s > 100.0),
        "{:?}",
        r.analysis.fit.snr_db
    );
    // A clean file warns of nothing but what the paper's run is: its final load was held
    // 3.5 times the slowest time constant, short of the five that give 99.3 %.
    assert!(
        r.warnings.len() == 1 && r.warnings[0].contains("extrapolation"),
        "{:?}",
        r.warnings
    );
    assert!(r.network.equilibrium.iec_equilibrium && !r.network.equilibrium.held_long_enough);
}

#[test]
fn paper_field_temperature_method_recovers_the_model() {
    let dir = common::tempdir();
    let path = dir.path().join("run.mcap");
    let options = SynthOptions {
        field_channel: FieldChannel::Nameplate,
        duration_s: 15000.0,
        ..SynthOptions::default()
    };
    let truth = synth::write(&path, &options).unwrap();
    let r = replay(&path, &ReplayOptions::default()).unwrap();
    assert!(matches!(
        r.signals.field_temperature.as_ref().map(|f| &f.source),
        Some(heatrun::losses::FieldTemperatureSource::ScaledArmatureRise { .. })
    ));
    assert_matches_truth(&r.estimate.model.phi, &truth.phi, 1e-3, "Φ");
    assert_matches_truth(&r.estimate.model.gamma, &truth.gamma, 1e-3, "Γ");
}

#[test]
fn fast_channels_are_block_averaged_onto_the_model_grid() {
    // Electrical channels at 20 Hz and temperatures at 5 Hz. Electrical windows are exact
    // (the load is held over each interval). A temperature window centred on t_k straddles
    // the instant where the input steps, so its mean is x(t_k) + 0.12·B·Δu (first order in
    // the step): the fast cooling-water constant comes out 1.6 % long on this noise-free
    // run, the slow ones and the steady state stay within 0.2 % and 0.02 K.
    let dir = common::tempdir();
    let path = dir.path().join("run.mcap");
    let options = SynthOptions {
        duration_s: 8000.0,
        electrical_rate_hz: 20.0,
        temperature_rate_hz: 5.0,
        ..SynthOptions::default()
    };
    let truth = synth::write(&path, &options).unwrap();
    let r = replay(&path, &ReplayOptions::default()).unwrap();
    let t = &r.analysis.spectrum.time_constants_s;
    let want = &truth.time_constants_s;
    assert!((t[0] - want[0]).abs() < 0.02 * want[0], "{t:?} vs {want:?}");
    assert!((t[1] - want[1]).abs() < 2e-3 * want[1], "{t:?} vs {want:?}");
    assert!((t[2] - want[2]).abs() < 2e-3 * want[2], "{t:?} vs {want:?}");
    for (ss, want) in r
        .analysis
        .steady_state
        .iter()
        .zip(&truth.steady_state_rise_k)
    {
        assert!((ss * 80.0 - want).abs() < 0.02, "{ss} vs {want}");
    }
    // Seven of the heat run and the coolant's inlet temperature and flow.
    assert_eq!(r.recording.channels.len(), 9);
    assert!(r.decimated.channels.iter().all(|c| c.block_averaged));
}

#[test]
fn temperatures_slower_than_the_grid_are_interpolated() {
    let dir = common::tempdir();
    let path = dir.path().join("run.mcap");
    let options = SynthOptions {
        duration_s: 12000.0,
        temperature_rate_hz: 0.5,
        ..SynthOptions::default()
    };
    let truth = synth::write(&path, &options).unwrap();
    let r = replay(&path, &ReplayOptions::default()).unwrap();
    let slow: Vec<_> = r
        .decimated
        .channels
        .iter()
        .filter(|c| !c.block_averaged)
        .collect();
    assert_eq!(
        slow.len(),
        5,
        "the three temperatures, the inlet and the flow are interpolated"
    );
    for (t, want) in r
        .analysis
        .spectrum
        .time_constants_s
        .iter()
        .zip(&truth.time_constants_s)
    {
        assert!((t - want).abs() < 0.02 * want, "{t} vs {want}");
    }
}

#[test]
fn a_machine_file_overrides_the_nameplate() {
    let dir = common::tempdir();
    let path = dir.path().join("run.mcap");
    synth::write(
        &path,
        &SynthOptions {
            duration_s: 6000.0,
            ..SynthOptions::default()
        },
    )
    .unwrap();
    let machine = dir.path().join("m.toml");
    std::fs::write(&machine, "temperature_base_k = 40\n").unwrap();
    let base = replay(&path, &ReplayOptions::default()).unwrap();
    let over = replay(
        &path,
        &ReplayOptions {
            machine: Some(machine),
            ..ReplayOptions::default()
        },
    )
    .unwrap();
    assert_eq!(over.nameplate.unwrap().temperature_base_k, 40.0);
    // Halving the temperature base doubles the rises in pu, and so Γ.
    let ratio = over.estimate.model.gamma[(0, 0)] / base.estimate.model.gamma[(0, 0)];
    assert!((ratio - 2.0).abs() < 1e-9, "{ratio}");
}

/// A PT100-noise heat run whose temperatures a historian stored by exception (deadband
/// 0.1 K, heartbeat 600 s), replayed end to end: the channels declare their storage, the
/// decimator keeps the stored samples as exact values, and the estimator treats the
/// instants between them as "within the deadband". Time constants within 3 % (the issue's
/// aim; 5 % is its bar).
#[test]
fn a_heat_run_stored_by_exception_identifies_within_three_percent() {
    let dir = common::tempdir();
    let path = dir.path().join("historian.mcap");
    let options = SynthOptions {
        temperature_storage: heatrun::recording::Storage::Exception {
            deadband: 0.1,
            max_interval_s: Some(600.0),
        },
        ..SynthOptions::default().with_noise_level(1.0)
    };
    let truth = synth::write(&path, &options).unwrap();
    let r = replay(&path, &ReplayOptions::default()).unwrap();
    assert!(
        r.data.output_observed.is_some(),
        "the stored samples are what is observed"
    );
    for (got, want) in r
        .analysis
        .spectrum
        .time_constants_s
        .iter()
        .zip(&truth.time_constants_s)
    {
        assert!((got - want).abs() < 0.03 * want, "{got} vs {want}");
    }
    // No gap warnings: a silence shorter than the heartbeat is an unchanged value.
    assert!(
        r.warnings.iter().all(|w| !w.contains("gap")),
        "{:?}",
        r.warnings
    );
}
