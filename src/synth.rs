//! Synthetic heat runs: a recording in the profile simulated from a known model.
//!
//! The truth is the continuous system dy/dt = A_c y + B_c u (by default the
//! continuous equivalent of the paper's Φ and Γ, eqs. 19–20) driven by the loss
//! model of the profile: the operating point (I_g, U_g, I_f) is held over each
//! interval [t_k, t_k + Ts) and the losses use the temperatures at t_k, so the
//! exact discretisation at Ts is the model x(k) = Φ x(k−1) + Γ u(k−1). Every channel
//! is sampled at its own rate with optional Gaussian noise and resolution.

use std::collections::{BTreeMap, HashMap};
use std::io::BufWriter;
use std::path::Path;

use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use serde::Serialize;

use crate::atomic::PendingOutput;
use crate::error::{Error, Result};
use crate::estimate::DiscreteModel;
use crate::losses::{self, copper_resistance};
use crate::model::matrix::{discretize, rows};
use crate::model::{ContinuousModel, Spectrum};
use crate::recording::{
    Nameplate, Quantity, NAMEPLATE_RECORD, SAMPLE_MESSAGE_ENCODING, SAMPLE_SCHEMA_ENCODING,
    SAMPLE_SCHEMA_NAME,
};

/// The JSON Schema of a sample message (also `schemas/sample.schema.json`).
pub const SAMPLE_SCHEMA: &str = include_str!("../schemas/sample.schema.json");

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
    let traj = simulate(o)?;
    let continuous = ContinuousModel::from_discrete(&o.truth)?;
    let spectrum = Spectrum::of(&o.truth)?;
    let np = &o.nameplate;
    let ts = o.truth.ts_s;
    let base = np.temperature_base_k;
    let th0 = o.initial_temperatures_c;
    let steps = traj.inputs.len();
    let ts_ns = (ts * 1e9).round() as u64;

    // Intra-interval propagation x(t_k + τ) = Φ(τ) x(k) + Γ(τ) u(k), cached by τ.
    let mut propagators: HashMap<u64, (DMatrix<f64>, DMatrix<f64>)> = HashMap::new();
    let mut state_at = |t_rel_ns: u64| -> DVector<f64> {
        let k = ((t_rel_ns / ts_ns) as usize).min(steps);
        let tau = t_rel_ns - k as u64 * ts_ns;
        if tau == 0 || k == steps {
            return traj.states[k].clone();
        }
        let (phi, gamma) = propagators
            .entry(tau)
            .or_insert_with(|| discretize(&continuous.a_c, &continuous.b_c, tau as f64 * 1e-9));
        &*phi * &traj.states[k] + &*gamma * &traj.inputs[k]
    };

    let mut rng = rand::rngs::StdRng::seed_from_u64(o.seed);
    let temp_noise = Normal::new(0.0, o.temperature_noise_k.max(0.0))
        .map_err(|e| Error::Usage(e.to_string()))?;
    let elec_noise = Normal::new(0.0, o.electrical_noise_pu.max(0.0))
        .map_err(|e| Error::Usage(e.to_string()))?;
    let quantize = |v: f64| {
        if o.temperature_resolution_k > 0.0 {
            (v / o.temperature_resolution_k).round() * o.temperature_resolution_k
        } else {
            v
        }
    };

    // Sample times, relative to the start, per channel kind. Electrical samples sit
    // symmetrically inside their intervals, temperature samples around the instants.
    let duration_ns = steps as u64 * ts_ns;
    let times = |rate: f64, centred_on_instants: bool| -> Vec<u64> {
        let period = 1e9 / rate;
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
    };
    let elec_times = times(o.electrical_rate_hz, false);
    let temp_times = times(o.temperature_rate_hz, o.temperature_rate_hz * ts >= 1.0);

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

    let pending = PendingOutput::new(out);
    let file = std::fs::File::create(pending.path()).map_err(|e| Error::WriteOutput {
        path: out.to_owned(),
        message: e.to_string(),
    })?;
    let wr = |e: mcap::McapError| Error::WriteOutput {
        path: out.to_owned(),
        message: e.to_string(),
    };
    let options = mcap::WriteOptions::new()
        .profile("heatrun-scada/1")
        .library(concat!("heatrun ", env!("CARGO_PKG_VERSION")))
        .compression(if o.compress {
            Some(mcap::Compression::Zstd)
        } else {
            None
        })
        .chunk_size(Some(o.chunk_size));
    let mut writer = options.create(BufWriter::new(file)).map_err(wr)?;
    let schema = writer
        .add_schema(
            SAMPLE_SCHEMA_NAME,
            SAMPLE_SCHEMA_ENCODING,
            SAMPLE_SCHEMA.as_bytes(),
        )
        .map_err(wr)?;
    let mut ids = Vec::new();
    for (q, unit) in &channels {
        let meta: BTreeMap<String, String> = [
            ("quantity".to_owned(), q.name().to_owned()),
            ("unit".to_owned(), unit.to_string()),
        ]
        .into();
        ids.push(
            writer
                .add_channel(
                    schema,
                    &format!("/scada/{}", q.name()),
                    SAMPLE_MESSAGE_ENCODING,
                    &meta,
                )
                .map_err(wr)?,
        );
    }
    let mut nameplate = np.clone();
    if o.field_channel != FieldChannel::Nameplate {
        nameplate.field_winding_final_temp_c = None;
    }
    writer
        .write_metadata(&mcap::records::Metadata {
            name: NAMEPLATE_RECORD.into(),
            metadata: nameplate.to_record(),
        })
        .map_err(wr)?;
    writer
        .write_metadata(&mcap::records::Metadata {
            name: "heatrun.test".into(),
            metadata: [
                ("test_id".to_owned(), format!("synthetic-seed-{}", o.seed)),
                ("site".to_owned(), "heatrun synth".to_owned()),
                ("kind".to_owned(), "heat run with load steps".to_owned()),
            ]
            .into(),
        })
        .map_err(wr)?;

    // Merge the two time lists so messages go out in time order.
    let (mut ie, mut it) = (0, 0);
    let mut seq = 0u32;
    let mut buf = String::new();
    while ie < elec_times.len() || it < temp_times.len() {
        let take_elec =
            it >= temp_times.len() || (ie < elec_times.len() && elec_times[ie] <= temp_times[it]);
        let t_rel = if take_elec {
            elec_times[ie]
        } else {
            temp_times[it]
        };
        let log_time = o.start_time_ns + t_rel;
        for (c, (q, _)) in channels.iter().enumerate() {
            if q.is_temperature() == take_elec {
                continue;
            }
            let k = ((t_rel / ts_ns) as usize).min(steps - 1);
            let p = traj.points[k];
            let value = match q {
                Quantity::ArmatureCurrent => {
                    p.armature_current_pu * np.rated_current_a * (1.0 + elec_noise.sample(&mut rng))
                        / 1e3
                }
                Quantity::FieldCurrent => {
                    p.field_current_pu
                        * np.rated_field_current_a.unwrap_or(1000.0)
                        * (1.0 + elec_noise.sample(&mut rng))
                }
                Quantity::LineVoltage => {
                    p.line_voltage_pu * np.rated_voltage_v * (1.0 + elec_noise.sample(&mut rng))
                        / 1e3
                }
                Quantity::FieldVoltage => {
                    let i_f = p.field_current_pu * np.rated_field_current_a.unwrap_or(1000.0);
                    let r = copper_resistance(
                        np.field_resistance_ohm,
                        np.field_resistance_ref_temp_c,
                        traj.field_temps[k],
                    );
                    i_f * r * (1.0 + elec_noise.sample(&mut rng))
                }
                _ => {
                    let x = state_at(t_rel);
                    let j = match q {
                        Quantity::StatorWindingTemp => 0,
                        Quantity::CoreTemp => 1,
                        Quantity::CoolingWaterOutletTemp => 2,
                        _ => {
                            // Field winding temperature from the stator winding's.
                            let cu = th0[0] + base * x[0];
                            let v = th0[0] + traj.field_scale * (cu - th0[0]);
                            buf.clear();
                            buf.push_str(&format!(
                                "{{\"value\":{}}}",
                                fmt_value(quantize(v + temp_noise.sample(&mut rng)))
                            ));
                            writer
                                .write_to_known_channel(
                                    &mcap::records::MessageHeader {
                                        channel_id: ids[c],
                                        sequence: seq,
                                        log_time,
                                        publish_time: log_time,
                                    },
                                    buf.as_bytes(),
                                )
                                .map_err(wr)?;
                            seq = seq.wrapping_add(1);
                            continue;
                        }
                    };
                    quantize(th0[j] + base * x[j] + temp_noise.sample(&mut rng))
                }
            };
            buf.clear();
            buf.push_str(&format!("{{\"value\":{}}}", fmt_value(value)));
            writer
                .write_to_known_channel(
                    &mcap::records::MessageHeader {
                        channel_id: ids[c],
                        sequence: seq,
                        log_time,
                        publish_time: log_time,
                    },
                    buf.as_bytes(),
                )
                .map_err(wr)?;
            seq = seq.wrapping_add(1);
        }
        if take_elec {
            ie += 1;
        } else {
            it += 1;
        }
    }
    writer.finish().map_err(wr)?;
    drop(writer);
    pending.commit()?;

    let last_u = traj.inputs[steps - 1].clone();
    let ss = continuous.steady_state(last_u.as_slice())?;
    let truth = Truth {
        phi: rows(&o.truth.phi),
        gamma: rows(&o.truth.gamma),
        a_c: rows(&continuous.a_c),
        b_c: rows(&continuous.b_c),
        sample_time_s: ts,
        time_constants_s: spectrum.time_constants_s,
        final_input_pu: last_u.iter().copied().collect(),
        steady_state_rise_k: ss.iter().map(|v| v * base).collect(),
        initial_temperatures_c: th0.to_vec(),
        final_temperatures_c: (0..3)
            .map(|j| th0[j] + base * traj.states[steps][j])
            .collect(),
        profile: o.profile.clone(),
        seed: o.seed,
    };
    let truth_path = truth_path(out);
    crate::atomic::write_atomically(
        &truth_path,
        serde_json::to_string_pretty(&truth)
            .unwrap_or_default()
            .as_bytes(),
    )?;
    Ok(truth)
}

/// Where the truth of a synthetic recording is written: `<OUT>.truth.json`.
pub fn truth_path(out: &Path) -> std::path::PathBuf {
    let mut s = out.as_os_str().to_owned();
    s.push(".truth.json");
    s.into()
}

/// A value with enough digits to be exact to 1e-12 relative, without trailing noise.
fn fmt_value(v: f64) -> String {
    let s = format!("{v:.12e}");
    // Re-parse to drop redundant digits: shortest representation that round-trips.
    s.parse::<f64>().map(|x| format!("{x}")).unwrap_or(s)
}
