//! What a synthetic run was made from, written beside it as `<OUT>.truth.json`.

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::machines::Machine;
use super::plant::{self, ChangeCause, Piece, Trajectory};
use super::Result;
use super::{Disturbances, OperatingPoint, SynthOptions};
use crate::estimate::DiscreteModel;
use crate::model::{ContinuousModel, Spectrum};
use crate::thermal::matrix::rows;

/// What a synthetic run was made from. States are in the machine's order (`states`);
/// Φ, Γ, A_c, B_c act on the rises in units of θ_base and the losses in pu of S_n.
#[derive(Debug, Clone, Serialize)]
pub struct Truth {
    /// The machine ("model" for a discrete model such as the paper's, "rc-unit", …).
    pub machine: String,
    /// The profile quantity of each state.
    pub states: Vec<String>,
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
    /// The true steady-state rises for it, K: above the initial temperatures for a
    /// discrete model, above the coolant inlet for a network.
    pub steady_state_rise_k: Vec<f64>,
    /// Initial temperatures, °C.
    pub initial_temperatures_c: Vec<f64>,
    /// Noise-free temperatures at the end, °C.
    pub final_temperatures_c: Vec<f64>,
    /// The operating schedule.
    pub profile: Vec<OperatingPoint>,
    /// The seed.
    pub seed: u64,
    /// The coolant: inlet, flow and the disturbances.
    pub coolant: TruthCoolant,
    /// The network of a network machine (at the start of the run), else absent.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub network: Option<TruthNetwork>,
    /// Where the network changes during the run (a pump switch, a fault).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub changes: Vec<NetworkChange>,
    /// The states no channel records (hidden states: the field winding's node of a
    /// machine run with `FieldChannel::Unmeasured`), by profile name; absent where
    /// every state is recorded.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub unmeasured: Vec<String>,
    /// The flaws laid on the written samples, if any were asked for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flaws: Option<super::FlawRecord>,
}

/// The coolant of the run.
#[derive(Debug, Clone, Serialize)]
pub struct TruthCoolant {
    /// The inlet at the start, °C.
    pub inlet_initial_c: f64,
    /// The inlet at the end, °C.
    pub inlet_final_c: f64,
    /// The flow at the start, l/s.
    pub flow_l_per_s: f64,
    /// Whether the recording has the inlet and flow channels.
    pub channels: bool,
    /// The disturbances of the run.
    pub disturbances: Disturbances,
    /// The unmeasured heat into the cooling water (with a heat walk), W.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coolant_heat_w: Option<CoolantHeat>,
}

/// What the unmeasured heat walk into the cooling water did over the run.
#[derive(Debug, Clone, Serialize)]
pub struct CoolantHeat {
    /// The heat over the last interval, W.
    pub final_w: f64,
    /// The largest |q| over the run, W.
    pub max_abs_w: f64,
    /// The root mean square of q over the run, W.
    pub rms_w: f64,
}

/// The true network C·dθ/dt = −L·θ + K·P + g₀·θ_in at the start of the run.
#[derive(Debug, Clone, Serialize)]
pub struct TruthNetwork {
    /// C_i, J/K.
    pub capacitance_j_per_k: Vec<f64>,
    /// G_ij between parts off the diagonal, G_i0 to the coolant on it, W/K.
    pub conductance_w_per_k: Vec<Vec<f64>>,
    /// K, n × 3: the share of each heat source entering each part.
    pub loss_distribution: Vec<Vec<f64>>,
    /// The state of the cooling-water outlet, whose G_i0 is c·ρ·Q.
    pub outlet_state: usize,
    /// c·ρ of the water, J/(l·K) (IF97 at the initial inlet temperature).
    pub heat_per_litre_j_per_k: f64,
    /// C⁻¹g₀, 1/s: the inlet's column of B_c (states and inlet in the same unit).
    pub inlet_b_c: Vec<f64>,
    /// Its zero-order-hold column of Γ at the sample time.
    pub inlet_gamma: Vec<f64>,
}

/// The network from a time on.
#[derive(Debug, Clone, Serialize)]
pub struct NetworkChange {
    /// From this time, s after the start (on the grid).
    pub time_s: f64,
    /// What changed.
    pub causes: Vec<ChangeCause>,
    /// The flow from then, l/s.
    pub flow_l_per_s: f64,
    /// The conductances from then, W/K.
    pub conductance_w_per_k: Vec<Vec<f64>>,
    /// A_c from then.
    pub a_c: Vec<Vec<f64>>,
    /// The time constants from then, s, ascending.
    pub time_constants_s: Vec<f64>,
    /// The steady-state rises above the inlet for the last input, K.
    pub steady_state_rise_k: Vec<f64>,
}

/// The number of loss inputs of a piece: its columns less the inlet's and the coolant
/// heat's.
fn losses_of(piece: &Piece) -> usize {
    piece.b_c.ncols() - 2
}

/// The losses' part of a piece: (Φ, Γ) at Ts and (A_c, B_c).
fn loss_model(piece: &Piece, ts: f64) -> (DiscreteModel, ContinuousModel) {
    let m = losses_of(piece);
    (
        DiscreteModel {
            phi: piece.phi.clone(),
            gamma: piece.gamma.columns(0, m).into_owned(),
            ts_s: ts,
        },
        ContinuousModel {
            a_c: piece.a_c.clone(),
            b_c: piece.b_c.columns(0, m).into_owned(),
        },
    )
}

/// The truth of a simulated run.
pub fn truth_of(o: &SynthOptions, traj: &Trajectory) -> Result<Truth> {
    let ts = o.machine.ts_s();
    let steps = traj.inputs.len();
    let base = o.nameplate.temperature_base_k;
    let n = traj.reference_c.len();
    let last_u = traj.inputs[steps - 1].clone();
    let first = &traj.pieces[0];
    let (discrete, continuous) = match &o.machine {
        // The paper's printed Φ and Γ, and their continuous equivalent.
        Machine::Model { model, .. } => (model.clone(), ContinuousModel::from_discrete(model)?),
        Machine::Network(_) => loss_model(first, ts),
    };
    let spectrum = Spectrum::of(&discrete)?;
    let ss = continuous.steady_state(last_u.as_slice())?;
    let network = network_of(o, first)?;
    let changes = traj.pieces[1..]
        .iter()
        .map(|p| change_of(p, ts, last_u.as_slice(), base))
        .collect::<Result<Vec<_>>>()?;
    let temps = |k: usize| -> Vec<f64> {
        (0..n)
            .map(|i| traj.temperature(&traj.states[k], i, base))
            .collect()
    };
    Ok(Truth {
        machine: o.machine.name().to_owned(),
        states: o.machine.states().iter().map(|q| q.name().into()).collect(),
        phi: rows(&discrete.phi),
        gamma: rows(&discrete.gamma),
        a_c: rows(&continuous.a_c),
        b_c: rows(&continuous.b_c),
        sample_time_s: ts,
        time_constants_s: spectrum.time_constants_s,
        final_input_pu: last_u.iter().copied().collect(),
        steady_state_rise_k: ss.iter().map(|v| v * base).collect(),
        initial_temperatures_c: temps(0),
        final_temperatures_c: temps(steps),
        profile: o.profile.clone(),
        seed: o.seed,
        coolant: TruthCoolant {
            inlet_initial_c: o.coolant.inlet_temp_c,
            inlet_final_c: plant::inlet_temperature_c(o, o.duration_s),
            flow_l_per_s: o.coolant.flow_l_per_s,
            channels: o.coolant.channels,
            disturbances: o.disturbances,
            coolant_heat_w: coolant_heat(o, traj),
        },
        network,
        changes,
        unmeasured: match o.field_channel {
            super::FieldChannel::Unmeasured => o
                .machine
                .states()
                .into_iter()
                .filter(|&q| q == crate::recording::Quantity::FieldWindingTemp)
                .map(|q| q.name().into())
                .collect(),
            _ => Vec::new(),
        },
        flaws: None,
    })
}

/// The heat walk's summary, where the run has one.
fn coolant_heat(o: &SynthOptions, traj: &Trajectory) -> Option<CoolantHeat> {
    let q = &traj.coolant_heat_w;
    (o.disturbances.coolant_heat_walk_kw_per_sqrt_h != 0.0 && !q.is_empty()).then(|| CoolantHeat {
        final_w: q[q.len() - 1],
        max_abs_w: q.iter().fold(0.0, |a, v| a.max(v.abs())),
        rms_w: (q.iter().map(|v| v * v).sum::<f64>() / q.len() as f64).sqrt(),
    })
}

fn network_of(o: &SynthOptions, first: &Piece) -> Result<Option<TruthNetwork>> {
    let (Machine::Network(machine), Some(g)) = (&o.machine, &first.conductance_w_per_k) else {
        return Ok(None);
    };
    let m = losses_of(first);
    Ok(Some(TruthNetwork {
        capacitance_j_per_k: machine.capacitance_j_per_k.clone(),
        conductance_w_per_k: rows(g),
        loss_distribution: rows(&machine.loss_distribution),
        outlet_state: machine
            .node(crate::recording::Quantity::CoolingWaterOutletTemp)
            .unwrap_or(0),
        heat_per_litre_j_per_k: plant::heat_per_litre_j_per_k(o)?,
        inlet_b_c: first.b_c.column(m).iter().copied().collect(),
        inlet_gamma: first.gamma.column(m).iter().copied().collect(),
    }))
}

fn change_of(piece: &Piece, ts: f64, last_u: &[f64], base: f64) -> Result<NetworkChange> {
    let (discrete, continuous) = loss_model(piece, ts);
    let spectrum = Spectrum::of(&discrete)?;
    let ss = continuous.steady_state(last_u)?;
    Ok(NetworkChange {
        time_s: piece.start_step as f64 * ts,
        causes: piece.causes.clone(),
        flow_l_per_s: piece.flow_l_per_s,
        conductance_w_per_k: piece
            .conductance_w_per_k
            .as_ref()
            .map(rows)
            .unwrap_or_default(),
        a_c: rows(&piece.a_c),
        time_constants_s: spectrum.time_constants_s,
        steady_state_rise_k: ss.iter().map(|v| v * base).collect(),
    })
}

/// Where the truth of a synthetic recording is written: `<OUT>.truth.json`.
pub fn truth_path(out: &Path) -> PathBuf {
    let mut s = out.as_os_str().to_owned();
    s.push(".truth.json");
    s.into()
}
