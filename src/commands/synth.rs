//! `heatrun synth`.

use heatrun::synth::{self, FieldChannel, OperatingPoint, SynthOptions};
use heatrun::writer::Storage;

use super::Outcome;
use crate::cli::{FieldArg, ProfileArg, SynthArgs};

pub fn run(args: SynthArgs) -> anyhow::Result<Outcome> {
    let mut options = SynthOptions {
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
    if args.profile == ProfileArg::SingleStep {
        let last = *synth::heat_run_with_load_steps()
            .last()
            .expect("the default profile has points");
        options.profile = vec![OperatingPoint {
            start_fraction: 0.0,
            ..last
        }];
    }
    let truth = synth::write(&args.out, &options)?;
    println!(
        "wrote {} ({:.0} s; true time constants [{}] s; true steady-state rise [{}] K) and {}",
        args.out.display(),
        options.duration_s,
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
