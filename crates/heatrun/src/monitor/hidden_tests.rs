//! The monitor with a model with hidden states, on a known system: the "rc field" unit
//! (stator winding, core, cooling-water outlet, and a field winding no sensor reads:
//! `FieldChannel::Unmeasured`), its model a replay with `[hidden]` (four states, given)
//! of a seeded noisy heat run, written as a report and read back. Later recordings of
//! the same machine: a healthy heat run (another seed) must raise nothing; one whose
//! cooler fouls (its conductances to the coolant 30 % lower from 10,000 s) must raise an
//! alarm, and none before the fault; with the fixed band and with the model band (the
//! hidden model's own covariance carried through y = C x + D u).
//!
//! Neither recording has a field channel: the loss model's R_f comes from the model's
//! own line from the stator winding (`with_model_field_line`), as in the heat run the
//! model was identified on.

use crate::model_file::ThermalModel;
use crate::monitor::{monitor, BandKind, BandRule, MonitorOptions};
use crate::predict::hidden_tests::four_state_model;
use crate::synth::{self, CoolerFault, SynthOptions};

/// The cooler fouls from here, s.
const FAULT_AT_S: f64 = 10_000.0;

fn heat_run(seed: u64) -> SynthOptions {
    synth::example::field_unmeasured(seed)
}

/// The hidden-state model of the seed-7 heat run, through its report.
fn hidden_model(dir: &std::path::Path) -> ThermalModel {
    let thermal = four_state_model(dir, "model.mcap", &heat_run(7));
    assert_eq!((thermal.order(), thermal.state_count()), (4, 3));
    assert!(thermal.uncertainty.theta_covariance.is_some());
    thermal
}

#[test]
fn a_hidden_state_model_monitors_a_healthy_unit_quietly_and_flags_a_fouled_cooler() {
    let dir = tempfile::tempdir().unwrap();
    let model = hidden_model(dir.path());
    let healthy = dir.path().join("healthy.mcap");
    synth::write(&healthy, &heat_run(8)).unwrap();
    let fouled = dir.path().join("fouled.mcap");
    let mut o = heat_run(9);
    o.disturbances.fault = Some(CoolerFault {
        time_s: FAULT_AT_S,
        conductance_drop: 0.3,
    });
    synth::write(&fouled, &o).unwrap();
    for kind in [BandKind::Fixed, BandKind::Model] {
        let options = MonitorOptions {
            band: BandRule {
                kind,
                ..BandRule::default()
            },
            ..MonitorOptions::default()
        };
        let quiet = monitor(&model, &healthy, &options, None).unwrap();
        for s in &quiet.stats {
            println!(
                "{kind:?} healthy {}: rms {:.3} K, band {:.3} K",
                s.state, s.rms_k, s.band_k
            );
        }
        assert!(quiet.healthy(), "{kind:?}: {:?}", quiet.alarms);
        let flagged = monitor(&model, &fouled, &options, None).unwrap();
        let first = flagged
            .alarms
            .first()
            .expect("the fouled cooler raises an alarm");
        let (start, raised) = (
            flagged.seconds(first.start_ns),
            flagged.seconds(first.raised_ns),
        );
        println!(
            "{kind:?} fouled: first alarm on {} raised at {raised:.0} s ({:.0} s after the \
             fault), peak {:+.2} K",
            first.state_name,
            raised - FAULT_AT_S,
            first.peak_deviation_k
        );
        assert!(
            start >= FAULT_AT_S,
            "{kind:?}: an alarm before the fault at {start} s"
        );
        // A fouled cooler runs hot; within the monitoring guide's documented 1,200 s.
        assert!(first.peak_deviation_k > 0.0);
        assert!(
            raised - FAULT_AT_S <= 1_200.0,
            "{kind:?}: raised at {raised} s"
        );
    }
}
