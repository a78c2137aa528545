//! Grey-box output error in the thermal network's own parameters (`--method rc`).
//!
//! The model is the passive network of the paper's Fig. 9 (see [`crate::network`]),
//!
//! ```text
//! C·dθ/dt = −L·θ + K·P,   A_c = −C⁻¹·L,   B_c = C⁻¹·K·P_base/θ_base,
//! L_ij = −G_ij (i ≠ j),   L_ii = G_i0 + Σ_{j≠i} G_ij,
//! ```
//!
//! parametrised so that every estimate is a physical network: p = [ln C_i; ln G_i0;
//! ln G_ij (i < j); η], each loss column of K on the simplex by the additive log-ratio
//! k_ij = e^{η_ij} / (1 + Σ_{l≠r_j} e^{η_lj}) with k_{r_j j} = 1 / (1 + Σ_l e^{η_lj})
//! (r_j the part that takes the largest share of loss j at the start). The columns of K
//! summing to 1 (energy conservation: every watt of loss enters a modelled part) is what
//! fixes the absolute scale of C and G, which temperatures and losses alone leave open.
//!
//! Φ = e^{A_c·Ts} and Γ (zero-order hold) follow from p; the fit minimises the same
//! simulation error as [`super::oe`], whose data pass gives the normal equations in
//! Θ = [Φ Γ]. With D = ∂Θ/∂p (exact: the Fréchet derivative of the exponential of the
//! block matrix [[A_c, B_c], [0, 0]]·Ts, from one exponential of a matrix twice its
//! size) the Jacobian in p is J_Θ·D, so JᵀJ and Jᵀr in p are Dᵀ(J_ΘᵀJ_Θ)D and Dᵀ J_Θᵀr:
//! one pass over the data per evaluation, as for OE. The start is the OE estimate's own
//! network, projected onto the passive set; that OE estimate is kept for comparison.
//!
//! Beside p, the fit estimates a constant offset d per output, ŷ = x + d
//! ([`Estimate::output_offset`]): each rise is measured from one noisy first sample, whose
//! error stays in every later value; left out, the slowly moving losses' columns of K and
//! the conductances to the coolant take it up (benches/network.rs: 4 and 6 of 10 seeds met
//! the acceptance bar without it, 10 and 10 with it).
//!
//! The covariance of p is σ²(JᵀJ)⁻¹ at the minimum; C and G get log-normal 95 %
//! intervals (exp(ln C ± 1.96 σ)), k_ij the delta-method interval ± 1.96 σ clipped to
//! [0, 1], and Θ the covariance D·cov(p)·Dᵀ that the model analysis propagates.
//! A record stored by exception is fitted as its kept values (without OE's censoring).

use crate::estimate::Method;
use std::cell::RefCell;

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt, TerminationReason};
use nalgebra::{DMatrix, DVector, Dyn, Owned};

use super::oe::{self, Evaluation, OutputError, Problem};
use super::{
    check_enough_rows, DiscreteModel, Estimate, EstimationError, Estimator, IdentificationData,
    Result,
};
use crate::thermal::network::{Labels, Network, NetworkIntervals, Parts, Scaling};
use crate::thermal::rc::{projected, Parametrisation, LOG_RANGE};
use crate::thermal::ContinuousModel;

/// The grey-box network estimator.
#[derive(Debug, Clone)]
pub struct ResistanceCapacitance {
    /// Per-output weights, as for [`OutputError::weights`].
    pub weights: Option<Vec<f64>>,
    /// The model's scaling (θ_base, P_base), which turns B_c·C into K.
    pub scaling: Scaling,
    /// Told each evaluation of the objective: OE's start fit's (`oe`), then the
    /// network's (`rc`).
    pub progress: crate::progress::Observer,
}

/// What the grey-box fit found besides Φ and Γ: the network itself.
#[derive(Debug, Clone)]
pub struct NetworkEstimate {
    /// C (J/K), G (W/K, G_i0 on the diagonal) and K at the minimum.
    pub parts: Parts,
    /// The scaling the network is in.
    pub scaling: Scaling,
    /// 95 % intervals of every C, G and k_ij.
    pub intervals: NetworkIntervals,
    /// Covariance of p = [ln C; ln G_i0; ln G_ij (i < j); η].
    pub covariance: DMatrix<f64>,
    /// The output-error estimate the fit started from (for comparison).
    pub output_error: Box<Estimate>,
}

impl Estimator for ResistanceCapacitance {
    fn method(&self) -> Method {
        Method::Rc
    }

    fn estimate(&self, data: &IdentificationData) -> Result<Estimate> {
        self.scaling_is_valid()?;
        let oe = OutputError {
            weights: self.weights.clone(),
            progress: self.progress.clone(),
        }
        .estimate(data)?;
        let map = Parametrisation::of_shape(
            data.ts_s,
            self.scaling,
            &start_parts(&oe.model, self.scaling),
        );
        let start = map.start.clone();
        let mut estimate = self.fit_from(data, map, &start)?;
        if let Some(network) = estimate.network.as_mut() {
            *network.output_error = oe;
        }
        Ok(estimate)
    }
}

impl ResistanceCapacitance {
    fn scaling_is_valid(&self) -> Result<()> {
        let s = self.scaling;
        let ok = |v: f64| v.is_finite() && v > 0.0;
        if ok(s.theta_base_k) && ok(s.p_base_w) {
            Ok(())
        } else {
            Err(EstimationError::NoNetworkStart {
                reason: format!(
                    "the scaling θ_base = {} K, P_base = {} W must be positive",
                    s.theta_base_k, s.p_base_w
                ),
            })
        }
    }

    /// Minimises the simulation error over the network parameters from `start` (laid out
    /// as p); the estimate's `network` holds the parameters and their intervals, with the
    /// start model as its `output_error` until [`Estimator::estimate`] puts OE's there.
    fn fit_from(
        &self,
        data: &IdentificationData,
        map: Parametrisation,
        start: &[f64],
    ) -> Result<Estimate> {
        let segments = data.segments();
        let rows_used = oe::compared_instants(data, &segments);
        check_enough_rows(data, rows_used)?;
        let start_model = map.model(start);
        let weights = match &self.weights {
            Some(w) => w.clone(),
            None => oe::normalised_inverse(
                &oe::simulation_error_variance(data, &segments, &start_model)
                    .iter()
                    .map(|v| v.max(1e-24))
                    .collect::<Vec<_>>(),
            ),
        };
        // The rises are measured from one noisy first sample each: a constant offset per
        // output, estimated beside the network (without it the slow columns of K and the
        // conductances to the coolant absorb it; docs/src/methods/thermal-network.md).
        let mut inner = Problem::new(data, segments, &start_model, &weights).with_output_offset();
        inner.progress = Some(oe::Reporting::new(&self.progress, self.method().name()));
        let mut problem = RcProblem::new(inner, map, start);
        let mut evaluations = 0;
        // Fewer evaluations than OE's 200·(p+1): a conductance or share that is zero in
        // truth walks its logarithm towards −∞ with ever smaller gains, and the fit stops
        // there rather than following it.
        let lm = LevenbergMarquardt::new()
            .with_patience(50)
            .with_ftol(1e-10)
            .with_xtol(1e-10)
            .with_gtol(1e-10);
        for pass in 0..2 {
            let before = problem.params.clone();
            let (solved, report) = lm.minimize(problem);
            problem = solved;
            evaluations += report.number_of_evaluations;
            // A step into parameters where the model cannot be evaluated (an exponential
            // out of range) ends the minimiser there; the fit is the last good point.
            let stopped_on_bad_point = matches!(report.termination, TerminationReason::User(_))
                || problem.residuals().is_none();
            if stopped_on_bad_point {
                let best = problem.best.borrow().clone().map(|(_, p)| p);
                match best {
                    Some(p) => problem.set_params(&p),
                    None if pass == 1 => problem.set_params(&before),
                    None => {
                        return Err(EstimationError::MinimisationFailed {
                            termination: report.termination,
                        })
                    }
                }
                break;
            }
            if !report.objective_function.is_finite() {
                return Err(EstimationError::MinimisationFailed {
                    termination: report.termination,
                });
            }
            if pass == 1 || self.weights.is_some() {
                break;
            }
            // Second pass on 1/σ_i² of the first pass's residuals (the sensor noise).
            let next = problem.inner.residual_weights();
            let change = next
                .iter()
                .zip(&problem.inner.sqrt_w)
                .map(|(a, b)| (a / b - 1.0).abs())
                .fold(0.0, f64::max);
            problem.inner.sqrt_w = next;
            *problem.cache.borrow_mut() = None;
            // Objectives under the old weights are not comparable with the new ones.
            *problem.best.borrow_mut() = None;
            if change < 0.05 {
                break;
            }
        }
        if !problem.inner.params.iter().all(|v| v.is_finite()) {
            return Err(EstimationError::MinimisationFailed {
                termination: TerminationReason::Numerical("a network the model cannot hold"),
            });
        }
        Ok(problem.conclude(self.method(), rows_used, evaluations, start_model))
    }
}

/// The start: the network of `model` (OE's), projected onto the passive set — conductances
/// and shares floored at `thermal::rc::START_FLOOR` (of the largest conductance; of 1), each column of
/// K renormalised to 1. Where the model has no network, a rough one from its diagonal.
fn start_parts(model: &DiscreteModel, scaling: Scaling) -> Parts {
    let (n, m) = (model.phi.nrows(), model.gamma.ncols());
    let continuous = ContinuousModel::from_discrete(model).ok();
    let network = continuous.as_ref().and_then(|c| {
        Network::from_continuous(&c.a_c, &c.b_c, scaling, None, &Labels::numbered(n, m)).ok()
    });
    let parts = match network {
        Some(net) => Parts {
            capacitance_j_per_k: net.capacitance_j_per_k.clone(),
            conductance_w_per_k: DMatrix::from_fn(n, n, |i, j| net.conductance_w_per_k[i][j]),
            loss_distribution: DMatrix::from_fn(n, m, |i, j| net.loss_distribution[i][j]),
        },
        None => rough_parts(continuous.as_ref(), model, scaling),
    };
    projected(parts)
}

/// A rough network where the identified model has none: rates from A_c's diagonal (or
/// the sample time's 1000th part), shares from B_c's positive entries, equal capacitances
/// scaled so that B_c's positive part is matched on average.
fn rough_parts(
    continuous: Option<&ContinuousModel>,
    model: &DiscreteModel,
    scaling: Scaling,
) -> Parts {
    let (n, m) = (model.phi.nrows(), model.gamma.ncols());
    let w = scaling.p_base_w / scaling.theta_base_k;
    let fallback_rate = 1e-3 / model.ts_s;
    let (rates, b_plus): (Vec<f64>, DMatrix<f64>) = match continuous {
        Some(c) => (
            (0..n)
                .map(|i| (-c.a_c[(i, i)]).max(fallback_rate))
                .collect(),
            c.b_c.map(|b| b.max(0.0)),
        ),
        None => (vec![fallback_rate; n], DMatrix::from_element(n, m, 1.0)),
    };
    let total_b = b_plus.sum().max(1e-300);
    let c = w * m as f64 / total_b;
    let loss_distribution = DMatrix::from_fn(n, m, |i, j| {
        let col = b_plus.column(j).sum();
        if col > 0.0 {
            b_plus[(i, j)] / col
        } else {
            1.0 / n as f64
        }
    });
    let conductance = DMatrix::from_fn(n, n, |i, j| {
        if i == j {
            0.5 * c * rates[i]
        } else {
            0.25 * c * rates[i].min(rates[j])
        }
    });
    Parts {
        capacitance_j_per_k: vec![c; n],
        conductance_w_per_k: conductance,
        loss_distribution,
    }
}

/// The least-squares problem LM sees: parameters [p; x0 of each segment], evaluated
/// through OE's problem in [Θ; x0].
struct RcProblem<'a> {
    inner: Problem<'a>,
    map: Parametrisation,
    /// [p; x0 of each segment] (x0 only where OE estimates them).
    params: DVector<f64>,
    /// D = ∂Θ/∂p at `params`.
    d: DMatrix<f64>,
    cache: RefCell<Option<(DVector<f64>, Evaluation)>>,
    /// The lowest objective evaluated so far and its parameters: where the minimiser
    /// stops on a point the model cannot be evaluated at, the fit returns here.
    best: RefCell<Option<(f64, DVector<f64>)>>,
}

impl<'a> RcProblem<'a> {
    fn new(inner: Problem<'a>, map: Parametrisation, start: &[f64]) -> RcProblem<'a> {
        let p_theta = inner.p_theta();
        let mut params: Vec<f64> = start.to_vec();
        params.extend(inner.params.iter().skip(p_theta).copied());
        let mut problem = RcProblem {
            d: DMatrix::zeros(0, 0),
            inner,
            map,
            params: DVector::from_vec(params),
            cache: RefCell::new(None),
            best: RefCell::new(None),
        };
        let params = problem.params.clone();
        problem.set_params(&params);
        problem
    }

    fn p(&self) -> &[f64] {
        &self.params.as_slice()[..self.map.len()]
    }

    /// OE's evaluation in [Θ; x0] carried to [p; x0] by T = diag(D, I).
    fn evaluate(&self) -> Evaluation {
        let e = self.inner.evaluate_full();
        let (pt, pp) = (self.inner.p_theta(), self.map.len());
        let rest = e.gram.nrows() - pt;
        let d = &self.d;
        let cols = pp + rest;
        let mut gram = DMatrix::zeros(cols, cols);
        let g_tt = e.gram.view((0, 0), (pt, pt));
        gram.view_mut((0, 0), (pp, pp))
            .copy_from(&(d.transpose() * g_tt * d));
        if rest > 0 {
            let g_tx = d.transpose() * e.gram.view((0, pt), (pt, rest));
            gram.view_mut((0, pp), (pp, rest)).copy_from(&g_tx);
            gram.view_mut((pp, 0), (rest, pp))
                .copy_from(&g_tx.transpose());
            gram.view_mut((pp, pp), (rest, rest))
                .copy_from(&e.gram.view((pt, pt), (rest, rest)));
        }
        let mut grad = DVector::zeros(cols);
        grad.rows_mut(0, pp)
            .copy_from(&(d.transpose() * e.grad.rows(0, pt)));
        grad.rows_mut(pp, rest).copy_from(&e.grad.rows(pt, rest));
        Evaluation {
            sse: e.sse,
            gram,
            grad,
        }
    }

    fn evaluated(&self) -> std::cell::Ref<'_, Evaluation> {
        oe::cached(&self.cache, &self.params, || self.evaluate())
    }

    /// The estimate at the minimum, with the network and its intervals.
    fn conclude(
        &self,
        method: Method,
        rows_used: usize,
        evaluations: usize,
        start_model: DiscreteModel,
    ) -> Estimate {
        let n = self.inner.n;
        let evaluation = self.evaluate();
        let entries: usize = self.inner.counts.iter().sum();
        let dof = entries.saturating_sub(self.params.len()).max(1) as f64;
        let sigma2 = evaluation.sse.iter().sum::<f64>() / dof;
        let (full, condition_number) = oe::covariance_from_gram(&evaluation.gram, sigma2);
        let pp = self.map.len();
        let cov_p = full.view((0, 0), (pp, pp)).into_owned();
        let theta_cov = &self.d * &cov_p * self.d.transpose();
        let noise_variance: Vec<f64> = (0..n)
            .map(|c| {
                let w = self.inner.sqrt_w[c].powi(2).max(1e-300);
                evaluation.sse[c] / self.inner.counts[c].max(1) as f64 / w
            })
            .collect();
        let p = self.p();
        let start_estimate = Estimate {
            model: start_model,
            // OE's, once [`Estimator::estimate`] puts its estimate here.
            method: Method::Oe,
            rows_used,
            condition_number: f64::NAN,
            covariance: None,
            noise_variance: Vec::new(),
            iterations: 0,
            output_offset: None,
            trajectory: None,
            network: None,
            predictor: None,
        };
        Estimate {
            model: self.map.model(p),
            method,
            rows_used,
            condition_number,
            covariance: Some(theta_cov),
            noise_variance,
            iterations: evaluations,
            output_offset: self.inner.output_offset(),
            trajectory: None,
            network: Some(Box::new(NetworkEstimate {
                parts: self.map.parts(p),
                scaling: self.map.scaling,
                intervals: self.map.intervals(p, &cov_p),
                covariance: cov_p,
                output_error: Box::new(start_estimate),
            })),
            predictor: None,
        }
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for RcProblem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.params.copy_from(x);
        let pp = self.map.len();
        // Logarithms within e^±LOG_RANGE of the start: the exponentials stay finite.
        for q in 0..pp {
            let s = self.map.start[q];
            self.params[q] = self.params[q].clamp(s - LOG_RANGE, s + LOG_RANGE);
        }
        let x = &self.params.clone();
        let p = &x.as_slice()[..pp];
        let theta = self.map.model(p).theta();
        let pt = self.inner.p_theta();
        for (q, t) in theta.iter().enumerate() {
            self.inner.params[q] = *t;
        }
        for q in pp..x.len() {
            self.inner.params[pt + q - pp] = x[q];
        }
        self.d = self.map.theta_jacobian(p);
    }

    fn params(&self) -> DVector<f64> {
        self.params.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        if !self.params.iter().all(|v| v.is_finite()) {
            return None;
        }
        let (r, _) = self.evaluated().square_root_form()?;
        if !r.iter().all(|v| v.is_finite()) {
            return None;
        }
        let objective = r.norm_squared();
        let mut best = self.best.borrow_mut();
        if best.as_ref().is_none_or(|(b, _)| objective < *b) {
            *best = Some((objective, self.params.clone()));
        }
        Some(r)
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let (_, j) = self.evaluated().square_root_form()?;
        j.iter().all(|v| v.is_finite()).then_some(j)
    }
}

#[cfg(test)]
mod tests;
