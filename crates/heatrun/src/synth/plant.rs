//! The simulation of a synthetic run: the machine's dynamics on the grid of its hold
//! interval Ts, piece by piece where the network changes (a pump switch, a fault).
//!
//! The state x holds the temperatures in units of θ_base above a per-state reference:
//! θ_i = θ_ref,i + θ_base·x_i. For a discrete model the reference is its initial
//! temperatures; for a network it is the coolant inlet's initial temperature θ_in(0),
//! and since L·1 = g₀ the network's equation in x is
//!
//! ```text
//! dx/dt = A_c x + B_c u + C⁻¹g₀·(θ_in − θ_in(0))/θ_base,   A_c = −C⁻¹L,  B_c = C⁻¹·K·S_n/θ_base
//! ```
//!
//! The losses u (pu of S_n), the operating point and the inlet are held over each
//! interval [t_k, t_k + Ts) (the losses at the temperatures of t_k, the inlet at the
//! interval's middle), so each piece's zero-order-hold discretisation [Φ, Γ | Γ_in] is
//! exact. An unmeasured heat flow q into the cooling-water node (a random walk,
//! [`coolant_heat_walk_w`]) is held the same way, its column e_out/(C_out·θ_base) per W:
//! [Φ, Γ | Γ_in | Γ_q].

use nalgebra::{DMatrix, DVector};

use super::machines::{Machine, NetworkMachine};
use super::{OperatingPoint, SynthOptions};
use super::{Result, SynthError};
use crate::losses;
use crate::model::ContinuousModel;
use crate::network::calorimetry::WaterModel;
use crate::network::{Labels, Network, Parts, ScaleSource, Scaling};
use crate::recording::Quantity;
use crate::thermal::matrix::discretize;

/// The period of the inlet's daily swing, s.
const DAY_S: f64 = 86_400.0;

/// Why the network changes during a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ChangeCause {
    /// The flow (and with it c·ρ·Q) changes: a pump switched.
    PumpSwitch,
    /// The conductances to the coolant fall: a fouled cooler.
    Fault,
}

/// The machine's dynamics from one grid instant on.
#[derive(Debug, Clone)]
pub struct Piece {
    /// The first interval it governs.
    pub start_step: usize,
    /// What changed there (none for the first piece).
    pub causes: Vec<ChangeCause>,
    /// The flow, l/s.
    pub flow_l_per_s: f64,
    /// The network's conductances (off-diagonal between nodes, diagonal to the coolant), W/K.
    pub conductance_w_per_k: Option<DMatrix<f64>>,
    /// A_c, 1/s.
    pub a_c: DMatrix<f64>,
    /// [B_c | C⁻¹g₀ | e_out/(C_out·θ_base)]: the losses' columns (1/s), the inlet's
    /// (1/s) and the unmeasured coolant heat's (per W, 1/s).
    pub b_c: DMatrix<f64>,
    /// Φ at Ts.
    pub phi: DMatrix<f64>,
    /// [Γ | Γ_in | Γ_q] at Ts.
    pub gamma: DMatrix<f64>,
}

/// How the field winding's temperature follows from the states.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FieldTemperature {
    /// The paper's method: θ_f = θ_0 + s·(θ_W − θ_0) of the stator winding's θ_W, θ_0 its
    /// initial temperature (a discrete model) or the coolant inlet's (a network machine,
    /// which may start warm).
    Scaled {
        /// The stator winding's state.
        winding: usize,
        /// s.
        scale: f64,
        /// θ_0, °C.
        reference_c: f64,
    },
    /// A node of the network.
    Node(usize),
}

/// The noise-free simulated run on the machine's grid.
pub struct Trajectory {
    /// States at each grid instant, N + 1 of them.
    pub states: Vec<DVector<f64>>,
    /// θ_ref per state, °C.
    pub reference_c: Vec<f64>,
    /// Operating point per interval.
    pub points: Vec<OperatingPoint>,
    /// Field winding temperature at each instant, °C.
    pub field_temps: Vec<f64>,
    /// Losses per interval, pu of S_n.
    pub inputs: Vec<DVector<f64>>,
    /// (θ_in − θ_in(0))/θ_base per interval.
    pub inlet_offsets: Vec<f64>,
    /// The unmeasured heat into the cooling-water node per interval, W.
    pub coolant_heat_w: Vec<f64>,
    /// The pieces, in time order; the first starts at 0.
    pub pieces: Vec<Piece>,
    /// How θ_f follows from the states.
    pub field: FieldTemperature,
}

impl Trajectory {
    /// The piece governing interval `k`.
    pub fn piece_index(&self, k: usize) -> usize {
        self.pieces
            .iter()
            .rposition(|p| p.start_step <= k)
            .unwrap_or(0)
    }

    /// θ_i in °C of state vector `x`.
    pub fn temperature(&self, x: &DVector<f64>, i: usize, base: f64) -> f64 {
        self.reference_c[i] + base * x[i]
    }

    /// The field winding temperature of state vector `x`, °C.
    pub fn field_temperature(&self, x: &DVector<f64>, base: f64) -> f64 {
        match self.field {
            FieldTemperature::Node(i) => self.temperature(x, i, base),
            FieldTemperature::Scaled {
                winding,
                scale,
                reference_c,
            } => reference_c + scale * (self.temperature(x, winding, base) - reference_c),
        }
    }
}

/// The coolant inlet's temperature at `t_s`, °C: the initial value plus a ramp of 0.6·D
/// over the run and a daily swing of 0.4·D·sin(2π·t/1 day), as river water warming
/// through the morning (D = 3 K: 1.8 K ramp and 1.2 K swing over the paper's 5.8 h); or,
/// with a wave's period P > 0, the slow wave D/2·(1 − cos(2π·t/P)).
pub fn inlet_temperature_c(o: &SynthOptions, t_s: f64) -> f64 {
    let d = o.disturbances.inlet_drift_k;
    let p = o.disturbances.inlet_wave_period_s;
    if p > 0.0 {
        return o.coolant.inlet_temp_c
            + 0.5 * d * (1.0 - (2.0 * std::f64::consts::PI * t_s / p).cos());
    }
    o.coolant.inlet_temp_c
        + 0.6 * d * t_s / o.duration_s
        + 0.4 * d * (2.0 * std::f64::consts::PI * t_s / DAY_S).sin()
}

/// The unmeasured heat flow into the cooling-water node held over each of `steps`
/// intervals, W: a random walk from 0, q(k+1) = q(k) + W·√(Ts/3600 s)·ε_k with W in W/√h
/// and ε_k ~ N(0, 1), so that its spread after t hours is W·√t. Its own seeded stream:
/// the sensor noise of a run with it is that of the same run without it.
pub fn coolant_heat_walk_w(o: &SynthOptions, steps: usize) -> Vec<f64> {
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    let w = o.disturbances.coolant_heat_walk_kw_per_sqrt_h * 1e3;
    if w == 0.0 {
        return vec![0.0; steps];
    }
    let step_sigma = w * (o.machine.ts_s() / 3600.0).sqrt();
    let mut rng = rand::rngs::StdRng::seed_from_u64(o.seed ^ 0x6865_6174_7761_6c6b);
    let mut q = 0.0;
    (0..steps)
        .map(|_| {
            let now = q;
            let e: f64 = StandardNormal.sample(&mut rng);
            q += step_sigma * e;
            now
        })
        .collect()
}

/// The recorded flow at `t_s`, l/s (the pump switch multiplies it).
pub fn flow_l_per_s(o: &SynthOptions, t_s: f64) -> f64 {
    match o.disturbances.pump_switch {
        Some(s) if t_s >= s.time_s => o.coolant.flow_l_per_s * s.factor,
        _ => o.coolant.flow_l_per_s,
    }
}

/// c·ρ of the water, J/(l·K): IF97 at the initial inlet temperature (flow metered there).
pub fn heat_per_litre_j_per_k(o: &SynthOptions) -> Result<f64> {
    let t = o.coolant.inlet_temp_c;
    WaterModel::MEASURED
        .heat_per_litre_j_per_k(t, t)
        .map_err(|e| SynthError::Options(format!("the coolant inlet: {e}")))
}

/// The pieces of the run: the first at the start, another where a pump switch or a
/// fault changes the network (snapped to the grid).
fn pieces(o: &SynthOptions, steps: usize) -> Result<Vec<Piece>> {
    let ts = o.machine.ts_s();
    let network = match &o.machine {
        Machine::Model { model, .. } => {
            let c = ContinuousModel::from_discrete(model)?;
            // No coolant node: the inlet's and the coolant heat's columns are zero.
            let extend = |m: &DMatrix<f64>| m.clone().insert_columns(m.ncols(), 2, 0.0);
            return Ok(vec![Piece {
                start_step: 0,
                causes: Vec::new(),
                flow_l_per_s: o.coolant.flow_l_per_s,
                conductance_w_per_k: None,
                a_c: c.a_c,
                b_c: extend(&c.b_c),
                phi: model.phi.clone(),
                gamma: extend(&model.gamma),
            }]);
        }
        Machine::Network(n) => n,
    };
    let c_rho = heat_per_litre_j_per_k(o)?;
    let step_of = |t: f64| ((t / ts).round().max(0.0) as usize).min(steps);
    let mut changes: Vec<(usize, ChangeCause)> = Vec::new();
    if let Some(s) = o.disturbances.pump_switch {
        changes.push((step_of(s.time_s), ChangeCause::PumpSwitch));
    }
    if let Some(f) = o.disturbances.fault {
        changes.push((step_of(f.time_s), ChangeCause::Fault));
    }
    changes.sort_by_key(|c| c.0);
    let mut starts: Vec<(usize, Vec<ChangeCause>)> = vec![(0, Vec::new())];
    for (step, cause) in changes {
        match starts.last_mut() {
            Some(last) if last.0 == step => last.1.push(cause),
            _ => starts.push((step, vec![cause])),
        }
    }
    let mut active = Vec::new();
    starts
        .into_iter()
        .map(|(start_step, causes)| {
            active.extend(causes.iter().copied());
            let flow = if active.contains(&ChangeCause::PumpSwitch) {
                flow_l_per_s(o, f64::INFINITY)
            } else {
                o.coolant.flow_l_per_s
            };
            let drop = match o.disturbances.fault {
                Some(f) if active.contains(&ChangeCause::Fault) => f.conductance_drop,
                _ => 0.0,
            };
            network_piece(o, network, start_step, causes, (flow, c_rho, drop), ts)
        })
        .collect()
}

/// One piece of a network machine at `flow` l/s of water of `c_rho` J/(l·K), with its
/// conductances to the coolant reduced by the fraction `drop`.
fn network_piece(
    o: &SynthOptions,
    machine: &NetworkMachine,
    start_step: usize,
    causes: Vec<ChangeCause>,
    (flow, c_rho, drop): (f64, f64, f64),
    ts: f64,
) -> Result<Piece> {
    let n = machine.nodes.len();
    let outlet = machine
        .node(Quantity::CoolingWaterOutletTemp)
        .ok_or_else(|| {
            SynthError::Options("a network machine needs a cooling-water outlet node".into())
        })?;
    let mut g = machine.conductance_w_per_k.clone();
    g[(outlet, outlet)] = c_rho * flow;
    for i in 0..n {
        g[(i, i)] *= 1.0 - drop;
    }
    let scaling = Scaling {
        theta_base_k: o.nameplate.temperature_base_k,
        p_base_w: o.nameplate.rated_apparent_power_va,
    };
    let parts = Parts {
        capacitance_j_per_k: machine.capacitance_j_per_k.clone(),
        conductance_w_per_k: g.clone(),
        loss_distribution: machine.loss_distribution.clone(),
    };
    let labels = Labels::numbered(n, machine.loss_distribution.ncols());
    let network = Network::from_parts(&parts, scaling, ScaleSource::Calorimetric, &labels)
        .map_err(|e| SynthError::Options(format!("the machine's network: {e}")))?;
    let (a_c, b_c) = network.to_continuous();
    let inlet = DVector::from_fn(n, |i, _| g[(i, i)] / machine.capacitance_j_per_k[i]);
    let m = b_c.ncols();
    let mut b_c = b_c.insert_columns(m, 2, 0.0);
    b_c.set_column(m, &inlet);
    b_c[(outlet, m + 1)] =
        1.0 / (machine.capacitance_j_per_k[outlet] * o.nameplate.temperature_base_k);
    let (phi, gamma) = discretize(&a_c, &b_c, ts);
    Ok(Piece {
        start_step,
        causes,
        flow_l_per_s: flow,
        conductance_w_per_k: Some(g),
        a_c,
        b_c,
        phi,
        gamma,
    })
}

/// θ_ref and x(0) of the machine.
fn start(o: &SynthOptions) -> (Vec<f64>, DVector<f64>) {
    let base = o.nameplate.temperature_base_k;
    match &o.machine {
        Machine::Model {
            initial_temperatures_c,
            ..
        } => (
            initial_temperatures_c.clone(),
            DVector::zeros(initial_temperatures_c.len()),
        ),
        Machine::Network(n) => (
            vec![o.coolant.inlet_temp_c; n.nodes.len()],
            DVector::from_element(n.nodes.len(), o.disturbances.start_above_k / base),
        ),
    }
}

/// Simulates the run (see the module's documentation). With the paper's field method
/// (the nameplate's final field temperature) the scale s is iterated to its fixed point.
pub fn simulate(o: &SynthOptions) -> Result<Trajectory> {
    let ts = o.machine.ts_s();
    let steps = (o.duration_s / ts).round() as usize;
    let base = o.nameplate.temperature_base_k;
    let pieces = pieces(o, steps)?;
    let (reference_c, x0) = start(o);
    let states = o.machine.states();
    let winding = states
        .iter()
        .position(|&q| q == Quantity::StatorWindingTemp)
        .ok_or_else(|| SynthError::Options("the machine has no stator winding".into()))?;
    let field_node = states.iter().position(|&q| q == Quantity::FieldWindingTemp);
    let final_field = o.nameplate.field_winding_final_temp_c.unwrap_or(81.0);
    // A network machine's field scales with the winding's rise above the coolant and is
    // iterated to end at the nameplate's final field temperature, whatever its channel; a
    // discrete model's, as the paper, from the winding's start (iterated for the nameplate
    // method only, the figures published from it so far unchanged).
    let (th_0, iterate) = match &o.machine {
        Machine::Model { .. } => (
            reference_c[winding] + base * x0[winding],
            o.field_channel.from_nameplate(),
        ),
        Machine::Network(_) => (o.coolant.inlet_temp_c, true),
    };
    let mut field = match field_node {
        Some(i) => FieldTemperature::Node(i),
        None => FieldTemperature::Scaled {
            winding,
            scale: (final_field - th_0) / 26.3,
            reference_c: th_0,
        },
    };
    let inlet_offsets: Vec<f64> = (0..steps)
        .map(|k| {
            let t = (k as f64 + 0.5) * ts;
            (inlet_temperature_c(o, t) - o.coolant.inlet_temp_c) / base
        })
        .collect();
    let mut traj = Trajectory {
        states: Vec::new(),
        reference_c,
        points: Vec::new(),
        field_temps: Vec::new(),
        inputs: Vec::new(),
        inlet_offsets,
        coolant_heat_w: coolant_heat_walk_w(o, steps),
        pieces,
        field,
    };
    for _ in 0..30 {
        traj.field = field;
        run(o, &mut traj, &x0, steps);
        let FieldTemperature::Scaled { scale, .. } = field else {
            break;
        };
        if !iterate {
            break;
        }
        let final_rise = traj.temperature(&traj.states[steps], winding, base) - th_0;
        if final_rise <= 0.5 {
            return Err(SynthError::Options(format!(
                "the synthetic run's stator winding ends {final_rise:.2} K above {th_0} °C, too little to scale the field winding's temperature to {final_field} °C"
            )));
        }
        let new_scale = (final_field - th_0) / final_rise;
        if (new_scale - scale).abs() < 1e-13 * scale.abs() {
            break;
        }
        field = FieldTemperature::Scaled {
            winding,
            scale: new_scale,
            reference_c: th_0,
        };
    }
    Ok(traj)
}

/// One pass of the simulation with the trajectory's field method.
fn run(o: &SynthOptions, traj: &mut Trajectory, x0: &DVector<f64>, steps: usize) {
    let np = &o.nameplate;
    let base = np.temperature_base_k;
    let winding = o
        .machine
        .states()
        .iter()
        .position(|&q| q == Quantity::StatorWindingTemp)
        .unwrap_or(0);
    let point_at = |k: usize| {
        let f = k as f64 / steps as f64;
        *o.profile
            .iter()
            .rev()
            .find(|p| p.start_fraction <= f + 1e-12)
            .unwrap_or(&o.profile[0])
    };
    traj.states = Vec::with_capacity(steps + 1);
    traj.field_temps = Vec::with_capacity(steps + 1);
    traj.inputs = Vec::with_capacity(steps);
    traj.points = Vec::with_capacity(steps);
    let mut x = x0.clone();
    let mut piece = 0;
    for k in 0..=steps {
        traj.states.push(x.clone());
        let theta_cu = traj.temperature(&x, winding, base);
        let theta_f = traj.field_temperature(&x, base);
        traj.field_temps.push(theta_f);
        if k == steps {
            break;
        }
        while piece + 1 < traj.pieces.len() && traj.pieces[piece + 1].start_step <= k {
            piece += 1;
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
            traj.inlet_offsets[k],
            traj.coolant_heat_w[k],
        ]);
        let pc = &traj.pieces[piece];
        x = &pc.phi * &x + &pc.gamma * &u;
        traj.inputs.push(u.rows(0, 3).into_owned());
        traj.points.push(p);
    }
}
