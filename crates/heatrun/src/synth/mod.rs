//! Synthetic heat runs: a recording in the profile simulated from a known machine.
//!
//! The machine ([`Machine`]) is either a model given by its discrete form (by default the
//! paper's Φ and Γ, eqs. 19–20, on the rises above its initial temperatures) or a thermal
//! RC network simulated in absolute temperatures with the coolant inlet as its reference
//! node ([`NetworkMachine`]: the "rc unit" of three nodes, the "rc field" unit with a
//! field-winding node). Either is driven by the loss model of the profile: the operating
//! point (I_g, U_g, I_f) is held over each interval [t_k, t_k + Ts) and the losses use
//! the temperatures at t_k, so the exact discretisation at Ts is the model
//! x(k) = Φ x(k−1) + Γ u(k−1) (see [`plant`]). A network machine takes disturbances
//! ([`Disturbances`]): an inlet drifting as river water over a day, a warm start, a pump
//! switch and a fouled cooler. Every channel is sampled at its own rate with optional
//! Gaussian noise and resolution, and the temperatures are optionally stored by
//! exception as a SCADA historian does (deadband and heartbeat). The ordinary flaws of
//! plant data ([`Flaws`]: dropouts, input timeouts, unflagged glitches, a frozen sensor)
//! are laid on the written samples, the noise unchanged.

pub mod example;
pub mod flaws;
mod machines;
pub mod plant;
mod truth;

use std::collections::HashMap;
use std::path::Path;

use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use serde::Serialize;

/// Why a synthetic heat run cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum SynthError {
    /// The options cannot make a run (a value out of range, a machine without the
    /// parts asked for); the message names the option.
    #[error("{0}")]
    Options(String),
    /// The machine's model cannot be analysed for its truth file.
    #[error(transparent)]
    Model(#[from] crate::model::ModelError),
    /// The recording or its truth file could not be written.
    #[error(transparent)]
    Write(#[from] crate::atomic::WriteError),
}

impl SynthError {
    /// Whether the error is the caller's (options, machine) rather than the machine's
    /// (an output that could not be written).
    pub fn is_bad_input(&self) -> bool {
        !matches!(self, SynthError::Write(_))
    }
}

/// The synthesiser's result.
pub type Result<T, E = SynthError> = std::result::Result<T, E>;
use crate::losses::copper_resistance;
use crate::recording::{Nameplate, Quantity};
use crate::thermal::matrix::discretize;
use crate::writer::{
    ChannelId, ChannelSpec, ExceptionFilter, RecordingWriter, Storage, WriterOptions,
};
use plant::Trajectory;

pub use crate::writer::SAMPLE_SCHEMA;
pub use flaws::{FlawRecord, Flaws, Freeze};
pub use machines::{
    paper_model, second_machine_model, Machine, NetworkMachine, PAPER_A_C, PAPER_B_C,
    PAPER_COOLING_WATER_FLOW_L_PER_S, PAPER_COOLING_WATER_INLET_C, PAPER_GAMMA,
    PAPER_INITIAL_TEMPERATURES_C, PAPER_PHI,
};
pub use plant::ChangeCause;
pub use truth::{truth_path, CoolantHeat, NetworkChange, Truth, TruthCoolant, TruthNetwork};

/// The coolant of a run: the inlet temperature at the start and the flow, recorded as
/// `cooling_water_inlet_temp` and `cooling_water_flow` (unless `channels` is false).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coolant {
    /// θ_in at the start, °C.
    pub inlet_temp_c: f64,
    /// Q, l/s; a network's outlet node loses c·ρ·Q W/K to the coolant.
    pub flow_l_per_s: f64,
    /// Whether the recording has the inlet and flow channels.
    pub channels: bool,
}

impl Default for Coolant {
    /// The paper's: 10.5 °C (its water at the start) and 48.2 l/s (eqs. 17–18).
    fn default() -> Self {
        Coolant {
            inlet_temp_c: PAPER_COOLING_WATER_INLET_C,
            flow_l_per_s: PAPER_COOLING_WATER_FLOW_L_PER_S,
            channels: true,
        }
    }
}

/// A pump switched during the run: the flow is multiplied by `factor` from `time_s`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PumpSwitch {
    /// From this time, s after the start.
    pub time_s: f64,
    /// The flow's factor (> 0).
    pub factor: f64,
}

/// A fouled cooler: the conductances to the coolant fall by `conductance_drop` from
/// `time_s`, the recorded flow unchanged.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CoolerFault {
    /// From this time, s after the start.
    pub time_s: f64,
    /// The fraction the conductances fall by, in [0, 1).
    pub conductance_drop: f64,
}

/// Disturbances of a network machine's heat run (none by default).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Disturbances {
    /// D, K: the inlet warms by a ramp of 0.6·D over the run and a daily swing of
    /// 0.4·D·sin(2π·t/1 day) (see [`plant::inlet_temperature_c`]).
    pub inlet_drift_k: f64,
    /// Every node starts this many kelvin above the coolant inlet (a warm start).
    pub start_above_k: f64,
    /// A pump switch.
    pub pump_switch: Option<PumpSwitch>,
    /// A fouled cooler.
    pub fault: Option<CoolerFault>,
    /// W, kW/√h: an unmeasured heat flow q into the cooling-water node (a valve, the air
    /// circuit, a neighbour) wandering as a random walk from 0, q(k+1) = q(k) + W·√(Ts/1 h)·ε,
    /// ε ~ N(0, 1) from its own seeded stream (see [`plant::coolant_heat_walk_w`]).
    #[serde(skip_serializing_if = "is_zero")]
    pub coolant_heat_walk_kw_per_sqrt_h: f64,
    /// P, s: where > 0, the inlet drifts along a slow wave instead,
    /// D/2·(1 − cos(2π·t/P)) (up by D over half a period and back; see
    /// [`plant::inlet_temperature_c`]).
    #[serde(skip_serializing_if = "is_zero")]
    pub inlet_wave_period_s: f64,
}

/// Whether a disturbance is off (left out of the truth file, which stays as it was).
fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl Disturbances {
    /// The name of the first disturbance set, if any (for the message that refuses it).
    pub fn first(&self) -> Option<&'static str> {
        if self.inlet_drift_k != 0.0 {
            Some("an inlet drift")
        } else if self.start_above_k != 0.0 {
            Some("a warm start")
        } else if self.pump_switch.is_some() {
            Some("a pump switch")
        } else if self.fault.is_some() {
            Some("a cooler fault")
        } else if self.coolant_heat_walk_kw_per_sqrt_h != 0.0 {
            Some("an unmeasured heat walk into the coolant")
        } else {
            None
        }
    }
}

/// How the field winding temperature reaches the recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FieldChannel {
    /// A `field_voltage` channel U_f = I_f·R_f(θ_f) (resistance method).
    Voltage,
    /// A `field_winding_temp` channel.
    Temperature,
    /// Neither: the nameplate's final field temperature (the paper's method).
    Nameplate,
    /// Neither, and the machine's field-winding node (where it has one) is read by no
    /// sensor: a hidden state, for the hidden-state models (`[hidden]`). The nameplate
    /// keeps its final field temperature, from which a replay scales R_f as for
    /// `Nameplate`; the truth names the node (`Truth::unmeasured`).
    Unmeasured,
}

impl FieldChannel {
    /// Whether the recording has no field channel (the nameplate's final field
    /// temperature stands in for it).
    pub fn from_nameplate(self) -> bool {
        matches!(self, FieldChannel::Nameplate | FieldChannel::Unmeasured)
    }
}

/// One operating point, held from `start_fraction` of the run until the next.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct OperatingPoint {
    /// Start as a fraction of the duration.
    pub start_fraction: f64,
    /// Armature current, pu of I_n.
    pub armature_current_pu: f64,
    /// Line voltage, pu of U_n.
    pub line_voltage_pu: f64,
    /// Field current, pu of I_fn.
    pub field_current_pu: f64,
}

/// The default heat run: a stepped load-up (25, 50, 75 % current), a reactive-power
/// test of 20 excitation and voltage steps about 250 s apart (each shows the fast
/// cooling-water transient), full load, a partial load rejection and reload, and the
/// paper's final operating point (eq. 30: I_g = 0.929 I_n, U_g = 1.0652 U_n,
/// I_f = 1.0759 I_fn) held for the last 60 % of the run. All three heat sources are
/// excited independently of each other.
pub fn heat_run_with_load_steps() -> Vec<OperatingPoint> {
    let p =
        |start_fraction, armature_current_pu, line_voltage_pu, field_current_pu| OperatingPoint {
            start_fraction,
            armature_current_pu,
            line_voltage_pu,
            field_current_pu,
        };
    let mut points = vec![
        p(0.00, 0.25, 1.000, 0.80),
        p(0.04, 0.50, 1.000, 0.85),
        p(0.08, 0.75, 1.020, 0.95),
    ];
    // Reactive-power test: alternate over- and under-excitation at 75 % current.
    let var_levels = [
        (1.050, 1.10),
        (0.980, 0.86),
        (1.030, 1.02),
        (0.960, 0.80),
        (1.060, 1.12),
    ];
    for step in 0..20 {
        let (u, i_f) = var_levels[step % var_levels.len()];
        points.push(p(0.12 + 0.012 * step as f64, 0.75, u, i_f));
    }
    points.extend([
        p(0.36, 0.929, 1.0652, 1.0759),
        // A partial load rejection and reload.
        p(0.38, 0.25, 1.000, 0.78),
        p(0.39, 0.929, 1.0652, 1.0759),
    ]);
    points
}

/// Options of a synthetic heat run.
#[derive(Debug, Clone)]
pub struct SynthOptions {
    /// The machine simulated (its hold interval is the model's sample time).
    pub machine: Machine,
    /// The machine's nameplate.
    pub nameplate: Nameplate,
    /// The coolant.
    pub coolant: Coolant,
    /// Disturbances (a network machine only).
    pub disturbances: Disturbances,
    /// Duration, s.
    pub duration_s: f64,
    /// Rate of the electrical channels, Hz.
    pub electrical_rate_hz: f64,
    /// Rate of the temperature channels, Hz.
    pub temperature_rate_hz: f64,
    /// Temperature noise σ, K.
    pub temperature_noise_k: f64,
    /// Electrical noise σ, relative to rated values.
    pub electrical_noise_pu: f64,
    /// Temperature resolution, K (0: none).
    pub temperature_resolution_k: f64,
    /// How the temperature channels are stored: every sample, or by exception
    /// (deadband in K, heartbeat in s), after noise and resolution.
    pub temperature_storage: Storage,
    /// Random seed.
    pub seed: u64,
    /// The operating schedule.
    pub profile: Vec<OperatingPoint>,
    /// How θ_f is recorded.
    pub field_channel: FieldChannel,
    /// Start time, ns since the epoch.
    pub start_time_ns: u64,
    /// zstd-compress the chunks.
    pub compress: bool,
    /// Target size of a chunk, bytes.
    pub chunk_size: u64,
    /// The flaws laid on the written samples (none by default).
    pub flaws: Flaws,
}

impl Default for SynthOptions {
    fn default() -> Self {
        SynthOptions {
            machine: Machine::paper(),
            nameplate: Nameplate::paper_table1(),
            coolant: Coolant::default(),
            disturbances: Disturbances::default(),
            duration_s: 20868.0,
            electrical_rate_hz: 1.0,
            temperature_rate_hz: 1.0,
            temperature_noise_k: 0.0,
            electrical_noise_pu: 0.0,
            temperature_resolution_k: 0.0,
            temperature_storage: Storage::Sampled,
            seed: 1,
            profile: heat_run_with_load_steps(),
            field_channel: FieldChannel::Voltage,
            // 2019-06-03T06:00:00Z
            start_time_ns: 1_559_541_600_000_000_000,
            compress: true,
            chunk_size: 1 << 20,
            flaws: Flaws::default(),
        }
    }
}

impl SynthOptions {
    /// Sensor noise at `level` × the PT100-like reference: temperatures σ = 0.05·level K
    /// at 0.01 K resolution, electrical channels σ = 0.05·level % of their value.
    pub fn with_noise_level(self, level: f64) -> SynthOptions {
        SynthOptions {
            temperature_noise_k: 0.05 * level,
            temperature_resolution_k: if level > 0.0 { 0.01 } else { 0.0 },
            electrical_noise_pu: 0.0005 * level,
            ..self
        }
    }
}

/// Writes a synthetic heat run to `out` and its truth to `<out>.truth.json`;
/// returns the truth.
pub fn write(out: &Path, o: &SynthOptions) -> Result<Truth> {
    check_options(o)?;
    let traj = plant::simulate(o)?;
    let mut truth = truth::truth_of(o, &traj)?;

    let mut writer = RecordingWriter::create(
        out,
        WriterOptions {
            compress: o.compress,
            chunk_size: o.chunk_size,
        },
    )?;
    let mut channels = add_channels(&mut writer, o)?;
    write_records(&mut writer, o)?;
    let mut source = SampleSource::new(o, &traj)?;
    let flaws = write_samples(&mut writer, &mut channels, &mut source, o)?;
    writer.finish()?;
    truth.flaws = flaws.asked.is_some().then_some(flaws);

    crate::atomic::write_atomically(
        &truth_path(out),
        serde_json::to_string_pretty(&truth)
            .unwrap_or_default()
            .as_bytes(),
    )?;
    Ok(truth)
}

/// The plant steps (duration / the machine's sample time) a synthetic run may take: the
/// trajectory is simulated whole before it is written, about 220 bytes a step (a run of
/// 10⁶ s at 1 s peaked at 216 MB resident), so 10⁷ steps (116 days at 1 s) need about 2 GB,
/// and a duration of 10⁹ s asked for 32 GB and aborted.
pub const MAX_PLANT_STEPS: usize = 10_000_000;

/// Rejects options that cannot make a run.
fn check_options(o: &SynthOptions) -> Result<()> {
    for (name, v) in [
        ("duration", o.duration_s),
        ("electrical rate", o.electrical_rate_hz),
        ("temperature rate", o.temperature_rate_hz),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(SynthError::Options(format!(
                "the {name} must be a positive number, not {v}"
            )));
        }
    }
    if o.duration_s < 10.0 * o.machine.ts_s() {
        return Err(SynthError::Options(
            "the duration must cover at least 10 sample times".into(),
        ));
    }
    for (name, v) in [
        ("temperature noise σ", o.temperature_noise_k),
        ("electrical noise σ", o.electrical_noise_pu),
        ("temperature resolution", o.temperature_resolution_k),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(SynthError::Options(format!(
                "the {name} must be a number ≥ 0 (0: none), not {v}"
            )));
        }
    }
    let steps = o.duration_s / o.machine.ts_s();
    if steps > MAX_PLANT_STEPS as f64 {
        return Err(SynthError::Options(format!(
            "the duration {} s is {steps:.0} steps of the plant's {} s, over the {MAX_PLANT_STEPS} \
             a synthetic run simulates in memory (about 2 GB; a week is 604800)",
            o.duration_s,
            o.machine.ts_s()
        )));
    }
    check_machine(o)?;
    o.flaws.check(o.duration_s)?;
    if let Storage::Exception {
        deadband,
        max_interval_s,
    } = o.temperature_storage
    {
        if !(deadband.is_finite() && deadband >= 0.0) {
            return Err(SynthError::Options(format!(
                "the deadband must be a number of kelvin ≥ 0, not {deadband}"
            )));
        }
        if let Some(h) = max_interval_s.filter(|h| !(h.is_finite() && *h > 0.0)) {
            return Err(SynthError::Options(format!(
                "the heartbeat must be a positive number of seconds, not {h}"
            )));
        }
    }
    Ok(())
}

/// A channel of the synthetic recording: what it carries, where it goes, and the
/// historian's filter when its samples are stored by exception.
struct SynthChannel {
    quantity: Quantity,
    id: ChannelId,
    exception: Option<ExceptionFilter>,
}

/// The channels, in the order the recording lists them (electrical, then temperatures).
fn channel_list(o: &SynthOptions) -> Vec<(Quantity, &'static str)> {
    let mut channels: Vec<(Quantity, &str)> = vec![
        (Quantity::ArmatureCurrent, "kA"),
        (Quantity::FieldCurrent, "A"),
        (Quantity::LineVoltage, "kV"),
    ];
    match o.field_channel {
        FieldChannel::Voltage => channels.push((Quantity::FieldVoltage, "V")),
        FieldChannel::Temperature => channels.push((Quantity::FieldWindingTemp, "degC")),
        FieldChannel::Nameplate | FieldChannel::Unmeasured => {}
    }
    // The field winding's node, if the machine has one, is recorded by the field channel.
    channels.extend(
        o.machine
            .states()
            .into_iter()
            .filter(|&q| q != Quantity::FieldWindingTemp)
            .map(|q| (q, "degC")),
    );
    if o.coolant.channels {
        channels.extend([
            (Quantity::CoolingWaterInletTemp, "degC"),
            (Quantity::CoolingWaterFlow, "l/s"),
        ]);
    }
    channels
}

/// Whether a channel is sampled at the temperature rate (the temperatures and the flow,
/// a slow process quantity) rather than the electrical one.
fn slow(quantity: Quantity) -> bool {
    quantity.is_temperature() || quantity == Quantity::CoolingWaterFlow
}

/// Rejects a machine and options that do not go together: disturbances on a machine
/// that is not a network, a field node without a field channel, a bad disturbance.
fn check_machine(o: &SynthOptions) -> Result<()> {
    let d = &o.disturbances;
    let network = match &o.machine {
        Machine::Model { .. } => {
            return match d.first() {
                Some(what) => Err(SynthError::Options(format!(
                    "{what} needs a machine built from a thermal network; the model given as Φ and Γ has no coolant node"
                ))),
                None => Ok(()),
            };
        }
        Machine::Network(n) => n,
    };
    if network.node(Quantity::FieldWindingTemp).is_some()
        && o.field_channel == FieldChannel::Nameplate
    {
        return Err(SynthError::Options(format!(
            "the machine '{}' has a field-winding node, recorded by its voltage or its temperature, not by the nameplate",
            network.name
        )));
    }
    if network.node(Quantity::FieldWindingTemp).is_none()
        && o.field_channel.from_nameplate()
        && d.start_above_k != 0.0
    {
        return Err(SynthError::Options(
            "a warm start with the nameplate's field temperature: the paper's method scales the field from the stator winding's rise above its start, which a warm start does not follow; record the field winding's voltage or temperature".into(),
        ));
    }
    let finite = |what: &str, v: f64, ok: bool| {
        if v.is_finite() && ok {
            Ok(())
        } else {
            Err(SynthError::Options(format!("{what} {v} is out of range")))
        }
    };
    finite("the inlet drift", d.inlet_drift_k, true)?;
    finite(
        "the inlet wave's period",
        d.inlet_wave_period_s,
        d.inlet_wave_period_s >= 0.0,
    )?;
    finite("the start above the coolant", d.start_above_k, true)?;
    finite(
        "the coolant heat walk",
        d.coolant_heat_walk_kw_per_sqrt_h,
        d.coolant_heat_walk_kw_per_sqrt_h >= 0.0,
    )?;
    finite(
        "the inlet temperature",
        o.coolant.inlet_temp_c,
        (0.0..=100.0).contains(&o.coolant.inlet_temp_c),
    )?;
    finite(
        "the flow",
        o.coolant.flow_l_per_s,
        o.coolant.flow_l_per_s > 0.0,
    )?;
    if let Some(s) = d.pump_switch {
        finite("the pump switch's time", s.time_s, s.time_s >= 0.0)?;
        finite("the pump switch's flow factor", s.factor, s.factor > 0.0)?;
    }
    if let Some(f) = d.fault {
        finite("the fault's time", f.time_s, f.time_s >= 0.0)?;
        finite(
            "the fault's conductance drop",
            f.conductance_drop,
            (0.0..1.0).contains(&f.conductance_drop),
        )?;
    }
    Ok(())
}

fn add_channels(writer: &mut RecordingWriter, o: &SynthOptions) -> Result<Vec<SynthChannel>> {
    channel_list(o)
        .into_iter()
        .map(|(quantity, unit)| {
            let exception = match o.temperature_storage {
                Storage::Exception {
                    deadband,
                    max_interval_s,
                } if quantity.is_temperature() => Some(ExceptionFilter::new(
                    deadband,
                    max_interval_s.unwrap_or(f64::INFINITY),
                )),
                _ => None,
            };
            let spec = ChannelSpec::new(quantity.name(), unit)
                .with_storage(exception.map_or(Storage::Sampled, |f| f.storage()));
            Ok(SynthChannel {
                quantity,
                id: writer.add_channel(&spec)?,
                exception,
            })
        })
        .collect()
}

/// The nameplate and the test record.
fn write_records(writer: &mut RecordingWriter, o: &SynthOptions) -> Result<()> {
    let mut nameplate = o.nameplate.clone();
    if !o.field_channel.from_nameplate() {
        // The field temperature is measured: the paper's method is not needed.
        nameplate.field_winding_final_temp_c = None;
    }
    writer.write_nameplate(&nameplate.to_record())?;
    writer.write_metadata(
        "heatrun.test",
        &[
            ("test_id".to_owned(), format!("synthetic-seed-{}", o.seed)),
            ("site".to_owned(), "heatrun synth".to_owned()),
            ("kind".to_owned(), "heat run with load steps".to_owned()),
        ]
        .into(),
    )?;
    Ok(())
}

/// Sample times relative to the start, ns, of a channel at `rate_hz` over
/// `duration_ns`. Electrical samples sit symmetrically inside their intervals of
/// `ts_ns`, temperature samples (`centred_on_instants`) around the grid instants.
fn sample_times(rate_hz: f64, centred_on_instants: bool, ts_ns: u64, duration_ns: u64) -> Vec<u64> {
    let period = 1e9 / rate_hz;
    let phase = if centred_on_instants {
        period / 2.0 - (ts_ns as f64) / 2.0
    } else {
        period / 2.0
    };
    let phase = phase.rem_euclid(period);
    (0..)
        .map(|i| (phase + i as f64 * period).round() as u64)
        .take_while(|t| *t < duration_ns)
        .collect()
}

/// Writes every channel's samples in time order: the electrical and the temperature
/// sample times merged, each instant's channels in the recording's order, the flaws laid
/// on them; returns the flaws as laid.
fn write_samples(
    writer: &mut RecordingWriter,
    channels: &mut [SynthChannel],
    source: &mut SampleSource,
    o: &SynthOptions,
) -> Result<FlawRecord> {
    let ts = o.machine.ts_s();
    let (ts_ns, steps) = (source.ts_ns, source.steps);
    let duration_ns = steps as u64 * ts_ns;
    let elec_times = sample_times(o.electrical_rate_hz, false, ts_ns, duration_ns);
    let temp_times = sample_times(
        o.temperature_rate_hz,
        o.temperature_rate_hz * ts >= 1.0,
        ts_ns,
        duration_ns,
    );
    let mut plan = flaws::FlawPlan::new(&o.flaws, elec_times.len(), temp_times.len(), o.seed);
    let (mut ie, mut it) = (0, 0);
    while ie < elec_times.len() || it < temp_times.len() {
        let take_elec =
            it >= temp_times.len() || (ie < elec_times.len() && elec_times[ie] <= temp_times[it]);
        let t_rel = if take_elec {
            elec_times[ie]
        } else {
            temp_times[it]
        };
        let log_time = o.start_time_ns + t_rel;
        for c in channels.iter_mut() {
            if slow(c.quantity) == take_elec {
                continue;
            }
            // The noise is drawn for every sample, stored or not, so a run stored by
            // exception holds a subset of the same run's samples.
            let value = source.value(c.quantity, t_rel);
            // A missing sample is written whatever the storage: it was due and did not
            // come (the historian's filter never sees it).
            match plan.apply(c.quantity, t_rel as f64 * 1e-9, value) {
                flaws::Written::Value(v) => {
                    if c.exception.as_mut().is_none_or(|f| f.keep(log_time, v)) {
                        writer.write_sample(c.id, log_time, v)?;
                    }
                }
                flaws::Written::Null => writer.write_dropout(c.id, log_time)?,
                flaws::Written::NaN => writer.write_nan_dropout(c.id, log_time)?,
            }
        }
        if take_elec {
            ie += 1;
        } else {
            it += 1;
        }
    }
    Ok(plan.finish())
}

/// The measured value of each channel at any time: the simulated trajectory seen
/// through the sensors (noise, resolution).
struct SampleSource<'a> {
    o: &'a SynthOptions,
    traj: &'a Trajectory,
    ts_ns: u64,
    steps: usize,
    /// Φ(τ), Γ(τ) of the propagation inside an interval, cached by piece and τ in ns.
    propagators: HashMap<(usize, u64), (DMatrix<f64>, DMatrix<f64>)>,
    rng: rand::rngs::StdRng,
    /// The coolant channels' own noise, so that adding them leaves the other channels'
    /// noise as it was.
    coolant_rng: rand::rngs::StdRng,
    temperature_noise: Normal<f64>,
    electrical_noise: Normal<f64>,
}

impl<'a> SampleSource<'a> {
    fn new(o: &'a SynthOptions, traj: &'a Trajectory) -> Result<SampleSource<'a>> {
        let noise = |sigma: f64| {
            Normal::new(0.0, sigma.max(0.0)).map_err(|e| SynthError::Options(e.to_string()))
        };
        Ok(SampleSource {
            o,
            traj,
            ts_ns: (o.machine.ts_s() * 1e9).round() as u64,
            steps: traj.inputs.len(),
            propagators: HashMap::new(),
            rng: rand::rngs::StdRng::seed_from_u64(o.seed),
            coolant_rng: rand::rngs::StdRng::seed_from_u64(o.seed ^ 0x0063_6f6f_6c61_6e74),
            temperature_noise: noise(o.temperature_noise_k)?,
            electrical_noise: noise(o.electrical_noise_pu)?,
        })
    }

    /// The state at `t_rel_ns` after the start:
    /// x(t_k + τ) = Φ(τ) x(k) + Γ(τ) [u(k); inlet(k); coolant heat(k)]
    /// with the piece of interval k.
    fn state_at(&mut self, t_rel_ns: u64) -> DVector<f64> {
        let k = ((t_rel_ns / self.ts_ns) as usize).min(self.steps);
        let tau = t_rel_ns - k as u64 * self.ts_ns;
        if tau == 0 || k == self.steps {
            return self.traj.states[k].clone();
        }
        let piece_index = self.traj.piece_index(k);
        let piece = &self.traj.pieces[piece_index];
        let (phi, gamma) = self
            .propagators
            .entry((piece_index, tau))
            .or_insert_with(|| discretize(&piece.a_c, &piece.b_c, tau as f64 * 1e-9));
        let m = self.traj.inputs[k].len();
        let u = self.traj.inputs[k]
            .clone()
            .insert_row(m, self.traj.inlet_offsets[k])
            .insert_row(m + 1, self.traj.coolant_heat_w[k]);
        &*phi * &self.traj.states[k] + &*gamma * &u
    }

    /// The value `quantity`'s sensor reads at `t_rel_ns` after the start, in the
    /// channel's unit, rounded to 12 significant digits.
    fn value(&mut self, quantity: Quantity, t_rel_ns: u64) -> f64 {
        let np = &self.o.nameplate;
        let k = ((t_rel_ns / self.ts_ns) as usize).min(self.steps - 1);
        let p = self.traj.points[k];
        let rated_field_current = np.rated_field_current_a.unwrap_or(1000.0);
        let value = match quantity {
            Quantity::ArmatureCurrent => {
                p.armature_current_pu * np.rated_current_a * self.electrical_factor() / 1e3
            }
            Quantity::FieldCurrent => {
                p.field_current_pu * rated_field_current * self.electrical_factor()
            }
            Quantity::LineVoltage => {
                p.line_voltage_pu * np.rated_voltage_v * self.electrical_factor() / 1e3
            }
            Quantity::FieldVoltage => {
                let i_f = p.field_current_pu * rated_field_current;
                let r = copper_resistance(
                    np.field_resistance_ohm,
                    np.field_resistance_ref_temp_c,
                    self.traj.field_temps[k],
                );
                i_f * r * self.electrical_factor()
            }
            Quantity::CoolingWaterFlow => {
                let noise = self.electrical_noise.sample(&mut self.coolant_rng);
                plant::flow_l_per_s(self.o, t_rel_ns as f64 * 1e-9) * (1.0 + noise)
            }
            Quantity::CoolingWaterInletTemp => {
                let t = plant::inlet_temperature_c(self.o, t_rel_ns as f64 * 1e-9);
                let noise = self.temperature_noise.sample(&mut self.coolant_rng);
                self.quantize(t + noise)
            }
            _ => {
                let temperature = self.true_temperature(quantity, t_rel_ns);
                let noise = self.temperature_noise.sample(&mut self.rng);
                self.quantize(temperature + noise)
            }
        };
        round_to_12_digits(value)
    }

    /// 1 + the relative noise of an electrical sensor.
    fn electrical_factor(&mut self) -> f64 {
        1.0 + self.electrical_noise.sample(&mut self.rng)
    }

    /// The noise-free temperature of a state's quantity (or the field winding's), °C.
    fn true_temperature(&mut self, quantity: Quantity, t_rel_ns: u64) -> f64 {
        let x = self.state_at(t_rel_ns);
        let base = self.o.nameplate.temperature_base_k;
        match self.o.machine.states().iter().position(|&q| q == quantity) {
            Some(j) => self.traj.temperature(&x, j, base),
            None => self.traj.field_temperature(&x, base),
        }
    }

    /// A temperature at the transducer's resolution.
    fn quantize(&self, v: f64) -> f64 {
        let r = self.o.temperature_resolution_k;
        if r > 0.0 {
            (v / r).round() * r
        } else {
            v
        }
    }
}

/// A value rounded to 12 significant digits: exact to 1e-12 relative, and written
/// (shortest form that reads back) without trailing noise.
fn round_to_12_digits(v: f64) -> f64 {
    format!("{v:.12e}").parse().unwrap_or(v)
}

#[cfg(test)]
mod tests;
