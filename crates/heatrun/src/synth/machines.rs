//! The machines a synthetic heat run is simulated from: a model given by its discrete
//! form (the paper's Φ and Γ, or a second machine), or a thermal RC network (the "rc
//! unit" of three nodes, the "rc field" unit of four with a field-winding node).

use nalgebra::DMatrix;

use crate::estimate::DiscreteModel;
use crate::recording::Quantity;

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

/// The paper's cooling-water flow, l/s (eqs. 17–18: Q = 48.2 l/s).
pub const PAPER_COOLING_WATER_FLOW_L_PER_S: f64 = 48.2;

/// The paper's cooling-water temperature at the start of its heat run, °C (θ_cw0).
pub const PAPER_COOLING_WATER_INLET_C: f64 = 10.5;

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
    let (phi, gamma) = crate::thermal::matrix::discretize(&a_c, &b_c, 1.0);
    DiscreteModel {
        phi,
        gamma,
        ts_s: 1.0,
    }
}

/// What a synthetic run is simulated from.
#[derive(Debug, Clone)]
pub enum Machine {
    /// A model given by its discrete form x(k) = Φ x(k−1) + Γ u(k−1) on the rises above
    /// `initial_temperatures_c` (states: stator winding, core, cooling-water outlet; inputs:
    /// the three heat sources, per unit of the nameplate), the paper's formulation. It
    /// has no coolant: the inlet and flow channels it writes are constant and enter nothing.
    Model {
        /// A short name ("paper").
        name: String,
        /// Φ, Γ and the sample time they hold the inputs over.
        model: DiscreteModel,
        /// The temperatures the rises start from, °C, one per state.
        initial_temperatures_c: Vec<f64>,
    },
    /// A thermal RC network simulated in absolute temperatures, the coolant inlet its
    /// reference node (see [`NetworkMachine`]).
    Network(NetworkMachine),
}

impl Machine {
    /// The paper's model (eqs. 19–20) from the paper's initial temperatures.
    pub fn paper() -> Machine {
        Machine::Model {
            name: "paper".into(),
            model: paper_model(),
            initial_temperatures_c: PAPER_INITIAL_TEMPERATURES_C.to_vec(),
        }
    }

    /// A discrete model from the paper's initial temperatures.
    pub fn from_model(model: DiscreteModel) -> Machine {
        Machine::Model {
            name: "model".into(),
            model,
            initial_temperatures_c: PAPER_INITIAL_TEMPERATURES_C.to_vec(),
        }
    }

    /// The interval each operating point and inlet temperature is held over, s.
    pub fn ts_s(&self) -> f64 {
        match self {
            Machine::Model { model, .. } => model.ts_s,
            Machine::Network(n) => n.ts_s,
        }
    }

    /// The temperature quantity of each state, in state order.
    pub fn states(&self) -> Vec<Quantity> {
        match self {
            Machine::Model { .. } => vec![
                Quantity::StatorWindingTemp,
                Quantity::CoreTemp,
                Quantity::CoolingWaterOutletTemp,
            ],
            Machine::Network(n) => n.nodes.clone(),
        }
    }

    /// A short name for people and the truth file ("paper", "rc-unit", …).
    pub fn name(&self) -> &str {
        match self {
            Machine::Model { name, .. } => name,
            Machine::Network(n) => &n.name,
        }
    }
}

/// A machine built from a known thermal RC network (the paper's Fig. 9), simulated in
/// absolute temperatures with the coolant inlet as the reference node:
///
/// ```text
/// C·dθ/dt = −L·θ + K·P + g₀·θ_in,   L_ij = −G_ij (i ≠ j),  L_ii = G_i0 + Σ_{j≠i} G_ij
/// ```
///
/// g₀ = (G_10, …, G_n0) the conductances to the coolant. The outlet node's G_out,0 is not
/// stored: it is c·ρ·Q of the recorded flow (eq. 17), set when the run is simulated.
/// With a constant inlet and a start at the inlet temperature the rises above it follow
/// the paper's model with A_c = −C⁻¹L and B_c = C⁻¹·K·S_n/θ_base.
#[derive(Debug, Clone)]
pub struct NetworkMachine {
    /// A short name ("rc-unit").
    pub name: String,
    /// The part each node is, as the profile quantity its temperature is recorded as.
    /// One must be the cooling-water outlet; a field-winding node is recorded by the
    /// field channel of the run (its voltage or its temperature).
    pub nodes: Vec<Quantity>,
    /// C_i, J/K.
    pub capacitance_j_per_k: Vec<f64>,
    /// G_ij between nodes off the diagonal (symmetric) and G_i0 to the coolant on it, W/K;
    /// the outlet node's diagonal entry is replaced by c·ρ·Q.
    pub conductance_w_per_k: DMatrix<f64>,
    /// K: k_ij, the share of heat source j (armature copper, field copper, iron) that
    /// enters node i; each column sums to 1.
    pub loss_distribution: DMatrix<f64>,
    /// The interval the operating point and the inlet temperature are held over, s.
    pub ts_s: f64,
}

impl NetworkMachine {
    /// The "rc unit": stator winding, iron core and cooling-water outlet. The winding
    /// couples to the core through its insulation (22 kW/K) and to the cooler through
    /// the air (9 kW/K), the core to the cooler (35 kW/K), the cooler to the coolant by
    /// c·ρ·Q. Capacitances 24.5 MJ/K, 137 MJ/K and 17.5 MJ/K give time constants of about
    /// 71 s, 710 s and 4500 s at the paper's flow of 48.2 l/s. Losses: armature copper
    /// 80 % winding, 15 % core, 5 % air; field copper (rotor, through the air) 15 %,
    /// 10 %, 75 %; iron 5 %, 85 %, 10 %.
    pub fn rc_unit() -> NetworkMachine {
        #[rustfmt::skip]
        let conductance = DMatrix::from_row_slice(3, 3, &[
            0.0, 22e3, 9e3,
            22e3, 0.0, 35e3,
            9e3, 35e3, 0.0,
        ]);
        #[rustfmt::skip]
        let loss_distribution = DMatrix::from_row_slice(3, 3, &[
            0.80, 0.15, 0.05,
            0.15, 0.10, 0.85,
            0.05, 0.75, 0.10,
        ]);
        NetworkMachine {
            name: "rc-unit".into(),
            nodes: vec![
                Quantity::StatorWindingTemp,
                Quantity::CoreTemp,
                Quantity::CoolingWaterOutletTemp,
            ],
            capacitance_j_per_k: vec![24.5e6, 137e6, 17.5e6],
            conductance_w_per_k: conductance,
            loss_distribution,
            ts_s: 1.0,
        }
    }

    /// The "rc field" unit: the rc unit with a fourth node, the field winding (rotor
    /// copper, 8 MJ/K), into which 80 % of the field copper loss and 5 % of the iron loss
    /// (pole faces) go; it couples to the stator winding and the core across the air gap
    /// (1 kW/K each) and to the cooler through the air (3 kW/K). Time constants about
    /// 70 s, 690 s, 1590 s and 4500 s.
    pub fn rc_field() -> NetworkMachine {
        #[rustfmt::skip]
        let conductance = DMatrix::from_row_slice(4, 4, &[
            0.0, 22e3, 9e3, 1e3,
            22e3, 0.0, 35e3, 1e3,
            9e3, 35e3, 0.0, 3e3,
            1e3, 1e3, 3e3, 0.0,
        ]);
        #[rustfmt::skip]
        let loss_distribution = DMatrix::from_row_slice(4, 3, &[
            0.80, 0.03, 0.05,
            0.15, 0.02, 0.75,
            0.05, 0.15, 0.15,
            0.00, 0.80, 0.05,
        ]);
        NetworkMachine {
            name: "rc-field".into(),
            nodes: vec![
                Quantity::StatorWindingTemp,
                Quantity::CoreTemp,
                Quantity::CoolingWaterOutletTemp,
                Quantity::FieldWindingTemp,
            ],
            capacitance_j_per_k: vec![24.5e6, 137e6, 17.5e6, 8e6],
            conductance_w_per_k: conductance,
            loss_distribution,
            ts_s: 1.0,
        }
    }

    /// A unit of this design as manufactured: every capacitance C_i and every stored
    /// conductance G_ij (a symmetric pair scaled together; the coolant conductances on
    /// the diagonal too) multiplied by its own factor 1 + s·ε, ε uniform in [−1, 1]
    /// drawn from `unit_seed`, so that `spread` = 0.03 is a ±3 % manufacturing
    /// tolerance. The loss shares K are the design's (where the heat arises is not a
    /// tolerance), and the outlet's c·ρ·Q still follows the recorded flow.
    pub fn manufactured(&self, spread: f64, unit_seed: u64) -> NetworkMachine {
        use rand::{Rng, SeedableRng};
        // Its own stream, apart from the noise's (seeded by the run's seed).
        let mut rng = rand::rngs::StdRng::seed_from_u64(unit_seed ^ 0x756e_6974_7370_7264);
        let mut factor = || 1.0 + spread * rng.random_range(-1.0..=1.0);
        let mut unit = self.clone();
        for c in &mut unit.capacitance_j_per_k {
            *c *= factor();
        }
        let n = unit.nodes.len();
        for i in 0..n {
            for j in i..n {
                let f = factor();
                unit.conductance_w_per_k[(i, j)] *= f;
                if i != j {
                    unit.conductance_w_per_k[(j, i)] *= f;
                }
            }
        }
        unit
    }

    /// The node a quantity is recorded from, if the network has one.
    pub fn node(&self, quantity: Quantity) -> Option<usize> {
        self.nodes.iter().position(|&q| q == quantity)
    }
}
