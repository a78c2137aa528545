//! Synthetic heat runs: a recording in the profile simulated from a known model.
//!
//! The truth is the continuous system dy/dt = A_c y + B_c u (by default the
//! continuous equivalent of the paper's Φ and Γ, eqs. 19–20) driven by the loss
//! model of the profile: the operating point (I_g, U_g, I_f) is held over each
//! interval [t_k, t_k + Ts) and the losses use the temperatures at t_k, so the
//! exact discretisation at Ts is the model x(k) = Φ x(k−1) + Γ u(k−1). Every channel
//! is sampled at its own rate with optional Gaussian noise and resolution, and the
//! temperatures are optionally stored by exception as a SCADA historian does
//! (deadband and heartbeat).

use std::collections::HashMap;
use std::path::Path;

use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use serde::Serialize;

use crate::error::{Error, Result};
use crate::estimate::DiscreteModel;
use crate::losses::{self, copper_resistance};
use crate::model::matrix::{discretize, rows};
use crate::model::{ContinuousModel, Spectrum};
use crate::recording::{Nameplate, Quantity};
use crate::writer::{
    ChannelId, ChannelSpec, ExceptionFilter, RecordingWriter, Storage, WriterOptions,
};

pub use crate::writer::SAMPLE_SCHEMA;

/// Φ of the paper, eq. (19), Ts = 1 s.
pub const PAPER_PHI: [[f64; 3]; 3] = [
    [0.99880000, 0.00045967, 0.00078830],
    [0.00019304, 0.99942000, 0.00307540],
    [0.00201840, 0.00110190, 0.95914000],
];

/// Γ of the paper, eq. (20), Ts = 1 s.
pub const PAPER_GAMMA: [[f64; 3]; 3] = [
    [0.0710060, 0.1158700, -0.0610920],
    [-0.0027636, -0.0110370, -0.0060849],
    [0.0088751, -0.2395500, 0.3480100],
];

/// The paper's printed continuous system matrix A_c, 1/s (eq. 22).
pub const PAPER_A_C: [[f64; 3]; 3] = [
    [-0.00119970, 0.00045965, 0.0007745],
    [0.00019001, -0.00057742, 0.0031408],
    [0.00206200, 0.00112490, -0.041717],
];

/// The paper's printed continuous input matrix B_c, 1/s (eq. 23).
pub const PAPER_B_C: [[f64; 3]; 3] = [
    [0.0710460, 0.1160400, -0.0612630],
    [-0.0027851, -0.0106720, -0.0066313],
    [0.0089894, -0.2447000, 0.3553900],
];

/// Measured initial temperatures of the paper: θ_Cu0, θ_Fe0, θ_cw0 in °C.
pub const PAPER_INITIAL_TEMPERATURES_C: [f64; 3] = [36.7, 36.3, 10.5];

/// The paper's model as a [`DiscreteModel`].
pub fn paper_model() -> DiscreteModel {
    let m = |a: [[f64; 3]; 3]| DMatrix::from_fn(3, 3, |i, j| a[i][j]);
    DiscreteModel {
        phi: m(PAPER_PHI),
        gamma: m(PAPER_GAMMA),
        ts_s: 1.0,
    }
}

/// A second machine of other time constants (about 60 s, 1100 s and 5000 s), for
/// accuracy figures that do not hang on the paper's model alone: A_c, B_c given in
/// continuous form and discretised (ZOH) at Ts = 1 s.
pub fn second_machine_model() -> DiscreteModel {
    #[rustfmt::skip]
    let a_c = DMatrix::from_row_slice(3, 3, &[
        -1.0 / 1100.0, 0.00010, 0.00020,
        0.00005, -1.0 / 5000.0, 0.00030,
        0.00050, 0.00030, -1.0 / 60.0,
    ]);
    #[rustfmt::skip]
    let b_c = DMatrix::from_row_slice(3, 3, &[
        0.050, 0.060, -0.020,
        0.004, 0.006, 0.012,
        0.010, -0.080, 0.140,
    ]);
    let (phi, gamma) = crate::model::matrix::discretize(&a_c, &b_c, 1.0);
    DiscreteModel {
        phi,
        gamma,
        ts_s: 1.0,
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
    /// The true model at its sample time (the interval the operating point is held over).
    pub truth: DiscreteModel,
    /// The machine.
    pub nameplate: Nameplate,
    /// Initial temperatures, °C.
    pub initial_temperatures_c: [f64; 3],
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
}

impl Default for SynthOptions {
    fn default() -> Self {
        SynthOptions {
            truth: paper_model(),
            nameplate: Nameplate::paper_table1(),
            initial_temperatures_c: PAPER_INITIAL_TEMPERATURES_C,
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

/// What a synthetic run was made from, written beside it as `<OUT>.truth.json`.
#[derive(Debug, Clone, Serialize)]
pub struct Truth {
    /// The true Φ.
    pub phi: Vec<Vec<f64>>,
    /// The true Γ.
    pub gamma: Vec<Vec<f64>>,
    /// The true A_c.
    pub a_c: Vec<Vec<f64>>,
    /// The true B_c.
    pub b_c: Vec<Vec<f64>>,
    /// Sample time of Φ and Γ, s.
    pub sample_time_s: f64,
    /// True time constants, s, ascending.
    pub time_constants_s: Vec<f64>,
    /// The last input, pu.
    pub final_input_pu: Vec<f64>,
    /// The true steady-state rises for it, K.
    pub steady_state_rise_k: Vec<f64>,
    /// Initial temperatures, °C.
    pub initial_temperatures_c: Vec<f64>,
    /// Noise-free temperatures at the end, °C.
    pub final_temperatures_c: Vec<f64>,
    /// The operating schedule.
    pub profile: Vec<OperatingPoint>,
    /// The seed.
    pub seed: u64,
}

/// The noise-free simulated run on the model's grid.
struct Trajectory {
    /// States (rise, pu) at each grid instant, N + 1 of them.
    states: Vec<DVector<f64>>,
    /// Operating point per interval.
    points: Vec<OperatingPoint>,
    /// Field winding temperature at each instant, °C.
    field_temps: Vec<f64>,
    /// Inputs per interval, pu.
    inputs: Vec<DVector<f64>>,
    /// Field scale used for the nameplate method.
    field_scale: f64,
}

fn simulate(o: &SynthOptions) -> Result<Trajectory> {
    let ts = o.truth.ts_s;
    let steps = (o.duration_s / ts).round() as usize;
    let np = &o.nameplate;
    let base = np.temperature_base_k;
    let th0 = o.initial_temperatures_c;
    let final_field = np.field_winding_final_temp_c.unwrap_or(81.0);
    let point_at = |k: usize| {
        let f = k as f64 / steps as f64;
        *o.profile
            .iter()
            .rev()
            .find(|p| p.start_fraction <= f + 1e-12)
            .unwrap_or(&o.profile[0])
    };
    // The paper's field temperature θ_f = θ_Cu0 + s (θ_Cu − θ_Cu0): iterate s to its fixed
    // point so that the final field temperature is the nameplate's.
    let mut scale = (final_field - th0[0]) / 26.3;
    let mut result = None;
    for _ in 0..30 {
        let mut x = DVector::zeros(3);
        let mut states = Vec::with_capacity(steps + 1);
        let mut field_temps = Vec::with_capacity(steps + 1);
        let mut inputs = Vec::with_capacity(steps);
        let mut points = Vec::with_capacity(steps);
        for k in 0..=steps {
            let theta_cu = th0[0] + base * x[0];
            let theta_f = th0[0] + scale * (theta_cu - th0[0]);
            states.push(x.clone());
            field_temps.push(theta_f);
            if k == steps {
                break;
            }
            let p = point_at(k);
            let i_g = p.armature_current_pu * np.rated_current_a;
            let i_f = p.field_current_pu * np.rated_field_current_a.unwrap_or(1000.0);
            let u_g = p.line_voltage_pu * np.rated_voltage_v;
            let s_n = np.rated_apparent_power_va;
            let u = DVector::from_vec(vec![
                losses::armature_copper_loss_w(np, i_g, theta_cu) / s_n,
                losses::field_copper_loss_w(np, i_f, theta_f) / s_n,
                losses::iron_loss_w(np, u_g) / s_n,
            ]);
            x = &o.truth.phi * &x + &o.truth.gamma * &u;
            inputs.push(u);
            points.push(p);
        }
        let final_rise = base * states[steps][0];
        if final_rise <= 0.5 {
            return Err(Error::Usage(
                "the synthetic run's stator winding does not heat up".into(),
            ));
        }
        let new_scale = (final_field - th0[0]) / final_rise;
        let converged = (new_scale - scale).abs() < 1e-13 * scale.abs();
        result = Some(Trajectory {
            states,
            points,
            field_temps,
            inputs,
            field_scale: scale,
        });
        if converged || o.field_channel != FieldChannel::Nameplate {
            break;
        }
        scale = new_scale;
    }
    result.ok_or_else(|| Error::Usage("empty synthetic run".into()))
}

/// Writes a synthetic heat run to `out` and its truth to `<out>.truth.json`;
/// returns the truth.
pub fn write(out: &Path, o: &SynthOptions) -> Result<Truth> {
    check_options(o)?;
    let traj = simulate(o)?;
    let continuous = ContinuousModel::from_discrete(&o.truth)?;
    let spectrum = Spectrum::of(&o.truth)?;

    let mut writer = RecordingWriter::create(
        out,
        WriterOptions {
            compress: o.compress,
            chunk_size: o.chunk_size,
        },
    )?;
    let mut channels = add_channels(&mut writer, o)?;
    write_records(&mut writer, o)?;
    let mut source = SampleSource::new(o, &traj, &continuous)?;
    write_samples(&mut writer, &mut channels, &mut source, o)?;
    writer.finish()?;

    let truth = truth_of(o, &traj, &continuous, spectrum)?;
    crate::atomic::write_atomically(
        &truth_path(out),
        serde_json::to_string_pretty(&truth)
            .unwrap_or_default()
            .as_bytes(),
    )?;
    Ok(truth)
}

/// Rejects options that cannot make a run.
fn check_options(o: &SynthOptions) -> Result<()> {
    for (name, v) in [
        ("duration", o.duration_s),
        ("electrical rate", o.electrical_rate_hz),
        ("temperature rate", o.temperature_rate_hz),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(Error::Usage(format!(
                "the {name} must be a positive number, not {v}"
            )));
        }
    }
    if o.duration_s < 10.0 * o.truth.ts_s {
        return Err(Error::Usage(
            "the duration must cover at least 10 sample times".into(),
        ));
    }
    if let Storage::Exception {
        deadband,
        max_interval_s,
    } = o.temperature_storage
    {
        if !(deadband.is_finite() && deadband >= 0.0) {
            return Err(Error::Usage(format!(
                "the deadband must be a number of kelvin ≥ 0, not {deadband}"
            )));
        }
        if let Some(h) = max_interval_s.filter(|h| !(h.is_finite() && *h > 0.0)) {
            return Err(Error::Usage(format!(
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
        FieldChannel::Nameplate => {}
    }
    channels.extend([
        (Quantity::StatorWindingTemp, "degC"),
        (Quantity::CoreTemp, "degC"),
        (Quantity::CoolingWaterOutletTemp, "degC"),
    ]);
    channels
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
    if o.field_channel != FieldChannel::Nameplate {
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
    )
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
/// sample times merged, each instant's channels in the recording's order.
fn write_samples(
    writer: &mut RecordingWriter,
    channels: &mut [SynthChannel],
    source: &mut SampleSource,
    o: &SynthOptions,
) -> Result<()> {
    let ts = o.truth.ts_s;
    let (ts_ns, steps) = (source.ts_ns, source.steps);
    let duration_ns = steps as u64 * ts_ns;
    let elec_times = sample_times(o.electrical_rate_hz, false, ts_ns, duration_ns);
    let temp_times = sample_times(
        o.temperature_rate_hz,
        o.temperature_rate_hz * ts >= 1.0,
        ts_ns,
        duration_ns,
    );
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
            if c.quantity.is_temperature() == take_elec {
                continue;
            }
            // The noise is drawn for every sample, stored or not, so a run stored by
            // exception holds a subset of the same run's samples.
            let value = source.value(c.quantity, t_rel);
            if c.exception.as_mut().is_none_or(|f| f.keep(log_time, value)) {
                writer.write_sample(c.id, log_time, value)?;
            }
        }
        if take_elec {
            ie += 1;
        } else {
            it += 1;
        }
    }
    Ok(())
}

/// The measured value of each channel at any time: the simulated trajectory seen
/// through the sensors (noise, resolution).
struct SampleSource<'a> {
    o: &'a SynthOptions,
    traj: &'a Trajectory,
    continuous: &'a ContinuousModel,
    ts_ns: u64,
    steps: usize,
    /// Φ(τ), Γ(τ) of the propagation inside an interval, cached by τ in ns.
    propagators: HashMap<u64, (DMatrix<f64>, DMatrix<f64>)>,
    rng: rand::rngs::StdRng,
    temperature_noise: Normal<f64>,
    electrical_noise: Normal<f64>,
}

impl<'a> SampleSource<'a> {
    fn new(
        o: &'a SynthOptions,
        traj: &'a Trajectory,
        continuous: &'a ContinuousModel,
    ) -> Result<SampleSource<'a>> {
        let noise =
            |sigma: f64| Normal::new(0.0, sigma.max(0.0)).map_err(|e| Error::Usage(e.to_string()));
        Ok(SampleSource {
            o,
            traj,
            continuous,
            ts_ns: (o.truth.ts_s * 1e9).round() as u64,
            steps: traj.inputs.len(),
            propagators: HashMap::new(),
            rng: rand::rngs::StdRng::seed_from_u64(o.seed),
            temperature_noise: noise(o.temperature_noise_k)?,
            electrical_noise: noise(o.electrical_noise_pu)?,
        })
    }

    /// The state at `t_rel_ns` after the start: x(t_k + τ) = Φ(τ) x(k) + Γ(τ) u(k).
    fn state_at(&mut self, t_rel_ns: u64) -> DVector<f64> {
        let k = ((t_rel_ns / self.ts_ns) as usize).min(self.steps);
        let tau = t_rel_ns - k as u64 * self.ts_ns;
        if tau == 0 || k == self.steps {
            return self.traj.states[k].clone();
        }
        let c = self.continuous;
        let (phi, gamma) = self
            .propagators
            .entry(tau)
            .or_insert_with(|| discretize(&c.a_c, &c.b_c, tau as f64 * 1e-9));
        &*phi * &self.traj.states[k] + &*gamma * &self.traj.inputs[k]
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

    /// The noise-free temperature of a temperature quantity, °C.
    fn true_temperature(&mut self, quantity: Quantity, t_rel_ns: u64) -> f64 {
        let x = self.state_at(t_rel_ns);
        let th0 = self.o.initial_temperatures_c;
        let base = self.o.nameplate.temperature_base_k;
        let j = match quantity {
            Quantity::StatorWindingTemp => 0,
            Quantity::CoreTemp => 1,
            Quantity::CoolingWaterOutletTemp => 2,
            _ => {
                // The field winding temperature, from the stator winding's.
                let cu = th0[0] + base * x[0];
                return th0[0] + self.traj.field_scale * (cu - th0[0]);
            }
        };
        th0[j] + base * x[j]
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

/// The truth beside the recording.
fn truth_of(
    o: &SynthOptions,
    traj: &Trajectory,
    continuous: &ContinuousModel,
    spectrum: Spectrum,
) -> Result<Truth> {
    let steps = traj.inputs.len();
    let base = o.nameplate.temperature_base_k;
    let th0 = o.initial_temperatures_c;
    let last_u = traj.inputs[steps - 1].clone();
    let ss = continuous.steady_state(last_u.as_slice())?;
    Ok(Truth {
        phi: rows(&o.truth.phi),
        gamma: rows(&o.truth.gamma),
        a_c: rows(&continuous.a_c),
        b_c: rows(&continuous.b_c),
        sample_time_s: o.truth.ts_s,
        time_constants_s: spectrum.time_constants_s,
        final_input_pu: last_u.iter().copied().collect(),
        steady_state_rise_k: ss.iter().map(|v| v * base).collect(),
        initial_temperatures_c: th0.to_vec(),
        final_temperatures_c: (0..3)
            .map(|j| th0[j] + base * traj.states[steps][j])
            .collect(),
        profile: o.profile.clone(),
        seed: o.seed,
    })
}

/// Where the truth of a synthetic recording is written: `<OUT>.truth.json`.
pub fn truth_path(out: &Path) -> std::path::PathBuf {
    let mut s = out.as_os_str().to_owned();
    s.push(".truth.json");
    s.into()
}

/// A value rounded to 12 significant digits: exact to 1e-12 relative, and written
/// (shortest form that reads back) without trailing noise.
fn round_to_12_digits(v: f64) -> f64 {
    format!("{v:.12e}").parse().unwrap_or(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reads a recording's messages: (topic, log time, JSON text).
    fn messages(path: &Path) -> Vec<(String, u64, String)> {
        let bytes = std::fs::read(path).unwrap();
        mcap::MessageStream::new(&bytes)
            .unwrap()
            .map(|m| {
                let m = m.unwrap();
                let text = String::from_utf8(m.data.to_vec()).unwrap();
                (m.channel.topic.clone(), m.log_time, text)
            })
            .collect()
    }

    #[test]
    fn storage_by_exception_keeps_a_subset_that_obeys_deadband_and_heartbeat() {
        let dir = std::env::temp_dir().join(format!("heatrun-synth-exc-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let base = SynthOptions {
            duration_s: 3000.0,
            ..SynthOptions::default().with_noise_level(1.0)
        };
        let exception = SynthOptions {
            temperature_storage: Storage::Exception {
                deadband: 0.1,
                max_interval_s: Some(600.0),
            },
            ..base.clone()
        };
        write(&dir.join("all.mcap"), &base).unwrap();
        write(&dir.join("exc.mcap"), &exception).unwrap();
        let all = messages(&dir.join("all.mcap"));
        let exc = messages(&dir.join("exc.mcap"));
        std::fs::remove_dir_all(&dir).unwrap();

        let value = |text: &str| -> f64 {
            serde_json::from_str::<serde_json::Value>(text).unwrap()["value"]
                .as_f64()
                .unwrap()
        };
        let topic = "/scada/stator_winding_temp";
        let full: Vec<(u64, f64)> = all
            .iter()
            .filter(|m| m.0 == topic)
            .map(|m| (m.1, value(&m.2)))
            .collect();
        let kept: Vec<(u64, f64)> = exc
            .iter()
            .filter(|m| m.0 == topic)
            .map(|m| (m.1, value(&m.2)))
            .collect();
        // The electrical channels are untouched.
        let electrical = |ms: &[(String, u64, String)]| {
            ms.iter()
                .filter(|m| m.0 == "/scada/armature_current")
                .count()
        };
        assert_eq!(electrical(&all), electrical(&exc));
        assert!(
            kept.len() < full.len() / 2,
            "{} of {}",
            kept.len(),
            full.len()
        );
        // Each stored sample is the full run's sample at that time; every sample in
        // between stayed within the deadband of the last stored one, inside the heartbeat.
        let mut j = 0;
        let mut last = full[0];
        assert_eq!(kept[0], full[0]);
        for &(t, v) in &full[1..] {
            let stored = j + 1 < kept.len() && kept[j + 1].0 == t;
            let due = (v - last.1).abs() > 0.1 || t - last.0 >= 600_000_000_000;
            assert_eq!(stored, due, "at {t}: {v} after {last:?}");
            if stored {
                assert_eq!(kept[j + 1].1, v);
                j += 1;
                last = (t, v);
            }
        }
        assert_eq!(j + 1, kept.len());
    }
}
