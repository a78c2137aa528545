//! `heatrun synth`.

use heatrun::synth::{
    self, Coolant, CoolerFault, Disturbances, FieldChannel, Machine, NetworkMachine,
    OperatingPoint, PumpSwitch, SynthOptions,
};
use heatrun::writer::Storage;

use super::Outcome;
use crate::cli::{FieldArg, MachineArg, ProfileArg, SynthArgs};

pub fn run(args: SynthArgs) -> anyhow::Result<Outcome> {
    let disturbances = disturbances(&args)?;
    let mut options = SynthOptions {
        machine: match args.machine {
            MachineArg::Paper => Machine::paper(),
            MachineArg::RcUnit => Machine::Network(NetworkMachine::rc_unit()),
            MachineArg::RcField => Machine::Network(NetworkMachine::rc_field()),
        },
        coolant: Coolant {
            channels: !args.no_coolant_channels,
            ..Coolant::default()
        },
        disturbances,
        duration_s: args.duration,
        electrical_rate_hz: args.electrical_rate,
        temperature_rate_hz: args.temperature_rate,
        temperature_noise_k: args.temperature_noise,
        electrical_noise_pu: args.electrical_noise,
        temperature_resolution_k: args.resolution,
        seed: args.seed,
        field_channel: match args.field {
            FieldArg::Voltage => FieldChannel::Voltage,
            FieldArg::Temperature => FieldChannel::Temperature,
            FieldArg::Nameplate => FieldChannel::Nameplate,
        },
        compress: !args.uncompressed,
        temperature_storage: match args.deadband {
            Some(deadband) => Storage::Exception {
                deadband,
                max_interval_s: Some(args.heartbeat),
            },
            None => Storage::Sampled,
        },
        ..SynthOptions::default()
    };
    if args.machine == MachineArg::RcField && args.field == FieldArg::Nameplate {
        return Err(super::Usage(
            "--machine rc-field records its field winding node: give --field voltage or --field temperature"
                .into(),
        )
        .into());
    }
    if args.profile == ProfileArg::SingleStep {
        let last = *synth::heat_run_with_load_steps()
            .last()
            .expect("the default profile has points");
        options.profile = vec![OperatingPoint {
            start_fraction: 0.0,
            ..last
        }];
    }
    let truth = synth::write(&args.out, &options).map_err(heatrun::Error::from)?;
    println!(
        "wrote {} ({:.0} s, {}; true time constants [{}] s; true steady-state rise [{}] K) and {}",
        args.out.display(),
        options.duration_s,
        truth.machine,
        truth
            .time_constants_s
            .iter()
            .map(|t| format!("{t:.2}"))
            .collect::<Vec<_>>()
            .join(", "),
        truth
            .steady_state_rise_k
            .iter()
            .map(|t| format!("{t:.3}"))
            .collect::<Vec<_>>()
            .join(", "),
        synth::truth_path(&args.out).display()
    );
    Ok(Outcome::Complete)
}

/// The disturbances of the command line; refused (naming the flag) for the paper's model,
/// which has no coolant node for them to enter.
fn disturbances(args: &SynthArgs) -> anyhow::Result<Disturbances> {
    let d = Disturbances {
        inlet_drift_k: args.inlet_drift.unwrap_or(0.0),
        start_above_k: args.start_above.unwrap_or(0.0),
        pump_switch: args
            .pump_switch
            .map(|(time_s, factor)| PumpSwitch { time_s, factor }),
        fault: args
            .fault_at
            .zip(args.fault_conductance_drop)
            .map(|(time_s, conductance_drop)| CoolerFault {
                time_s,
                conductance_drop,
            }),
    };
    if args.machine == MachineArg::Paper {
        let given = [
            ("--inlet-drift", args.inlet_drift.is_some()),
            ("--start-above", args.start_above.is_some()),
            ("--pump-switch", args.pump_switch.is_some()),
            ("--fault-at", args.fault_at.is_some()),
        ];
        if let Some((flag, _)) = given.iter().find(|(_, set)| *set) {
            return Err(super::Usage(format!(
                "{flag} needs a machine built from a thermal network, and the paper's model is not one; give --machine rc-unit or --machine rc-field"
            ))
            .into());
        }
    }
    Ok(d)
}
