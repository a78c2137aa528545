//! Models with hidden states: n states of which p outputs are measured,
//!
//! x(k+1) = Φ x(k) + Γ u(k),   y(k) = C x(k) + D u(k),
//!
//! where the measured-state model of the paper (eq. 1) is the case C = I, D = 0. Some
//! thermal systems need states no sensor reads: a heater behind its thermistor's lag
//! (TCLab), the interior of a furnace, the generator's field winding seen only through
//! U_f/I_f.
//!
//! Identification in three steps, each in its own module:
//! - [`subspace`]: the start, by a subspace method (PO-MOESP: block Hankel matrices, an
//!   orthogonal projection by an LQ factorisation, the SVD for the order, least squares
//!   for Φ, C from the shift invariance of the observability matrix and for Γ, D, x0 from
//!   the outputs, which are linear in them);
//! - [`refine`]: output error, the simulation error of the measured outputs minimised
//!   by Levenberg–Marquardt over Φ, Γ, C, D and each segment's x0;
//! - [`starts`]: several starts for each order (the subspace start at two horizons, the
//!   order below's model with a state added), the refined model of least cost kept;
//! - [`order`]: the order n chosen on the estimation data alone (five-fold
//!   cross-validation: each fifth simulated by the model of the rest), or given.
//!
//! Where it is the replay's model, [`analysis`] gives its time constants, the measured
//! outputs' sensitivities to them and its steady state; [`covariance`] the covariance
//! of its parameters (the sandwich H⁺ M H⁺ at the optimum, the changes of basis left out), which
//! the bands and intervals of the uses of the model carry through y = C x + D u; and
//! [`traces`] what the .rrd and the HTML page draw of it (its simulated outputs, its
//! output sensitivity responses).
//!
//! Its input is the estimators' [`IdentificationData`] (its p columns are the measured
//! outputs; an unobserved entry is left out of every comparison); its output a
//! [`HiddenEstimate`].

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use crate::estimate::IdentificationData;

pub mod analysis;
pub mod covariance;
pub mod order;
pub mod refine;
pub mod starts;
pub mod subspace;
pub mod traces;

pub use order::{identify, HiddenEstimate, HiddenOptions, OrderCandidate, OrderChoice};

/// How the outputs read the states.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum OutputMatrix {
    /// C is estimated: the states are any basis of the system's state space.
    Free,
    /// Sensor i reads state i: C = [I_p 0], fixed; states p..n are hidden. Every model
    /// whose C has full row rank has this form after a change of basis, so this is no
    /// restriction on the input-output behaviour, and the measured states keep their
    /// physical meaning (temperatures) for the uses of the model.
    Measured,
}

/// Errors of hidden-state identification.
#[derive(Debug, Clone, thiserror::Error, PartialEq)]
pub enum HiddenError {
    /// Too few complete windows for the block Hankel matrices.
    #[error(
        "too few instants for a subspace identification: {windows} complete windows of \
         {horizon} instants, {needed} needed"
    )]
    TooFewWindows {
        /// Windows found.
        windows: usize,
        /// Instants per window (twice the block rows).
        horizon: usize,
        /// Windows needed.
        needed: usize,
    },
    /// The order asked for is not in 1 ..= the largest the data allow.
    #[error("model order {order} outside 1..={largest} (the block rows times the outputs)")]
    Order {
        /// The order asked for.
        order: usize,
        /// The largest the horizon allows.
        largest: usize,
    },
    /// `OutputMatrix::Measured` needs at least as many states as outputs.
    #[error("{outputs} measured outputs need at least {outputs} states, not {order}")]
    FewerStatesThanOutputs {
        /// Measured outputs p.
        outputs: usize,
        /// The order n.
        order: usize,
    },
    /// A linear solve failed (singular data).
    #[error("the {what} is singular: the data do not determine it")]
    Singular {
        /// Which solve.
        what: &'static str,
    },
    /// The model found is unstable (a pole on or outside the unit circle).
    #[error("the order-{order} model is unstable (spectral radius {radius:.4})")]
    Unstable {
        /// Its order.
        order: usize,
        /// Largest pole modulus.
        radius: f64,
    },
    /// No candidate order gave a stable model.
    #[error("no model order gave a stable model; the smallest: {reason}")]
    NoOrder {
        /// Why the smallest order was refused.
        reason: String,
    },
    /// Levenberg–Marquardt ended on a non-finite cost.
    #[error("the output-error refinement diverged")]
    Diverged,
}

/// A state-space model with hidden states: x(k+1) = Φ x(k) + Γ u(k), y(k) = C x(k) + D u(k)
/// (in the estimators' convention, x(k) = Φ x(k−1) + Γ u(k−1)).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HiddenStateModel {
    /// State transition matrix Φ (n × n).
    pub phi: DMatrix<f64>,
    /// Input matrix Γ (n × m).
    pub gamma: DMatrix<f64>,
    /// Output matrix C (p × n).
    pub c: DMatrix<f64>,
    /// Feedthrough D (p × m).
    pub d: DMatrix<f64>,
    /// Sample time Ts in s.
    pub ts_s: f64,
}

impl HiddenStateModel {
    /// Number of states n.
    pub fn order(&self) -> usize {
        self.phi.nrows()
    }

    /// Largest modulus of Φ's eigenvalues (stable below 1; NaN for non-finite Φ).
    pub fn spectral_radius(&self) -> f64 {
        crate::thermal::matrix::spectral_radius(&self.phi)
    }

    /// The time constants τ_i = −Ts / ln|λ_i| of Φ's eigenvalues λ_i, ascending (s): the
    /// continuous model's −1/Re(s_i) for s_i = ln(λ_i)/Ts. They do not depend on the
    /// basis of the states. `None` for an unstable Φ.
    pub fn time_constants_s(&self) -> Option<Vec<f64>> {
        if !(self.spectral_radius() < 1.0) {
            return None;
        }
        let mut tau: Vec<f64> = self
            .phi
            .clone()
            .complex_eigenvalues()
            .iter()
            .map(|z| -self.ts_s / z.norm().ln())
            .collect();
        tau.sort_by(f64::total_cmp);
        Some(tau)
    }

    /// The steady-state gain G = C (I − Φ)⁻¹ Γ + D (p × m): y_ss = G u for a constant u,
    /// the sensitivity of each output's steady state to each input. `None` where I − Φ
    /// is singular (a pole at 1).
    pub fn steady_state_gain(&self) -> Option<DMatrix<f64>> {
        let n = self.order();
        let lu = (DMatrix::identity(n, n) - &self.phi).lu();
        let x = lu.solve(&self.gamma)?;
        Some(&self.c * x + &self.d)
    }

    /// The outputs simulated over `range` of `data` from x(range.start) = `x0`, one row
    /// per instant of the range: ŷ(k) = C x(k) + D u(k).
    pub fn simulate(
        &self,
        data: &IdentificationData,
        range: std::ops::Range<usize>,
        x0: &DVector<f64>,
    ) -> DMatrix<f64> {
        let (p, m) = (self.c.nrows(), self.gamma.ncols());
        let mut out = DMatrix::zeros(range.len(), p);
        let mut x = x0.clone();
        let mut u = DVector::zeros(m);
        for (r, k) in range.enumerate() {
            for l in 0..m {
                u[l] = data.inputs[(k, l)];
            }
            let y = &self.c * &x + &self.d * &u;
            out.row_mut(r).copy_from(&y.transpose());
            x = &self.phi * &x + &self.gamma * &u;
        }
        out
    }

    /// The simulated outputs over the whole of `data` (N × p), each segment from the
    /// initial state that best fits its observed outputs (least squares: ŷ is linear in
    /// x0, as SITB's `compare` estimates it), NaN outside the segments. The form
    /// `model::fit::fit` compares with the measurement.
    pub fn simulate_segments(&self, data: &IdentificationData) -> DMatrix<f64> {
        let p = self.c.nrows();
        let mut out = DMatrix::from_element(data.len(), p, f64::NAN);
        for seg in data.segments() {
            let x0 = self.fitted_initial_state(data, seg.clone());
            let sim = self.simulate(data, seg.clone(), &x0);
            out.rows_mut(seg.start, seg.len()).copy_from(&sim);
        }
        out
    }

    /// The x0 minimising Σ (y − ŷ)² over the observed outputs of `range`: the free
    /// response C Φ^(k−start) x0 regressed on the measurement less the forced response.
    pub fn fitted_initial_state(
        &self,
        data: &IdentificationData,
        range: std::ops::Range<usize>,
    ) -> DVector<f64> {
        let n = self.order();
        let forced = self.simulate(data, range.clone(), &DVector::zeros(n));
        let mut rows = Vec::new();
        let mut rhs = Vec::new();
        let mut free = self.c.clone();
        for (r, k) in range.enumerate() {
            for j in 0..self.c.nrows() {
                if data.observed(k, j) && forced[(r, j)].is_finite() {
                    rows.push(free.row(j).clone_owned());
                    rhs.push(data.outputs[(k, j)] - forced[(r, j)]);
                }
            }
            free = &free * &self.phi;
        }
        if rows.is_empty() {
            return DVector::zeros(n);
        }
        let a = DMatrix::from_rows(&rows);
        let b = DVector::from_vec(rhs);
        least_squares(&a, &b).unwrap_or_else(|| DVector::zeros(n))
    }
}

/// The least-squares solution of A x ≈ b by the SVD (the minimum-norm one where A is
/// rank-deficient), `None` where the SVD fails.
pub(crate) fn least_squares(a: &DMatrix<f64>, b: &DVector<f64>) -> Option<DVector<f64>> {
    let svd = a.clone().svd(true, true);
    let tol = svd.singular_values.max() * 1e-10 * a.nrows().max(a.ncols()) as f64;
    svd.solve(b, tol).ok()
}

#[cfg(test)]
pub(crate) mod testing;
