//! Estimation stage: measured states and inputs → the discrete model Θ = [Φ Γ].
//!
//! Input: [`IdentificationData`], generic in the number of states n and inputs m
//! (the generator's 3 × 3 is one configuration). Output: an [`Estimate`]. Each
//! method lives in its own module behind the [`Estimator`] interface.

use std::ops::Range;

use nalgebra::DMatrix;
use serde::Serialize;

use crate::error::{Error, Result};
use crate::losses::ThermalSignals;

pub mod iv;
pub mod oe;
pub mod qr;
pub mod rls;
pub mod wls;

pub use iv::InstrumentalVariables;
pub use oe::OutputError;
pub use rls::RecursiveLeastSquares;
pub use wls::WeightedLeastSquares;

/// Sampled outputs y(k) (N × n) and inputs u(k) (N × m) of a system
/// x(k) = Φ x(k−1) + Γ u(k−1), y = x, with what is known where.
#[derive(Debug, Clone)]
pub struct IdentificationData {
    /// Sample time Ts in s.
    pub ts_s: f64,
    /// Outputs, one row per instant (unknown entries hold 0 and are masked).
    pub outputs: DMatrix<f64>,
    /// Inputs, one row per instant, held over [t_k, t_k + Ts).
    pub inputs: DMatrix<f64>,
    /// Whether every output is known at instant k.
    pub outputs_known: Vec<bool>,
    /// Whether every input is known at instant k.
    pub inputs_known: Vec<bool>,
}

impl IdentificationData {
    /// Builds the data from full matrices (every value known).
    pub fn complete(ts_s: f64, outputs: DMatrix<f64>, inputs: DMatrix<f64>) -> Self {
        let n = outputs.nrows();
        IdentificationData {
            ts_s,
            outputs,
            inputs,
            outputs_known: vec![true; n],
            inputs_known: vec![true; n],
        }
    }

    /// The instants in `range` as data of their own.
    pub fn slice(&self, range: Range<usize>) -> IdentificationData {
        IdentificationData {
            ts_s: self.ts_s,
            outputs: self.outputs.rows(range.start, range.len()).into_owned(),
            inputs: self.inputs.rows(range.start, range.len()).into_owned(),
            outputs_known: self.outputs_known[range.clone()].to_vec(),
            inputs_known: self.inputs_known[range].to_vec(),
        }
    }

    /// Number of instants N.
    pub fn len(&self) -> usize {
        self.outputs.nrows()
    }

    /// Whether there are no instants.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Number of states n.
    pub fn states(&self) -> usize {
        self.outputs.ncols()
    }

    /// Number of inputs m.
    pub fn input_count(&self) -> usize {
        self.inputs.ncols()
    }

    /// Whether the equation for y(k) can be formed: y(k), y(k−1) and u(k−1) known.
    /// Rows that would touch missing data are left out, never bridged.
    pub fn row_usable(&self, k: usize) -> bool {
        k >= 1 && self.outputs_known[k] && self.outputs_known[k - 1] && self.inputs_known[k - 1]
    }

    /// The instants k ≥ 1 whose equation can be formed.
    pub fn usable_rows(&self) -> Vec<usize> {
        (1..self.len()).filter(|&k| self.row_usable(k)).collect()
    }

    /// Maximal runs of instants over which the model can be simulated without
    /// crossing missing data: within a run every equation k > start is usable.
    /// Runs of a single instant are left out.
    pub fn segments(&self) -> Vec<Range<usize>> {
        let mut out = Vec::new();
        let mut k = 0;
        while k < self.len() {
            if !self.outputs_known[k] {
                k += 1;
                continue;
            }
            let start = k;
            while k + 1 < self.len() && self.row_usable(k + 1) {
                k += 1;
            }
            if k > start {
                out.push(start..k + 1);
            }
            k += 1;
        }
        out
    }
}

impl From<&ThermalSignals> for IdentificationData {
    /// The rises (pu) as outputs and the heat sources (pu) as inputs.
    fn from(s: &ThermalSignals) -> Self {
        let n = s.len();
        let mut outputs = DMatrix::zeros(n, 3);
        let mut inputs = DMatrix::zeros(n, 3);
        let mut outputs_known = vec![true; n];
        let mut inputs_known = vec![true; n];
        for k in 0..n {
            for j in 0..3 {
                match s.rise_pu(j, k) {
                    Some(v) => outputs[(k, j)] = v,
                    None => outputs_known[k] = false,
                }
                match s.inputs_pu[j].get(k) {
                    Some(v) => inputs[(k, j)] = v,
                    None => inputs_known[k] = false,
                }
            }
        }
        IdentificationData {
            ts_s: s.ts_s,
            outputs,
            inputs,
            outputs_known,
            inputs_known,
        }
    }
}

/// A discrete-time model x(k) = Φ x(k−1) + Γ u(k−1) (eq. 1) with y = x.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DiscreteModel {
    /// State transition matrix Φ (n × n).
    pub phi: DMatrix<f64>,
    /// Input matrix Γ (n × m).
    pub gamma: DMatrix<f64>,
    /// Sample time Ts in s.
    pub ts_s: f64,
}

impl DiscreteModel {
    /// Simulates eq. (8), ŷ(k) = Φ ŷ(k−1) + Γ u(k−1), over `range` from the
    /// measured ŷ(start) = y(start). Returns one row per instant of the range.
    pub fn simulate(&self, data: &IdentificationData, range: Range<usize>) -> DMatrix<f64> {
        let n = self.phi.nrows();
        let mut out = DMatrix::zeros(range.len(), n);
        if range.is_empty() {
            return out;
        }
        let m = self.gamma.ncols();
        for j in 0..n {
            out[(0, j)] = data.outputs[(range.start, j)];
        }
        // Row by row in place: this runs once per instant of a week-long recording in
        // every estimator iteration, so it must not allocate.
        for (i, k) in range.clone().enumerate().skip(1) {
            for r in 0..n {
                let mut next = 0.0;
                for c in 0..n {
                    next += self.phi[(r, c)] * out[(i - 1, c)];
                }
                for c in 0..m {
                    next += self.gamma[(r, c)] * data.inputs[(k - 1, c)];
                }
                out[(i, r)] = next;
            }
        }
        out
    }

    /// The simulated output over every segment, NaN outside them (eq. 8 run from the
    /// measured state at the start of each segment).
    pub fn simulate_segments(
        &self,
        data: &IdentificationData,
        segments: &[Range<usize>],
    ) -> DMatrix<f64> {
        let mut out = DMatrix::from_element(data.len(), data.states(), f64::NAN);
        for seg in segments {
            let sim = self.simulate(data, seg.clone());
            out.view_mut((seg.start, 0), (seg.len(), data.states()))
                .copy_from(&sim);
        }
        out
    }

    /// Θ = [Φ Γ] as one vector, row by row: index i·(n+m) + j.
    pub fn theta(&self) -> Vec<f64> {
        let (n, m) = (self.phi.nrows(), self.gamma.ncols());
        (0..n)
            .flat_map(|i| (0..n + m).map(move |j| (i, j)))
            .map(|(i, j)| {
                if j < n {
                    self.phi[(i, j)]
                } else {
                    self.gamma[(i, j - n)]
                }
            })
            .collect()
    }

    /// The model with Θ from a vector laid out as [`DiscreteModel::theta`].
    pub fn with_theta(&self, theta: &[f64]) -> DiscreteModel {
        let (n, m) = (self.phi.nrows(), self.gamma.ncols());
        let p = n + m;
        DiscreteModel {
            phi: DMatrix::from_fn(n, n, |i, j| theta[i * p + j]),
            gamma: DMatrix::from_fn(n, m, |i, j| theta[i * p + n + j]),
            ts_s: self.ts_s,
        }
    }

    /// Largest modulus of Φ's eigenvalues (the model is stable below 1).
    pub fn spectral_radius(&self) -> f64 {
        self.phi
            .clone()
            .complex_eigenvalues()
            .iter()
            .map(|z| z.norm())
            .fold(0.0, f64::max)
    }
}

/// An estimator's result.
#[derive(Debug, Clone, Serialize)]
pub struct Estimate {
    /// The model.
    pub model: DiscreteModel,
    /// The method's name (`wls`, …).
    pub method: String,
    /// Number of equations (regression rows) used.
    pub rows_used: usize,
    /// 2-norm condition number of the column-scaled regression (or Jacobian) matrix.
    pub condition_number: f64,
    /// Covariance of Θ laid out as [`DiscreteModel::theta`], when the method gives one.
    #[serde(skip)]
    pub covariance: Option<DMatrix<f64>>,
    /// Estimated noise variance per output (pu²): of the equation error for ls/wls/iv,
    /// of the simulation error for oe.
    pub noise_variance: Vec<f64>,
    /// Iterations taken (IV re-estimations, LM evaluations), 0 for closed-form methods.
    pub iterations: usize,
    /// Estimated constant output offset c (y = x + c, pu), where the method estimates one:
    /// the error of the initial values the rises are measured from.
    pub output_offset: Option<Vec<f64>>,
}

/// An identification method.
pub trait Estimator {
    /// The method's name as given to `--method`.
    fn name(&self) -> &'static str;
    /// Estimates Φ and Γ from the data.
    fn estimate(&self, data: &IdentificationData) -> Result<Estimate>;
}

/// Fewest usable equations per unknown parameter before an estimate is attempted.
pub const MIN_ROWS_PER_PARAMETER: usize = 10;

/// Checks there are enough usable rows for n + m parameters per output.
pub(crate) fn check_enough_rows(data: &IdentificationData, rows: usize) -> Result<()> {
    let p = data.states() + data.input_count();
    if rows < MIN_ROWS_PER_PARAMETER * p {
        return Err(Error::Estimation(format!(
            "only {rows} usable samples (instants where the states and inputs are known), \
             too few to estimate {p} parameters per state; at least {} are needed",
            MIN_ROWS_PER_PARAMETER * p
        )));
    }
    Ok(())
}
