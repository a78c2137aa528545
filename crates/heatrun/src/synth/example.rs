//! A known thermal network for tests and benchmarks: a generator-like machine that is not
//! the paper's model, passive by construction, every conductance and share positive.

use nalgebra::DMatrix;

use super::OperatingPoint;
use crate::thermal::network::{Labels, Parts};

/// Stator winding, iron core, cooling-water outlet; the generator's three losses.
///
/// C = [6, 45, 5] MJ/K; G_10 = 12, G_20 = 30, G_30 = 201.6 (c·ρ·Q at 48.2 l/s),
/// G_12 = 20, G_13 = 15, G_23 = 60 kW/K; K: the armature copper loss 85 % into the winding,
/// the field copper loss 70 % into the water (through the rotor's air), the iron loss
/// 85 % into the core; each column sums to 1.
pub fn generator_like() -> (Parts, Labels) {
    let parts = Parts {
        capacitance_j_per_k: vec![6e6, 45e6, 5e6],
        conductance_w_per_k: DMatrix::from_row_slice(
            3,
            3,
            &[12e3, 20e3, 15e3, 20e3, 30e3, 60e3, 15e3, 60e3, 201.6e3],
        ),
        loss_distribution: DMatrix::from_row_slice(
            3,
            3,
            &[0.85, 0.05, 0.05, 0.10, 0.25, 0.85, 0.05, 0.70, 0.10],
        ),
    };
    (parts, generator_labels())
}

/// The generator's three parts and three losses, in the model's order.
pub fn generator_labels() -> Labels {
    Labels {
        states: vec![
            "stator winding".into(),
            "iron core".into(),
            "cooling water".into(),
        ],
        inputs: vec![
            "armature copper loss".into(),
            "field copper loss".into(),
            "iron loss".into(),
        ],
    }
}

/// A heat run that moves all three losses independently and holds each point long enough
/// for the core to follow: 32 points of 1/32 of the run (1,250 s of a 40,000 s run), the
/// armature current, line voltage and field current each cycling through its own levels
/// with periods 3, 4 and 5, so that no loss follows another. The default heat run holds
/// the voltage, and so the iron loss, nearly constant, which leaves the iron loss's shares
/// and the core's conductance to the coolant loosely determined.
pub fn rich_heat_run() -> Vec<OperatingPoint> {
    let current = [0.5, 1.0, 0.75];
    let voltage = [0.95, 1.05, 1.0, 1.08];
    let field = [0.8, 1.1, 0.9, 1.2, 1.0];
    (0..32)
        .map(|k| OperatingPoint {
            start_fraction: k as f64 / 32.0,
            armature_current_pu: current[k % 3],
            line_voltage_pu: voltage[k % 4],
            field_current_pu: field[k % 5],
        })
        .collect()
}

/// The disturbance fixture (issue 23 item 4): the RC unit's heat run of 5.8 h at 1 s
/// (the default schedule) whose cooling water also takes an unmeasured heat, a random
/// walk q(k+1) = q(k) + W·√(Ts / 1 h)·ε_k of `walk_kw_per_sqrt_h` = W, with the sensors'
/// noise σ 0.05 K at 0.01 K resolution; its truth is what [`super::write`] returns (time
/// constants, steady-state rises, the walk's course). Small enough to make in a test
/// (~0.1 s), so it is made there rather than kept in `fixtures/`.
pub fn unmeasured_heat(walk_kw_per_sqrt_h: f64, seed: u64) -> super::SynthOptions {
    super::SynthOptions {
        machine: super::Machine::Network(super::NetworkMachine::rc_unit()),
        disturbances: super::Disturbances {
            coolant_heat_walk_kw_per_sqrt_h: walk_kw_per_sqrt_h,
            ..super::Disturbances::default()
        },
        temperature_noise_k: 0.05,
        temperature_resolution_k: 0.01,
        seed,
        ..super::SynthOptions::default()
    }
}

/// The "rc field" unit with a node no sensor reads: stator winding, core and
/// cooling-water outlet measured, the field winding (the fourth node) neither by a sensor
/// nor through U_f/I_f (`FieldChannel::Unmeasured`), as `heatrun synth --machine rc-field
/// --field unmeasured`; the sensors' noise σ 0.05 K at 0.01 K resolution and the electrical
/// channels' 0.05 % (noise level 1). The hidden-state model's known system of the
/// predict, rating, monitor and report tests.
pub fn field_unmeasured(seed: u64) -> super::SynthOptions {
    super::SynthOptions {
        machine: super::Machine::Network(super::NetworkMachine::rc_field()),
        field_channel: super::FieldChannel::Unmeasured,
        seed,
        ..super::SynthOptions::default()
    }
    .with_noise_level(1.0)
}
