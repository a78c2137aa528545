//! `heatrun synth`: its flags, and the [`Synth`] they are validated into: the library's
//! options, the disturbances only on a machine they can enter, the field node recorded.

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use heatrun::synth::{
    self, Coolant, CoolerFault, Disturbances, FieldChannel, Flaws, Freeze, Machine, NetworkMachine,
    OperatingPoint, PumpSwitch, SynthOptions,
};
use heatrun::writer::Storage;

use super::Usage;

/// How the synthetic recording carries the field winding temperature.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FieldArg {
    /// A field_voltage channel (resistance method).
    Voltage,
    /// A field_winding_temp channel.
    Temperature,
    /// No channel: the nameplate's final field temperature (the paper's method).
    Nameplate,
    /// No channel, and rc-field's field-winding node read by no sensor: a hidden state
    /// (the truth names it under `unmeasured`).
    Unmeasured,
}

/// The machine of a synthetic run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MachineArg {
    /// The paper's Φ and Γ (eqs. 19-20) from its initial temperatures.
    Paper,
    /// A 3-node thermal RC network (stator winding, core, cooling-water outlet).
    RcUnit,
    /// The RC unit with a fourth node, the field winding.
    RcField,
}

/// Operating profile of a synthetic run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ProfileArg {
    /// A heat run with load and excitation steps (all three heat sources excited).
    LoadSteps,
    /// One step to the final operating point (the inputs are nearly collinear).
    SingleStep,
}

/// Arguments of `heatrun synth`.
#[derive(Debug, Args)]
pub struct SynthArgs {
    /// The MCAP file to write; the true model goes to OUT.truth.json.
    pub out: PathBuf,
    /// Duration in seconds (the paper's heat run: 20868 s).
    #[arg(long, default_value_t = 20868.0)]
    pub duration: f64,
    /// Sample rate of the electrical channels, Hz.
    #[arg(long, default_value_t = 1.0)]
    pub electrical_rate: f64,
    /// Sample rate of the temperature channels, Hz.
    #[arg(long, default_value_t = 1.0)]
    pub temperature_rate: f64,
    /// Gaussian temperature noise σ, K (PT100-like: 0.05).
    #[arg(long, default_value_t = 0.0)]
    pub temperature_noise: f64,
    /// Gaussian electrical noise σ, relative (0.002 = 0.2 %).
    #[arg(long, default_value_t = 0.0)]
    pub electrical_noise: f64,
    /// Temperature resolution, K (0: none; PT100 transducers: 0.01).
    #[arg(long, default_value_t = 0.0)]
    pub resolution: f64,
    /// Random seed of the noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// How the field winding temperature is recorded.
    #[arg(long, value_enum, default_value_t = FieldArg::Voltage)]
    pub field: FieldArg,
    /// Operating profile.
    #[arg(long, value_enum, default_value_t = ProfileArg::LoadSteps)]
    pub profile: ProfileArg,
    /// Write uncompressed chunks instead of zstd.
    #[arg(long)]
    pub uncompressed: bool,
    /// The machine simulated: the paper's model, or a thermal RC network (required for
    /// the disturbances below).
    #[arg(long, value_enum, default_value_t = MachineArg::Paper)]
    pub machine: MachineArg,
    /// Network machines: the coolant inlet warms by K kelvin as river water over a day (a
    /// ramp of 0.6·K over the run and a daily swing of 0.4·K).
    #[arg(long, value_name = "K")]
    pub inlet_drift: Option<f64>,
    /// With --inlet-drift: the inlet drifts along a slow wave of this period instead, up
    /// by K over half a period and back (K/2·(1 − cos(2π·t/S))).
    #[arg(long, value_name = "S", requires = "inlet_drift")]
    pub inlet_wave: Option<f64>,
    /// Network machines: every part starts K kelvin above the coolant (a warm start).
    #[arg(long, value_name = "K")]
    pub start_above: Option<f64>,
    /// Network machines: the flow is multiplied by FACTOR from T seconds (a pump switch;
    /// the coolant conductance c·ρ·Q follows it).
    #[arg(long, value_name = "T:FACTOR", value_parser = parse_pump_switch)]
    pub pump_switch: Option<(f64, f64)>,
    /// Network machines: a fouled cooler from T seconds (with --fault-conductance-drop).
    #[arg(long, value_name = "T", requires = "fault_conductance_drop")]
    pub fault_at: Option<f64>,
    /// With --fault-at: the fraction, in [0, 1), the conductances to the coolant fall by.
    #[arg(long, value_name = "F", requires = "fault_at")]
    pub fault_conductance_drop: Option<f64>,
    /// Network machines: a unit of the design as manufactured, every capacitance and
    /// conductance scaled by its own factor within ±PCT % (drawn from --unit-seed).
    #[arg(long, value_name = "PCT")]
    pub spread: Option<f64>,
    /// With --spread: the seed of the unit's factors (one seed, one unit).
    #[arg(long, value_name = "N", default_value_t = 1, requires = "spread")]
    pub unit_seed: u64,
    /// Network machines: an unmeasured heat flow into the cooling water wandering as a
    /// random walk of KW kW per √hour from zero (a valve, the air circuit, a neighbour).
    #[arg(long, value_name = "KW")]
    pub coolant_heat_walk: Option<f64>,
    /// Leave out the cooling_water_inlet_temp and cooling_water_flow channels.
    #[arg(long)]
    pub no_coolant_channels: bool,
    /// Store the temperatures by exception, as a SCADA historian does: a sample only
    /// when it moved by more than this many kelvin since the last stored one (or the
    /// heartbeat passed).
    #[arg(long, value_name = "K")]
    pub deadband: Option<f64>,
    /// With --deadband: the heartbeat, the longest time between stored samples, s.
    #[arg(long, value_name = "S", default_value_t = 600.0, requires = "deadband")]
    pub heartbeat: f64,
    /// Flaw: every N-th sample of the stator winding and core temperatures written
    /// missing, alternately {"value":null} and {"value":NaN}.
    #[arg(long, value_name = "N")]
    pub dropout_every: Option<usize>,
    /// Flaw: N single missing samples ("I/O Timeout") of the armature current, spread
    /// over the run.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub input_timeouts: usize,
    /// Flaw: N unflagged glitches of the core temperature at spread, seeded times, half
    /// the reading + 15 K, half the fault code -3276.8.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub glitches: usize,
    /// Flaw: the stator winding temperature frozen at its reading at T0 until T1
    /// (seconds after the start), as a SCADA link holding the last good value.
    #[arg(long, value_name = "T0:T1", value_parser = parse_freeze)]
    pub freeze: Option<(f64, f64)>,
}

/// `T0:T1`, two numbers of seconds with T0 < T1.
fn parse_freeze(s: &str) -> Result<(f64, f64), String> {
    let (t0, t1) = s
        .split_once(':')
        .ok_or_else(|| format!("`{s}` is not T0:T1 (e.g. 9000:12600)"))?;
    let num = |v: &str| {
        v.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite() && *v >= 0.0)
            .ok_or_else(|| format!("`{v}` in `{s}` is not a number of seconds"))
    };
    let (t0, t1) = (num(t0)?, num(t1)?);
    if t0 >= t1 {
        return Err(format!("`{s}`: the freeze must end after it starts"));
    }
    Ok((t0, t1))
}

/// `T:FACTOR`, two numbers.
fn parse_pump_switch(s: &str) -> Result<(f64, f64), String> {
    let (t, f) = s
        .split_once(':')
        .ok_or_else(|| format!("`{s}` is not T:FACTOR (e.g. 7200:0.7)"))?;
    let num = |v: &str| {
        v.trim()
            .parse::<f64>()
            .map_err(|_| format!("`{v}` in `{s}` is not a number"))
    };
    Ok((num(t)?, num(f)?))
}

/// `heatrun synth` as validated.
#[derive(Debug)]
pub struct Synth {
    /// The recording to write (the truth beside it).
    pub out: PathBuf,
    /// What to simulate and how to record it.
    pub options: SynthOptions,
}

impl TryFrom<SynthArgs> for Synth {
    type Error = anyhow::Error;

    /// The library's options, once the disturbances and the field channel suit the
    /// machine.
    fn try_from(args: SynthArgs) -> anyhow::Result<Synth> {
        let disturbances = disturbances(&args)?;
        if args.machine == MachineArg::RcField && args.field == FieldArg::Nameplate {
            return Err(Usage(
                "--machine rc-field records its field winding node: give --field voltage or --field temperature (or --field unmeasured for a node no sensor reads)"
                    .into(),
            )
            .into());
        }
        let mut options = SynthOptions {
            machine: match args.machine {
                MachineArg::Paper => Machine::paper(),
                MachineArg::RcUnit => {
                    Machine::Network(manufactured(NetworkMachine::rc_unit(), &args)?)
                }
                MachineArg::RcField => {
                    Machine::Network(manufactured(NetworkMachine::rc_field(), &args)?)
                }
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
                FieldArg::Unmeasured => FieldChannel::Unmeasured,
            },
            compress: !args.uncompressed,
            temperature_storage: match args.deadband {
                Some(deadband) => Storage::Exception {
                    deadband,
                    max_interval_s: Some(args.heartbeat),
                },
                None => Storage::Sampled,
            },
            flaws: Flaws {
                dropout_every: args.dropout_every,
                input_timeouts: args.input_timeouts,
                glitches: args.glitches,
                freeze: args.freeze.map(|(from_s, to_s)| Freeze { from_s, to_s }),
                ..Flaws::default()
            },
            ..SynthOptions::default()
        };
        if args.profile == ProfileArg::SingleStep {
            // The load-steps profile's last point, held from the start.
            if let Some(last) = synth::heat_run_with_load_steps().last() {
                options.profile = vec![OperatingPoint {
                    start_fraction: 0.0,
                    ..*last
                }];
            }
        }
        Ok(Synth {
            out: args.out,
            options,
        })
    }
}

/// The design's unit as manufactured with `--spread` (a percentage in [0, 50)), or the
/// design itself.
fn manufactured(design: NetworkMachine, args: &SynthArgs) -> anyhow::Result<NetworkMachine> {
    match args.spread {
        None => Ok(design),
        Some(pct) if (0.0..50.0).contains(&pct) => {
            Ok(design.manufactured(pct / 100.0, args.unit_seed))
        }
        Some(pct) => Err(Usage(format!(
            "--spread {pct}: a manufacturing spread is a percentage in [0, 50)"
        ))
        .into()),
    }
}

/// The disturbances of the command line; refused (naming the flag) for the paper's model,
/// which has no coolant node for them to enter.
fn disturbances(args: &SynthArgs) -> anyhow::Result<Disturbances> {
    if args.machine == MachineArg::Paper {
        let given = [
            ("--inlet-drift", args.inlet_drift.is_some()),
            ("--start-above", args.start_above.is_some()),
            ("--pump-switch", args.pump_switch.is_some()),
            ("--fault-at", args.fault_at.is_some()),
            ("--coolant-heat-walk", args.coolant_heat_walk.is_some()),
            ("--spread", args.spread.is_some()),
        ];
        if let Some((flag, _)) = given.iter().find(|(_, set)| *set) {
            return Err(Usage(format!(
                "{flag} needs a machine built from a thermal network, and the paper's model is not one; give --machine rc-unit or --machine rc-field"
            ))
            .into());
        }
    }
    Ok(Disturbances {
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
        coolant_heat_walk_kw_per_sqrt_h: args.coolant_heat_walk.unwrap_or(0.0),
        inlet_wave_period_s: args.inlet_wave.unwrap_or(0.0),
    })
}
