//! Uncertainty of the derived quantities, by first-order propagation of the
//! parameter covariance (the delta method): for a derived g(Θ),
//! var g ≈ ∇gᵀ C ∇g, with ∇g by central differences, and a 95 % interval
//! ±1.96·√(var g) (normal approximation).

use nalgebra::DVector;
use serde::Serialize;

use super::continuous::{ContinuousModel, Spectrum};
use crate::estimate::Estimate;

/// z of the two-sided 95 % normal interval.
pub const Z95: f64 = 1.959_963_984_540_054;

/// 95 % confidence half-widths.
#[derive(Debug, Clone, Serialize)]
pub struct Uncertainty {
    /// Half-width of the 95 % interval of each time constant (ascending order), s.
    pub time_constants_ci95_s: Vec<f64>,
    /// Half-width of the 95 % interval of each steady-state output, pu.
    pub steady_state_ci95: Vec<f64>,
    /// Standard error of each entry of Θ laid out as [`crate::estimate::DiscreteModel::theta`].
    pub theta_standard_error: Vec<f64>,
}

/// Propagates the estimate's covariance to the time constants and the steady state
/// for input `u`; `None` when the method gives no covariance.
pub fn propagate(estimate: &Estimate, u: &[f64]) -> Option<Uncertainty> {
    let cov = estimate.covariance.as_ref()?;
    let theta = estimate.model.theta();
    let derived = |t: &[f64]| -> Option<Vec<f64>> {
        let model = estimate.model.with_theta(t);
        let spectrum = Spectrum::of(&model).ok()?;
        let steady = ContinuousModel::from_discrete(&model)
            .ok()?
            .steady_state(u)
            .ok()?;
        Some(
            spectrum
                .time_constants_s
                .into_iter()
                .chain(steady)
                .collect(),
        )
    };
    let base = derived(&theta)?;
    let k = base.len();
    let mut grads = vec![DVector::zeros(theta.len()); k];
    for j in 0..theta.len() {
        let sd = cov[(j, j)].max(0.0).sqrt();
        let h = (1e-3 * sd).max(1e-9 * theta[j].abs()).max(1e-14);
        let mut plus = theta.clone();
        let mut minus = theta.clone();
        plus[j] += h;
        minus[j] -= h;
        let (gp, gm) = (derived(&plus)?, derived(&minus)?);
        for (q, g) in grads.iter_mut().enumerate() {
            g[j] = (gp[q] - gm[q]) / (2.0 * h);
        }
    }
    let half: Vec<f64> = grads
        .iter()
        .map(|g| Z95 * (g.transpose() * cov * g)[(0, 0)].max(0.0).sqrt())
        .collect();
    let n = estimate.model.phi.nrows();
    Some(Uncertainty {
        time_constants_ci95_s: half[..n].to_vec(),
        steady_state_ci95: half[n..].to_vec(),
        theta_standard_error: (0..theta.len())
            .map(|j| cov[(j, j)].max(0.0).sqrt())
            .collect(),
    })
}
